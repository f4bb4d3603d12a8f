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
        emit, panic_message, publisher, subscription, typed_publisher, ComponentTask, SignalWriter,
        Watched,
    },
    error::{Result, SlotError},
    local::Inbox,
    msg::{Empty, ResponseState, RosMessage, Time, TypeName},
    names::ComponentName,
    participant::Participant,
    qos::{signal_qos, state_qos},
    radar::Radar,
    raw::RawMessage,
    refs::{AsResponse, ResponseRef},
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

/// What a running slot tells the response's driver before it ends (rules 9 and 10).
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
        let state_pub =
            typed_publisher::<ResponseState>(g, &mut node, &name.topic("state"), &state_qos())?;

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
        let task = ComponentTask::spawn(move |stop_rx| async move {
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
        });
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

async fn drive<R: Response>(
    response: Arc<Mutex<R>>,
    mut machine: ResponseMachine<R::Start, R::Output>,
    io: Io<R>,
    slots: SlotReaders,
    mut inboxes: Inboxes,
    mut stop: tokio::sync::oneshot::Receiver<()>,
    participant: Arc<Participant>,
) {
    let name = io.name.clone();
    let (start_topic, int_topic, exit_topic) = (
        name.topic("start"),
        name.topic("interrupt"),
        name.topic("exit"),
    );
    let (start_t, empty_t) = (R::Start::ros_type_name(), Empty::ros_type_name());
    // samples from publishers of another type (see graph), and malformed ones, are dropped
    let SlotReaders {
        start: start_sub,
        interrupt: interrupt_sub,
        exit: exit_sub,
    } = &slots;
    // `None`: a message that did not decode (counted)
    let starts = start_sub
        .decoded::<R::Start>(&start_topic, &start_t)
        .map(|d| d.map(|(m, _)| Input::Start(m)));
    let interrupts = interrupt_sub
        .decoded::<Empty>(&int_topic, &empty_t)
        .map(|d| d.map(|_| Input::Interrupt));
    let exits = exit_sub
        .decoded::<Empty>(&exit_topic, &empty_t)
        .map(|d| d.map(|_| Input::Exit));
    let Inboxes {
        start: local_start,
        interrupt: local_interrupt,
        exit: local_exit,
    } = &mut inboxes;
    let local_starts = local_start.stream().map(|raw| match raw.decode::<R::Start>() {
        Ok(m) => Some(Input::Start(m)),
        Err(e) => {
            tracing::warn!(response = %name, error = %e, "a start delivered in this process did not decode");
            None
        }
    });
    let local = futures::stream::select(
        local_starts,
        futures::stream::select(
            local_interrupt.stream().map(|_| Some(Input::Interrupt)),
            local_exit.stream().map(|_| Some(Input::Exit)),
        ),
    );
    // what this process delivers is looked at first: it is there without polling the DDS readers
    let mut signals = Box::pin(futures::stream::select_with_strategy(
        local,
        futures::stream::select(starts, futures::stream::select(interrupts, exits)),
        |_: &mut ()| futures::stream::PollNext::Left,
    ));

    let mut current: Option<Slot<R::Output>> = None;
    // the state to write once the slot just begun has run up to its first await
    let mut pending_state: Option<ResponseState> = None;
    let publish_state = |st: ResponseState| {
        emit(&io.state_pub, "state", st.clone());
        io.state_tx.send_replace(st);
    };
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
                match current.as_mut() {
                    Some(slot) => slot.await,
                    None => std::future::pending().await,
                }
            } => {
                current = None;
                if let Some(st) = pending_state.take() {
                    publish_state(st);
                }
                // what the slot said before it ended comes first (a goal accepted and finished at once)
                let mut fx = Vec::new();
                while let Ok(note) = notes.try_recv() {
                    if let Some(input) = note_input(note) {
                        fx.extend(machine.handle(input));
                    }
                }
                fx.extend(machine.handle(done.into_input()));
                fx
            }
            // a slot that was just begun has run up to its first await (above): now the state
            _ = std::future::ready(()), if pending_state.is_some() => {
                publish_state(pending_state.take().expect("guarded"));
                continue;
            }
            Some(note) = notes.recv() => match note_input(note) {
                Some(input) => machine.handle(input),
                None => continue,
            },
            _ = &mut stop, if !stop_requested => {
                stop_requested = true;
                machine.stop()
            }
            sig = signals.next() => match sig {
                Some(Some(input)) => machine.handle(input),
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
        // whether a slot was begun (it runs before the state is written)
        let began = fx.iter().any(|e| {
            matches!(
                e,
                Effect::RunStart(_) | Effect::RunInterrupt | Effect::RunExit(_)
            )
        });
        for effect in fx {
            match effect {
                Effect::EmitStarted(p) => io.started.emit("started", p),
                Effect::RunStart(p) => {
                    let r = Arc::clone(&response);
                    current = Some(Box::pin(SLOT_NOTES.scope(notes_tx.clone(), async move {
                        let mut guard = r.lock_owned().await;
                        let end = match AssertUnwindSafe(guard.start(p)).catch_unwind().await {
                            Ok(Ok(o)) => StartEnd::Returned(o),
                            Ok(Err(e)) => StartEnd::Failed(e.0),
                            Err(panic) => StartEnd::Panicked(panic_message(panic)),
                        };
                        SlotDone::Start(end)
                    })));
                }
                Effect::CancelStart => current = None,
                Effect::EmitInterrupted => io.interrupted.emit("interrupted", Empty::default()),
                Effect::RunInterrupt => {
                    let r = Arc::clone(&response);
                    current = Some(Box::pin(SLOT_NOTES.scope(notes_tx.clone(), async move {
                        let mut guard = r.lock_owned().await;
                        let panic = AssertUnwindSafe(guard.interrupt())
                            .catch_unwind()
                            .await
                            .err();
                        SlotDone::Interrupt(panic.map(panic_message))
                    })));
                }
                Effect::RunExit(reason) => {
                    let r = Arc::clone(&response);
                    current = Some(Box::pin(SLOT_NOTES.scope(notes_tx.clone(), async move {
                        let mut guard = r.lock_owned().await;
                        let res = AssertUnwindSafe(guard.exit(reason)).catch_unwind().await;
                        SlotDone::Exit(res.map_err(panic_message))
                    })));
                }
                Effect::EmitExited(o) => io.exited.emit("exited", o),
                Effect::ReportPanic { slot, message } => {
                    tracing::error!(response = %name, slot, %message, "slot panicked; the response carries on")
                }
                Effect::Ignored { signal, phase } => {
                    tracing::debug!(response = %name, signal, phase = phase.label(), "signal ignored")
                }
            }
        }
        let mut st = state_message::<R>(&name, &machine);
        st.malformed = malformed;
        if began && current.is_some() {
            // the behaviour first: the state write is not on the way from a signal to its slot
            pending_state = Some(st);
        } else {
            publish_state(st);
        }
        if stop_requested && current.is_none() {
            break;
        }
    }
    tracing::info!(response = %name, "response stopped");
    // the final `exited` and state were just written: the participant's pool keeps their writers a moment
    // so they are not lost, without holding up the shutdown (the slots are gone already)
    drop(signals);
    drop(inboxes);
    drop(slots);
    participant.pool().retire(Box::new(io));
}
