//! [`Radar::waitfor`] and [`Radar::waiter`]: a signal waited for that cannot be missed
//! (`connections/waiter.rs`).

use crate::connections::waiter::Waiter;
use crate::{
    error::Error,
    radar::Radar,
    wait::{Wait, DEFAULT_TIMEOUT},
    wire::msg::RosMessage,
    wire::refs::AsSignal,
};

impl Radar {
    /// Arms a waiter for `source` (a signal, or an event for its `triggered`): returns once it is armed
    /// (discovery: [`DEFAULT_TIMEOUT`], `.timeout(d)` to change), see [`Waiter`].
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, dock: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// let mut docked = radar.waiter::<radar_ros::msg::Empty>(dock.exited()).await?;
    /// // ... make the robot dock ...
    /// docked.recv().await?;
    /// # Ok(()) }
    /// ```
    pub fn waiter<M: RosMessage>(&self, source: impl AsSignal) -> Wait<'static, Waiter<M>> {
        let radar = self.clone();
        let source = source.signal();
        Wait::discovery(move |t| async move {
            let (tx, rx) = tokio::sync::oneshot::channel();
            let mut tx = Some(tx);
            let topic = source.topic().to_owned();
            let c = radar
                .once(source)
                .call(move |m: M| {
                    if let Some(tx) = tx.take() {
                        let _ = tx.send(m);
                    }
                })
                .timeout(t)
                .await?;
            Ok(Waiter {
                rx,
                topic,
                connection: Some(c),
            })
        })
    }

    /// `waitfor source`: arms a waiter and waits for the payload of its first signal. By default arming may
    /// take [`DEFAULT_TIMEOUT`] and the signal as long as it takes; `.timeout(d)` bounds the whole call. A
    /// signal emitted while the waiter arms is not seen: when what you do next makes the signal come, arm
    /// first with [`Radar::waiter`].
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, bumper: radar_ros::EventRef) -> radar_ros::Result<()> {
    /// use std::time::Duration;
    /// let _: radar_ros::msg::Empty = radar.waitfor(&bumper).timeout(Duration::from_secs(60)).await?;
    /// # Ok(()) }
    /// ```
    pub fn waitfor<M: RosMessage>(&self, source: impl AsSignal) -> Wait<'static, M> {
        let radar = self.clone();
        let source = source.signal();
        Wait::new(None, move |limit| async move {
            let what = format!("a signal on {}", source.topic());
            let start = tokio::time::Instant::now();
            let mut waiter = radar
                .waiter::<M>(source)
                .timeout(limit.unwrap_or(DEFAULT_TIMEOUT))
                .await?;
            match limit {
                None => waiter.recv().await,
                Some(t) => waiter
                    .recv()
                    .timeout(t.saturating_sub(start.elapsed()))
                    .await
                    .map_err(|e| match e {
                        Error::Timeout { .. } => Error::Timeout { what, after: t },
                        e => e,
                    }),
            }
        })
    }
}
