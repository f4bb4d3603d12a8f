//! What a whole trace says when read back: statements with their lives, runs with their slots, emissions by
//! number. Built afresh for every check from the records alone.

use std::collections::{BTreeMap, HashMap};

use crate::trace::{
    Accepts, Cause, Comp, Component, Kind, Obs, Payload, Policy, Record, Role, Run, SigId, Signal,
    SignalKind, SlotKind, Stmt, Target, Time,
};

/// A trace's two halves, borrowed.
#[derive(Clone, Copy)]
pub(crate) struct TraceRef<'t> {
    pub(crate) components: &'t [Component],
    pub(crate) records: &'t [Record],
}

impl TraceRef<'_> {
    pub(crate) fn name(&self, c: Comp) -> &str {
        self.components
            .get(usize::from(c.0))
            .map_or("?", |c| c.name.as_str())
    }

    pub(crate) fn response(&self, c: Comp) -> Option<(Policy, bool)> {
        match self.components.get(usize::from(c.0))?.role {
            Role::Response { policy, causes } => Some((policy, causes)),
            Role::Event | Role::Program => None,
        }
    }

    /// The program (and manager) of the trace, if it names one.
    pub(crate) fn program(&self) -> Option<Comp> {
        self.components
            .iter()
            .position(|c| c.role == Role::Program)
            .map(|i| Comp(i as u16))
    }
}

/// A component instance: the component, and which of its instances.
pub(crate) type Who = (Comp, u32);

/// A statement's life, by record index.
#[derive(Clone, Debug)]
pub(crate) struct StmtView {
    pub(crate) armed: usize,
    pub(crate) kind: Kind,
    pub(crate) source: Signal,
    pub(crate) target: Target,
    pub(crate) until: Option<Signal>,
    pub(crate) since: Time,
    pub(crate) accepts: Accepts,
    pub(crate) scope_ended: Option<usize>,
    pub(crate) ended: Option<usize>,
    /// Every delivery it made.
    pub(crate) sent: Vec<usize>,
    /// Every call of its anonymous slot.
    pub(crate) called: Vec<usize>,
    /// Every loss it saw.
    pub(crate) losses: Vec<usize>,
}

impl StmtView {
    /// The end of its life (its scope's end, or the manager's), if it has one.
    pub(crate) fn over(&self) -> Option<usize> {
        match (self.scope_ended, self.ended) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The response its `until` interrupts: its target's.
    pub(crate) fn until_response(&self) -> Option<Comp> {
        match (self.until, self.target) {
            (Some(_), Target::Slot(s)) => Some(s.comp),
            _ => None,
        }
    }
}

/// How a run's start behaviour ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ending {
    /// Still running at the end of the trace.
    Running,
    /// It ended by itself.
    ByItself,
    /// It was cancelled, at this record.
    Cancelled(usize),
}

/// One run of a response instance, by record index.
#[derive(Clone, Debug)]
pub(crate) struct RunView {
    pub(crate) comp: Comp,
    pub(crate) inst: u32,
    pub(crate) run: Run,
    pub(crate) began: usize,
    pub(crate) payload: u8,
    pub(crate) cause: Option<Cause>,
    /// The response's clock when it began.
    pub(crate) now: Time,
    /// Every record of the run (its slots and its signals), in order, `began` first.
    pub(crate) records: Vec<usize>,
    pub(crate) ending: Ending,
    /// Its `exited`.
    pub(crate) exited: Option<usize>,
}

impl RunView {
    pub(crate) fn who(&self) -> Who {
        (self.comp, self.inst)
    }
}

/// An emission: its signal, the instance that emitted it, stamp, cause, payload and when it was emitted.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Emission {
    pub(crate) signal: Signal,
    pub(crate) inst: u32,
    pub(crate) stamp: Time,
    pub(crate) cause: Option<Cause>,
    pub(crate) payload: Payload,
    pub(crate) at: Time,
}

/// A trace read back.
pub(crate) struct View<'t> {
    pub(crate) trace: TraceRef<'t>,
    pub(crate) emitted: HashMap<SigId, usize>,
    pub(crate) stmts: BTreeMap<Stmt, StmtView>,
    /// Per response instance, its runs in order.
    pub(crate) runs: BTreeMap<Who, Vec<RunView>>,
    /// Per record, the index of the first record of its step.
    step_start: Vec<usize>,
}

impl<'t> View<'t> {
    pub(crate) fn of(trace: TraceRef<'t>) -> View<'t> {
        let records = trace.records;
        let mut v = View {
            trace,
            emitted: HashMap::new(),
            stmts: BTreeMap::new(),
            runs: BTreeMap::new(),
            step_start: Vec::with_capacity(records.len()),
        };
        let mut current: BTreeMap<Who, usize> = BTreeMap::new();
        for (i, r) in records.iter().enumerate() {
            let start = match i {
                0 => 0,
                _ if records[i - 1].step == r.step => v.step_start[i - 1],
                _ => i,
            };
            v.step_start.push(start);
            v.read(i, r, &mut current);
        }
        v
    }

    fn stmt(&mut self, s: Stmt) -> Option<&mut StmtView> {
        self.stmts.get_mut(&s)
    }

    fn read(&mut self, i: usize, r: &Record, current: &mut BTreeMap<Who, usize>) {
        if !self.read_statement(i, r.obs) {
            self.read_run(i, r.obs, current);
        }
    }

    /// Record `i` if it is about a statement (armed, its scope's end, its end, a send, a call, a loss it saw):
    /// true then.
    fn read_statement(&mut self, i: usize, obs: Obs) -> bool {
        match obs {
            Obs::Armed {
                stmt,
                kind,
                source,
                target,
                until,
                since,
                accepts,
            } => {
                self.stmts.insert(
                    stmt,
                    StmtView {
                        armed: i,
                        kind,
                        source,
                        target,
                        until,
                        since,
                        accepts,
                        scope_ended: None,
                        ended: None,
                        sent: Vec::new(),
                        called: Vec::new(),
                        losses: Vec::new(),
                    },
                );
            }
            Obs::ScopeEnded { stmt } => {
                if let Some(st) = self.stmt(stmt) {
                    st.scope_ended.get_or_insert(i);
                }
            }
            Obs::Ended { stmt } => {
                if let Some(st) = self.stmt(stmt) {
                    st.ended.get_or_insert(i);
                }
            }
            Obs::Sent { stmt, .. } => {
                if let Some(st) = self.stmt(stmt) {
                    st.sent.push(i);
                }
            }
            Obs::Called { stmt, .. } => {
                if let Some(st) = self.stmt(stmt) {
                    st.called.push(i);
                }
            }
            Obs::LossSeen { stmt, .. } => {
                if let Some(st) = self.stmt(stmt) {
                    st.losses.push(i);
                }
            }
            _ => return false,
        }
        true
    }

    /// Record `i` if it is about an emission or a response's run (its records, how it ended).
    fn read_run(&mut self, i: usize, obs: Obs, current: &mut BTreeMap<Who, usize>) {
        match obs {
            Obs::Emitted {
                sig, signal, inst, ..
            } => {
                self.emitted.entry(sig).or_insert(i);
                if !matches!(signal.kind, SignalKind::Triggered | SignalKind::Dropped) {
                    let who = (signal.comp, inst);
                    self.add_to_run(who, i, current);
                    if signal.kind == SignalKind::Exited {
                        if let Some(run) = self.current_run_mut(who, current) {
                            run.exited.get_or_insert(i);
                        }
                        current.remove(&who);
                    }
                }
            }
            Obs::RunBegan {
                comp,
                inst,
                run,
                payload,
                cause,
                now,
            } => {
                let runs = self.runs.entry((comp, inst)).or_default();
                runs.push(RunView {
                    comp,
                    inst,
                    run,
                    began: i,
                    payload,
                    cause,
                    now,
                    records: vec![i],
                    ending: Ending::Running,
                    exited: None,
                });
                current.insert((comp, inst), runs.len() - 1);
            }
            Obs::StartEnded { comp, inst, .. } => {
                self.add_to_run((comp, inst), i, current);
                if let Some(run) = self.current_run_mut((comp, inst), current) {
                    if run.ending == Ending::Running {
                        run.ending = Ending::ByItself;
                    }
                }
            }
            Obs::Cancelled { comp, inst, .. } => {
                self.add_to_run((comp, inst), i, current);
                if let Some(run) = self.current_run_mut((comp, inst), current) {
                    if run.ending == Ending::Running {
                        run.ending = Ending::Cancelled(i);
                    }
                }
            }
            Obs::InterruptBegan { comp, inst, .. }
            | Obs::InterruptEnded { comp, inst, .. }
            | Obs::ExitBegan { comp, inst, .. }
            | Obs::ExitEnded { comp, inst, .. } => self.add_to_run((comp, inst), i, current),
            Obs::Left {
                comp,
                instance,
                crashed: true,
            } => {
                current.remove(&(comp, instance));
            }
            _ => {}
        }
    }

    fn current_run_mut(
        &mut self,
        who: Who,
        current: &BTreeMap<Who, usize>,
    ) -> Option<&mut RunView> {
        let k = *current.get(&who)?;
        self.runs.get_mut(&who)?.get_mut(k)
    }

    fn add_to_run(&mut self, who: Who, i: usize, current: &BTreeMap<Who, usize>) {
        if let Some(run) = self.current_run_mut(who, current) {
            if run.records.last() != Some(&i) {
                run.records.push(i);
            }
        }
    }

    pub(crate) fn obs(&self, i: usize) -> Obs {
        self.trace.records[i].obs
    }

    pub(crate) fn len(&self) -> usize {
        self.trace.records.len()
    }

    /// Whether records `a` and `b` are of one step.
    pub(crate) fn same_step(&self, a: usize, b: usize) -> bool {
        self.step_start[a] == self.step_start[b]
    }

    /// The records of `i`'s step.
    pub(crate) fn step_of(&self, i: usize) -> std::ops::Range<usize> {
        let start = self.step_start[i];
        let mut end = i + 1;
        while end < self.len() && self.step_start[end] == start {
            end += 1;
        }
        start..end
    }

    /// The emission `sig`.
    pub(crate) fn emission(&self, sig: SigId) -> Option<Emission> {
        let i = *self.emitted.get(&sig)?;
        let r = &self.trace.records[i];
        match r.obs {
            Obs::Emitted {
                signal,
                inst,
                stamp,
                cause,
                payload,
                ..
            } => Some(Emission {
                signal,
                inst,
                stamp,
                cause,
                payload,
                at: r.at,
            }),
            _ => None,
        }
    }

    /// The run of instance `who` that record `i` falls in (begun at or before `i`, not yet exited before `i`).
    pub(crate) fn run_at(&self, who: Who, i: usize) -> Option<&RunView> {
        self.runs
            .get(&who)?
            .iter()
            .rev()
            .find(|r| r.began <= i)
            .filter(|r| r.exited.is_none_or(|e| e >= i))
    }

    /// Whether instance `who` was told to stop before record `i`.
    pub(crate) fn stopping_before(&self, who: Who, i: usize) -> bool {
        self.trace.records[..i.min(self.len())]
            .iter()
            .any(|r| matches!(r.obs, Obs::Stopping { comp, inst } if (comp, inst) == who))
    }

    /// Whether instance `who` was killed before record `i`.
    pub(crate) fn crashed_by(&self, who: Who, i: usize) -> bool {
        self.trace.records[..i.min(self.len())].iter().any(|r| {
            matches!(r.obs, Obs::Left { comp, instance, crashed: true } if (comp, instance) == who)
        })
    }

    /// Whether instance `who` left (ended or was killed) before record `i`.
    pub(crate) fn left_by(&self, who: Who, i: usize) -> bool {
        self.trace.records[..i.min(self.len())]
            .iter()
            .any(|r| matches!(r.obs, Obs::Left { comp, instance, .. } if (comp, instance) == who))
    }

    /// The instances of `comp` alive just before record `i` (instance 0 is there from the start).
    pub(crate) fn alive_at(&self, comp: Comp, i: usize) -> Vec<u32> {
        let mut alive = vec![0];
        for r in &self.trace.records[..i.min(self.len())] {
            match r.obs {
                Obs::Left {
                    comp: c, instance, ..
                } if c == comp => alive.retain(|n| *n != instance),
                Obs::Spawned {
                    comp: c, instance, ..
                } if c == comp => alive.push(instance),
                _ => {}
            }
        }
        alive
    }

    /// Whether the program (with its manager) left before record `i`.
    pub(crate) fn program_left(&self, i: usize) -> bool {
        self.trace
            .program()
            .is_some_and(|p| self.left_by((p, 0), i))
    }

    /// The slot reads of instance `who` in `range`, with their indices (starts that could not be read left
    /// out: the response drops them).
    pub(crate) fn reads_of(
        &self,
        who: Who,
        range: std::ops::Range<usize>,
    ) -> impl Iterator<Item = (usize, SlotKind, Time, Option<Cause>, Time)> + '_ {
        range.filter_map(move |j| match self.obs(j) {
            Obs::Read {
                comp,
                inst,
                slot,
                stamp,
                by,
                now,
                payload,
            } if (comp, inst) == who && !(slot == SlotKind::Start && payload.unreadable) => {
                Some((j, slot, stamp, by, now))
            }
            _ => None,
        })
    }
}
