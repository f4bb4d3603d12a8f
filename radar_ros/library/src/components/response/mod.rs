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
//! Signal QoS is reliable, volatile, keep-last 10 ([`crate::wire::qos::signal_qos`]). What happens
//! on each signal is decided by [`ResponseMachine`]; this module runs the slots and moves the messages.
//!
//! Files: this one holds the [`Response`] trait and [`FnResponse`]; `handle.rs` the user's [`ResponseHandle`];
//! `spawn.rs` makes a response's node and endpoints; `driver.rs` runs it (signals in, the machine's effects
//! out, the run finished if the runtime goes); `slots.rs` runs one slot and carries what it says before it
//! ends.

pub(crate) mod driver;
mod handle;
mod slots;
pub(crate) mod spawn;

use std::future::Future;

use futures::{future::BoxFuture, FutureExt};

use radar_semantics::response::{ExitAction, ExitReason, StartPolicy};

use crate::{
    components::own_node::ComponentNode,
    error::{Result, SlotError},
    wire::msg::RosMessage,
};
pub use handle::ResponseHandle;
pub(crate) use slots::{accepted, hand_over};

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

    /// The ROS type of the `start` slot and of `started`, as `pkg/msg/Name`. Default: `Start`'s. A response
    /// whose `Start` is a [`DynMessage`](crate::topics::DynMessage) says here what it is.
    fn start_type(&self) -> String {
        Self::Start::ros_type_name()
    }

    /// The ROS type of `exited`. Default: `Output`'s; say it here when that is a
    /// [`DynMessage`](crate::topics::DynMessage).
    fn output_type(&self) -> String {
        Self::Output::ros_type_name()
    }

    /// The `exited` payload of a run that did not complete (interrupted, failed, ended by an exit signal)
    /// when `Output::default()` is no message of the output type: a [`DynMessage`](crate::topics::DynMessage)'s
    /// default has no bytes, so a response whose `Output` is one gives its type's default message here.
    /// Default `None`: `Output::default()` is sent.
    fn incomplete_output(&self) -> Option<Self::Output> {
        None
    }

    /// What `start` does while a run is in progress. Default: ignore.
    fn start_policy(&self) -> StartPolicy {
        StartPolicy::Ignore
    }

    /// Called once when the response's node exists, before any slot runs: declare parameters here
    /// ([`ResponseNode::declare`]).
    fn attach(&mut self, node: &mut ResponseNode<'_>) -> Result<()> {
        let _ = node;
        Ok(())
    }
}

/// A response's own node while it is being set up ([`Response::attach`]): a [`ComponentNode`].
pub type ResponseNode<'a> = ComponentNode<'a>;

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
