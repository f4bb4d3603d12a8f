//! What goes in and out of a response machine: signals with their cause and time, the slots' ends, the
//! effects, the phases and policies, the counters.

/// A statement (a connection) that delivers signals, unique on the ROS graph: the binding makes it from its
/// manager's participant and the connection's number.
pub type StatementId = u128;

/// Which statement delivered a slot signal, and which of its deliveries it was (R13). On the wire it is the
/// DDS sample's related sample identity; peers that know nothing of it (rclpy) send none and ignore it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cause {
    /// The statement.
    pub statement: StatementId,
    /// Its delivery, counted from 1 (0 on an `until`'s interrupt, which names the statement only).
    pub delivery: u64,
}

/// When, and by which statement, a slot signal was sent (R11-R13).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Sent {
    /// When the signal that caused it was emitted, in ns since the epoch: the DDS source timestamp of the
    /// original signal (a relay keeps it).
    pub at: i64,
    /// For a `start`: the statement delivery that sent it (`None`: injected, or sent by a peer that carries no
    /// cause). For an `interrupt`: the `until` statement whose run it is meant for (`None`: whatever runs).
    /// Not looked at for `exit`.
    pub by: Option<Cause>,
}

impl Sent {
    /// A signal emitted at `at` by no statement.
    pub fn at(at: i64) -> Sent {
        Sent { at, by: None }
    }

    /// A signal emitted at `at`, sent by `cause`.
    pub fn by(at: i64, cause: Cause) -> Sent {
        Sent {
            at,
            by: Some(cause),
        }
    }

    /// This signal as a receiver whose clock reads `now` takes it: its stamp brought within
    /// [`LATE`](crate::time::LATE) before `now` (rule T1).
    pub fn received(self, now: i64) -> Sent {
        Sent {
            at: crate::time::received(self.at, now),
            ..self
        }
    }
}

/// Where a response is in its lifecycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Waiting for `start`.
    Idle,
    /// The start behaviour runs.
    Running,
    /// The interrupt slot runs.
    Interrupting,
    /// The exit slot runs.
    Exiting,
}

impl Phase {
    /// The word shown in the state message.
    pub fn label(self) -> &'static str {
        match self {
            Phase::Idle => "idle",
            Phase::Running => "running",
            Phase::Interrupting => "interrupting",
            Phase::Exiting => "exiting",
        }
    }

    /// The `radar_msgs/msg/ResponseState` constant.
    pub fn code(self) -> u8 {
        match self {
            Phase::Idle => 0,
            Phase::Running => 1,
            Phase::Interrupting => 2,
            Phase::Exiting => 3,
        }
    }
}

/// What a response does with `start` while it is not idle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum StartPolicy {
    /// Ignore the signal (counted in the state). The default, as in RADAR.
    #[default]
    Ignore,
    /// Interrupt the current run (interrupt slot, exit slot, `exited`), then start with the new payload.
    Restart,
    /// Keep the newest payload and start it after the current run's `exited`.
    QueueOne,
}

impl StartPolicy {
    /// The word shown in the state message.
    pub fn label(self) -> &'static str {
        match self {
            StartPolicy::Ignore => "ignore",
            StartPolicy::Restart => "restart",
            StartPolicy::QueueOne => "queue_one",
        }
    }
}

/// When a response emits `started` (R9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Announce {
    /// As the start behaviour begins (R1). The default.
    #[default]
    OnStart,
    /// When the start behaviour reports [`Input::Accepted`] (an action server accepted the goal).
    WhenAccepted,
}

/// Why the exit slot is running.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum ExitReason {
    /// The start behaviour returned normally.
    Completed,
    /// An `interrupt` signal ended the run (the interrupt slot has run).
    Interrupted,
    /// An `exit` signal ended the run, or the response was stopped.
    ExitSignal,
    /// The start behaviour returned an error.
    Failed(String),
    /// The start behaviour panicked.
    Panicked(String),
}

impl ExitReason {
    /// The text shown in the state message.
    pub fn describe(&self) -> String {
        match self {
            ExitReason::Completed => "completed".into(),
            ExitReason::Interrupted => "interrupted".into(),
            ExitReason::ExitSignal => "exit_signal".into(),
            ExitReason::Failed(e) => format!("failed: {e}"),
            ExitReason::Panicked(e) => format!("panicked: {e}"),
        }
    }

    /// The reason a state message shows ([`ExitReason::describe`]'s text), back as a reason; `None` for a
    /// text that is none of them (an empty one: no run has ended yet).
    ///
    /// ```
    /// use radar_semantics::response::ExitReason;
    /// let r = ExitReason::Failed("no map".into());
    /// assert_eq!(ExitReason::parse(&r.describe()), Some(r));
    /// assert_eq!(ExitReason::parse(""), None);
    /// ```
    pub fn parse(text: &str) -> Option<ExitReason> {
        Some(match text {
            "completed" => ExitReason::Completed,
            "interrupted" => ExitReason::Interrupted,
            "exit_signal" => ExitReason::ExitSignal,
            _ => match text.split_once(": ") {
                Some(("failed", e)) => ExitReason::Failed(e.into()),
                Some(("panicked", e)) => ExitReason::Panicked(e.into()),
                _ => return None,
            },
        })
    }
}

/// How the start behaviour ended.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum StartEnd<O> {
    /// It returned this output.
    Returned(O),
    /// It returned an error.
    Failed(String),
    /// It panicked with this message.
    Panicked(String),
}

/// What the exit slot decided.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ExitAction {
    /// Go idle after `exited`.
    #[default]
    Done,
    /// Start again with the same payload after `exited` (the paper's `on exit: restart`).
    Restart,
}

/// An input to the machine.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Input<P, O> {
    /// A `start` signal with its payload.
    Start(P, Sent),
    /// An `interrupt` signal.
    Interrupt(Sent),
    /// An `exit` signal.
    Exit(Sent),
    /// The start behaviour ended by itself.
    StartEnded(StartEnd<O>),
    /// The interrupt slot finished (`Some(message)` if it panicked).
    InterruptEnded(Option<String>),
    /// The exit slot finished with a decision, or panicked (`Err(message)`).
    ExitEnded(Result<ExitAction, String>),
    /// The start behaviour has really begun (R9: emits `started` under [`Announce::WhenAccepted`]).
    Accepted,
    /// A slot handed over the run's output before ending (R10).
    Output(O),
}

/// Why a signal was ignored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IgnoreReason {
    /// Nothing it could act on: an `interrupt` or `exit` while not running (R5), a `start` while busy (R6), or
    /// anything while stopping.
    Phase,
    /// It was emitted before the current run began (R11).
    Before,
    /// An `until`'s interrupt for runs of another statement than the one running (R13).
    OtherRun,
}

/// Something the runtime must do, in the order given.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Effect<P, O> {
    /// Publish `started` with the payload, carrying the run's cause (R13).
    EmitStarted(P, Option<Cause>),
    /// Begin the start behaviour with the payload.
    RunStart(P),
    /// Cancel the running start behaviour (drop it at its current await point).
    CancelStart,
    /// Publish `interrupted`, carrying the run's cause.
    EmitInterrupted(Option<Cause>),
    /// Begin the interrupt slot.
    RunInterrupt,
    /// Begin the exit slot.
    RunExit(ExitReason),
    /// Publish `dropped` carrying this cause: a start that statement sent was not taken (R6), so no run of it
    /// comes (C3).
    EmitDropped(Cause),
    /// Publish `exited` with the output of the run (the start behaviour's result, or the default), carrying
    /// the run's cause.
    EmitExited(O, Option<Cause>),
    /// A slot panicked: log it (it is already counted).
    ReportPanic {
        /// Which slot.
        slot: &'static str,
        /// The panic message.
        message: String,
    },
    /// A signal was ignored: log it at debug level (it is already counted).
    Ignored {
        /// Which signal.
        signal: &'static str,
        /// The phase it arrived in.
        phase: Phase,
        /// Why.
        why: IgnoreReason,
    },
}

/// Counters exposed in the state message.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Counters {
    /// Runs started (including restarts).
    pub starts: u64,
    /// Runs that reached `exited`.
    pub exits: u64,
    /// Runs ended by `interrupt`.
    pub interrupts: u64,
    /// Runs ended by `exit`.
    pub exit_signals: u64,
    /// Start behaviours that returned normally.
    pub completed: u64,
    /// Start behaviours that returned an error.
    pub failures: u64,
    /// Panics caught in any slot.
    pub panics: u64,
    /// Restarts asked for by the exit slot.
    pub restarts: u64,
    /// `start` signals ignored or replaced in the queue.
    pub ignored_starts: u64,
    /// `interrupt` signals ignored.
    pub ignored_interrupts: u64,
    /// `exit` signals ignored.
    pub ignored_exits: u64,
}
