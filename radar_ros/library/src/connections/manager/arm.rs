//! Arming a statement: which endpoints it needs (its [`Plan`]), holding them while discovery matches them, then
//! entering it in the table with a relay per source and an outlet per slot.

use std::sync::{Arc, Mutex};

use radar_semantics::connection::{Kind, Until};
use radar_semantics::response::Sent;

use super::{
    anon::AnonQueue, faults::Faults, ConnectionGuard, Manager, Record, Spec, State, Target,
    TargetSpec, UntilSpec,
};
use crate::{
    error::{Error, Result},
    node::participant::Participant,
    node::pool::{Dir, Key},
    node::topics::{RawPublisher, RawSubscription},
    wire::msg::{Empty, ResponseState, RosMessage, TypeName},
    wire::refs::{Signal, Slot},
};

use crate::wire::local::{now_ns, Buffered, Emitted};

fn key(topic: &str, ros_type: &str, depth: usize, dir: Dir) -> Key {
    Key {
        topic: topic.to_owned(),
        ros_type: ros_type.to_owned(),
        depth,
        dir,
    }
}

fn check_types(source: &Signal, slot: &Slot) -> Result<()> {
    if slot.ros_type() == Empty::ros_type_name() || slot.ros_type() == source.ros_type() {
        Ok(())
    } else {
        Err(Error::TypeMismatch {
            source_topic: source.topic().to_owned(),
            source_type: source.ros_type().to_owned(),
            slot_topic: slot.topic().to_owned(),
            slot_type: slot.ros_type().to_owned(),
        })
    }
}

/// The `until` part's endpoints: U, R's `started`, `exited` and `dropped` (read), R's `interrupt` (written).
struct UntilKeys {
    source: Key,
    started: Key,
    exited: Key,
    dropped: Key,
    interrupt: Key,
}

/// The endpoints a statement needs, by role, and every one with its signal or slot (to wait for its peers and
/// say which did not come).
struct Plan {
    source: Key,
    /// A slot target (none for an anonymous slot).
    target: Option<Key>,
    until: Option<UntilKeys>,
    /// Every source the table will read: the statement's, then the `until`'s.
    reads: Vec<(Key, Signal)>,
    /// Every slot the table will write: the target, then the `until`'s interrupt.
    writes: Vec<(Key, Slot)>,
}

impl Plan {
    /// The endpoints of `spec`, after checking that its source (as mapped) can feed its slot.
    fn of(spec: &Spec) -> Result<Plan> {
        let depth = spec.depth;
        let reader = |s: &Signal| key(s.topic(), s.ros_type(), depth, Dir::Reader);
        let writer = |s: &Slot| key(s.topic(), s.ros_type(), depth, Dir::Writer);
        let source = reader(&spec.source);
        let mut reads = vec![(source.clone(), spec.source.clone())];
        let mut writes = Vec::new();
        let target = match &spec.target {
            TargetSpec::Slot(slot) => {
                let delivered = match &spec.mapped_type {
                    Some(t) => Signal::new(spec.source.topic(), t.clone()),
                    None => spec.source.clone(),
                };
                check_types(&delivered, slot)?;
                let k = writer(slot);
                writes.push((k.clone(), slot.clone()));
                Some(k)
            }
            TargetSpec::Anon(_) => None,
        };
        let until = spec.until.as_ref().map(|u: &UntilSpec| {
            let keys = UntilKeys {
                source: reader(&u.source),
                started: reader(&u.started),
                exited: reader(&u.exited),
                dropped: reader(&u.dropped),
                interrupt: writer(&u.interrupt),
            };
            reads.extend([
                (keys.source.clone(), u.source.clone()),
                (keys.started.clone(), u.started.clone()),
                (keys.exited.clone(), u.exited.clone()),
                (keys.dropped.clone(), u.dropped.clone()),
            ]);
            writes.push((keys.interrupt.clone(), u.interrupt.clone()));
            keys
        });
        Ok(Plan {
            source,
            target,
            until,
            reads,
            writes,
        })
    }
}

/// Pool holds taken by a statement while it arms, given back when dropped (on success, on error, on a
/// cancelled arm).
struct Holds<'a> {
    participant: &'a Participant,
    keys: Mutex<Vec<Key>>,
    /// With local delivery the readers made are those this process's signal writers send nothing to over DDS.
    local: bool,
}

impl<'a> Holds<'a> {
    fn new(participant: &'a Participant, local: bool) -> Holds<'a> {
        Holds {
            participant,
            keys: Mutex::new(Vec::new()),
            local,
        }
    }
    fn reader(&self, k: &Key) -> Result<Arc<RawSubscription>> {
        // marked as made (RustDDS patch 62): what this process emits on `k` comes to it by the tap alone
        let r = match self.local {
            true => crate::wire::local::marked(|| self.participant.pooled_reader(k))?,
            false => self.participant.pooled_reader(k)?,
        };
        self.keys.lock().unwrap().push(k.clone());
        Ok(r)
    }
    fn writer(&self, k: &Key) -> Result<Arc<RawPublisher>> {
        let w = self.participant.pooled_writer(k)?;
        self.keys.lock().unwrap().push(k.clone());
        Ok(w)
    }
}

impl Drop for Holds<'_> {
    fn drop(&mut self) {
        for k in self.keys.get_mut().unwrap().drain(..) {
            self.participant.release(&k);
        }
    }
}

/// A plan's endpoints, held and matched: a reader per source, and per slot a writer (`None`: a response of
/// this process reads the slot, no DDS writer is needed); with local delivery, per source what this process's
/// components emitted on it from before its reader was made (see [`Buffered`]).
struct Matched {
    readers: Vec<Arc<RawSubscription>>,
    writers: Vec<Option<Arc<RawPublisher>>>,
    kept: Vec<Option<Buffered>>,
}

impl Manager {
    /// Arms a statement: holds its endpoints while discovery matches them, then enters it in the table.
    pub(crate) async fn arm(self: &Arc<Self>, spec: Spec) -> Result<ConnectionGuard> {
        // C1 counts from here: the statement's own reader may activate an event whose condition already
        // holds, and its trigger, emitted while the statement arms, is not older than the statement
        let began = now_ns();
        let plan = Plan::of(&spec)?;
        // this statement's own holds while it arms: released whatever happens
        let held = Holds::new(&self.participant, self.local);
        let mut matched = self.hold_and_match(&plan, &held, spec.timeout).await?;
        let causes = spec
            .until
            .as_ref()
            .is_some_and(|u| self.keeps_causes(&u.state, &u.interrupt));
        if let Some(u) = &spec.until {
            tracing::debug!(response = %u.state, causes, "until: the response keeps causes (C6) or not (C7)");
        }
        let id = self.enter(plan, &mut matched, spec, causes, began)?;
        drop(held);
        self.changed.send_modify(|g| *g += 1);
        Ok(ConnectionGuard {
            id,
            manager: self.clone(),
        })
    }

    /// Over Zenoh a key carries its type's hash: one this program has no Rust type for is learned from the
    /// peers first (a relay made without it matches nobody), by `deadline`.
    async fn learn_type_hashes(
        &self,
        plan: &Plan,
        deadline: std::time::Instant,
        timeout: std::time::Duration,
    ) -> Result<()> {
        let reads = plan
            .reads
            .iter()
            .enumerate()
            .filter(|(i, _)| !(plan.until.is_some() && (*i == 1 || *i == 4)))
            .map(|(_, (k, _))| k);
        let writes = plan
            .writes
            .iter()
            .map(|(k, _)| k)
            .filter(|k| !self.reads_here(k));
        for k in reads.chain(writes) {
            self.participant
                .learn_type_hash(k, deadline)
                .await
                .map_err(|e| match e {
                    Error::Timeout { what, .. } => Error::Timeout {
                        what,
                        after: timeout,
                    },
                    e => e,
                })?;
        }
        Ok(())
    }

    /// With local delivery, what this process emits on each source is kept from before its reader is made
    /// (which may activate an event, C1): the writers of this process send that reader nothing over DDS.
    fn keep_local(&self, plan: &Plan) -> Vec<Option<Buffered>> {
        plan.reads
            .iter()
            .map(|(k, _)| {
                self.local.then(|| {
                    self.participant
                        .taps()
                        .get(&k.topic, &k.ros_type)
                        .buffer(k.depth)
                })
            })
            .collect()
    }

    /// Holds the plan's endpoints and waits (up to `timeout` in all) until every reader has a publisher
    /// and every writer a subscriber.
    async fn hold_and_match(
        &self,
        plan: &Plan,
        held: &Holds<'_>,
        timeout: std::time::Duration,
    ) -> Result<Matched> {
        // one deadline for every wait: `.timeout(d)` bounds the arming, not each endpoint's match
        let deadline = std::time::Instant::now() + timeout;
        let left = || deadline.saturating_duration_since(std::time::Instant::now());
        let kept = self.keep_local(plan);
        self.learn_type_hashes(plan, deadline, timeout).await?;
        let readers = plan
            .reads
            .iter()
            .map(|(k, _)| held.reader(k))
            .collect::<Result<Vec<_>>>()?;
        // a slot is reached through a response of this process that reads it, or else over DDS
        let writers = plan
            .writes
            .iter()
            .map(|(k, _)| match self.reads_here(k) {
                true => Ok(None),
                false => held.writer(k).map(Some),
            })
            .collect::<Result<Vec<_>>>()?;
        for (i, (r, (_, s))) in readers.iter().zip(&plan.reads).enumerate() {
            // an until's signal often comes from one-shot publishers (an operator's `ros2 topic pub --once`, a
            // fresh process per stop): wait only for those the graph knows now, so that none is missed; R's
            // `dropped` likewise (an rclpy response has none, and a RADAR one announces it with its others)
            // (reads: source, then until: U, started, exited, dropped)
            let optional = plan.until.is_some() && (i == 1 || i == 4);
            if optional && self.graph().writer_participants(s.topic()).is_empty() {
                tracing::debug!(
                    topic = s.topic(),
                    "until: no publisher on the graph yet, armed without one"
                );
                continue;
            }
            r.wait_for_publishers(1)
                .timeout(left())
                .await
                .map_err(|_| Error::Timeout {
                    what: format!(
                        "a publisher of {} on {}: is the component that emits it running?",
                        s.ros_type(),
                        s.topic()
                    ),
                    after: timeout,
                })?;
        }
        for (w, (_, s)) in writers.iter().zip(&plan.writes) {
            let Some(w) = w else { continue };
            w.wait_for_subscribers(1)
                .timeout(left())
                .await
                .map_err(|_| Error::Timeout {
                    what: format!(
                        "a subscriber of {} on {}: is the response running?",
                        s.ros_type(),
                        s.topic()
                    ),
                    after: timeout,
                })?;
        }
        Ok(Matched {
            readers,
            writers,
            kept,
        })
    }

    /// Whether a response of this process reads the slot `k` (with local delivery).
    fn reads_here(&self, k: &Key) -> bool {
        self.local
            && self
                .participant
                .inlets()
                .find(&k.topic, &k.ros_type)
                .is_some()
    }

    /// Enters the matched statement in the table: the table's own holds (one relay per source, one outlet per
    /// slot, shared by every connection on them), the anonymous slot's queue, the connection and its record,
    /// for the signals emitted since `began` (C1).
    fn enter(
        self: &Arc<Self>,
        plan: Plan,
        matched: &mut Matched,
        mut spec: Spec,
        causes: bool,
        began: i64,
    ) -> Result<radar_semantics::connection::ConnId> {
        self.watch_instances();
        let mut st = self.state();
        // what the taps kept while this statement armed, for the sources it gives a relay to
        let mut replay: Vec<(Key, Emitted)> = Vec::new();
        for (((k, _), r), kept) in plan
            .reads
            .iter()
            .zip(&matched.readers)
            .zip(&mut matched.kept)
        {
            if !st.relays.contains_key(k) {
                self.participant.pooled_reader(k)?;
                let (relay, kept) = self.relay(k, r.clone(), kept.take());
                replay.extend(kept.into_iter().map(|e| (k.clone(), e)));
                st.relays.insert(k.clone(), relay);
            }
        }
        for ((k, _), w) in plan.writes.iter().zip(&matched.writers) {
            self.hold_outlet(&mut st, k, w)?;
        }
        let faults = Arc::new(Faults::new(statement_label(&spec, &plan)));
        let record = self.record(plan.target.as_ref(), &mut spec, faults.clone());
        let target = match (spec.target, plan.target) {
            (TargetSpec::Slot(_), Some(k)) => Target::Slot(k),
            (TargetSpec::Anon(f), _) => {
                let faults = faults.clone();
                anon_target(&mut st, spec.source.topic(), spec.depth, f, faults)
            }
            (TargetSpec::Slot(_), None) => unreachable!("a slot target has its key"),
        };
        let until = plan.until.map(|u| Until {
            source: u.source,
            started: u.started,
            exited: u.exited,
            dropped: u.dropped,
            interrupt: Target::Slot(u.interrupt),
            causes,
        });
        let call = matches!(target, Target::Anon(_));
        let id = st
            .table
            .arm_from(plan.source, target, spec.kind, until, began, now_ns());
        st.table.set_rearm(id, spec.rearm);
        st.table.set_starts(id, spec.starts);
        st.table.set_call(id, call);
        st.records.insert(id, record);
        self.replay(st, replay);
        Ok(id)
    }

    /// What the manager keeps of a statement beside the table: who made it, its closures, the check of its
    /// start payloads (C2: for a start slot of a type this process can read, unless a map makes the payload).
    fn record(&self, target: Option<&Key>, spec: &mut Spec, faults: Arc<Faults>) -> Record {
        let reads = match (target, spec.starts, &spec.map) {
            // (an Empty start takes any signal: its payload is dropped)
            (Some(k), true, None) if k.ros_type != Empty::ros_type_name() => {
                self.participant.readers().get(&k.ros_type)
            }
            _ => None,
        };
        Record {
            owner: std::mem::take(&mut spec.owner),
            faults,
            filter: spec.filter.take(),
            map: spec.map.take(),
            starts: spec.starts,
            reads,
            target: target
                .map(|k| (k.topic.clone(), k.ros_type.clone()))
                .unwrap_or_default(),
            departure: None,
            suspended: None,
        }
    }

    /// Hands the table what the taps kept while a statement armed (now that it is in the table), in the order
    /// emitted, before anything its relays get from the taps from now on (they wait for the table's lock).
    fn replay(&self, mut st: std::sync::MutexGuard<'_, State>, mut kept: Vec<(Key, Emitted)>) {
        if kept.is_empty() {
            return;
        }
        kept.sort_by_key(|(_, (_, at, _))| *at);
        let mut changed = false;
        for (k, (raw, at, by)) in kept {
            changed |= self.dispatch_held(&mut st, &k, raw, Sent { at, by });
        }
        drop(st);
        self.signal_told(changed);
    }

    /// The outlet of slot `k`, made if the table has none, given the DDS writer `w` if it has none (B1: its
    /// response of this process left, and a new statement reaches the slot over DDS).
    fn hold_outlet(
        self: &Arc<Self>,
        st: &mut State,
        k: &Key,
        w: &Option<Arc<RawPublisher>>,
    ) -> Result<()> {
        match st.outlets.get_mut(k) {
            Some(o) => {
                if let (None, Some(w)) = (&o.dds, w) {
                    self.participant.pooled_writer(k)?;
                    o.dds = Some(w.clone());
                    let _ = o.more.send(w.matched_watch());
                }
            }
            None => {
                if w.is_some() {
                    self.participant.pooled_writer(k)?;
                }
                let inlet = self.local.then(|| self.participant.inlets().hold(&k.topic));
                let outlet = self.outlet(k, inlet, w.clone());
                st.outlets.insert(k.clone(), outlet);
            }
        }
        Ok(())
    }

    /// Whether the response whose `state` topic is `state_topic` keeps causes (C6): one of this process (its
    /// slot is read here), or one that publishes a `radar_msgs/msg/ResponseState` (a RADAR response; its state
    /// writer is announced before its signal writers, which arming has waited for). An rclpy response does not.
    fn keeps_causes(&self, state_topic: &str, interrupt: &Slot) -> bool {
        if self.local
            && self
                .participant
                .inlets()
                .find(interrupt.topic(), interrupt.ros_type())
                .is_some()
        {
            return true;
        }
        let state_t = TypeName::of::<ResponseState>().dds;
        self.graph().types_on(true, state_topic).contains(&state_t)
    }
}

/// An anonymous slot's target: a queue of `depth` payloads from `source`, and the task that calls `f` with each
/// (a call that panics is reported on `faults`, and the next payload gets the next call).
/// How a statement is named in what its closures' faults report: `once /a/triggered -> /b/start`.
fn statement_label(spec: &Spec, plan: &Plan) -> String {
    format!(
        "{} {} {}",
        match spec.kind {
            Kind::Once => "once",
            Kind::Whenever => "whenever",
        },
        spec.source.topic(),
        match &plan.target {
            Some(k) => format!("-> {}", k.topic),
            None => "call (anonymous slot)".into(),
        }
    )
}

fn anon_target(
    st: &mut State,
    source: &str,
    depth: usize,
    mut f: super::AnonFn,
    faults: Arc<Faults>,
) -> Target {
    let k = st.next_anon;
    st.next_anon += 1;
    let q = Arc::new(AnonQueue::new(source.to_owned(), depth));
    let consumer = q.clone();
    tokio::spawn(async move {
        while let Some(m) = consumer.next().await {
            // a call not begun when the statement's scope ended is not begun at all (C4)
            if !consumer.call(m, |m| {
                faults.run("call", || f(m));
            }) {
                break;
            }
        }
    });
    st.anon.insert(k, q);
    Target::Anon(k)
}
