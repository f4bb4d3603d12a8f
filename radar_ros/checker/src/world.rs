//! The state of a bounded system: its processes with their clocks, component instances with the real machines
//! inside, the manager with the real connection table, the messages on their way, and the trace so far.
//!
//! What the model takes from the binding (`radar_ros`), as it does it: a relay hands each signal it reads to
//! the table with the stamp taken as rule T1 says (this process's own components hand theirs at once, through
//! the in-process tap), and drops what arrives for a source it no longer reads; the table's sends go to the
//! slot's reader in the manager's process if there is one, else over the topic to every live reader; a
//! response carries out its machine's effects in order and resumes the machine once a begun run reaches its
//! first await, before it reads anything else; an event's activation follows its listener count as discovery
//! tells it; the manager tells the table a component is gone when no instance of it is left on the graph (a
//! clean exit: at once; a crash: when its lease runs out), and runs the instance watcher on each change of the
//! graph; a scope's end removes the connection (cancelling the anonymous slot's queue of a live one) and lets
//! go of what the table released.
//!
//! Time: every process has a clock of its own that moves with each of its steps, and a message is read no
//! earlier than it was sent (a reader's clock is moved past the sender's stamp). So two steps of different
//! processes that touch nothing in common commute, and the exploration can leave out the orders of such steps
//! that say nothing new (see `crate::System`).

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use radar_semantics::{
    connection::{ConnId, ConnectionTable, Kind as TableKind, Until},
    event::{Activation, Transition},
    instances::{Instances, Liveness, Seen},
    response::{
        Cause as MCause, Effect, ExitAction as MExitAction, ExitReason as MExitReason, Input,
        ResponseMachine, Sent, StartEnd as MStartEnd, StartPolicy,
    },
    time,
};
use radar_spec::trace::{
    Cause, Comp, ExitAction, ExitReason, Kind, Obs, Payload, Policy, Record, SigId, Signal,
    SignalKind, Slot, SlotKind, StartEnd, Target, Time,
};

use crate::scenario::{ArmAt, Fault, Part, Scenario};

/// How far a process's clock moves at each of its steps (ns).
pub const STEP: Time = 1_000;

/// When every clock starts (ns): far enough from 0 that `now - LATE` means something.
pub const EPOCH: Time = 1_000_000_000_000;

/// Where a table delivers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Tgt {
    /// A response's slot.
    Slot(Slot),
    /// Statement `k`'s anonymous slot.
    Anon(u8),
}

/// One end of the table's connections, as the manager watches it (rule C5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum End {
    /// A source it reads.
    Source(Signal),
    /// A slot it writes.
    Target(Slot),
}

impl End {
    fn comp(self) -> Comp {
        match self {
            End::Source(s) => s.comp,
            End::Target(s) => s.comp,
        }
    }
}

/// What runs in a response instance's slot now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Running {
    /// The start behaviour.
    Start,
    /// The interrupt slot.
    Interrupt,
    /// The exit slot.
    Exit,
}

/// A response instance.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Resp {
    /// The real machine.
    pub m: ResponseMachine<u8, u8>,
    /// The slot running.
    pub slot: Option<Running>,
    /// Restarts its exit slot may still ask for.
    pub restarts: u8,
    /// Its current run's number in the trace.
    pub run: u64,
    /// Runs begun.
    pub runs: u64,
}

/// An event instance.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Ev {
    /// The real activation rule.
    pub act: Activation,
    /// Checking now.
    pub checking: bool,
    /// The next payload to emit.
    pub next: u8,
}

/// What an instance is.
// (states are cloned whole at every move: boxing the large variant would add an allocation to each clone)
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Body {
    /// An event.
    Event(Ev),
    /// A response.
    Response(Resp),
    /// The program with the manager (the manager's state is [`World::mgr`]).
    Program,
}

/// One process's instance of a component.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Inst {
    /// Which component.
    pub comp: Comp,
    /// Its instance number (0: there from the start).
    pub no: u32,
    /// Its process.
    pub proc: u8,
    /// Running.
    pub alive: bool,
    /// Still on the graph as others see it (a killed one stays until its lease runs out).
    pub on_graph: bool,
    /// Signals it emitted.
    pub emitted: u64,
    /// Its clock (true time): each instance runs on threads of its own.
    pub clock: Time,
    /// What it is.
    pub body: Body,
}

/// An anonymous slot's queue.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Anon {
    /// The signals waiting for a call.
    pub q: VecDeque<SigId>,
    /// The guard dropped: begins no further call.
    pub cancelled: bool,
}

/// The manager.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Mgr {
    /// Running.
    pub alive: bool,
    /// Its program was told to stop.
    pub stopping: bool,
    /// The real connection table.
    pub table: ConnectionTable<Signal, Tgt>,
    /// Per statement, its connection once made.
    pub conn: Vec<Option<ConnId>>,
    /// Per statement, whether its scope ended.
    pub scope_ended: Vec<bool>,
    /// The sources it reads (has a relay for).
    pub reading: BTreeSet<Signal>,
    /// Anonymous slots, by statement.
    pub anon: BTreeMap<u8, Anon>,
    /// Ends reported gone (and not back).
    pub gone: BTreeSet<End>,
    /// The instance watcher's knowledge, per component.
    pub instances: BTreeMap<Comp, Instances<u32>>,
    /// Components whose instances on the graph changed since the manager last looked.
    pub looks: BTreeSet<Comp>,
    /// The signals it read, by source and stamp as taken: which emission an `until`'s interrupt carries.
    pub read: BTreeMap<(Signal, Time), SigId>,
    /// Per sending instance, how far its clock runs ahead (T1: the relay dates stamps by it).
    pub leads: BTreeMap<u8, time::Lead>,
}

/// A message on its way, with the time it was sent (by the sender's true clock).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Msg {
    /// A signal, to the manager's relay.
    Signal {
        /// The emission.
        sig: SigId,
        /// Its stamp.
        stamp: Time,
        /// Its cause.
        cause: Option<MCause>,
        /// Its payload.
        payload: Payload,
        /// When it was sent.
        at: Time,
    },
    /// A slot signal, to a response instance.
    Slot {
        /// Its stamp and cause.
        sent: Sent,
        /// Its payload.
        payload: Payload,
        /// When it was sent.
        at: Time,
    },
    /// Discovery: how many listen to an event instance's `triggered`.
    Listeners(u32, Time),
}

impl Msg {
    fn sent_at(&self) -> Time {
        match self {
            Msg::Signal { at, .. } | Msg::Slot { at, .. } | Msg::Listeners(_, at) => *at,
        }
    }
}

/// A channel: one writer to one reader, in order (a reliable DDS topic, or an in-process queue).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Chan {
    /// Instance `inst`'s signal `kind`, to the manager.
    Signal(u8, SignalKind),
    /// The manager's outlet to instance `inst`'s slot.
    Slot(u8, SlotKind),
    /// Discovery, to event instance `inst`.
    Discovery(u8),
}

/// A process.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Proc {
    /// Running.
    pub alive: bool,
    /// Told to stop.
    pub stopping: bool,
    /// Left (ended or killed).
    pub left: bool,
    /// How far its clock is ahead of the true time.
    pub skew: Time,
    /// The scenario process whose components it runs.
    pub of: u8,
}

/// A move of the system.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    /// An event instance's condition holds.
    Trigger(u8),
    /// The next message on a channel is read.
    Deliver(Chan),
    /// A response instance's start behaviour ends by itself.
    StartEnds(u8, StartEnd),
    /// A response instance's interrupt slot ends.
    InterruptEnds(u8),
    /// A response instance's exit slot ends.
    ExitEnds(u8, ExitAction),
    /// The program makes statement `k`.
    Arm(u8),
    /// Statement `k`'s scope ends.
    ScopeEnd(u8),
    /// Statement `k`'s anonymous slot takes the next payload.
    Call(u8),
    /// A fault strikes (its index in the scenario).
    Fault(u8),
    /// A stopping process whose responses are idle leaves.
    Exit(u8),
    /// A killed instance's lease runs out.
    LeaseExpires(u8),
    /// The manager looks at the instances of a component on the graph.
    Look(Comp),
}

/// The whole system.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct World {
    /// What happened.
    pub trace: Vec<Record>,
    /// Steps taken.
    pub steps: u32,
    /// Instances, in the order they came.
    pub insts: Vec<Inst>,
    /// The manager.
    pub mgr: Mgr,
    /// Processes.
    pub procs: Vec<Proc>,
    /// Messages on their way.
    pub chans: BTreeMap<Chan, VecDeque<Msg>>,
    /// Faults that struck.
    pub struck: Vec<bool>,
    /// Moves not worth taking from here: they commute with the move that led here, whose other order is
    /// explored already (sleep sets).
    pub sleep: Vec<Action>,
    /// The rules broken (bit `i`: `radar_spec::rules::ALL[i]`).
    pub broken: u64,
    /// Whether the state has no move left and broke nothing (liveness was judged).
    pub over: bool,
}

/// Which statement a connection is.
fn stmt_of(mgr: &Mgr, id: ConnId) -> Option<u8> {
    mgr.conn
        .iter()
        .position(|c| *c == Some(id))
        .map(|k| k as u8)
}

/// The trace's number of statement `k`.
pub fn stmt_no(k: u8) -> u64 {
    u64::from(k) + 1
}

/// The emission number of instance `i`'s `n`-th signal (unique, and the same whatever else happened).
pub fn sig_no(i: u8, n: u64) -> SigId {
    (u64::from(i) + 1) << 24 | n
}

/// The instance an emission number came from.
pub fn sig_inst(sig: SigId) -> u8 {
    ((sig >> 24) - 1) as u8
}

fn policy(p: Policy) -> StartPolicy {
    match p {
        Policy::Ignore => StartPolicy::Ignore,
        Policy::Restart => StartPolicy::Restart,
        Policy::QueueOne => StartPolicy::QueueOne,
    }
}

fn reason(r: &MExitReason) -> ExitReason {
    match r {
        MExitReason::Completed => ExitReason::Completed,
        MExitReason::Interrupted => ExitReason::Interrupted,
        MExitReason::ExitSignal => ExitReason::ExitSignal,
        MExitReason::Failed(_) => ExitReason::Failed,
        MExitReason::Panicked(_) => ExitReason::Panicked,
    }
}

impl World {
    /// The system before anything happens: every instance up, statements made at the start armed.
    pub fn new(s: &Scenario) -> World {
        let mut w = World {
            trace: Vec::new(),
            steps: 0,
            insts: Vec::new(),
            mgr: Mgr {
                alive: true,
                stopping: false,
                table: ConnectionTable::new(),
                conn: vec![None; s.statements.len()],
                scope_ended: vec![false; s.statements.len()],
                reading: BTreeSet::new(),
                anon: BTreeMap::new(),
                gone: BTreeSet::new(),
                instances: BTreeMap::new(),
                looks: BTreeSet::new(),
                read: BTreeMap::new(),
                leads: BTreeMap::new(),
            },
            procs: (0..s.procs())
                .map(|p| Proc {
                    alive: true,
                    stopping: false,
                    left: false,
                    skew: s.skew.get(usize::from(p)).copied().unwrap_or(0),
                    of: p,
                })
                .collect(),
            chans: BTreeMap::new(),
            struck: vec![false; s.faults.len()],
            sleep: Vec::new(),
            broken: 0,
            over: false,
        };
        for (i, c) in s.components.iter().enumerate() {
            w.insts
                .push(Self::instance(s, Comp(i as u16), 0, c.proc, EPOCH));
        }
        for (k, st) in s.statements.iter().enumerate() {
            if st.arm == ArmAt::Start {
                w.arm(s, k as u8);
            }
        }
        w
    }

    fn instance(s: &Scenario, comp: Comp, no: u32, proc: u8, clock: Time) -> Inst {
        let body = match &s.components[usize::from(comp.0)].part {
            Part::Program => Body::Program,
            Part::Event { .. } => Body::Event(Ev {
                act: Activation::new(),
                checking: false,
                next: 0,
            }),
            Part::Response {
                policy: p,
                restarts,
                ..
            } => Body::Response(Resp {
                m: ResponseMachine::new(policy(*p)),
                slot: None,
                restarts: *restarts,
                run: 0,
                runs: 0,
            }),
        };
        Inst {
            comp,
            no,
            proc,
            alive: true,
            on_graph: true,
            emitted: 0,
            clock,
            body,
        }
    }

    /// Whether the two states are the same but for what they remember of the past.
    pub fn same_now(&self, other: &World) -> bool {
        self.insts == other.insts
            && self.mgr == other.mgr
            && self.procs == other.procs
            && self.chans == other.chans
            && self.struck == other.struck
    }

    /// The records of the last step.
    pub fn last_step(&self) -> &[Record] {
        let n = self
            .trace
            .iter()
            .rev()
            .take_while(|r| r.step + 1 == self.steps)
            .count();
        &self.trace[self.trace.len() - n..]
    }

    /// The instance of the program (the manager's clock is its).
    pub fn mgr_inst(&self) -> u8 {
        self.insts
            .iter()
            .position(|i| matches!(i.body, Body::Program))
            .map_or(0, |i| i as u8)
    }

    fn rec(&mut self, actor: u8, obs: Obs) {
        let at = self.insts[usize::from(actor)].clock;
        self.trace.push(Record {
            at,
            step: self.steps,
            obs,
        });
    }

    /// An instance's clock as it reads it (its process's skew included).
    fn now(&self, actor: u8) -> Time {
        let i = &self.insts[usize::from(actor)];
        i.clock + self.procs[usize::from(i.proc)].skew
    }

    fn spec_cause(&self, c: Option<MCause>) -> Option<Cause> {
        let c = c?;
        let k = stmt_of(&self.mgr, c.statement as u64)?;
        Some(Cause {
            stmt: stmt_no(k),
            delivery: c.delivery,
        })
    }

    // ----------------------------------------------------------------------------------------- emitting

    /// Instance `i` emits signal `kind`: the trace, then the manager's relay (at once through the tap in its own
    /// process, if it reads the signal; else on the way, dropped there if it does not read it by then).
    fn emit(
        &mut self,
        s: &Scenario,
        i: u8,
        kind: SignalKind,
        payload: Payload,
        cause: Option<MCause>,
    ) {
        let inst = &mut self.insts[usize::from(i)];
        inst.emitted += 1;
        let (comp, proc, no) = (inst.comp, inst.proc, inst.no);
        let sig = sig_no(i, inst.emitted);
        let stamp = self.now(i);
        let signal = Signal { comp, kind };
        let spec_cause = self.spec_cause(cause);
        self.rec(
            i,
            Obs::Emitted {
                sig,
                inst: no,
                signal,
                stamp,
                cause: spec_cause,
                payload,
            },
        );
        if proc == s.manager_proc() {
            if self.mgr.alive && self.mgr.reading.contains(&signal) {
                // the tap: the manager takes it on this thread, at this moment
                let m = usize::from(self.mgr_inst());
                self.insts[m].clock = self.insts[m].clock.max(self.insts[usize::from(i)].clock);
                self.dispatch(
                    s,
                    signal,
                    sig,
                    Sent {
                        at: stamp,
                        by: cause,
                    },
                    payload,
                );
            }
        } else {
            let at = self.insts[usize::from(i)].clock;
            self.chans
                .entry(Chan::Signal(i, kind))
                .or_default()
                .push_back(Msg::Signal {
                    sig,
                    stamp,
                    cause,
                    payload,
                    at,
                });
        }
    }

    // ----------------------------------------------------------------------------------------- the manager

    /// The manager's actor: its program's instance.
    fn mp(&self, _: &Scenario) -> u8 {
        self.mgr_inst()
    }

    /// The manager reads one signal: the table decides, the manager carries it out.
    fn dispatch(&mut self, s: &Scenario, source: Signal, sig: SigId, sent: Sent, payload: Payload) {
        let mp = self.mp(s);
        let now = self.now(mp);
        self.rec(mp, Obs::ManagerRead { sig, now });
        self.mgr.read.insert((source, sent.at), sig);
        let stopping = self.mgr.stopping;
        let conn = self.mgr.conn.clone();
        let accept = |id: ConnId| {
            let Some(k) = conn.iter().position(|c| *c == Some(id)) else {
                return true;
            };
            let st = &s.statements[k];
            let starts = matches!(
                st.target,
                Target::Slot(Slot {
                    kind: SlotKind::Start,
                    ..
                })
            );
            // a filter that looks at values (a typed closure) refuses what does not decode; so does the check
            // of a start slot's type, and an anonymous slot's decoding (the binding's `reads`, C2)
            let reads = !payload.unreadable || !(starts || st.target == Target::Call);
            st.accepts.passes(payload) == Some(true) && reads && !(stopping && starts)
        };
        let out = self.mgr.table.signal(&source, sent, now, accept);
        for d in out.sends {
            let Some(k) = stmt_of(&self.mgr, d.id) else {
                continue;
            };
            let to = match d.target {
                Tgt::Slot(slot) => Target::Slot(slot),
                Tgt::Anon(_) => Target::Call,
            };
            // an until's interrupt carries the signal of U it was decided for (C7: perhaps one read earlier)
            let (carried, carried_payload) = match d.via {
                radar_semantics::connection::Via::Until { at } => {
                    let u = s.statements[usize::from(k)].until.expect("an until");
                    (
                        self.mgr.read.get(&(u, at)).copied().unwrap_or(sig),
                        Payload::default(),
                    )
                }
                radar_semantics::connection::Via::Signal { .. } => (sig, payload),
            };
            let by = self.spec_cause(d.sent.by);
            self.rec(
                mp,
                Obs::Sent {
                    stmt: stmt_no(k),
                    sig: carried,
                    to,
                    stamp: d.sent.at,
                    by,
                },
            );
            match d.target {
                Tgt::Slot(slot) => self.outlet(s, slot, d.sent, carried_payload),
                Tgt::Anon(a) => {
                    if let Some(q) = self.mgr.anon.get_mut(&a) {
                        q.q.push_back(sig);
                    }
                }
            }
        }
        for id in out.ended {
            if let Some(k) = stmt_of(&self.mgr, id) {
                self.rec(mp, Obs::Ended { stmt: stmt_no(k) });
            }
        }
        self.release(s, out.released);
    }

    /// A slot signal from the manager: to the response of the manager's process that reads the slot, if there
    /// is one, else over the topic to every live reader.
    fn outlet(&mut self, s: &Scenario, slot: Slot, sent: Sent, payload: Payload) {
        let at = self.insts[usize::from(self.mp(s))].clock;
        let mp = s.manager_proc();
        let live: Vec<u8> = (0..self.insts.len() as u8)
            .filter(|&i| {
                let inst = &self.insts[usize::from(i)];
                inst.comp == slot.comp && inst.alive
            })
            .collect();
        let local: Vec<u8> = live
            .iter()
            .copied()
            .filter(|&i| self.insts[usize::from(i)].proc == mp)
            .collect();
        let to = if local.is_empty() { live } else { local };
        for i in to {
            self.chans
                .entry(Chan::Slot(i, slot.kind))
                .or_default()
                .push_back(Msg::Slot { sent, payload, at });
        }
    }

    /// Lets go of what the table released: relays (the events they listened to hear of it) and anonymous
    /// queues (a payload already queued is still called).
    fn release(&mut self, s: &Scenario, (sources, _targets): (Vec<Signal>, Vec<Tgt>)) {
        let mp = self.mp(s);
        for src in sources {
            if self.mgr.reading.remove(&src) {
                self.rec(
                    mp,
                    Obs::Reading {
                        signal: src,
                        on: false,
                    },
                );
                self.tell_listeners(s, src.comp, src.kind);
            }
        }
    }

    /// Makes relays for the sources the table reads that have none. A statement is armed once its readers
    /// have matched their sources' writers (the binding waits for it), so the events it reads know of their
    /// new listener by then.
    fn hold_sources(&mut self, s: &Scenario) {
        let mp = self.mp(s);
        for src in self.mgr.table.sources() {
            if self.mgr.reading.insert(src) {
                self.rec(
                    mp,
                    Obs::Reading {
                        signal: src,
                        on: true,
                    },
                );
                if src.kind == SignalKind::Triggered {
                    for i in 0..self.insts.len() as u8 {
                        let inst = &self.insts[usize::from(i)];
                        if inst.comp == src.comp
                            && inst.alive
                            && matches!(inst.body, Body::Event(_))
                        {
                            // what discovery told it before: it is read now
                            self.chans.remove(&Chan::Discovery(i));
                            self.listeners(i, 1);
                        }
                    }
                }
            }
        }
    }

    /// Discovery tells the instances of event `comp` how many read their `triggered`.
    fn tell_listeners(&mut self, s: &Scenario, comp: Comp, kind: SignalKind) {
        if kind != SignalKind::Triggered {
            return;
        }
        let n = u32::from(self.mgr.alive && self.mgr.reading.contains(&Signal { comp, kind }));
        let at = self.insts[usize::from(self.mp(s))].clock;
        for i in 0..self.insts.len() {
            let inst = &self.insts[i];
            if inst.comp == comp && inst.alive && matches!(inst.body, Body::Event(_)) {
                self.chans
                    .entry(Chan::Discovery(i as u8))
                    .or_default()
                    .push_back(Msg::Listeners(n, at));
            }
        }
    }

    /// The program makes statement `k`.
    pub fn arm(&mut self, s: &Scenario, k: u8) {
        let mp = self.mp(s);
        let st = &s.statements[usize::from(k)];
        let now = self.now(mp);
        let target = match st.target {
            Target::Slot(slot) => Tgt::Slot(slot),
            Target::Call => {
                self.mgr.anon.insert(k, Anon::default());
                Tgt::Anon(k)
            }
        };
        let until = match (st.until, st.target) {
            (Some(u), Target::Slot(slot)) => Some(Until {
                source: u,
                started: Signal {
                    comp: slot.comp,
                    kind: SignalKind::Started,
                },
                exited: Signal {
                    comp: slot.comp,
                    kind: SignalKind::Exited,
                },
                dropped: Signal {
                    comp: slot.comp,
                    kind: SignalKind::Dropped,
                },
                interrupt: Tgt::Slot(Slot {
                    comp: slot.comp,
                    kind: SlotKind::Interrupt,
                }),
                causes: true,
            }),
            _ => None,
        };
        let kind = match st.kind {
            Kind::Once => TableKind::Once,
            Kind::Whenever => TableKind::Whenever,
        };
        let id = self
            .mgr
            .table
            .arm_from(st.source, target, kind, until, now, now);
        self.mgr.table.set_starts(
            id,
            matches!(
                st.target,
                Target::Slot(Slot {
                    kind: SlotKind::Start,
                    ..
                })
            ),
        );
        self.mgr.table.set_call(id, st.target == Target::Call);
        self.mgr.conn[usize::from(k)] = Some(id);
        let since = self.insts[usize::from(mp)].clock;
        self.rec(
            mp,
            Obs::Armed {
                stmt: stmt_no(k),
                kind: st.kind,
                source: st.source,
                target: st.target,
                until: st.until,
                since,
                accepts: st.accepts,
            },
        );
        self.hold_sources(s);
        // the instance watcher's first look at the components of its ends
        let mut comps: Vec<Comp> = vec![st.source.comp];
        if let Target::Slot(slot) = st.target {
            comps.push(slot.comp);
        }
        for c in comps {
            self.look_instances(c);
        }
    }

    /// The instances of `comp` on the graph.
    fn hosts(&self, comp: Comp) -> BTreeSet<u32> {
        self.insts
            .iter()
            .filter(|i| i.comp == comp && i.on_graph)
            .map(|i| i.no)
            .collect()
    }

    /// The ends of the table that are `comp`'s.
    fn ends_of(&self, comp: Comp) -> Vec<End> {
        let mut ends: Vec<End> = self
            .mgr
            .reading
            .iter()
            .filter(|s| s.comp == comp)
            .map(|s| End::Source(*s))
            .collect();
        for t in self.mgr.table.targets() {
            if let Tgt::Slot(slot) = t {
                if slot.comp == comp {
                    ends.push(End::Target(slot));
                }
            }
        }
        ends
    }

    fn lost(&mut self, s: &Scenario, end: End) {
        let ids = match end {
            End::Source(src) => self.mgr.table.source_lost(&src),
            End::Target(slot) => self.mgr.table.target_lost(&Tgt::Slot(slot)),
        };
        let mp = self.mp(s);
        for id in ids {
            if let Some(k) = stmt_of(&self.mgr, id) {
                self.rec(
                    mp,
                    Obs::LossSeen {
                        stmt: stmt_no(k),
                        comp: end.comp(),
                    },
                );
            }
        }
        // a spent `once ... until` whose response left is over (C3, C5)
        for id in self.mgr.table.take_ended() {
            if let Some(k) = stmt_of(&self.mgr, id) {
                self.rec(mp, Obs::Ended { stmt: stmt_no(k) });
            }
        }
        let released = self.mgr.table.take_released();
        self.release(s, released);
    }

    /// The instance watcher's look at `comp`; what is known of each instance's life: the truth (every process
    /// runs on this host, whose sockets tell).
    fn look_instances(&mut self, comp: Comp) -> Seen<u32> {
        let hosts = self.hosts(comp);
        let alive: BTreeSet<u32> = self
            .insts
            .iter()
            .filter(|i| i.comp == comp && i.alive)
            .map(|i| i.no)
            .collect();
        self.mgr
            .instances
            .entry(comp)
            .or_default()
            .look(hosts, |n| {
                if alive.contains(&n) {
                    Liveness::Alive
                } else {
                    Liveness::Dead
                }
            })
    }

    fn back(&mut self, s: &Scenario, end: End) {
        let now = self.now(self.mp(s));
        let _ = match end {
            End::Source(src) => self.mgr.table.source_back(&src),
            End::Target(slot) => self.mgr.table.target_back(&Tgt::Slot(slot), now),
        };
    }

    /// The manager looks at `comp` on the graph: the instance watcher, then each end's presence.
    fn look(&mut self, s: &Scenario, comp: Comp) {
        let ends = self.ends_of(comp);
        if ends.is_empty() {
            self.mgr.instances.remove(&comp);
            return;
        }
        let hosts = self.hosts(comp);
        let replaced = matches!(self.look_instances(comp), Seen::Replaced { .. });
        if replaced {
            for &e in &ends {
                self.lost(s, e);
                self.back(s, e);
            }
        }
        for e in self.ends_of(comp) {
            if hosts.is_empty() && self.mgr.gone.insert(e) {
                self.lost(s, e);
            } else if !hosts.is_empty() && self.mgr.gone.remove(&e) {
                self.back(s, e);
            }
        }
    }

    fn scope_end(&mut self, s: &Scenario, k: u8) {
        let mp = self.mp(s);
        self.mgr.scope_ended[usize::from(k)] = true;
        self.rec(mp, Obs::ScopeEnded { stmt: stmt_no(k) });
        let Some(id) = self.mgr.conn[usize::from(k)] else {
            return;
        };
        // as the binding's `Manager::remove`: the table forgets the connection; its anonymous slot (of a live
        // connection, or of one that fired) begins no further call
        if let Some(Tgt::Anon(a)) = self.mgr.table.forget(id) {
            if let Some(q) = self.mgr.anon.get_mut(&a) {
                q.cancelled = true;
            }
        }
        let released = self.mgr.table.take_released();
        self.release(s, released);
    }

    // ----------------------------------------------------------------------------------------- responses

    /// Carries out a response instance's effects, in order; resumes the machine once a run it began reaches
    /// its first await.
    fn effects(&mut self, s: &Scenario, i: u8, fx: Vec<Effect<u8, u8>>) {
        let mut began = false;
        let (comp, no) = {
            let inst = &self.insts[usize::from(i)];
            (inst.comp, inst.no)
        };
        let proc = i;
        for e in fx {
            match e {
                Effect::EmitStarted(p, cause) => {
                    let r = self.resp(i);
                    r.runs += 1;
                    let run = sig_no(i, r.runs);
                    r.run = run;
                    let now = self.now(proc);
                    let spec_cause = self.spec_cause(cause);
                    self.rec(
                        proc,
                        Obs::RunBegan {
                            comp,
                            inst: no,
                            run,
                            payload: p,
                            cause: spec_cause,
                            now,
                        },
                    );
                    self.emit(
                        s,
                        i,
                        SignalKind::Started,
                        Payload {
                            value: p,
                            unreadable: false,
                        },
                        cause,
                    );
                }
                Effect::RunStart(_) => {
                    began = true;
                    self.resp(i).slot = Some(Running::Start);
                }
                Effect::CancelStart => {
                    let run = self.resp(i).run;
                    self.rec(
                        proc,
                        Obs::Cancelled {
                            comp,
                            inst: no,
                            run,
                        },
                    );
                    self.resp(i).slot = None;
                }
                Effect::EmitInterrupted(cause) => {
                    self.emit(s, i, SignalKind::Interrupted, Payload::default(), cause)
                }
                Effect::RunInterrupt => {
                    let run = self.resp(i).run;
                    self.rec(
                        proc,
                        Obs::InterruptBegan {
                            comp,
                            inst: no,
                            run,
                        },
                    );
                    self.resp(i).slot = Some(Running::Interrupt);
                }
                Effect::RunExit(r) => {
                    let run = self.resp(i).run;
                    self.rec(
                        proc,
                        Obs::ExitBegan {
                            comp,
                            inst: no,
                            run,
                            reason: reason(&r),
                        },
                    );
                    self.resp(i).slot = Some(Running::Exit);
                }
                Effect::EmitExited(o, cause) => {
                    self.resp(i).slot = None;
                    self.emit(
                        s,
                        i,
                        SignalKind::Exited,
                        Payload {
                            value: o,
                            unreadable: false,
                        },
                        cause,
                    );
                }
                Effect::EmitDropped(cause) => {
                    self.emit(s, i, SignalKind::Dropped, Payload::default(), Some(cause))
                }
                Effect::ReportPanic { .. } | Effect::Ignored { .. } => {}
            }
        }
        if began {
            let fx = self.resp(i).m.resume();
            if !fx.is_empty() {
                self.effects(s, i, fx);
            }
        }
    }

    fn resp(&mut self, i: u8) -> &mut Resp {
        match &mut self.insts[usize::from(i)].body {
            Body::Response(r) => r,
            _ => unreachable!("instance {i} is not a response"),
        }
    }

    fn input(&mut self, s: &Scenario, i: u8, input: Input<u8, u8>) {
        let now = self.now(i);
        let fx = self.resp(i).m.handle_at(input, now);
        self.effects(s, i, fx);
    }

    // ----------------------------------------------------------------------------------------- moves

    /// The moves possible now (before sleep sets are applied).
    pub fn actions(&self, s: &Scenario, out: &mut Vec<Action>) {
        let mp = usize::from(s.manager_proc());
        for (i, inst) in self.insts.iter().enumerate() {
            let i = i as u8;
            if !inst.alive {
                if inst.on_graph {
                    out.push(Action::LeaseExpires(i));
                }
                continue;
            }
            let stopping = self.procs[usize::from(inst.proc)].stopping;
            match &inst.body {
                Body::Event(e) => {
                    let Part::Event { payloads } = &s.components[usize::from(inst.comp.0)].part
                    else {
                        continue;
                    };
                    if e.checking && !stopping && usize::from(e.next) < payloads.len() {
                        out.push(Action::Trigger(i));
                    }
                }
                Body::Response(r) => {
                    let Part::Response { ends, done, .. } =
                        &s.components[usize::from(inst.comp.0)].part
                    else {
                        continue;
                    };
                    match r.slot {
                        Some(Running::Start) => {
                            out.extend(ends.iter().map(|e| Action::StartEnds(i, *e)))
                        }
                        Some(Running::Interrupt) => out.push(Action::InterruptEnds(i)),
                        Some(Running::Exit) => {
                            if *done || r.restarts == 0 || stopping {
                                out.push(Action::ExitEnds(i, ExitAction::Done));
                            }
                            if r.restarts > 0 && !stopping {
                                out.push(Action::ExitEnds(i, ExitAction::Restart));
                            }
                        }
                        None => {}
                    }
                }
                Body::Program => {}
            }
        }
        for (c, q) in &self.chans {
            if q.is_empty() {
                continue;
            }
            let to_alive = match *c {
                Chan::Signal(..) => self.mgr.alive,
                Chan::Slot(i, _) | Chan::Discovery(i) => self.insts[usize::from(i)].alive,
            };
            if to_alive {
                out.push(Action::Deliver(*c));
            }
        }
        if self.mgr.alive {
            let stopping = self.procs[mp].stopping;
            for (k, st) in s.statements.iter().enumerate() {
                let k8 = k as u8;
                let made = self.mgr.conn[k].is_some();
                if !made && st.arm == ArmAt::Any && !stopping {
                    out.push(Action::Arm(k8));
                }
                if made && st.scope_ends && !self.mgr.scope_ended[k] {
                    out.push(Action::ScopeEnd(k8));
                }
            }
            for (a, q) in &self.mgr.anon {
                if !q.cancelled && !q.q.is_empty() {
                    out.push(Action::Call(*a));
                }
            }
            for c in &self.mgr.looks {
                out.push(Action::Look(*c));
            }
        }
        for (f, fault) in s.faults.iter().enumerate() {
            if self.struck[f] {
                continue;
            }
            let ok = match *fault {
                Fault::Crash(p) | Fault::Stop(p) | Fault::Duplicate(p) => {
                    let pr = &self.procs[usize::from(p)];
                    pr.alive && !pr.stopping
                }
                Fault::Respawn(p) => {
                    let pr = &self.procs[usize::from(p)];
                    !pr.alive && pr.left
                }
                Fault::Wait => true,
            };
            if ok {
                out.push(Action::Fault(f as u8));
            }
        }
        for (p, pr) in self.procs.iter().enumerate() {
            if pr.alive && pr.stopping {
                let idle = self.insts.iter().all(|i| {
                    usize::from(i.proc) != p
                        || !i.alive
                        || !matches!(&i.body, Body::Response(r) if r.slot.is_some())
                });
                if idle {
                    out.push(Action::Exit(p as u8));
                }
            }
        }
    }

    /// The instances a move is a step of (their clocks move; the program's instance stands for the manager):
    /// what it touches, for telling which moves commute.
    pub fn acts_in(&self, s: &Scenario, a: Action) -> Vec<u8> {
        let mp = s.manager_proc();
        let m = self.mgr_inst();
        // an instance in the manager's process hands its signals to the manager on its own thread
        let with_mgr = |i: u8| {
            if self.insts[usize::from(i)].proc == mp && i != m {
                vec![i, m]
            } else {
                vec![i]
            }
        };
        let of = |p: u8| -> Vec<u8> {
            let mut v: Vec<u8> = (0..self.insts.len() as u8)
                .filter(|&i| self.insts[usize::from(i)].proc == p)
                .collect();
            if !v.contains(&m) {
                v.push(m);
            }
            v
        };
        match a {
            Action::Trigger(i)
            | Action::StartEnds(i, _)
            | Action::InterruptEnds(i)
            | Action::ExitEnds(i, _)
            | Action::Deliver(Chan::Slot(i, _))
            | Action::Deliver(Chan::Discovery(i)) => with_mgr(i),
            Action::Deliver(Chan::Signal(..))
            | Action::Arm(_)
            | Action::ScopeEnd(_)
            | Action::Call(_)
            | Action::Look(_) => vec![m],
            // the graph's view of a killed instance: the manager's, while it runs
            Action::LeaseExpires(i) if !self.mgr.alive => vec![i],
            Action::LeaseExpires(_) => vec![m],
            Action::Exit(p) => of(p),
            Action::Fault(f) => match s.faults[usize::from(f)] {
                Fault::Crash(p) | Fault::Stop(p) | Fault::Respawn(p) | Fault::Duplicate(p) => of(p),
                Fault::Wait => (0..self.insts.len() as u8).collect(),
            },
        }
    }

    /// Carries out one move.
    pub fn step(&mut self, s: &Scenario, a: Action) {
        let actors = self.acts_in(s, a);
        for &i in &actors {
            if let Some(inst) = self.insts.get_mut(usize::from(i)) {
                inst.clock += STEP;
            }
        }
        match a {
            Action::Trigger(i) => {
                let comp = self.insts[usize::from(i)].comp;
                let Part::Event { payloads } = &s.components[usize::from(comp.0)].part else {
                    return;
                };
                let Body::Event(e) = &mut self.insts[usize::from(i)].body else {
                    return;
                };
                let payload = payloads[usize::from(e.next)];
                e.next += 1;
                self.emit(s, i, SignalKind::Triggered, payload, None);
            }
            Action::Deliver(c) => {
                let Some(m) = self.chans.get_mut(&c).and_then(|q| q.pop_front()) else {
                    return;
                };
                if self.chans.get(&c).is_some_and(|q| q.is_empty()) {
                    self.chans.remove(&c);
                }
                // read no earlier than it was sent
                let r = usize::from(actors[0]);
                self.insts[r].clock = self.insts[r].clock.max(m.sent_at() + STEP);
                self.deliver(s, c, m);
            }
            Action::StartEnds(i, how) => {
                let (comp, _, no) = self.who(i);
                let run = self.resp(i).run;
                self.rec(
                    i,
                    Obs::StartEnded {
                        comp,
                        inst: no,
                        run,
                        how,
                    },
                );
                let end = match how {
                    StartEnd::Returned => MStartEnd::Returned(7),
                    StartEnd::Failed => MStartEnd::Failed("failed".into()),
                    StartEnd::Panicked => MStartEnd::Panicked("panicked".into()),
                };
                self.input(s, i, Input::StartEnded(end));
            }
            Action::InterruptEnds(i) => {
                let (comp, _, no) = self.who(i);
                let run = self.resp(i).run;
                self.rec(
                    i,
                    Obs::InterruptEnded {
                        comp,
                        inst: no,
                        run,
                    },
                );
                self.input(s, i, Input::InterruptEnded(None));
            }
            Action::ExitEnds(i, action) => {
                let (comp, _, no) = self.who(i);
                let run = self.resp(i).run;
                let now = self.now(i);
                self.rec(
                    i,
                    Obs::ExitEnded {
                        comp,
                        inst: no,
                        run,
                        action,
                        now,
                    },
                );
                let action = match action {
                    ExitAction::Done => MExitAction::Done,
                    ExitAction::Restart => {
                        self.resp(i).restarts -= 1;
                        MExitAction::Restart
                    }
                };
                self.input(s, i, Input::ExitEnded(Ok(action)));
            }
            Action::Arm(k) => self.arm(s, k),
            Action::ScopeEnd(k) => self.scope_end(s, k),
            Action::Call(k) => {
                let mp = self.mp(s);
                if let Some(sig) = self.mgr.anon.get_mut(&k).and_then(|q| q.q.pop_front()) {
                    self.rec(
                        mp,
                        Obs::Called {
                            stmt: stmt_no(k),
                            sig,
                        },
                    );
                }
            }
            Action::Fault(f) => {
                self.struck[usize::from(f)] = true;
                match s.faults[usize::from(f)] {
                    Fault::Crash(p) => self.crash(s, p),
                    Fault::Respawn(p) => self.respawn(s, p),
                    Fault::Duplicate(p) => self.duplicate(s, p),
                    Fault::Stop(p) => self.stop(s, p),
                    Fault::Wait => {
                        for i in &mut self.insts {
                            i.clock += radar_spec::rules::LATE + radar_spec::rules::HOLD;
                        }
                    }
                }
            }
            Action::Exit(p) => self.exit(s, p),
            Action::LeaseExpires(i) => {
                let inst = &mut self.insts[usize::from(i)];
                inst.on_graph = false;
                let comp = inst.comp;
                let program = matches!(inst.body, Body::Program);
                if self.mgr.alive {
                    self.mgr.looks.insert(comp);
                }
                if program {
                    // the manager's readers are gone from the graph: its events hear of it
                    let reading: Vec<Signal> =
                        std::mem::take(&mut self.mgr.reading).into_iter().collect();
                    for src in reading {
                        self.tell_listeners(s, src.comp, src.kind);
                    }
                }
            }
            Action::Look(c) => {
                self.mgr.looks.remove(&c);
                self.look(s, c);
            }
        }
        self.steps += 1;
    }

    fn who(&self, i: u8) -> (Comp, u8, u32) {
        let inst = &self.insts[usize::from(i)];
        (inst.comp, inst.proc, inst.no)
    }

    fn deliver(&mut self, s: &Scenario, c: Chan, m: Msg) {
        match (c, m) {
            (
                Chan::Signal(i, kind),
                Msg::Signal {
                    sig,
                    stamp,
                    cause,
                    payload,
                    ..
                },
            ) => {
                let signal = Signal {
                    comp: self.insts[usize::from(i)].comp,
                    kind,
                };
                // a relay let go of is gone: what comes for it is dropped
                if !self.mgr.reading.contains(&signal) {
                    return;
                }
                let now = self.now(self.mp(s));
                // a response's signals speak of its runs only from the instance the manager follows: another
                // live instance of that name (a second process) closes no `until` window (C5)
                let (comp, no) = (signal.comp, self.insts[usize::from(i)].no);
                let followed = self
                    .mgr
                    .instances
                    .get(&comp)
                    .and_then(|x| x.current())
                    .is_none_or(|c| c == no);
                // the relay takes the stamp as rule T1 says, by its sender's lead
                let sent = Sent {
                    at: self.mgr.leads.entry(i).or_default().date(stamp, now),
                    by: cause.filter(|_| followed),
                };
                self.dispatch(s, signal, sig, sent, payload);
            }
            (Chan::Slot(i, kind), Msg::Slot { sent, payload, .. }) => {
                let (comp, _, no) = self.who(i);
                let now = self.now(i);
                let by = self.spec_cause(sent.by);
                self.rec(
                    i,
                    Obs::Read {
                        comp,
                        inst: no,
                        slot: kind,
                        stamp: sent.at,
                        by,
                        payload,
                        now,
                    },
                );
                let input = match kind {
                    // a start that does not decode is dropped (and counted) by the response
                    SlotKind::Start if payload.unreadable => return,
                    SlotKind::Start => Input::Start(payload.value, sent),
                    SlotKind::Interrupt => Input::Interrupt(sent),
                    SlotKind::Exit => Input::Exit(sent),
                };
                self.input(s, i, input);
            }
            (Chan::Discovery(i), Msg::Listeners(n, _)) => self.listeners(i, n),
            (c, m) => unreachable!("{m:?} on {c:?}"),
        }
    }

    /// Event instance `i` learns how many listen to its `triggered`.
    fn listeners(&mut self, i: u8, n: u32) {
        {
            {
                let (comp, _, no) = self.who(i);
                let proc = i;
                self.rec(proc, Obs::Listeners { comp, inst: no, n });
                let Body::Event(e) = &mut self.insts[usize::from(i)].body else {
                    return;
                };
                match e.act.set_listeners(n as usize) {
                    Some(Transition::Activate) => {
                        e.checking = true;
                        self.rec(
                            proc,
                            Obs::Checking {
                                comp,
                                inst: no,
                                on: true,
                            },
                        );
                    }
                    Some(Transition::Deactivate) => {
                        e.checking = false;
                        self.rec(
                            proc,
                            Obs::Checking {
                                comp,
                                inst: no,
                                on: false,
                            },
                        );
                    }
                    None => {}
                }
            }
        }
    }

    /// The live instances of process `p`.
    fn of_proc(&self, p: u8) -> Vec<u8> {
        (0..self.insts.len() as u8)
            .filter(|&i| self.insts[usize::from(i)].proc == p && self.insts[usize::from(i)].alive)
            .collect()
    }

    fn crash(&mut self, s: &Scenario, p: u8) {
        let pr = &mut self.procs[usize::from(p)];
        pr.alive = false;
        pr.left = true;
        for i in self.of_proc(p) {
            let (comp, _, no) = self.who(i);
            self.insts[usize::from(i)].alive = false;
            self.rec(
                i,
                Obs::Left {
                    comp,
                    instance: no,
                    crashed: true,
                },
            );
            self.chans
                .retain(|c, _| !matches!(c, Chan::Slot(j, _) | Chan::Discovery(j) if *j == i));
        }
        if p == s.manager_proc() {
            self.mgr.alive = false;
            self.mgr.looks.clear();
            for q in self.mgr.anon.values_mut() {
                q.cancelled = true;
            }
        }
    }

    fn respawn(&mut self, s: &Scenario, p: u8) {
        let pr = &mut self.procs[usize::from(p)];
        pr.alive = true;
        pr.left = false;
        pr.stopping = false;
        let of = pr.of;
        self.spawn(s, of, p);
    }

    fn duplicate(&mut self, s: &Scenario, p: u8) {
        let skew = self.procs[usize::from(p)].skew;
        self.procs.push(Proc {
            alive: true,
            stopping: false,
            left: false,
            skew,
            of: p,
        });
        let q = (self.procs.len() - 1) as u8;
        self.spawn(s, p, q);
    }

    /// New instances, in process `q`, of the components of scenario process `of`.
    fn spawn(&mut self, s: &Scenario, of: u8, q: u8) {
        for (c, comp) in s.components.iter().enumerate() {
            if comp.proc != of || matches!(comp.part, Part::Program) {
                continue;
            }
            let comp = Comp(c as u16);
            let no = self.insts.iter().filter(|i| i.comp == comp).count() as u32;
            let beside = self.insts.iter().any(|i| i.comp == comp && i.alive);
            // it starts no earlier than the instance of that name before it
            let clock = self
                .insts
                .iter()
                .filter(|i| i.comp == comp)
                .map(|i| i.clock)
                .max()
                .unwrap_or(EPOCH);
            self.insts.push(Self::instance(s, comp, no, q, clock));
            let new = (self.insts.len() - 1) as u8;
            self.rec(
                new,
                Obs::Spawned {
                    comp,
                    instance: no,
                    beside,
                },
            );
            if self.mgr.alive {
                self.mgr.looks.insert(comp);
            }
            self.tell_listeners(s, comp, SignalKind::Triggered);
        }
    }

    fn stop(&mut self, s: &Scenario, p: u8) {
        self.procs[usize::from(p)].stopping = true;
        for i in self.of_proc(p) {
            let (comp, _, no) = self.who(i);
            self.rec(i, Obs::Stopping { comp, inst: no });
            match &mut self.insts[usize::from(i)].body {
                Body::Response(r) => {
                    let fx = r.m.stop();
                    self.effects(s, i, fx);
                }
                Body::Event(e) => {
                    if e.checking {
                        e.checking = false;
                        self.rec(
                            i,
                            Obs::Checking {
                                comp,
                                inst: no,
                                on: false,
                            },
                        );
                    }
                }
                Body::Program => self.mgr.stopping = true,
            }
        }
    }

    fn exit(&mut self, s: &Scenario, p: u8) {
        if p == s.manager_proc() {
            // `main` returns: every guard drops
            for k in 0..s.statements.len() as u8 {
                if self.mgr.conn[usize::from(k)].is_some() && !self.mgr.scope_ended[usize::from(k)]
                {
                    self.scope_end(s, k);
                }
            }
        }
        let pr = &mut self.procs[usize::from(p)];
        pr.alive = false;
        pr.left = true;
        for i in self.of_proc(p) {
            let (comp, _, no) = self.who(i);
            let inst = &mut self.insts[usize::from(i)];
            inst.alive = false;
            inst.on_graph = false;
            self.rec(
                i,
                Obs::Left {
                    comp,
                    instance: no,
                    crashed: false,
                },
            );
            if self.mgr.alive {
                self.mgr.looks.insert(comp);
            }
            self.chans
                .retain(|c, _| !matches!(c, Chan::Slot(j, _) | Chan::Discovery(j) if *j == i));
        }
        if p == s.manager_proc() {
            self.mgr.alive = false;
            self.mgr.looks.clear();
        }
    }
}
