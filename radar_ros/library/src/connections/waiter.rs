//! `waitfor`: waiting in plain code for a component's signal, without missing one.
//!
//! [`Radar::waiter`] arms a `once` connection from the source to a private slot and returns when it is armed;
//! [`Waiter::recv`] then gives the payload of the first signal emitted after that moment. Arming first, then
//! doing what makes the signal come, then waiting, cannot miss it:
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar, arm: radar_ros::ResponseRef) -> radar_ros::Result<()> {
//! use radar_ros::msg::Empty;
//! let mut done = radar.waiter::<Empty>(arm.exited()).await?; // armed
//! radar.inject(arm.start_slot(), Empty::default()).await?;   // start it
//! let output = done.recv().await?;                         // its exited, whenever it comes
//! # Ok(()) }
//! ```
//!
//! [`Radar::waitfor`] does both steps in one call, for signals that do not depend on anything the caller does
//! next (a sensor event, another program's response).
//!
//! If the component leaves the graph before it sends the signal, the wait ends with
//! [`Error::ComponentLost`](crate::Error::ComponentLost) (see [components that leave](crate#when-components-leave)).
//!
//! Which signals a waiter sees: those its source emits once it is armed, and those emitted while it armed
//! (stamped, by the emitter's clock, at or after the moment arming began: C1; the waiter's own reader may
//! activate an event whose condition already holds), from any publisher of the source's type that discovery has
//! matched with the waiter's reader; for a publisher in this process that means every one, for one in another
//! process every one that has matched the reader back (DDS completes discovery on each side separately:
//! see the crate documentation on arming).

use crate::{
    connections::manager::ConnectionGuard, error::Error, wait::Wait, wire::msg::RosMessage,
};

/// An armed `waitfor`: [`recv`](Waiter::recv) gives the payload of the first signal emitted since it was armed.
/// Dropping it disarms it.
#[must_use = "a waiter waits only while it lives; call .recv() on it"]
pub struct Waiter<M> {
    pub(crate) rx: tokio::sync::oneshot::Receiver<M>,
    pub(crate) topic: String,
    /// Until it has given its signal (or its source left).
    pub(crate) connection: Option<ConnectionGuard>,
}

impl<M: RosMessage> Waiter<M> {
    /// The payload of the first signal emitted since the waiter was armed: unbounded unless `.timeout(d)`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, r: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// use radar_ros::msg::Empty;
    /// let mut w = radar.waiter::<Empty>(r.exited()).await?;
    /// let _ = w.recv().timeout(std::time::Duration::from_secs(60)).await?;
    /// # Ok(()) }
    /// ```
    ///
    /// If every publisher of the signal leaves the graph first (the component exits, crashes, hangs or is cut
    /// off), this fails with [`Error::ComponentLost`], naming the component and the cause: a signal it sent
    /// before it left is still delivered. A waiter gives one signal (or that error), and lets go of its
    /// connection then; asked again, it fails with [`Error::Closed`].
    ///
    /// # Cancel safety
    ///
    /// Cancel safe: if the wait is dropped before it completes (a `select!` branch that lost, a timeout), the
    /// waiter stays armed, and a signal that came meanwhile is what the next `recv` gives.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, r: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// use std::time::Duration;
    /// let mut done = radar.waiter::<radar_ros::msg::Empty>(r.exited()).await?;
    /// loop {
    ///     tokio::select! {
    ///         out = done.recv() => { out?; break; }
    ///         _ = tokio::time::sleep(Duration::from_secs(1)) => println!("still waiting"),
    ///     }
    /// }
    /// # Ok(()) }
    /// ```
    pub fn recv(&mut self) -> Wait<'_, M> {
        let what = format!("a signal on {}", self.topic);
        Wait::signal(what.clone(), async move {
            let spent =
                || Error::Closed(format!("{} (this waiter has given its signal)", self.topic));
            let Some(connection) = self.connection.as_ref() else {
                return Err(spent());
            };
            let m = tokio::select! {
                biased;
                m = &mut self.rx => m.map_err(|_| spent()),
                d = connection.departure_seen() => match d {
                    // a signal the relay read before it saw the source go was sent before it went
                    Some(departure) => self
                        .rx
                        .try_recv()
                        .map_err(|_| Error::ComponentLost { waiting_for: what, departure }),
                    None => (&mut self.rx).await.map_err(|_| spent()),
                },
            };
            // it has given what it had: the once connection goes
            self.connection = None;
            m
        })
    }
}

impl<M> std::fmt::Debug for Waiter<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Waiter")
            .field("topic", &self.topic)
            .finish_non_exhaustive()
    }
}
