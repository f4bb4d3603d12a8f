//! Running a response: its signals in, the machine's effects out, the state published; the run finished if
//! the runtime drops the task.

use std::{panic::AssertUnwindSafe, sync::Arc};

use futures::{FutureExt, StreamExt};
use tokio::sync::{watch, Mutex};

use radar_semantics::response::{Effect, ExitReason, Input, ResponseMachine};

use super::{
    slots::{exit_slot, interrupt_slot, note_input, start_slot, NotesTx, Slot, SlotNote},
    Response,
};
use crate::{
    node::endpoints::{emit, panic_message, SignalWriter, Watched},
    node::participant::Participant,
    wire::local::now_ns,
    wire::local::Inbox,
    wire::msg::{Empty, ResponseState, RosMessage, Time},
    wire::names::ComponentName,
    wire::raw::RawMessage,
};

/// A response's endpoints, as its task takes them.
pub(crate) struct Endpoints<R: Response> {
    pub(crate) slots: SlotReaders,
    pub(crate) inboxes: Inboxes,
    pub(crate) io: Io<R>,
}

/// What this process's connections hand a response's slots directly (see [`crate::wire::local`]).
pub(crate) struct Inboxes {
    pub(crate) start: Inbox,
    pub(crate) interrupt: Inbox,
    pub(crate) exit: Inbox,
}

/// The slot readers of a response.
pub(crate) struct SlotReaders {
    pub(crate) start: Watched<crate::node::transport::Subscription<RawMessage>>,
    pub(crate) interrupt: Watched<crate::node::transport::Subscription<RawMessage>>,
    pub(crate) exit: Watched<crate::node::transport::Subscription<RawMessage>>,
}

/// A response's writers: its signals and its state.
pub(crate) struct Io<R: Response> {
    pub(crate) name: ComponentName,
    /// The ROS type of its start slot.
    pub(crate) start_type: String,
    /// `exited`'s payload for a run that did not complete, if `Output::default()` is not one
    /// ([`Response::incomplete_output`]).
    pub(crate) incomplete_output: Option<R::Output>,
    pub(crate) started: SignalWriter<R::Start>,
    pub(crate) interrupted: SignalWriter<Empty>,
    pub(crate) exited: SignalWriter<R::Output>,
    /// A start a statement sent that was not taken, with its cause (R6).
    /// `None` where security does not grant it (an enclave's permissions from before it).
    pub(crate) dropped: Option<SignalWriter<Empty>>,
    pub(crate) state_pub: Watched<crate::node::transport::Publisher<ResponseState>>,
    pub(crate) state_tx: watch::Sender<ResponseState>,
}

/// The state message of the response `name` whose machine is `m`.
pub(crate) fn state_message<R: Response>(
    name: &ComponentName,
    start_type: &str,
    m: &ResponseMachine<R::Start, R::Output>,
) -> ResponseState {
    let c = m.counters();
    ResponseState {
        stamp: Time::now(),
        name: name.fully_qualified(),
        state: m.phase().code(),
        state_label: m.phase().label().to_owned(),
        start_type: start_type.to_owned(),
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
    /// What `exited` carries for the machine's output `o`: `o`, unless it is the default of a type whose
    /// default is no message (a `DynMessage` without bytes), then the response's
    /// [`incomplete_output`](Response::incomplete_output).
    fn exited_payload(&self, o: R::Output) -> R::Output {
        match &self.incomplete_output {
            Some(d) if crate::wire::raw::RawMessage::encode(&o).is_ok_and(|r| r.is_empty()) => {
                d.clone()
            }
            _ => o,
        }
    }

    /// Waits (blocking the thread, at most `limit`) until the subscribers of the signals and the state have
    /// acknowledged what was sent: the program is about to leave.
    fn flush(&self, limit: std::time::Duration) {
        let deadline = std::time::Instant::now() + limit;
        let left = || deadline.saturating_duration_since(std::time::Instant::now());
        let _ = self.exited.wait_for_acknowledgments(left());
        if let Some(d) = &self.dropped {
            let _ = d.wait_for_acknowledgments(left());
        }
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
/// of a run (the program's `main` returned), the drop finishes the run (R7; [`crate::node::shutdown`]).
struct Driver<R: Response> {
    name: ComponentName,
    response: Arc<Mutex<R>>,
    machine: Option<ResponseMachine<R::Start, R::Output>>,
    io: Option<Io<R>>,
    /// The slot running now.
    current: Option<Slot<R::Output>>,
    /// The state to write once the slot just begun has run up to its first await.
    pending_state: Option<ResponseState>,
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

    /// The slot that ran has ended with `done`: what it said before it ended first (a goal accepted and
    /// finished at once), then its end; the machine's effects.
    fn slot_ended(
        &mut self,
        done: super::slots::SlotDone<R::Output>,
        notes: &mut tokio::sync::mpsc::UnboundedReceiver<SlotNote>,
    ) -> Vec<Effect<R::Start, R::Output>> {
        self.current = None;
        if let Some(st) = self.pending_state.take() {
            self.io().publish_state(st);
        }
        let mut fx = Vec::new();
        while let Ok(note) = notes.try_recv() {
            if let Some(input) = note_input(note) {
                fx.extend(self.machine().handle_at(input, now_ns()));
            }
        }
        fx.extend(self.machine().handle_at(done.into_input(), now_ns()));
        fx
    }

    /// The slot just begun has run up to its first await: its state goes out, and the machine resumes (R12).
    fn first_await(&mut self) -> Vec<Effect<R::Start, R::Output>> {
        if let Some(st) = self.pending_state.take() {
            self.io().publish_state(st);
        }
        self.machine().resume()
    }

    /// Publishes the state after effects were carried out; if they began a slot, holds it until that slot has
    /// run to its first await (the behaviour first: the state write is not on the way from a signal to its
    /// slot).
    fn state_after(&mut self, began: bool, malformed: u64) {
        let machine = self
            .machine
            .as_ref()
            .expect("the machine lives until the driver ends");
        let start_type = self.io.as_ref().map_or("", |io| io.start_type.as_str());
        let mut st = state_message::<R>(&self.name, start_type, machine);
        st.malformed = malformed;
        if began && self.current.is_some() {
            self.pending_state = Some(st);
        } else {
            self.io().publish_state(st);
        }
    }

    /// Carries out the machine's effects; whether a slot was begun.
    fn apply(&mut self, fx: Vec<Effect<R::Start, R::Output>>, notes: &NotesTx) -> bool {
        let mut began = false;
        for effect in fx {
            match effect {
                Effect::EmitStarted(p, cause) => {
                    self.io().started.emit("started", p, cause);
                }
                Effect::RunStart(p) => {
                    began = true;
                    self.current = Some(start_slot(Arc::clone(&self.response), p, notes));
                }
                Effect::CancelStart => self.current = None,
                Effect::EmitInterrupted(cause) => {
                    self.io()
                        .interrupted
                        .emit("interrupted", Empty::default(), cause);
                }
                Effect::RunInterrupt => {
                    began = true;
                    self.current = Some(interrupt_slot(Arc::clone(&self.response), notes));
                }
                Effect::RunExit(reason) => {
                    began = true;
                    self.current = Some(exit_slot(Arc::clone(&self.response), reason, notes));
                }
                Effect::EmitExited(o, cause) => {
                    let io = self.io();
                    let o = io.exited_payload(o);
                    io.exited.emit("exited", o, cause);
                }
                Effect::EmitDropped(cause) => {
                    if let Some(d) = &self.io().dropped {
                        d.emit("dropped", Empty::default(), Some(cause));
                    }
                }
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
        let finished = crate::node::shutdown::run_detached(what, timeout, async move {
            let mut guard = response.lock_owned().await;
            let res = AssertUnwindSafe(async { guard.exit(reason).await })
                .catch_unwind()
                .await;
            drop(guard);
            let fx = machine.handle_at(Input::ExitEnded(res.map_err(panic_message)), now_ns());
            for e in fx {
                match e {
                    Effect::EmitExited(o, cause) => {
                        let o = io.exited_payload(o);
                        io.exited.emit("exited", o, cause);
                    }
                    Effect::ReportPanic { slot, message } => {
                        tracing::error!(response = %name, slot, %message, "slot panicked")
                    }
                    _ => {}
                }
            }
            io.publish_state(state_message::<R>(&name, &io.start_type, &machine));
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

/// A response's slot topics and their types.
struct SlotTopics {
    response: String,
    start: String,
    interrupt: String,
    exit: String,
    start_type: String,
    empty_type: String,
}

impl SlotTopics {
    fn of(name: &ComponentName, start_type: &str) -> SlotTopics {
        SlotTopics {
            response: name.fully_qualified(),
            start: name.endpoint(crate::endpoint::Endpoint::Start),
            interrupt: name.endpoint(crate::endpoint::Endpoint::Interrupt),
            exit: name.endpoint(crate::endpoint::Endpoint::Exit),
            start_type: start_type.to_owned(),
            empty_type: Empty::ros_type_name(),
        }
    }
}

/// A response's slot signals as the machine's inputs: what this process delivers first (it is there without
/// polling the DDS readers), then the DDS readers'. Samples from publishers of another type (see graph) are
/// dropped; `None` is a message that did not decode (counted). Each signal comes with when and by which
/// statement it was sent (R11-R13).
fn slot_signals<'a, R: Response>(
    t: &'a SlotTopics,
    slots: &'a SlotReaders,
    inboxes: &'a mut Inboxes,
) -> impl futures::Stream<Item = Option<Input<R::Start, R::Output>>> + 'a {
    let sent = |info: &ros2_client::MessageInfo| crate::wire::cause::sent(info, now_ns());
    let starts = slots
        .start
        .decoded::<R::Start>(&t.start, &t.start_type)
        .map(move |d| d.map(|(m, info)| Input::Start(m, sent(&info))));
    let interrupts = slots
        .interrupt
        .decoded::<Empty>(&t.interrupt, &t.empty_type)
        .map(move |d| d.map(|(_, info)| Input::Interrupt(sent(&info))));
    let exits = slots
        .exit
        .decoded::<Empty>(&t.exit, &t.empty_type)
        .map(move |d| d.map(|(_, info)| Input::Exit(sent(&info))));
    let name = &t.response;
    let Inboxes {
        start: local_start,
        interrupt: local_interrupt,
        exit: local_exit,
    } = inboxes;
    let local_starts = local_start
        .stream()
        .map(move |(raw, s)| match raw.decode::<R::Start>() {
            Ok(m) => Some(Input::Start(m, s)),
            Err(e) => {
                tracing::warn!(response = %name, error = %crate::error::Report(&e), "a start delivered in this process did not decode");
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
    futures::stream::select_with_strategy(
        local,
        futures::stream::select(starts, futures::stream::select(interrupts, exits)),
        |_: &mut ()| futures::stream::PollNext::Left,
    )
}

/// Runs a response until it is stopped and its last run has ended.
/// Signals that did not decode, counted: shown in the state at the next change, or at most once a second for
/// a flood of garbage alone.
#[derive(Default)]
struct Malformed {
    count: u64,
    reported: Option<std::time::Instant>,
}

impl Malformed {
    /// One more; whether to show the count now.
    fn note(&mut self) -> bool {
        self.count += 1;
        if self
            .reported
            .is_some_and(|at| at.elapsed() < MALFORMED_REPORT_EVERY)
        {
            return false;
        }
        self.reported = Some(std::time::Instant::now());
        true
    }
}

pub(crate) async fn drive<R: Response>(
    response: Arc<Mutex<R>>,
    machine: ResponseMachine<R::Start, R::Output>,
    endpoints: Endpoints<R>,
    mut stop: tokio::sync::oneshot::Receiver<()>,
    participant: Arc<Participant>,
) {
    let Endpoints {
        slots,
        mut inboxes,
        io,
    } = endpoints;
    let name = io.name.clone();
    let topics = SlotTopics::of(&name, &io.start_type);
    // declared first, dropped last: if the runtime drops this task, the slots' readers go first, then the
    // driver finishes the run
    let mut d = Driver {
        name: name.clone(),
        response,
        machine: Some(machine),
        io: Some(io),
        current: None,
        pending_state: None,
        participant,
        finished: false,
    };
    let mut signals = Box::pin(slot_signals::<R>(&topics, &slots, &mut inboxes));
    let (notes_tx, mut notes) = tokio::sync::mpsc::unbounded_channel::<SlotNote>();
    let mut stop_requested = false;
    let mut malformed = Malformed::default();
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
            } => d.slot_ended(done, &mut notes),
            // a slot that was just begun has run up to its first await (above): the state, and R12
            _ = std::future::ready(()), if d.pending_state.is_some() => match d.first_await() {
                fx if fx.is_empty() => continue,
                fx => fx,
            },
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
                Some(None) if malformed.note() => Vec::new(),
                Some(None) => continue,
                None => break,
            },
        };
        let began = d.apply(fx, &notes_tx);
        d.state_after(began, malformed.count);
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
