//! A bounded system to explore: its components and the processes they run in, its statements, and the faults
//! that may strike at any step.

use radar_spec::trace::{
    Accepts, Kind, Payload, Policy, Signal, SignalKind, Slot, SlotKind, Target,
};

pub use radar_spec::trace::Comp;

/// What a component is, with what it may do.
#[derive(Clone, Debug)]
pub enum Part {
    /// The deliberative program and its connection manager.
    Program,
    /// An event that triggers (while checking) with these payloads, in order, one per trigger.
    Event {
        /// One payload per trigger it may emit.
        payloads: Vec<Payload>,
    },
    /// A response.
    Response {
        /// Its start policy.
        policy: Policy,
        /// What its start behaviour may do when it ends by itself (none: it runs until something ends it).
        ends: Vec<radar_spec::trace::StartEnd>,
        /// How many times its exit slot may ask for a restart.
        restarts: u8,
        /// Its exit slot may also end without asking for one (else: always restart while it may).
        done: bool,
    },
}

/// One component: its name, what it is, and the process it runs in (processes are numbered from 0).
#[derive(Clone, Debug)]
pub struct Component {
    /// Its ROS name.
    pub name: &'static str,
    /// What it is.
    pub part: Part,
    /// Its process.
    pub proc: u8,
}

/// When a statement is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArmAt {
    /// Before anything happens.
    Start,
    /// At any step (a deliberative program that makes it as it goes).
    Any,
}

/// A statement of the deliberative program.
#[derive(Clone, Debug)]
pub struct Statement {
    /// Once or whenever.
    pub kind: Kind,
    /// What it listens to.
    pub source: Signal,
    /// Where it delivers.
    pub target: Target,
    /// `until U`.
    pub until: Option<Signal>,
    /// Its filter.
    pub accepts: Accepts,
    /// When it is made.
    pub arm: ArmAt,
    /// Its scope may end at any step.
    pub scope_ends: bool,
}

/// A fault that may strike once, at any step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Fault {
    /// The process is killed (`kill -9`).
    Crash(u8),
    /// The process (killed before) is started again at once, within its lease.
    Respawn(u8),
    /// A second live process of that process's components (two terminals, one launch file).
    Duplicate(u8),
    /// The process is told to stop (Ctrl-C): it stops its components, then leaves.
    Stop(u8),
    /// Time jumps further than `HOLD` and `LATE`.
    Wait,
}

/// A bounded system.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Its name.
    pub name: &'static str,
    /// Its components; the one [`Part::Program`] runs the manager.
    pub components: Vec<Component>,
    /// Its statements.
    pub statements: Vec<Statement>,
    /// The faults that may strike.
    pub faults: Vec<Fault>,
    /// Per process, how far its clock is ahead of the true time (ns).
    pub skew: Vec<i64>,
}

impl Scenario {
    /// The component named `name`.
    pub fn comp(&self, name: &str) -> Comp {
        Comp(
            self.components
                .iter()
                .position(|c| c.name == name)
                .unwrap_or_else(|| panic!("no component {name}")) as u16,
        )
    }

    /// The process of the manager.
    pub fn manager_proc(&self) -> u8 {
        self.components
            .iter()
            .find(|c| matches!(c.part, Part::Program))
            .map_or(0, |c| c.proc)
    }

    /// How many processes there are at the start.
    pub fn procs(&self) -> u8 {
        self.components
            .iter()
            .map(|c| c.proc + 1)
            .max()
            .unwrap_or(0)
    }
}

// ------------------------------------------------------------------------------------------------ helpers

/// The signal `kind` of component `c`.
pub fn signal(c: Comp, kind: SignalKind) -> Signal {
    Signal { comp: c, kind }
}

/// The start slot of `c`.
pub fn start(c: Comp) -> Target {
    Target::Slot(Slot {
        comp: c,
        kind: SlotKind::Start,
    })
}

/// The interrupt slot of `c`.
pub fn interrupt(c: Comp) -> Target {
    Target::Slot(Slot {
        comp: c,
        kind: SlotKind::Interrupt,
    })
}

/// The exit slot of `c`.
pub fn exit(c: Comp) -> Target {
    Target::Slot(Slot {
        comp: c,
        kind: SlotKind::Exit,
    })
}

/// `triggered` of `c`.
pub fn triggered(c: Comp) -> Signal {
    signal(c, SignalKind::Triggered)
}

/// An event in process `proc` that may trigger `n` times (payloads 0, 1, ...).
pub fn event(name: &'static str, proc: u8, n: u8) -> Component {
    Component {
        name,
        part: Part::Event {
            payloads: (0..n)
                .map(|value| Payload {
                    value,
                    unreadable: false,
                })
                .collect(),
        },
        proc,
    }
}

/// An event in process `proc` that triggers with these payloads.
pub fn event_with(name: &'static str, proc: u8, payloads: Vec<Payload>) -> Component {
    Component {
        name,
        part: Part::Event { payloads },
        proc,
    }
}

/// A response in process `proc` whose start behaviour may return, and whose exit slot asks for nothing.
pub fn response(name: &'static str, proc: u8, policy: Policy) -> Component {
    Component {
        name,
        part: Part::Response {
            policy,
            ends: vec![radar_spec::trace::StartEnd::Returned],
            restarts: 0,
            done: true,
        },
        proc,
    }
}

/// The program (and manager) in process `proc`.
pub fn program(proc: u8) -> Component {
    Component {
        name: "/program",
        part: Part::Program,
        proc,
    }
}

/// A statement made before anything happens, whose scope does not end.
pub fn stmt(kind: Kind, source: Signal, target: Target, until: Option<Signal>) -> Statement {
    Statement {
        kind,
        source,
        target,
        until,
        accepts: Accepts::All,
        arm: ArmAt::Start,
        scope_ends: false,
    }
}
