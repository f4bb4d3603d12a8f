//! A RADAR response as an action server: the rules S1-S7 are [`radar_semantics::served`]'s; this file reads
//! goals, cancel requests and the response's signals, and carries out what the rules decide.

use std::{sync::Arc, time::Duration};

use crate::node::action_server::{CancelRequest, Goal, NewGoal};
use crate::node::transport::action::{GoalEndStatus, GoalId};

use radar_semantics::{
    response::ExitReason,
    served::{Effect, EndStatus, ResponseView, ServedAction},
};

use super::{wire::Wire, Action};
use crate::{
    graph::Graph,
    node::endpoints::REPLY_WAIT,
    node::shutdown::ComponentTask,
    wire::dds_names::{self, ActionService},
    wire::msg::{Empty, ResponseState},
    wire::names::ComponentName,
};

/// A response served as an action server; dropping it stops the server (a running goal is aborted).
#[must_use = "the action server runs only while its handle lives; bind it (`let s = radar.serve_as_action(..)?`)"]
pub struct ActionServerHandle {
    pub(crate) action: String,
    pub(crate) response: ComponentName,
    pub(crate) task: ComponentTask,
}

impl ActionServerHandle {
    /// The action's fully qualified name.
    pub fn action(&self) -> &str {
        &self.action
    }
    /// The response it drives.
    pub fn response(&self) -> &ComponentName {
        &self.response
    }
    /// Stops the server (a running goal is aborted, the response is interrupted) and waits (unbounded unless
    /// `.timeout(d)`).
    ///
    /// # Cancel safety
    ///
    /// The stop is asked for when this is called; dropping the returned wait (or its timeout running out)
    /// leaves the component finishing on its own, its exit slot included.
    pub fn shutdown(self) -> crate::Wait<'static, ()> {
        self.task.shutdown()
    }
}

impl std::fmt::Debug for ActionServerHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ActionServerHandle")
            .field("action", &self.action)
            .field("response", &self.response.fully_qualified())
            .finish()
    }
}

pub(crate) struct ServerIo<A: Action> {
    pub(crate) start: crate::node::topics::SignalPublisher<A::Goal>,
    pub(crate) interrupt: crate::node::topics::SignalPublisher<Empty>,
    pub(crate) started: crate::node::topics::SignalSubscription<A::Goal>,
    pub(crate) exited: crate::node::topics::SignalSubscription<A::Result>,
    pub(crate) feedback: crate::node::topics::SignalSubscription<A::Feedback>,
    pub(crate) state: crate::node::topics::SignalSubscription<ResponseState>,
}

use super::wire::Server;

/// Numbers the statements of served actions (R13): far above any connection's number, so that a manager of
/// the same participant never takes one for its own.
static SERVER_STATEMENTS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1 << 48);

enum Incoming<G> {
    /// A goal request, and its goal (`None`: it did not decode).
    Goal(NewGoal<Wire<G>>, Option<Wire<G>>),
    Cancel(CancelRequest),
}

/// Waits (at most [`REPLY_WAIT`] each) until every participant that has a request writer on the action's
/// `service` is matched by our reply writer (and, for goals, our feedback writer): a fresh client process (`ros2 action send_goal`) can send its
/// request before we have matched its reply reader, and a reply sent then goes nowhere.
async fn wait_callers(graph: &Graph, action: &str, service: ActionService) {
    let request = dds_names::request(&service.of(action));
    let reply = dds_names::reply(&service.of(action));
    // a goal's sender also reads feedback (a volatile topic): match it first, or a fresh client (`ros2
    // action send_goal --feedback`) misses the first feedback of the goal
    let feedback = dds_names::topic(&dds_names::action_feedback(action));
    let callers = graph.participants_matched_on(&[(false, request)]);
    for c in callers {
        if !graph.wait_reader_of(&reply, c, REPLY_WAIT).await {
            tracing::debug!(%action, ?service, "answering before the caller's reply reader is matched");
        }
        if service == ActionService::SendGoal
            && !graph.wait_reader_of(&feedback, c, REPLY_WAIT).await
        {
            tracing::debug!(%action, "starting a goal before the caller's feedback reader is matched");
        }
    }
}

/// The goal the server runs, by how far it got.
enum Handle<G> {
    Accepted(Goal<Wire<G>>),
    Executing(Goal<Wire<G>>),
}

/// A goal just read: its request and its payload.
type Fresh<G> = (NewGoal<Wire<G>>, G);

/// What the rules look at: the response's last state and whether its start slot is matched.
fn view(state: &Option<ResponseState>, on_graph: bool) -> ResponseView {
    match state {
        // a response that publishes no state is taken to be idle
        None => ResponseView {
            idle: true,
            on_graph,
            ..ResponseView::default()
        },
        Some(s) => ResponseView {
            idle: s.state == crate::Phase::Idle.code(),
            on_graph,
            exits: s.exits,
            ignored_starts: s.ignored_starts,
            last_exit: ExitReason::parse(&s.last_exit_reason),
        },
    }
}

/// The action server's side of a served response: reads what comes, asks the rules, carries out their effects.
struct Serving<A: Action> {
    server: Arc<Server<A>>,
    io: ServerIo<A>,
    action: String,
    rules: ServedAction<GoalId, A::Result>,
    /// A goal just read, until the rules accept or reject it.
    new: Option<Fresh<A::Goal>>,
    /// The cancel request just read, until the rules answer it.
    cancel: Option<CancelRequest>,
    /// The current goal's handle.
    goal: Option<(GoalId, Handle<A::Goal>)>,
}

impl<A: Action> Serving<A> {
    /// Carries out `effects` in order (rules S1-S7 of [`radar_semantics::served`]).
    /// S1: the new goal is accepted, and its start sent to the response.
    async fn accept(&mut self, goal: GoalId, start: radar_semantics::response::Sent) {
        let action = &self.action;
        let Some((h, payload)) = self.new.take() else {
            return;
        };
        match self.server.accept_goal(h).await {
            Ok(h) => {
                self.goal = Some((goal, Handle::Accepted(h)));
                if let Err(e) = self.io.start.publish_sent(payload, start) {
                    tracing::warn!(%action, error = %crate::error::Report(&e), "could not start the response");
                }
            }
            Err(e) => {
                tracing::warn!(%action, error = ?e, "could not accept a goal");
                self.rules.accept_failed(&goal);
            }
        }
    }

    async fn carry_out(&mut self, effects: Vec<Effect<GoalId, A::Result>>) {
        let action = self.action.clone();
        let action = action.as_str();
        for fx in effects {
            match fx {
                Effect::Accept { goal, start } => self.accept(goal, start).await,
                Effect::Reject(_) => {
                    let Some((h, _)) = self.new.take() else {
                        continue;
                    };
                    tracing::info!(%action, "goal rejected: the response is busy or not on the graph (rule S2)");
                    if let Err(e) = self.server.reject_goal(h).await {
                        tracing::warn!(%action, error = ?e, "could not reject a goal");
                    }
                }
                Effect::AnswerCancel(goals) => {
                    let Some(c) = self.cancel.take() else {
                        continue;
                    };
                    if let Err(e) = self
                        .server
                        .respond_to_cancel_requests(&c, goals.into_iter())
                        .await
                    {
                        tracing::warn!(%action, error = ?e, "could not answer a cancel request");
                    }
                }
                Effect::Interrupt(sent) => {
                    if let Err(e) = self.io.interrupt.publish_sent(Empty::default(), sent) {
                        tracing::warn!(%action, error = %crate::error::Report(&e), "could not interrupt the response");
                    }
                }
                Effect::Execute(goal) => {
                    let accepted = |(id, h): &(GoalId, Handle<A::Goal>)| {
                        *id == goal && matches!(h, Handle::Accepted(_))
                    };
                    if let Some((id, Handle::Accepted(h))) = self.goal.take_if(|g| accepted(g)) {
                        match self.server.start_executing_goal(h).await {
                            Ok(e) => self.goal = Some((id, Handle::Executing(e))),
                            Err(e) => {
                                tracing::warn!(%action, error = ?e, "could not mark the goal executing")
                            }
                        }
                    }
                }
                Effect::Finish {
                    goal,
                    status,
                    result,
                } => {
                    let Some((_, h)) = self.goal.take_if(|(id, _)| *id == goal) else {
                        continue;
                    };
                    if status == EndStatus::Aborted && result.is_none() {
                        tracing::info!(%action, "goal aborted: the response ignored it, did not start it in time, left, or the server stops (rule S6)");
                    }
                    let status = match status {
                        EndStatus::Succeeded => GoalEndStatus::Succeeded,
                        EndStatus::Canceled => GoalEndStatus::Canceled,
                        EndStatus::Aborted => GoalEndStatus::Aborted,
                    };
                    finish::<A>(&self.server, action, h, status, result.unwrap_or_default());
                }
            }
        }
    }

    /// S5: feedback goes to the executing goal.
    async fn feedback(&self, f: A::Feedback) {
        if let Some((_, Handle::Executing(h))) = &self.goal {
            if let Err(e) = self.server.publish_feedback(h, Wire(f)).await {
                tracing::debug!(action = %self.action, error = ?e, "feedback not sent");
            }
        }
    }
}

/// Reads goals and cancel requests in tasks of their own (a read is never cancelled half-way), each once its
/// sender's reply reader is matched, and hands them over in the order they were read.
fn read_requests<A: Action>(
    server: &Arc<Server<A>>,
    graph: &Graph,
    action: &str,
) -> (
    tokio::sync::mpsc::UnboundedReceiver<Incoming<A::Goal>>,
    [tokio::task::JoinHandle<()>; 3],
) {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let (s, tx2, g, a) = (server.clone(), tx.clone(), graph.clone(), action.to_owned());
    let goals = tokio::spawn(async move {
        while let Ok((h, goal)) = s.receive_new_goal().await {
            wait_callers(&g, &a, ActionService::SendGoal).await;
            if tx2.send(Incoming::Goal(h, goal)).is_err() {
                break;
            }
        }
    });
    let (s, g, a) = (server.clone(), graph.clone(), action.to_owned());
    let cancels = tokio::spawn(async move {
        while let Ok(c) = s.receive_cancel_request().await {
            wait_callers(&g, &a, ActionService::CancelGoal).await;
            if tx.send(Incoming::Cancel(c)).is_err() {
                break;
            }
        }
    });
    let s = server.clone();
    let results = tokio::spawn(async move { s.answer_results().await });
    (rx, [goals, cancels, results])
}

/// Resolves at `deadline` (ns since the epoch), never if there is none.
async fn sleep_until_ns(deadline: Option<i64>) {
    match deadline {
        Some(t) => {
            let ns = (t - crate::wire::local::now_ns()).max(0) as u64;
            tokio::time::sleep(Duration::from_nanos(ns)).await
        }
        None => std::future::pending().await,
    }
}

pub(crate) async fn serve<A: Action>(
    server: Arc<Server<A>>,
    io: ServerIo<A>,
    graph: Graph,
    action: String,
    mut stop: tokio::sync::oneshot::Receiver<()>,
) {
    let (mut incoming, readers) = read_requests::<A>(&server, &graph, &action);
    // this server's starts carry causes of its own (R13): its participant's statement base, and a number no
    // connection of its manager has
    let statement = (u128::from(crate::wire::cause::statement_base(graph.own_id())) << 64)
        | u128::from(SERVER_STATEMENTS.fetch_add(1, std::sync::atomic::Ordering::Relaxed));
    let mut state = io.state.try_recv();
    let mut s = Serving::<A> {
        server,
        io,
        action,
        rules: ServedAction::new(statement),
        new: None,
        cancel: None,
        goal: None,
    };
    let now = crate::wire::local::now_ns;
    loop {
        // a RADAR response publishes its state, and carries causes
        let keeps_causes = s.io.state.publishers() > 0;
        let deadline = s.rules.next_deadline();
        let effects = tokio::select! {
            _ = &mut stop => break,
            Some(inc) = incoming.recv() => match inc {
                Incoming::Goal(h, goal) => match goal {
                    Some(Wire(goal)) => {
                        let id = h.goal_id();
                        s.new = Some((h, goal));
                        let v = view(&state, s.io.start.subscribers() > 0);
                        s.rules.goal(id, &v, now())
                    }
                    None => {
                        tracing::warn!(action = %s.action, "a goal that does not decode: rejected");
                        let _ = s.server.reject_goal(h).await;
                        Vec::new()
                    }
                },
                Incoming::Cancel(c) => {
                    let fx = s.rules.cancel(|g| c.contains_goal(g), now());
                    s.cancel = Some(c);
                    fx
                }
            },
            Ok((_, sent)) = s.io.started.recv_sent() => s.rules.started(&sent, keeps_causes, now()),
            Ok(f) = s.io.feedback.recv() => {
                s.feedback(f).await;
                Vec::new()
            }
            Ok((result, sent)) = s.io.exited.recv_sent() => {
                let v = view(&state, s.io.start.subscribers() > 0);
                s.rules.exited(result, &sent, keeps_causes, &v, now())
            }
            Ok(st) = s.io.state.recv() => {
                state = Some(st);
                let v = view(&state, s.io.start.subscribers() > 0);
                s.rules.state(&v, now())
            }
            _ = sleep_until_ns(deadline) => s.rules.tick(now()),
            _ = s.io.start.wait_for_no_subscribers(), if s.rules.goal_running() => s.rules.response_gone(),
        };
        s.carry_out(effects).await;
    }
    let effects = s.rules.stop(now());
    s.carry_out(effects).await;
    for r in readers {
        r.abort();
    }
}

/// Sends the goal's result in a task of its own: the reply waits for the client's result request.
fn finish<A: Action>(
    server: &Arc<Server<A>>,
    action: &str,
    h: Handle<A::Goal>,
    status: GoalEndStatus,
    result: A::Result,
) {
    let (server, action) = (server.clone(), action.to_owned());
    tokio::spawn(async move {
        let (Handle::Executing(h) | Handle::Accepted(h)) = h;
        let send = server.send_result_response(h, status, Wire(result));
        match tokio::time::timeout(Duration::from_secs(60), send).await {
            Ok(Ok(())) => tracing::debug!(%action, ?status, "goal result sent"),
            Ok(Err(e)) => tracing::warn!(%action, error = ?e, "could not send a goal's result"),
            Err(_) => tracing::debug!(%action, "no client asked for the goal's result within 60 s"),
        }
    });
}
