//! The handle of a running response.

use tokio::sync::watch;

use crate::{
    node::shutdown::ComponentTask,
    wait::Wait,
    wire::msg::ResponseState,
    wire::names::ComponentName,
    wire::refs::{AsResponse, ResponseRef},
};

/// A running response node. Dropping it stops the response like [`ResponseHandle::shutdown`] does, without
/// waiting. It names the response wherever one is expected ([`AsResponse`]).
///
/// A handle that is not kept stops its response at once, so leaving it unused is a warning (here made an
/// error, so that this example fails to compile):
///
/// ```compile_fail
/// #![deny(unused_must_use)]
/// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
/// use radar_ros::{FnResponse, msg::Empty};
/// radar.spawn_response("beep", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
/// # Ok(()) }
/// ```
///
/// ```no_run
/// #![deny(unused_must_use)]
/// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
/// use radar_ros::{FnResponse, msg::Empty};
/// let beep = radar.spawn_response("beep", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
/// # Ok(()) }
/// ```
#[must_use = "the response runs only while its handle lives; bind it (`let r = radar.spawn_response(..)?`)"]
pub struct ResponseHandle {
    pub(crate) name: ComponentName,
    /// Its signal and slot topics with their types.
    pub(crate) reference: ResponseRef,
    pub(crate) state: watch::Receiver<ResponseState>,
    /// Publishers matched with the `start`, `interrupt` and `exit` readers.
    pub(crate) slot_publishers: [watch::Receiver<usize>; 3],
    /// Subscriptions matched with the `started`, `interrupted` and `exited` writers.
    pub(crate) signal_subscribers: [watch::Receiver<usize>; 3],
    pub(crate) task: ComponentTask,
}

impl ResponseHandle {
    /// The response's fully qualified name.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, msg::Empty};
    /// let dock = radar.spawn_response("dock", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
    /// assert_eq!(dock.name().fully_qualified(), "/dock");
    /// assert_eq!(dock.topic("start"), "/dock/start");
    /// let _ = dock.reference().exited(); // its signals and slots
    /// # Ok(()) }
    /// ```
    pub fn name(&self) -> &ComponentName {
        &self.name
    }

    /// The absolute topic of one of its endpoints, e.g. `topic("start")`.
    pub fn topic(&self, endpoint: &str) -> String {
        self.name.topic(endpoint)
    }

    /// Its signals and slots (`handle.reference().exited()`); the handle itself stands for the response in
    /// statements (`radar.once(&e).start(&handle)`).
    pub fn reference(&self) -> &ResponseRef {
        &self.reference
    }

    /// The latest state, as published on `state`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, msg::Empty};
    /// let dock = radar.spawn_response("dock", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
    /// let s = dock.state();
    /// println!("{}: {} runs, {} interrupted", s.state_label, s.starts, s.interrupts);
    /// let mut changes = dock.watch_state();
    /// changes.changed().await.ok();
    /// # Ok(()) }
    /// ```
    pub fn state(&self) -> ResponseState {
        self.state.borrow().clone()
    }

    /// A receiver that sees every state change.
    pub fn watch_state(&self) -> watch::Receiver<ResponseState> {
        self.state.clone()
    }

    /// Publishers matched now with the `start`, `interrupt` and `exit` slot readers.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, msg::Empty};
    /// let dock = radar.spawn_response("dock", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
    /// let [start, interrupt, exit] = dock.slot_publishers();
    /// let [started, interrupted, exited] = dock.signal_subscribers();
    /// # Ok(()) }
    /// ```
    pub fn slot_publishers(&self) -> [usize; 3] {
        self.slot_publishers.each_ref().map(|w| *w.borrow())
    }

    /// Subscriptions matched now with the `started`, `interrupted` and `exited` writers.
    pub fn signal_subscribers(&self) -> [usize; 3] {
        self.signal_subscribers.each_ref().map(|w| *w.borrow())
    }

    /// Waits until each slot reader (`start`, `interrupt`, `exit`) has matched at least `slot_publishers`
    /// publishers and each signal writer (`started`, `interrupted`, `exited`) at least `signal_subscribers`
    /// subscriptions (default limit [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change).
    /// DDS discovery completes on each side separately, and a volatile writer sends only to readers it has
    /// matched, so a peer seeing the match from its side is not enough for nothing to be lost.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, msg::Empty};
    /// let dock = radar.spawn_response("dock", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
    /// // another program will drive it: wait until its publisher on each slot is matched both ways
    /// dock.wait_for_peers(1, 0).timeout(std::time::Duration::from_secs(30)).await?;
    /// # Ok(()) }
    /// ```
    pub fn wait_for_peers(
        &self,
        slot_publishers: usize,
        signal_subscribers: usize,
    ) -> Wait<'_, ()> {
        Wait::discovery(move |timeout| async move {
            let wanted = self
                .slot_publishers
                .iter()
                .map(|w| (w, slot_publishers))
                .chain(
                    self.signal_subscribers
                        .iter()
                        .map(|w| (w, signal_subscribers)),
                );
            let wait = async {
                for (w, n) in wanted {
                    let mut w = w.clone();
                    if w.wait_for(|c| *c >= n).await.is_err() {
                        return Err(crate::Error::Closed(self.name.fully_qualified()));
                    }
                }
                Ok(())
            };
            tokio::time::timeout(timeout, wait)
                .await
                .map_err(|_| crate::Error::Timeout {
                    what: format!(
                        "{slot_publishers} publisher(s) per slot and {signal_subscribers} subscriber(s) per signal of {} \
                         (now {:?} and {:?})",
                        self.name,
                        self.slot_publishers(),
                        self.signal_subscribers()
                    ),
                    after: timeout,
                })?
        })
    }

    /// Stops the response: a running start behaviour is ended as by an `exit` signal (the exit slot runs and
    /// `exited` is sent), then the node leaves the ROS graph. Waits until it has (unbounded unless
    /// `.timeout(d)`).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, msg::Empty};
    /// let dock = radar.spawn_response("dock", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
    /// dock.shutdown().await?; // a running start behaviour ends through the exit slot
    /// # Ok(()) }
    /// ```
    ///
    /// # Cancel safety
    ///
    /// The stop is asked for when this is called; dropping the returned wait (or its timeout running out)
    /// leaves the component finishing on its own, its exit slot included.
    pub fn shutdown(self) -> Wait<'static, ()> {
        self.task.shutdown()
    }
}

impl AsResponse for ResponseHandle {
    fn response_ref(&self) -> ResponseRef {
        self.reference.clone()
    }
}

impl std::fmt::Debug for ResponseHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ResponseHandle")
            .field("name", &self.name.fully_qualified())
            .finish_non_exhaustive()
    }
}
