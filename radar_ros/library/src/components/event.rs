//! Events as ROS 2 nodes.
//!
//! An event named `NS/NAME` is a node that publishes `NS/NAME/triggered` (its payload type, default
//! `std_msgs/msg/Empty`, signal QoS) and `NS/NAME/state` (`radar_msgs/msg/EventState`, transient-local).
//!
//! It is **active exactly while at least one subscription is matched on `triggered`** (a relay, an rclpy
//! node, `ros2 topic echo`): the ROS form of RADAR's self-activating events. While active it runs
//! [`Event::check`] in a loop; every value the check resolves with is published on `triggered`. When the last
//! subscriber leaves, the running check is dropped (cancelled at its current await point). The match count
//! comes from DDS discovery events (see the crate docs), so activation follows a subscriber within a few
//! milliseconds, and also follows a subscriber process that was killed, once DDS declares it lost.

use std::{future::Future, panic::AssertUnwindSafe, pin::Pin, sync::Arc, time::Duration};

use futures::FutureExt;
use tokio::sync::{watch, Mutex};

use radar_semantics::event::{Activation, Transition};

use crate::{
    components::own_node::{ComponentNode, EventSubscription},
    components::trigger::{CheckTrigger, Emitted, Nudge, Trigger},
    error::{Result, SlotError},
    node::endpoints::{emit, panic_message, SignalWriter, Throttle, Watched},
    node::shutdown::ComponentTask,
    wire::msg::{Empty, EventState, RosMessage, Time},
    wire::names::ComponentName,
    wire::refs::{AsSignal, Signal},
};

/// A condition check.
///
/// ```
/// use radar_ros::{Event, SlotError, msg::Empty};
/// /// Triggers 2 s after it becomes active, then every 2 s (the paper's `StartEvent`).
/// struct StartEvent;
/// impl Event for StartEvent {
///     type Payload = Empty;
///     async fn check(&mut self) -> Result<Empty, SlotError> {
///         tokio::time::sleep(std::time::Duration::from_secs(2)).await;
///         Ok(Empty::default())
///     }
/// }
/// ```
pub trait Event: Send + 'static {
    /// What `triggered` carries.
    type Payload: RosMessage;

    /// Resolves when the condition holds, with the payload to emit. Called again after each trigger while
    /// the event is active. An error is counted and reported on `state`, and the check is retried after
    /// [`Event::retry_after`].
    fn check(&mut self) -> impl Future<Output = Result<Self::Payload, SlotError>> + Send;

    /// Called before each check with that check's own writer of `triggered`: an event whose condition is seen
    /// on a thread of its own can emit from there ([`Trigger::emit`]) instead of resolving the check and waiting
    /// for the event's task to emit. A check that emitted this way still resolves (soon after: the trigger is
    /// counted in `state` then), and the value it resolves with is not emitted again. A thread that sees the
    /// condition again and again emits with [`Trigger::emit_and_continue`] instead: each emission is one check's
    /// value and begins the next check there, so the event's task is not woken per trigger. Default: unused.
    fn before_check(&mut self, trigger: Trigger<Self::Payload>) {
        let _ = trigger;
    }

    /// Called when the event becomes active, before the first check.
    fn on_activate(&mut self) {}

    /// Called when the event becomes inactive, after the running check was dropped.
    fn on_deactivate(&mut self) {}

    /// Called once when the event's node exists, to create extra ROS endpoints on it (see [`TopicEvent`]).
    fn attach(&mut self, node: &mut EventNode<'_>) -> Result<()> {
        let _ = node;
        Ok(())
    }

    /// The ROS type of `triggered`, as `pkg/msg/Name`. Default: `Payload`'s. An event whose `Payload` is a
    /// [`DynMessage`](crate::topics::DynMessage) says here what it is.
    fn payload_type(&self) -> String {
        Self::Payload::ros_type_name()
    }

    /// Pause before checking again after an error or panic. Default 100 ms.
    fn retry_after(&self) -> Duration {
        Duration::from_millis(100)
    }
}

/// An event's own node while it is being set up ([`Event::attach`]): a [`ComponentNode`].
pub type EventNode<'a> = ComponentNode<'a>;

/// Triggers every `period` while active, first `period` after activation. With `use_sim_time` it runs on
/// simulated time (see [`crate::node::clock`]): a backward jump of the time starts the period over.
#[derive(Clone, Debug)]
pub struct TimerEvent {
    period: Duration,
    next: tokio::time::Instant,
    clock: crate::node::clock::Clock,
    /// The next trigger in simulated time.
    sim_next: crate::wire::msg::Time,
    /// `Some` once [`TimerEvent::configurable`] asked for the `period` parameter (declared in `attach`).
    params: Option<Option<crate::node::params::Params>>,
}

impl TimerEvent {
    /// A timer with this period.
    ///
    /// ```
    /// use radar_ros::TimerEvent;
    /// let every_second = TimerEvent::new(std::time::Duration::from_secs(1));
    /// ```
    pub fn new(period: Duration) -> Self {
        TimerEvent {
            period,
            next: tokio::time::Instant::now() + period,
            clock: crate::node::clock::Clock::wall(),
            sim_next: crate::wire::msg::Time::default(),
            params: None,
        }
    }
}

impl TimerEvent {
    /// Makes the period the node's parameter `period` (seconds, a `double`): set from the command line
    /// (`-p tick:period:=0.5`) or `ros2 param set /tick period 0.5`, applied from the next trigger. Off by
    /// default, because parameters cost a timer six services on the graph.
    ///
    /// ```
    /// use radar_ros::TimerEvent;
    /// let tick = TimerEvent::new(std::time::Duration::from_secs(1)).configurable();
    /// ```
    pub fn configurable(mut self) -> Self {
        self.params = Some(None);
        self
    }

    /// The period now: the parameter's when configurable.
    fn period(&self) -> Duration {
        match &self.params {
            Some(Some(p)) => p.f64("period").map_or(self.period, Duration::from_secs_f64),
            _ => self.period,
        }
    }

    fn sim_after(&self, t: crate::wire::msg::Time) -> crate::wire::msg::Time {
        let ns = i64::from(t.sec) * 1_000_000_000
            + i64::from(t.nanosec)
            + self.period().as_nanos() as i64;
        crate::wire::msg::Time {
            sec: ns.div_euclid(1_000_000_000) as i32,
            nanosec: ns.rem_euclid(1_000_000_000) as u32,
        }
    }
}

impl Event for TimerEvent {
    type Payload = Empty;
    fn attach(&mut self, node: &mut EventNode<'_>) -> Result<()> {
        self.clock = node.clock();
        if self.params.is_some() {
            self.params = Some(Some(
                node.declare([crate::node::params::ParamDecl::new(
                    "period",
                    self.period.as_secs_f64(),
                )
                .description("seconds between triggers while the event is active")
                .float_range(0.000_001, 86_400.0)])?,
            ));
        }
        Ok(())
    }
    fn on_activate(&mut self) {
        self.next = tokio::time::Instant::now() + self.period();
        self.sim_next = self.sim_after(self.clock.now());
    }
    async fn check(&mut self) -> Result<Empty, SlotError> {
        if !self.clock.is_simulated() {
            // the wall clock: tokio's monotonic timer, which no clock adjustment moves
            tokio::time::sleep_until(self.next).await;
            self.next += self.period();
            return Ok(Empty::default());
        }
        while self.clock.sleep_until(self.sim_next).await == crate::node::clock::Woke::JumpedBack {
            self.sim_next = self.sim_after(self.clock.now());
        }
        // periods the time jumped over are skipped, as rclcpp's timers skip them
        let now = self.clock.now();
        while self.sim_next <= now {
            self.sim_next = self.sim_after(self.sim_next);
        }
        Ok(Empty::default())
    }
}

type Predicate<M, P> = Box<dyn FnMut(&M) -> Option<P> + Send>;

/// Triggers when a message on a ROS topic satisfies a predicate, with a payload mapped from it.
///
/// The subscription is made once, on the event's own node; messages that arrive while the event is inactive
/// are discarded on activation, so a trigger always comes from a message received while active.
///
/// ```no_run
/// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
/// use radar_ros::{TopicEvent, msg::{Float64, Empty}};
/// let low_battery = TopicEvent::new("battery_level", |m: &Float64| (m.data < 0.2).then(Empty::default));
/// let handle = radar.spawn_event("low_battery", low_battery)?;
/// # Ok(()) }
/// ```
pub struct TopicEvent<M: RosMessage, P: RosMessage> {
    topic: String,
    predicate: Predicate<M, P>,
    sub: Option<EventSubscription<M>>,
}

impl<M: RosMessage, P: RosMessage> TopicEvent<M, P> {
    /// Watches `topic` (type `M`); triggers with `f(msg)` whenever it returns `Some`.
    pub fn new(topic: &str, f: impl FnMut(&M) -> Option<P> + Send + 'static) -> Self {
        TopicEvent {
            topic: topic.to_owned(),
            predicate: Box::new(f),
            sub: None,
        }
    }
}

impl<M: RosMessage, P: RosMessage> Event for TopicEvent<M, P> {
    type Payload = P;
    fn attach(&mut self, node: &mut EventNode<'_>) -> Result<()> {
        self.sub = Some(node.subscribe::<M>(&self.topic)?);
        Ok(())
    }
    fn on_activate(&mut self) {
        if let Some(sub) = &self.sub {
            while sub.take().is_some() {}
        }
    }
    async fn check(&mut self) -> Result<P, SlotError> {
        let sub = self
            .sub
            .as_ref()
            .ok_or_else(|| SlotError::msg("TopicEvent used before attach"))?;
        loop {
            let m = sub
                .recv()
                .await
                .map_err(|e| SlotError::msg(e.to_string()))?;
            if let Some(p) = (self.predicate)(&m) {
                return Ok(p);
            }
        }
    }
}

/// A running event node. Dropping it (or [`EventHandle::shutdown`]) removes the node from the graph. It names
/// the event's `triggered` wherever a connection's source is expected ([`AsSignal`]).
#[must_use = "the event runs only while its handle lives; bind it (`let ev = radar.spawn_event(..)?`)"]
pub struct EventHandle {
    pub(crate) name: ComponentName,
    pub(crate) payload_type: String,
    pub(crate) state: watch::Receiver<EventState>,
    pub(crate) task: ComponentTask,
}

impl EventHandle {
    /// The event's fully qualified name.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::TimerEvent;
    /// let tick = radar.spawn_event("tick", TimerEvent::new(std::time::Duration::from_secs(1)))?;
    /// assert_eq!(tick.name().fully_qualified(), "/tick");
    /// assert_eq!(tick.topic("triggered"), "/tick/triggered");
    /// # Ok(()) }
    /// ```
    pub fn name(&self) -> &ComponentName {
        &self.name
    }

    /// The absolute topic of one of its endpoints, e.g. `topic("triggered")`.
    pub fn topic(&self, endpoint: &str) -> String {
        self.name.topic(endpoint)
    }

    /// Its `triggered` signal, for connections (the handle itself stands for it too).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::TimerEvent;
    /// let tick = radar.spawn_event("tick", TimerEvent::new(std::time::Duration::from_secs(1)))?;
    /// let t = tick.triggered();
    /// assert_eq!((t.topic(), t.ros_type()), ("/tick/triggered", "std_msgs/msg/Empty"));
    /// # Ok(()) }
    /// ```
    pub fn triggered(&self) -> Signal {
        Signal::new(
            self.name.endpoint(crate::endpoint::Endpoint::Triggered),
            self.payload_type.clone(),
        )
    }

    /// The latest state.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::TimerEvent;
    /// let tick = radar.spawn_event("tick", TimerEvent::new(std::time::Duration::from_secs(1)))?;
    /// let s = tick.state();
    /// println!("active: {}, triggers: {}", s.active, s.triggers);
    /// let mut changes = tick.watch_state();
    /// changes.changed().await.ok();
    /// tick.shutdown().await; // stops checking, leaves the graph
    /// # Ok(()) }
    /// ```
    pub fn state(&self) -> EventState {
        self.state.borrow().clone()
    }

    /// A receiver that sees every state change.
    pub fn watch_state(&self) -> watch::Receiver<EventState> {
        self.state.clone()
    }

    /// Stops checking and removes the node; waits until it is gone (unbounded unless `.timeout(d)`).
    ///
    /// # Cancel safety
    ///
    /// The stop is asked for when this is called; dropping the returned wait (or its timeout running out)
    /// leaves the component finishing on its own, its exit slot included.
    pub fn shutdown(self) -> crate::Wait<'static, ()> {
        self.task.shutdown()
    }
}

impl AsSignal for EventHandle {
    fn signal(&self) -> Signal {
        self.triggered()
    }
}

impl std::fmt::Debug for EventHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EventHandle")
            .field("name", &self.name.fully_qualified())
            .finish_non_exhaustive()
    }
}

/// Minimum spacing of `state` messages caused by triggers alone (activation changes and errors are
/// published at once). A high-rate event does not double its traffic with state updates.
const STATE_TRIGGER_THROTTLE: Duration = Duration::from_millis(100);

/// A running check, and its trigger's event side.
struct Check<P> {
    run: Pin<Box<dyn Future<Output = Result<P, SlotError>> + Send>>,
    trigger: CheckTrigger,
}

impl<P> Check<P> {
    /// Ends the check's trigger (see [`CheckTrigger::close`]); the future is dropped with `self`.
    fn end(self) -> Emitted {
        self.trigger.close()
    }
}

fn new_check<E: Event>(
    event: &Arc<Mutex<E>>,
    writer: &Arc<SignalWriter<E::Payload>>,
    nudge: &Arc<Nudge>,
    delay: Option<Duration>,
) -> Check<E::Payload> {
    let e = Arc::clone(event);
    let (trigger, side) = CheckTrigger::open(writer, nudge);
    let run = Box::pin(async move {
        if let Some(d) = delay {
            tokio::time::sleep(d).await;
        }
        let mut guard = e.lock_owned().await;
        let checked = AssertUnwindSafe(async {
            guard.before_check(trigger);
            guard.check().await
        });
        match checked.catch_unwind().await {
            Ok(r) => r,
            Err(p) => Err(SlotError::msg(format!(
                "check panicked: {}",
                panic_message(p)
            ))),
        }
    });
    Check { run, trigger: side }
}

/// A running event's task state: the event, its writers, and what its `state` says.
struct Driver<E: Event> {
    event: Arc<Mutex<E>>,
    triggered: Arc<SignalWriter<E::Payload>>,
    state_pub: Watched<crate::node::transport::Publisher<EventState>>,
    state_tx: watch::Sender<EventState>,
    st: EventState,
    activation: Activation,
    check: Option<Check<E::Payload>>,
    /// Pokes the task when a check's trigger emitted and continued (its count is due in `state`).
    nudge: Arc<Nudge>,
    throttle: Throttle,
    /// A state is stamped when it was entered: a trigger's, when `triggered` was emitted (so that a reader can
    /// put it in order with the signals it caused).
    entered: Option<i64>,
}

impl<E: Event> Driver<E> {
    fn publish(&mut self) {
        // armed before counting: a trigger the count below misses pokes again
        self.nudge.rearm();
        self.count_continued();
        self.st.stamp = self.entered.take().map_or_else(Time::now, Time::from_nanos);
        emit(&self.state_pub, "state", self.st.clone());
        self.state_tx.send_replace(self.st.clone());
        self.throttle.published();
    }

    /// `n` triggers emitted, the first at `at` (ns), by the event's task or by the check itself.
    fn count(&mut self, n: u64, at: i64) {
        self.entered.get_or_insert(at);
        self.st.triggers += n;
    }

    /// Counts what the running check's trigger emitted and continued.
    fn count_continued(&mut self) {
        if let Some((n, last)) = self.check.as_ref().and_then(|c| c.trigger.take_continued()) {
            self.count(n, last);
        }
    }

    /// A check's trigger emitted and continued: counted, in `state` when the throttle lets it.
    fn on_continued(&mut self) {
        self.count_continued();
        if self.throttle.changed() {
            self.publish();
        }
    }

    /// Ends the running check, if any: nothing more goes out through its trigger, and what it emitted is
    /// counted. Whether it had emitted its own value.
    fn end_check(&mut self) -> bool {
        let Some(emitted) = self.check.take().map(Check::end) else {
            return false;
        };
        if let Some((n, last)) = emitted.continued {
            self.count(n, last);
        }
        match emitted.own {
            Some(at) => {
                self.count(1, at);
                true
            }
            None => false,
        }
    }

    /// A new count of listeners: the event activates (its check starts) or deactivates (its check stops).
    async fn on_listeners(&mut self, n: usize) {
        self.st.listeners = n as u32;
        match self.activation.set_listeners(n) {
            Some(Transition::Activate) => {
                self.event.lock().await.on_activate();
                self.check = Some(new_check(&self.event, &self.triggered, &self.nudge, None));
                tracing::debug!(event = %self.st.name, listeners = n, "activated");
            }
            Some(Transition::Deactivate) => {
                self.end_check();
                self.event.lock().await.on_deactivate();
                tracing::debug!(event = %self.st.name, "deactivated");
            }
            None => {}
        }
        self.st.active = self.activation.is_active();
        self.st.activations = self.activation.activations();
        self.publish();
    }

    /// The running check ended with `res`: its value emitted (unless it emitted itself), or its error counted,
    /// and the next check begun.
    async fn on_checked(&mut self, res: Result<E::Payload, SlotError>) {
        let emitted = self.end_check();
        match res {
            Ok(payload) => {
                if !emitted {
                    let at = self.triggered.emit("triggered", payload, None);
                    self.count(1, at);
                }
                self.check = Some(new_check(&self.event, &self.triggered, &self.nudge, None));
                if self.throttle.changed() {
                    self.publish();
                }
            }
            Err(e) => {
                tracing::warn!(event = %self.st.name, error = %e, "event check failed; retrying");
                self.st.check_errors += 1;
                self.st.last_error = e.into_message();
                let delay = self.event.lock().await.retry_after();
                self.check = Some(new_check(
                    &self.event,
                    &self.triggered,
                    &self.nudge,
                    Some(delay),
                ));
                self.publish();
            }
        }
    }
}

pub(crate) async fn drive_event<E: Event>(
    event: E,
    triggered: SignalWriter<E::Payload>,
    state_pub: Watched<crate::node::transport::Publisher<EventState>>,
    state_tx: watch::Sender<EventState>,
    st: EventState,
    mut listeners: watch::Receiver<usize>,
    mut stop: tokio::sync::oneshot::Receiver<()>,
) {
    let mut d = Driver {
        event: Arc::new(Mutex::new(event)),
        triggered: Arc::new(triggered),
        state_pub,
        state_tx,
        st,
        activation: Activation::new(),
        check: None,
        nudge: Nudge::new(),
        throttle: Throttle::new(STATE_TRIGGER_THROTTLE),
        entered: None,
    };
    // the count may already be non-zero
    let mut pending_count = Some(*listeners.borrow_and_update());
    loop {
        if let Some(n) = pending_count.take() {
            d.on_listeners(n).await;
        }
        tokio::select! {
            _ = &mut stop => break,
            changed = listeners.changed() => match changed {
                Ok(()) => pending_count = Some(*listeners.borrow_and_update()),
                Err(_) => break,
            },
            res = async {
                match d.check.as_mut() {
                    Some(c) => c.run.as_mut().await,
                    None => std::future::pending().await,
                }
            } => d.on_checked(res).await,
            _ = d.nudge.poked() => d.on_continued(),
            _ = d.throttle.due() => d.publish(),
        }
    }
    if let Some(c) = d.check.take() {
        c.end();
    }
    tracing::info!(event = %d.st.name, "event stopped");
}
