//! [`Radar::once`] and [`Radar::whenever`]: the statements user code writes (`connections/statement.rs`).

use crate::connections::statement::Statement;
use crate::{radar::Radar, wire::refs::AsSignal};
use radar_semantics::connection::Kind;

impl Radar {
    /// `once source ...`: the connection delivers one signal. The source is a signal, or an event (for its
    /// `triggered`); a slot is not accepted.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, start_event: radar_ros::EventHandle, count_up: radar_ros::ResponseHandle)
    /// #     -> radar_ros::Result<()> {
    /// let _c = radar.once(&start_event).start(&count_up).await?;
    /// # Ok(()) }
    /// ```
    pub fn once(&self, source: impl AsSignal) -> Statement {
        Statement {
            manager: self.manager().clone(),
            kind: Kind::Once,
            source: source.signal(),
        }
    }

    /// `whenever source ...`: the connection delivers every signal while it lives.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, tick: radar_ros::EventHandle, go: radar_ros::ResponseHandle)
    /// #     -> radar_ros::Result<()> {
    /// let _c = radar.whenever(&tick).start(&go).await?;
    /// # Ok(()) }
    /// ```
    pub fn whenever(&self, source: impl AsSignal) -> Statement {
        Statement {
            manager: self.manager().clone(),
            kind: Kind::Whenever,
            source: source.signal(),
        }
    }
}
