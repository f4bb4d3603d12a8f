//! Responses as ROS 2 nodes.
//!
//! A response named `NS/NAME` is a node with these topics (all under `NS/NAME/`):
//!
//! | topic | direction | type | QoS |
//! |---|---|---|---|
//! | `start` | slot (subscribed) | the response's start type (default `std_msgs/msg/Empty`) | signal |
//! | `interrupt`, `exit` | slot (subscribed) | `std_msgs/msg/Empty` | signal |
//! | `started` | signal (published) | the start type, carrying the payload the run started with | signal |
//! | `interrupted` | signal (published) | `std_msgs/msg/Empty` | signal |
//! | `exited` | signal (published) | the response's output type (default `std_msgs/msg/Empty`) | signal |
//! | `state` | published | `radar_msgs/msg/ResponseState` | state (transient-local, depth 1) |
//!
//! Signal QoS is reliable, volatile, keep-last 10 ([`crate::qos::signal_qos`]). What happens
//! on each signal is decided by [`ResponseMachine`]; this module runs the slots and moves the messages.

use std::{future::Future, panic::AssertUnwindSafe, pin::Pin, sync::Arc};

use futures::{future::BoxFuture, FutureExt, StreamExt};
use tokio::sync::{watch, Mutex};

use radar_semantics::response::{
    Announce, Effect, ExitAction, ExitReason, Input, ResponseMachine, StartEnd, StartPolicy,
};

use crate::{
    endpoints::{
        emit, panic_message, publisher, subscription, typed_publisher, SignalWriter, Watched,
    },
    error::{Result, SlotError},
    local::now_ns,
    local::Inbox,
    msg::{Empty, ResponseState, RosMessage, Time, TypeName},
    names::ComponentName,
    participant::Participant,
    qos::{signal_qos, state_qos},
    radar::Radar,
    raw::RawMessage,
    refs::{AsResponse, ResponseRef},
    shutdown::ComponentTask,
    wait::Wait,
};

/// Behaviour with `start`, `interrupt` and `exit` slots.
///
/// Slots are async and run on the tokio runtime: sleep with `tokio::time::sleep`, never block the thread. An
/// interrupt or exit signal cancels the start behaviour at its current await point (its future is dropped).
///
/// ```
/// use radar_ros::{Response, SlotError, ExitReason, ExitAction, msg::Empty};
/// struct CountUp { i: u32 }
/// impl Response for CountUp {
///     type Start = Empty;
///     type Output = Empty;
///     async fn start(&mut self, _: Empty) -> Result<Empty, SlotError> {
///         self.i = 0;
///         while self.i < 10 {
///             tokio::time::sleep(std::time::Duration::from_millis(500)).await;
///             self.i += 1;
///         }
///         Ok(Empty::default())
///     }
///     async fn exit(&mut self, _why: ExitReason) -> ExitAction { ExitAction::Restart }
/// }
/// ```
pub trait Response: Send + 'static {
    /// What the `start` slot accepts, and `started` carries.
    type Start: RosMessage;
    /// What `exited` carries: the start behaviour's result, or `Default` when the run did not complete.
    type Output: RosMessage;

    /// The main behaviour. Returning ends the run normally; an error ends it as failed. Either way the exit
    /// slot runs next.
    fn start(
        &mut self,
        payload: Self::Start,
    ) -> impl Future<Output = Result<Self::Output, SlotError>> + Send;

    /// Runs after an `interrupt` signal cancelled the start behaviour, before the exit slot.
    fn interrupt(&mut self) -> impl Future<Output = ()> + Send {
        async {}
    }

    /// Always runs last, whatever ended the run. Return [`ExitAction::Restart`] to start again with the same
    /// payload after `exited`.
    fn exit(&mut self, reason: ExitReason) -> impl Future<Output = ExitAction> + Send {
        let _ = reason;
        async { ExitAction::Done }
    }

    /// What `start` does while a run is in progress. Default: ignore.
    fn start_policy(&self) -> StartPolicy {
        StartPolicy::Ignore
    }
}

type StartFn<P, O> = Box<dyn FnMut(P) -> BoxFuture<'static, Result<O, SlotError>> + Send>;
type InterruptFn = Box<dyn FnMut() -> BoxFuture<'static, ()> + Send>;
type ExitFn = Box<dyn FnMut(ExitReason) -> BoxFuture<'static, ExitAction> + Send>;

/// A [`Response`] made of closures, for responses without much state.
///
/// ```
/// use radar_ros::{FnResponse, ExitAction, msg::{Empty, StringMsg}};
/// let r = FnResponse::new(|goal: StringMsg| async move {
///     println!("going to {}", goal.data);
///     Ok(Empty::default())
/// })
/// .on_exit(|why| async move { println!("ended: {why:?}"); ExitAction::Done });
/// ```
pub struct FnResponse<P, O> {
    start: StartFn<P, O>,
    interrupt: InterruptFn,
    exit: ExitFn,
    policy: StartPolicy,
}

impl<P: RosMessage, O: RosMessage> FnResponse<P, O> {
    /// A response whose start behaviour is `start`.
    ///
    /// ```
    /// use radar_ros::{FnResponse, ExitAction, StartPolicy, msg::{Empty, StringMsg}};
    /// let go_to = FnResponse::new(|goal: StringMsg| async move {
    ///     println!("going to {}", goal.data);
    ///     Ok(Empty::default())
    /// })
    /// .on_interrupt(|| async { println!("stopping") })
    /// .on_exit(|why| async move { println!("ended: {}", why.describe()); ExitAction::Done })
    /// .start_policy(StartPolicy::Restart);
    /// ```
    pub fn new<F, Fut>(mut start: F) -> Self
    where
        F: FnMut(P) -> Fut + Send + 'static,
        Fut: Future<Output = Result<O, SlotError>> + Send + 'static,
    {
        FnResponse {
            start: Box::new(move |p| start(p).boxed()),
            interrupt: Box::new(|| async {}.boxed()),
            exit: Box::new(|_| async { ExitAction::Done }.boxed()),
            policy: StartPolicy::Ignore,
        }
    }

    /// Sets the interrupt slot.
    #[must_use]
    pub fn on_interrupt<F, Fut>(mut self, mut f: F) -> Self
    where
        F: FnMut() -> Fut + Send + 'static,
        Fut: Future<Output = ()> + Send + 'static,
    {
        self.interrupt = Box::new(move || f().boxed());
        self
    }

    /// Sets the exit slot.
    #[must_use]
    pub fn on_exit<F, Fut>(mut self, mut f: F) -> Self
    where
        F: FnMut(ExitReason) -> Fut + Send + 'static,
        Fut: Future<Output = ExitAction> + Send + 'static,
    {
        self.exit = Box::new(move |r| f(r).boxed());
        self
    }

    /// Sets the policy for `start` while running.
    #[must_use]
    pub fn start_policy(mut self, policy: StartPolicy) -> Self {
        self.policy = policy;
        self
    }
}

impl<P: RosMessage, O: RosMessage> Response for FnResponse<P, O> {
    type Start = P;
    type Output = O;
    fn start(&mut self, payload: P) -> impl Future<Output = Result<O, SlotError>> + Send {
        (self.start)(payload)
    }
    fn interrupt(&mut self) -> impl Future<Output = ()> + Send {
        (self.interrupt)()
    }
    fn exit(&mut self, reason: ExitReason) -> impl Future<Output = ExitAction> + Send {
        (self.exit)(reason)
    }
    fn start_policy(&self) -> StartPolicy {
        self.policy
    }
}

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
    name: ComponentName,
    /// Its signal and slot topics with their types.
    reference: ResponseRef,
    state: watch::Receiver<ResponseState>,
    /// Publishers matched with the `start`, `interrupt` and `exit` readers.
    slot_publishers: [watch::Receiver<usize>; 3],
    /// Subscriptions matched with the `started`, `interrupted` and `exited` writers.
    signal_subscribers: [watch::Receiver<usize>; 3],
    task: ComponentTask,
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
    /// `exited` is sent), then the node leaves the ROS graph. Waits until it has.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, msg::Empty};
    /// let dock = radar.spawn_response("dock", FnResponse::new(|_: Empty| async { Ok(Empty::default()) }))?;
    /// dock.shutdown().await; // a running start behaviour ends through the exit slot
    /// # Ok(()) }
    /// ```
    pub async fn shutdown(self) {
        self.task.stop_and_wait().await;
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

enum SlotDone<O> {
    Start(StartEnd<O>),
    Interrupt(Option<String>),
    Exit(Result<ExitAction, String>),
}

impl<O> SlotDone<O> {
    fn into_input<P>(self) -> Input<P, O> {
        match self {
            SlotDone::Start(e) => Input::StartEnded(e),
            SlotDone::Interrupt(p) => Input::InterruptEnded(p),
            SlotDone::Exit(r) => Input::ExitEnded(r),
        }
    }
}

type Slot<O> = Pin<Box<dyn Future<Output = SlotDone<O>> + Send>>;

/// What a running slot tells the response's driver before it ends (rules R9 and R10).
enum SlotNote {
    /// The start behaviour has really begun: say `started` now (responses that announce on acceptance).
    Accepted,
    /// The run's output, handed over early (a `Box<R::Output>`).
    Output(Box<dyn std::any::Any + Send>),
}

tokio::task_local! {
    static SLOT_NOTES: tokio::sync::mpsc::UnboundedSender<SlotNote>;
}

/// Called from a start behaviour of a response spawned with `Announce::WhenAccepted`: `started` goes out now.
/// Does nothing outside a slot.
pub(crate) fn accepted() {
    let _ = SLOT_NOTES.try_with(|tx| tx.send(SlotNote::Accepted));
}

/// Called from any slot: `exited` will carry `output` unless the start behaviour returns another one.
/// `O` must be the response's output type (anything else is dropped). Does nothing outside a slot.
pub(crate) fn hand_over<O: Send + 'static>(output: O) {
    let _ = SLOT_NOTES.try_with(|tx| tx.send(SlotNote::Output(Box::new(output))));
}

/// Feeds a slot's note to the machine.
fn note_input<P, O: 'static>(note: SlotNote) -> Option<Input<P, O>> {
    match note {
        SlotNote::Accepted => Some(Input::Accepted),
        SlotNote::Output(b) => match b.downcast::<O>() {
            Ok(o) => Some(Input::Output(*o)),
            Err(_) => {
                tracing::warn!("a slot handed over an output of another type; dropped");
                None
            }
        },
    }
}

impl Radar {
    /// Starts `response` as the ROS 2 node `name` (relative to this participant's namespace, or absolute).
    ///
    /// Fails before creating anything if the name is not a valid ROS name or is already used in this process.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, StartPolicy, msg::{Empty, StringMsg}};
    /// let say = radar.spawn_response("say", FnResponse::new(|s: StringMsg| async move {
    ///     println!("{}", s.data);
    ///     Ok(Empty::default())
    /// }).start_policy(StartPolicy::QueueOne))?;
    /// # Ok(()) }
    /// ```
    pub fn spawn_response<R: Response>(&self, name: &str, response: R) -> Result<ResponseHandle> {
        self.spawn_response_with(name, Announce::OnStart, |_, _, _| Ok(response))
    }

    /// Starts the response that `make` builds on the response's node (for responses whose behaviour needs
    /// endpoints of their own, such as an action client), announcing `started` as `announce` says.
    pub(crate) fn spawn_response_with<R: Response>(
        &self,
        name: &str,
        announce: Announce,
        make: impl FnOnce(&mut ros2_client::Node, &crate::graph::Graph, &ComponentName) -> Result<R>,
    ) -> Result<ResponseHandle> {
        let name = self.resolve(name)?;
        let (mut node, claim) = self.participant().claim_node(&name)?;
        let (g, sq) = (self.graph(), signal_qos());
        let (start_t, empty_t) = (TypeName::of::<R::Start>(), TypeName::of::<Empty>());
        let output_t = TypeName::of::<R::Output>();
        let response = make(&mut node, g, &name)?;
        let start_sub =
            subscription::<RawMessage>(g, &mut node, &name.topic("start"), &start_t, &sq)?;
        let interrupt_sub =
            subscription::<RawMessage>(g, &mut node, &name.topic("interrupt"), &empty_t, &sq)?;
        let exit_sub =
            subscription::<RawMessage>(g, &mut node, &name.topic("exit"), &empty_t, &sq)?;
        // what this process's connections deliver without a DDS hop
        let inlets = self.participant().inlets();
        let (start_ros, empty_ros) = (R::Start::ros_type_name(), Empty::ros_type_name());
        let inboxes = Inboxes {
            start: inlets.open(&name.topic("start"), &start_ros),
            interrupt: inlets.open(&name.topic("interrupt"), &empty_ros),
            exit: inlets.open(&name.topic("exit"), &empty_ros),
        };
        // the state writer is made (so announced) before the signal writers: whoever has discovered those has
        // discovered it, and knows this response keeps causes (C6)
        let state_pub =
            typed_publisher::<ResponseState>(g, &mut node, &name.topic("state"), &state_qos())?;
        let taps = self.participant().taps();
        let signal = |what: &str, ty: &TypeName| (name.topic(what), ty.ros.clone());
        let (t, ty) = signal("started", &start_t);
        let started = SignalWriter::new(
            taps,
            publisher::<R::Start>(g, &mut node, &t, &start_t, &sq)?,
            &t,
            &ty,
        );
        let (t, ty) = signal("interrupted", &empty_t);
        let interrupted = SignalWriter::new(
            taps,
            publisher::<Empty>(g, &mut node, &t, &empty_t, &sq)?,
            &t,
            &ty,
        );
        let (t, ty) = signal("exited", &output_t);
        let exited = SignalWriter::new(
            taps,
            publisher::<R::Output>(g, &mut node, &t, &output_t, &sq)?,
            &t,
            &ty,
        );

        let slot_publishers = [
            start_sub.matched.clone(),
            interrupt_sub.matched.clone(),
            exit_sub.matched.clone(),
        ];
        let signal_subscribers = [
            started.matched.clone(),
            interrupted.matched.clone(),
            exited.matched.clone(),
        ];
        let policy = response.start_policy();
        let machine = ResponseMachine::<R::Start, R::Output>::with_announce(policy, announce);
        let initial = state_message::<R>(&name, &machine);
        emit(&state_pub, "state", initial.clone());
        let (state_tx, state_rx) = watch::channel(initial);

        let participant = self.participant().clone();
        let io = Io::<R> {
            name: name.clone(),
            started,
            interrupted,
            exited,
            state_pub,
            state_tx,
        };
        let components = self.participant().components();
        let task = ComponentTask::spawn(
            components,
            &name.fully_qualified(),
            move |stop_rx| async move {
                let _claim = claim;
                let _node = node;
                drive(
                    Arc::new(Mutex::new(response)),
                    machine,
                    io,
                    SlotReaders {
                        start: start_sub,
                        interrupt: interrupt_sub,
                        exit: exit_sub,
                    },
                    inboxes,
                    stop_rx,
                    participant,
                )
                .await;
            },
        );
        tracing::info!(response = %name, start_type = %R::Start::ros_type_name(), policy = policy.label(), "response up");
        Ok(ResponseHandle {
            reference: ResponseRef::new(
                name.clone(),
                R::Start::ros_type_name(),
                R::Output::ros_type_name(),
            ),
            name,
            state: state_rx,
            slot_publishers,
            signal_subscribers,
            task,
        })
    }
}

/// What this process's connections hand a response's slots directly (see [`crate::local`]).
struct Inboxes {
    start: Inbox,
    interrupt: Inbox,
    exit: Inbox,
}

/// The slot readers of a response.
struct SlotReaders {
    start: Watched<ros2_client::Subscription<RawMessage>>,
    interrupt: Watched<ros2_client::Subscription<RawMessage>>,
    exit: Watched<ros2_client::Subscription<RawMessage>>,
}

struct Io<R: Response> {
    name: ComponentName,
    started: SignalWriter<R::Start>,
    interrupted: SignalWriter<Empty>,
    exited: SignalWriter<R::Output>,
    state_pub: Watched<ros2_client::Publisher<ResponseState>>,
    state_tx: watch::Sender<ResponseState>,
}

fn state_message<R: Response>(
    name: &ComponentName,
    m: &ResponseMachine<R::Start, R::Output>,
) -> ResponseState {
    let c = m.counters();
    ResponseState {
        stamp: Time::now(),
        name: name.fully_qualified(),
        state: m.phase().code(),
        state_label: m.phase().label().to_owned(),
        start_type: R::Start::ros_type_name(),
        start_policy: m.policy().label().to_owned(),
        last_exit_reason: m.last_exit().map(ExitReason::describe).unwrap_or_default(),
        starts: c.starts,
        exits: c.exits,
        interrupts: c.interrupts,
        exit_signals: c.exit_signals,
        completed: c.completed,
        failures: c.failures,
        panics: c.panics,
        restarts: c.restarts,
        ignored_starts: c.ignored_starts,
        ignored_interrupts: c.ignored_interrupts,
        ignored_exits: c.ignored_exits,
        start_queued: m.start_queued(),
        malformed: 0,
    }
}

/// How often a response republishes its state for malformed slot messages alone.
const MALFORMED_REPORT_EVERY: std::time::Duration = std::time::Duration::from_secs(1);

/// How long a response that stops with its program waits for its last signals to be acknowledged.
const FLUSH_LIMIT: std::time::Duration = std::time::Duration::from_secs(1);

impl<R: Response> Io<R> {
    /// Waits (blocking the thread, at most `limit`) until the subscribers of the signals and the state have
    /// acknowledged what was sent: the program is about to leave.
    fn flush(&self, limit: std::time::Duration) {
        let deadline = std::time::Instant::now() + limit;
        let left = || deadline.saturating_duration_since(std::time::Instant::now());
        let _ = self.exited.wait_for_acknowledgments(left());
        let _ = self.interrupted.wait_for_acknowledgments(left());
        let _ = self.started.wait_for_acknowledgments(left());
        let _ = self.state_pub.wait_for_acknowledgments(left());
    }

    fn publish_state(&self, st: ResponseState) {
        emit(&self.state_pub, "state", st.clone());
        self.state_tx.send_replace(st);
    }
}

/// What a response's task owns that must outlive a cancelled task: if the runtime drops the task in the middle
/// of a run (the program's `main` returned), the drop finishes the run (R7; [`crate::shutdown`]).
struct Driver<R: Response> {
    name: ComponentName,
    response: Arc<Mutex<R>>,
    machine: Option<ResponseMachine<R::Start, R::Output>>,
    io: Option<Io<R>>,
    /// The slot running now.
    current: Option<Slot<R::Output>>,
    participant: Arc<Participant>,
    /// The task ended by itself: nothing to finish.
    finished: bool,
}

impl<R: Response> Driver<R> {
    fn machine(&mut self) -> &mut ResponseMachine<R::Start, R::Output> {
        self.machine
            .as_mut()
            .expect("the machine lives until the driver ends")
    }

    fn io(&self) -> &Io<R> {
        self.io
            .as_ref()
            .expect("the writers live until the driver ends")
    }

    /// Carries out the machine's effects; whether a slot was begun.
    fn apply(&mut self, fx: Vec<Effect<R::Start, R::Output>>, notes: &NotesTx) -> bool {
        let mut began = false;
        for effect in fx {
            match effect {
                Effect::EmitStarted(p, cause) => self.io().started.emit("started", p, cause),
                Effect::RunStart(p) => {
                    let r = Arc::clone(&self.response);
                    began = true;
                    // the start slot is called inside the unwind guard: a closure that panics before it returns
                    // its future is a panicking start behaviour too (R7)
                    self.current = Some(Box::pin(SLOT_NOTES.scope(notes.clone(), async move {
                        let mut guard = r.lock_owned().await;
                        let end = match AssertUnwindSafe(async { guard.start(p).await })
                            .catch_unwind()
                            .await
                        {
                            Ok(Ok(o)) => StartEnd::Returned(o),
                            Ok(Err(e)) => StartEnd::Failed(e.0),
                            Err(panic) => StartEnd::Panicked(panic_message(panic)),
                        };
                        SlotDone::Start(end)
                    })));
                }
                Effect::CancelStart => self.current = None,
                Effect::EmitInterrupted(cause) => {
                    self.io()
                        .interrupted
                        .emit("interrupted", Empty::default(), cause)
                }
                Effect::RunInterrupt => {
                    let r = Arc::clone(&self.response);
                    began = true;
                    self.current = Some(Box::pin(SLOT_NOTES.scope(notes.clone(), async move {
                        let mut guard = r.lock_owned().await;
                        let panic = AssertUnwindSafe(async { guard.interrupt().await })
                            .catch_unwind()
                            .await
                            .err();
                        SlotDone::Interrupt(panic.map(panic_message))
                    })));
                }
                Effect::RunExit(reason) => {
                    let r = Arc::clone(&self.response);
                    began = true;
                    self.current = Some(Box::pin(SLOT_NOTES.scope(notes.clone(), async move {
                        let mut guard = r.lock_owned().await;
                        let res = AssertUnwindSafe(async { guard.exit(reason).await })
                            .catch_unwind()
                            .await;
                        SlotDone::Exit(res.map_err(panic_message))
                    })));
                }
                Effect::EmitExited(o, cause) => self.io().exited.emit("exited", o, cause),
                Effect::ReportPanic { slot, message } => {
                    tracing::error!(response = %self.name, slot, %message, "slot panicked; the response carries on")
                }
                Effect::Ignored { signal, phase, why } => {
                    tracing::debug!(response = %self.name, signal, phase = phase.label(), ?why, "signal ignored")
                }
            }
        }
        began
    }

    /// The task ends by itself: the last signals are acknowledged if the program is leaving, and the writers
    /// linger a moment in the participant's pool so that nothing just written is lost.
    async fn finish(mut self) {
        self.finished = true;
        let Some(io) = self.io.take() else {
            return;
        };
        let io = if self.participant.components().stopping() {
            match tokio::task::spawn_blocking(move || {
                io.flush(FLUSH_LIMIT);
                io
            })
            .await
            {
                Ok(io) => io,
                Err(_) => return,
            }
        } else {
            io
        };
        self.participant.pool().retire(Box::new(io));
    }
}

impl<R: Response> Drop for Driver<R> {
    fn drop(&mut self) {
        if self.finished {
            return;
        }
        // the runtime dropped the task: cancel the slot that ran (it holds the response), then finish the run
        self.current = None;
        let (Some(mut machine), Some(io)) = (self.machine.take(), self.io.take()) else {
            return;
        };
        let reason = machine.abandon().into_iter().find_map(|e| match e {
            Effect::RunExit(r) => Some(r),
            _ => None,
        });
        let Some(reason) = reason else {
            return; // idle: nothing to finish
        };
        let (response, name) = (Arc::clone(&self.response), self.name.clone());
        let timeout = self.participant.shutdown_timeout();
        tracing::debug!(response = %name, "the runtime went in the middle of a run: the exit slot runs");
        let what = format!("the exit slot of {name}");
        let finished = crate::shutdown::run_detached(what, timeout, async move {
            let mut guard = response.lock_owned().await;
            let res = AssertUnwindSafe(async { guard.exit(reason).await })
                .catch_unwind()
                .await;
            drop(guard);
            let fx = machine.handle_at(Input::ExitEnded(res.map_err(panic_message)), now_ns());
            for e in fx {
                match e {
                    Effect::EmitExited(o, cause) => io.exited.emit("exited", o, cause),
                    Effect::ReportPanic { slot, message } => {
                        tracing::error!(response = %name, slot, %message, "slot panicked")
                    }
                    _ => {}
                }
            }
            io.publish_state(state_message::<R>(&name, &machine));
            io.flush(FLUSH_LIMIT);
        });
        if !finished {
            tracing::error!(
                response = %self.name,
                "the runtime went in the middle of a run and the exit slot did not finish within {timeout:?}; raise \
                 RadarBuilder::shutdown_timeout if it needs longer"
            );
        }
    }
}

type NotesTx = tokio::sync::mpsc::UnboundedSender<SlotNote>;

async fn drive<R: Response>(
    response: Arc<Mutex<R>>,
    machine: ResponseMachine<R::Start, R::Output>,
    io: Io<R>,
    slots: SlotReaders,
    mut inboxes: Inboxes,
    mut stop: tokio::sync::oneshot::Receiver<()>,
    participant: Arc<Participant>,
) {
    let name = io.name.clone();
    // declared first, dropped last: if the runtime drops this task, the slots' readers go first, then the
    // driver finishes the run
    let mut d = Driver {
        name: name.clone(),
        response,
        machine: Some(machine),
        io: Some(io),
        current: None,
        participant,
        finished: false,
    };
    let (start_topic, int_topic, exit_topic) = (
        name.topic("start"),
        name.topic("interrupt"),
        name.topic("exit"),
    );
    let (start_t, empty_t) = (R::Start::ros_type_name(), Empty::ros_type_name());
    // samples from publishers of another type (see graph), and malformed ones, are dropped; each signal comes
    // with when and by which statement it was sent (R11-R13)
    let SlotReaders {
        start: start_sub,
        interrupt: interrupt_sub,
        exit: exit_sub,
    } = &slots;
    let sent = |info: &ros2_client::MessageInfo| crate::cause::sent(info, now_ns());
    // `None`: a message that did not decode (counted)
    let starts = start_sub
        .decoded::<R::Start>(&start_topic, &start_t)
        .map(move |d| d.map(|(m, info)| Input::Start(m, sent(&info))));
    let interrupts = interrupt_sub
        .decoded::<Empty>(&int_topic, &empty_t)
        .map(move |d| d.map(|(_, info)| Input::Interrupt(sent(&info))));
    let exits = exit_sub
        .decoded::<Empty>(&exit_topic, &empty_t)
        .map(move |d| d.map(|(_, info)| Input::Exit(sent(&info))));
    let Inboxes {
        start: local_start,
        interrupt: local_interrupt,
        exit: local_exit,
    } = &mut inboxes;
    let local_starts = local_start
        .stream()
        .map(|(raw, s)| match raw.decode::<R::Start>() {
            Ok(m) => Some(Input::Start(m, s)),
            Err(e) => {
                tracing::warn!(response = %name, error = %e, "a start delivered in this process did not decode");
                None
            }
        });
    let local = futures::stream::select(
        local_starts,
        futures::stream::select(
            local_interrupt
                .stream()
                .map(|(_, s)| Some(Input::Interrupt(s))),
            local_exit.stream().map(|(_, s)| Some(Input::Exit(s))),
        ),
    );
    // what this process delivers is looked at first: it is there without polling the DDS readers
    let mut signals = Box::pin(futures::stream::select_with_strategy(
        local,
        futures::stream::select(starts, futures::stream::select(interrupts, exits)),
        |_: &mut ()| futures::stream::PollNext::Left,
    ));

    // the state to write once the slot just begun has run up to its first await
    let mut pending_state: Option<ResponseState> = None;
    // a slot was just begun: once it has run to its first await, the state goes out and the machine resumes
    let mut first_await = false;
    let (notes_tx, mut notes) = tokio::sync::mpsc::unbounded_channel::<SlotNote>();
    let mut stop_requested = false;
    let mut malformed: u64 = 0;
    let mut last_malformed_report = std::time::Instant::now() - MALFORMED_REPORT_EVERY;
    loop {
        // Biased: the running slot is polled before any signal is taken, so a start behaviour that was just
        // begun runs up to its first await point before an interrupt can cancel it (`started` never announces
        // a behaviour that did not run at all).
        let fx = tokio::select! {
            biased;
            done = async {
                match d.current.as_mut() {
                    Some(slot) => slot.await,
                    None => std::future::pending().await,
                }
            } => {
                d.current = None;
                first_await = false;
                if let Some(st) = pending_state.take() {
                    d.io().publish_state(st);
                }
                // what the slot said before it ended comes first (a goal accepted and finished at once)
                let mut fx = Vec::new();
                while let Ok(note) = notes.try_recv() {
                    if let Some(input) = note_input(note) {
                        fx.extend(d.machine().handle_at(input, now_ns()));
                    }
                }
                fx.extend(d.machine().handle_at(done.into_input(), now_ns()));
                fx
            }
            // a slot that was just begun has run up to its first await (above): the state, and R12
            _ = std::future::ready(()), if first_await => {
                first_await = false;
                if let Some(st) = pending_state.take() {
                    d.io().publish_state(st);
                }
                let fx = d.machine().resume();
                if fx.is_empty() {
                    continue;
                }
                fx
            }
            Some(note) = notes.recv() => match note_input(note) {
                Some(input) => d.machine().handle_at(input, now_ns()),
                None => continue,
            },
            _ = &mut stop, if !stop_requested => {
                stop_requested = true;
                d.machine().stop()
            }
            sig = signals.next() => match sig {
                Some(Some(input)) => d.machine().handle_at(input, now_ns()),
                Some(None) => {
                    malformed += 1;
                    // shown at the next change; at most once a second for a flood of garbage alone
                    if last_malformed_report.elapsed() < MALFORMED_REPORT_EVERY {
                        continue;
                    }
                    last_malformed_report = std::time::Instant::now();
                    Vec::new()
                }
                None => break,
            },
        };
        let began = d.apply(fx, &notes_tx);
        let mut st = state_message::<R>(&name, d.machine());
        st.malformed = malformed;
        if began && d.current.is_some() {
            // the behaviour first: the state write is not on the way from a signal to its slot
            pending_state = Some(st);
            first_await = true;
        } else {
            d.io().publish_state(st);
        }
        if stop_requested && d.current.is_none() {
            break;
        }
    }
    tracing::info!(response = %name, "response stopped");
    drop(signals);
    drop(inboxes);
    drop(slots);
    d.finish().await;
}
