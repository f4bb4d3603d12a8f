//! What a trace holds: the components of a system and what was seen of it, in the order it happened.
//!
//! A trace is a history of plain values. It says what was *emitted* (a signal, with the stamp its sender put on
//! it and the cause it carries), what a connection manager *read* and *sent*, what a response *read* on its
//! slots and which of its slots *ran*, which statements were armed and when they ended, and which components
//! left. Each [`Record`] has the time it happened ([`Record::at`]): in a model the one true clock, in a
//! recording the recorder's clock. Records of one step (one input handled, with everything it caused) share
//! their time and follow each other in the order they were caused.

/// Nanoseconds.
pub type Time = i64;

/// A statement (a `once` or `whenever`), numbered within the trace.
pub type Stmt = u64;

/// One emission of a signal, numbered within the trace.
pub type SigId = u64;

/// One run of a response, numbered within the trace.
pub type Run = u64;

/// A component: an index into [`Trace::components`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Comp(pub u16);

/// What a component is.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Role {
    /// An event: a condition check that emits `triggered`.
    Event,
    /// The deliberative program that makes statements, with the connection manager that carries them out.
    Program,
    /// A response with its start policy; `causes`: it orders its slot signals by the causes they carry (a
    /// RADAR response; an rclpy one does not).
    Response {
        /// What it does with a start while busy.
        policy: Policy,
        /// Whether it keeps causes.
        causes: bool,
    },
}

/// A response's start policy (what a `start` does while a run goes on).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Policy {
    /// Nothing.
    Ignore,
    /// The run is interrupted and the newest start runs after it.
    Restart,
    /// The newest start runs after the run.
    QueueOne,
}

/// A component of the traced system.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Component {
    /// Its ROS name (`/count_up`).
    pub name: String,
    /// Event or response.
    pub role: Role,
}

/// The signals of components.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SignalKind {
    /// An event's.
    Triggered,
    /// A response's: a run began.
    Started,
    /// A response's: a run was interrupted.
    Interrupted,
    /// A response's: a run ended (after its exit slot).
    Exited,
    /// A response's: a start a statement sent (its cause) was not taken, and no run of it will come.
    Dropped,
}

/// The slots of a response.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SlotKind {
    /// Begins a run.
    Start,
    /// Interrupts a run.
    Interrupt,
    /// Ends a run through its exit slot.
    Exit,
}

/// A component's signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Signal {
    /// Whose.
    pub comp: Comp,
    /// Which.
    pub kind: SignalKind,
}

/// A response's slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Slot {
    /// Whose.
    pub comp: Comp,
    /// Which.
    pub kind: SlotKind,
}

/// Where a statement delivers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    /// A response's slot.
    Slot(Slot),
    /// An anonymous slot: code of the statement's program, called with each delivered payload.
    Call,
}

/// `once` or `whenever`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// Delivers one signal.
    Once,
    /// Delivers every signal.
    Whenever,
}

/// The cause a slot signal or a response's signal carries: the statement, and which of its deliveries (0 on
/// an `until`'s interrupt, which names the statement only).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cause {
    /// The statement.
    pub stmt: Stmt,
    /// Its delivery, from 1; 0 for an `until`'s interrupt.
    pub delivery: u64,
}

/// A payload as far as the rules care: a small value a filter may look at, and whether it is a well-formed
/// message of its signal's type (one that is not cannot be delivered to a slot that reads that type).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Payload {
    /// The value.
    pub value: u8,
    /// Whether a reader of the signal's type can read it.
    pub unreadable: bool,
}

/// Which payloads a statement's filter (and transform) lets through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Accepts {
    /// Every readable payload.
    All,
    /// Readable payloads whose value is in the set (bit `v` for value `v < 32`).
    Values(u32),
    /// Not known (a recording does not say what a closure decided): any payload may have been refused.
    Unknown,
}

impl Accepts {
    /// Whether `p` passes: `Some(answer)`, or `None` when it is not known.
    /// (A payload that cannot be read passes no filter that looks at values.)
    pub fn passes(self, p: Payload) -> Option<bool> {
        match self {
            Accepts::All => Some(true),
            Accepts::Values(set) => {
                Some(!p.unreadable && p.value < 32 && set & (1 << p.value) != 0)
            }
            Accepts::Unknown => None,
        }
    }
}

/// Why an exit slot runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ExitReason {
    /// The start behaviour returned.
    Completed,
    /// An interrupt ended the run (after the interrupt slot).
    Interrupted,
    /// An `exit` signal ended the run, or the response was stopped.
    ExitSignal,
    /// The start behaviour failed.
    Failed,
    /// The start behaviour panicked.
    Panicked,
}

/// How a start behaviour ended by itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StartEnd {
    /// It returned.
    Returned,
    /// It returned an error.
    Failed,
    /// It panicked.
    Panicked,
}

/// What an exit slot asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ExitAction {
    /// Nothing more.
    Done,
    /// Start again with the same payload.
    Restart,
}

/// One thing seen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Obs {
    // ---------------------------------------------------------------- statements and their manager
    /// A statement was armed: it delivers signals of `source` emitted from `since` on.
    Armed {
        /// The statement.
        stmt: Stmt,
        /// Once or whenever.
        kind: Kind,
        /// What it listens to.
        source: Signal,
        /// Where it delivers.
        target: Target,
        /// The `until U` of a statement that starts a response: U.
        until: Option<Signal>,
        /// When the statement began (C1 counts from here).
        since: Time,
        /// What its filter lets through.
        accepts: Accepts,
    },
    /// The statement's scope ended (its guard was dropped): C4.
    ScopeEnded {
        /// The statement.
        stmt: Stmt,
    },
    /// The manager ended the statement by itself (a `once` spent): its guard's `closed()` resolves.
    Ended {
        /// The statement.
        stmt: Stmt,
    },
    /// The manager began (`on`) or stopped reading a signal.
    Reading {
        /// The signal.
        signal: Signal,
        /// Reading from now on, or not.
        on: bool,
    },
    /// The manager read an emitted signal.
    ManagerRead {
        /// Which emission.
        sig: SigId,
        /// The manager's clock as it read it.
        now: Time,
    },
    /// A statement delivered the emitted signal `sig` (its source's, or its `until`'s): a slot signal sent,
    /// or a payload handed to its anonymous slot.
    Sent {
        /// The statement.
        stmt: Stmt,
        /// The signal it delivers.
        sig: SigId,
        /// To which slot.
        to: Target,
        /// The time the slot signal carries.
        stamp: Time,
        /// The cause it carries.
        by: Option<Cause>,
    },
    /// A statement's anonymous slot was called with the payload of `sig`.
    Called {
        /// The statement.
        stmt: Stmt,
        /// The signal.
        sig: SigId,
    },
    /// The manager took `comp` as gone for the statement (C5).
    LossSeen {
        /// The statement.
        stmt: Stmt,
        /// Which of its components.
        comp: Comp,
    },
    // ---------------------------------------------------------------- components
    /// A component emitted a signal.
    Emitted {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The emission's number.
        sig: SigId,
        /// Which signal.
        signal: Signal,
        /// The time its sender stamped on it (its own clock).
        stamp: Time,
        /// The cause it carries.
        cause: Option<Cause>,
        /// What it carries.
        payload: Payload,
    },
    /// A response read a slot signal.
    Read {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// Which slot.
        slot: SlotKind,
        /// The time the slot signal carries.
        stamp: Time,
        /// The cause it carries.
        by: Option<Cause>,
        /// What it carries.
        payload: Payload,
        /// The response's clock as it read it.
        now: Time,
    },
    /// A run began, with this payload and cause.
    RunBegan {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// The run.
        run: Run,
        /// Its payload.
        payload: u8,
        /// Its cause.
        cause: Option<Cause>,
        /// The response's clock.
        now: Time,
    },
    /// The run's start behaviour ended by itself.
    StartEnded {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// The run.
        run: Run,
        /// How.
        how: StartEnd,
    },
    /// The run's start behaviour was cancelled (an interrupt, an exit signal, a stop, a restart).
    Cancelled {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// The run.
        run: Run,
    },
    /// The run's interrupt slot began.
    InterruptBegan {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// The run.
        run: Run,
    },
    /// The run's interrupt slot ended.
    InterruptEnded {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// The run.
        run: Run,
    },
    /// The run's exit slot began, for this reason.
    ExitBegan {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// The run.
        run: Run,
        /// Why.
        reason: ExitReason,
    },
    /// The run's exit slot ended, asking for this.
    ExitEnded {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The response.
        comp: Comp,
        /// The run.
        run: Run,
        /// Restart or not.
        action: ExitAction,
        /// The response's clock.
        now: Time,
    },
    /// An event learned how many listen to its `triggered`.
    Listeners {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The event.
        comp: Comp,
        /// How many.
        n: u32,
    },
    /// An event began (`on`) or stopped checking its condition.
    Checking {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The event.
        comp: Comp,
        /// Checking from now on, or not.
        on: bool,
    },
    // ---------------------------------------------------------------- processes
    /// The component's program was told to stop.
    Stopping {
        /// Which instance of the component (0: the one there when the trace began).
        inst: u32,
        /// The component.
        comp: Comp,
    },
    /// An instance of the component left the graph: it ended, or (`crashed`) it was killed.
    Left {
        /// The component.
        comp: Comp,
        /// Which of its instances (0: the one there when the trace began).
        instance: u32,
        /// Killed: nothing of it ran to its end.
        crashed: bool,
    },
    /// A new instance of the component is on the graph: a respawn after it left, or a second live process of
    /// that name (`beside`: another instance is still alive).
    Spawned {
        /// The component.
        comp: Comp,
        /// The new instance's number.
        instance: u32,
        /// Another instance of that name is still alive.
        beside: bool,
    },
}

/// One observation with the time it happened and the step it is part of.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Record {
    /// When, by the clock of the process it happened in (in a recording: the recorder's).
    pub at: Time,
    /// The step: one input handled with everything it caused, in one process (records of a step follow each
    /// other).
    pub step: u32,
    /// What.
    pub obs: Obs,
}

/// How the trace ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum End {
    /// Nothing is left to happen (a model's final state): every liveness rule is judged.
    Quiescent,
    /// Cut off (a recording stopped): liveness rules judge only what is older than `grace` at the last record.
    Cut {
        /// How long an obligation may be left open at the end.
        grace: Time,
    },
    /// Not yet over (a model's state with moves left): liveness rules are not judged.
    Open,
}

/// A traced system: its components and what was seen.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Trace {
    /// The components, indexed by [`Comp`].
    pub components: Vec<Component>,
    /// The records, in the order they happened.
    pub records: Vec<Record>,
}

impl Trace {
    /// An empty trace of these components.
    pub fn new(components: Vec<Component>) -> Trace {
        Trace {
            components,
            records: Vec::new(),
        }
    }

    /// Adds a record as a step of its own.
    pub fn push(&mut self, at: Time, obs: Obs) {
        let step = self.records.last().map_or(0, |r| r.step + 1);
        self.records.push(Record { at, step, obs });
    }

    /// Adds a record to the last step.
    pub fn push_to_step(&mut self, at: Time, obs: Obs) {
        let step = self.records.last().map_or(0, |r| r.step);
        self.records.push(Record { at, step, obs });
    }

    /// The component's name (`?` for an index out of range).
    pub fn name(&self, c: Comp) -> &str {
        self.components
            .get(usize::from(c.0))
            .map_or("?", |c| c.name.as_str())
    }

    /// The response's policy and whether it keeps causes, if `c` is a response.
    pub fn response(&self, c: Comp) -> Option<(Policy, bool)> {
        match self.components.get(usize::from(c.0))?.role {
            Role::Response { policy, causes } => Some((policy, causes)),
            Role::Event | Role::Program => None,
        }
    }
}
