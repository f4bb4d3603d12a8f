//! A live connection's handle: the connection lives as long as it.

use std::sync::Arc;

use radar_semantics::connection::{ConnId, Link};

use super::Manager;
use crate::{departure::Departure, wait::Wait};

/// A live connection. Dropping it removes the connection: once the drop returns, nothing more is delivered
/// through it (an anonymous slot already running finishes; no new call begins).
///
/// ```no_run
/// # async fn f(radar: radar_ros::Radar, tick: radar_ros::EventHandle, go: radar_ros::ResponseHandle)
/// #     -> radar_ros::Result<()> {
/// {
///     let c = radar.whenever(&tick).start(&go).await?;
///     println!("connection {} is live: {}", c.id(), c.is_live());
/// } // dropped here: tick no longer starts go
/// # Ok(()) }
/// ```
#[must_use = "a connection lives only as long as this guard; bind it (`let _c = ...`) to keep it for the scope"]
pub struct ConnectionGuard {
    pub(super) id: ConnId,
    pub(super) manager: Arc<Manager>,
}

impl ConnectionGuard {
    /// Its id in the manager's list.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// Panics caught in the connection's own code so far (its filter, map, or anonymous slot's call): each one
    /// refused its signal (a filter or map) or ended its call (an anonymous slot), and the connection went on.
    /// The manager's `connections` list shows the count and the last message too.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, tick: radar_ros::EventRef) -> radar_ros::Result<()> {
    /// use radar_ros::msg::Empty;
    /// let c = radar.whenever(&tick).call(|_: Empty| panic!("bug")).await?;
    /// // ... later: the program goes on, and the panics are counted
    /// println!("{} panics", c.panics());
    /// # Ok(()) }
    /// ```
    pub fn panics(&self) -> u64 {
        self.manager.panics(self.id)
    }

    /// Delivers nothing while `why` is given (a service-made connection whose owner is silent), and again
    /// once it is not.
    pub(crate) fn suspend(&self, why: Option<String>) {
        self.manager.suspend(self.id, why);
    }

    /// Whether it still delivers (a fired `once` without `until` does not).
    pub fn is_live(&self) -> bool {
        self.manager.contains(self.id)
    }

    /// Resolves when the connection no longer delivers: a `once` (without `until`) that fired. (An anonymous
    /// slot's call for that last delivery runs in its own task and may still be running.)
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, go: radar_ros::EventRef, r: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// let c = radar.once(&go).start(&r).await?;
    /// c.closed().await?; // the once has fired
    /// assert!(!c.is_live());
    /// # Ok(()) }
    /// ```
    ///
    /// Unbounded unless `.timeout(d)`. Cancel safe: it only looks.
    pub fn closed(&self) -> Wait<'_, ()> {
        Wait::signal(format!("connection {} to close", self.id), async move {
            let mut rx = self.manager.changed.subscribe();
            while self.is_live() {
                if rx.changed().await.is_err() {
                    break;
                }
            }
            Ok(())
        })
    }

    /// Whether it can deliver now ([`Link::Armed`]), or waits because a component left; `None` once it no
    /// longer exists (a fired `once`). See [components that leave](crate#when-components-leave).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, tick: radar_ros::EventRef, go: radar_ros::ResponseRef)
    /// #     -> radar_ros::Result<()> {
    /// use radar_ros::manager::Link;
    /// let c = radar.whenever(&tick).start(&go).await?;
    /// let d = c.departed().await?.expect("a whenever lives until dropped");
    /// eprintln!("{d}");                       // which component left, and why
    /// match c.link() {
    ///     Some(Link::WaitingForSource) => eprintln!("tick will be heard again when it is back"),
    ///     Some(Link::TargetLost) => eprintln!("go is gone: make the statement again when it is back"),
    ///     other => eprintln!("{other:?}"),
    /// }
    /// # Ok(()) }
    /// ```
    pub fn link(&self) -> Option<Link> {
        self.manager.link(self.id).map(|(l, _)| l)
    }

    /// The component whose leaving put the connection out of [`Link::Armed`], while it is out.
    pub fn departure(&self) -> Option<Departure> {
        self.manager.link(self.id).and_then(|(_, d)| d)
    }

    /// Resolves when a component of this connection leaves the graph (its source's last publisher, or its
    /// target's last subscriber, or the response of its `until`), with who left and why, also when that ended
    /// it (a spent `once ... until` whose response left); or with `None` when the connection ends without that
    /// (a fired `once`). Resolves at once if one has already left. Unbounded
    /// unless `.timeout(d)`. Cancel safe: it only looks.
    pub fn departed(&self) -> Wait<'_, Option<Departure>> {
        let what = format!("a component of connection {} to leave", self.id);
        Wait::signal(what, async move { Ok(self.departure_seen().await) })
    }

    /// [`ConnectionGuard::departed`], for code of this crate that selects on it.
    pub(crate) async fn departure_seen(&self) -> Option<Departure> {
        let mut rx = self.manager.changed.subscribe();
        loop {
            match self.manager.link(self.id) {
                // over: because a component left (a spent `once ... until` whose response went), or not
                None => return self.manager.over_by(self.id),
                Some((_, Some(d))) => return Some(d),
                Some((_, None)) => {}
            }
            if rx.changed().await.is_err() {
                return None;
            }
        }
    }

    /// Signals delivered from its source so far (0 once a fired `once` is gone).
    pub fn delivered(&self) -> u64 {
        self.manager.delivered(self.id)
    }
}

impl std::fmt::Debug for ConnectionGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConnectionGuard")
            .field("id", &self.id)
            .finish()
    }
}

impl Drop for ConnectionGuard {
    fn drop(&mut self) {
        self.manager.remove(self.id);
    }
}
