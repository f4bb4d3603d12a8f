//! RADAR connections, with no I/O: which signal reaches which slot, and when a connection ends.
//!
//! A connection ties a *source* signal (an event's `triggered`, a response's `started`/`interrupted`/
//! `exited`) to a *target* slot (a response's `start`/`interrupt`/`exit`, or an anonymous slot). The runtime
//! feeds every signal it reads to [`ConnectionTable::on_signal`] with the time the signal was emitted (and, for
//! a response's signals, the [`Cause`] they carry), and performs the [`Delivery`]s it gets back. The rules,
//! C1-C7 (the crate documentation, the README and the tests use these numbers):
//!
//! - **C1.** A connection delivers only signals emitted at or after it was armed. Older signals (in flight when
//!   the statement ran, or replayed from a DDS cache) are never delivered. A statement that takes a while to
//!   arm (its endpoints to be matched) counts from when it began ([`ConnectionTable::arm_from`]): its own
//!   reader may activate an event whose condition already holds, and that trigger is not older than it.
//! - **C2.** `whenever` delivers every such signal until it is removed; `once` delivers exactly one, then its
//!   source is released, even when the source emits a burst, and each of several `once`s on one source gets
//!   exactly one. A signal a connection property refuses (a filter, a transform that gives nothing) is not a
//!   delivery: it does not use up a `once`.
//! - **C3.** `... until U`: U's signals interrupt the target response R only within a run that this statement
//!   started, from the moment that run began. A run R starts by itself (an exit-slot restart) or that another
//!   statement started is not interrupted by this one, nor is a run that begins after the signal of U.
//!   U is read (and so active) from arming until the statement is over: until removal for a `whenever`; for a
//!   `once`, until the run its start began has ended (R's `exited` for it), or R did not take the start (R's
//!   `dropped` for it: R was busy, the start was replaced in R's queue, R was stopping), or R left (C5), when
//!   the connection is removed as a `once` without `until` is when it fires (its guard's `closed()` resolves;
//!   U, and R's `started`, `exited` and `dropped`, are released, so an event that was U for it alone
//!   deactivates, as the paper's once-only connections go once their condition has fired).
//! - **C4.** [`ConnectionTable::remove`] (the statement's scope ending) ends a connection at once: after it
//!   returns nothing more is delivered through it.
//! - **C5.** Components leave (they exit, crash, hang, or the network cuts them off; the runtime tells the table
//!   with [`ConnectionTable::source_lost`] and [`ConnectionTable::target_lost`]). A connection whose source left
//!   [waits for the source](Link::WaitingForSource): it delivers again what a source of that name emits when
//!   one comes back. A connection whose target left delivers nothing more: it is [lost](Link::TargetLost),
//!   unless it was armed to [re-arm](ConnectionTable::set_rearm), in which case it
//!   [waits for the target](Link::WaitingForTarget) and, when a target of that name comes back, delivers
//!   signals emitted from that moment on (C1 again: nothing emitted while it waited). When the response R of
//!   an `until` leaves, its run ends: a new R of that name did not take this statement's start. A lost
//!   connection no longer reads its source (an event whose only listener it was deactivates).
//!
//! How C3 is kept when signals are read in another order than they were sent (they travel on different
//! topics, from different processes):
//!
//! - **C6.** Every start a statement delivers carries its [`Cause`] (the statement and the delivery's number),
//!   and the interrupts its `until` sends name the statement. A RADAR response (radar_ros) keeps causes
//!   ([`Until::causes`]): it applies such an interrupt only to a run of that statement that began before the
//!   signal of U was emitted (response rules R11-R13), so the table only has to send it while a run of the
//!   statement may be going: from the statement's latest start delivery to R's `exited` carrying that delivery.
//!   It does not have to know whether R took the start, nor when R's `started` comes.
//! - **C7.** A signal of U emitted after the start it should interrupt can be read before that start's source
//!   signal (U's topic is faster): the newest such signal of U is kept for [`HOLD`] and sent right after the
//!   start, if the start's source was emitted before it. For a response that carries no causes (rclpy), the
//!   table decides the window itself from R's `started` and `exited` in the order they were emitted (source
//!   stamps), and a kept signal of U is sent when R's `started` turns out to be older than it; what it cannot
//!   know is whether R took the start (it assumes so when R was idle, by the stamps, when the start was sent).
//!
//! [`ConnectionTable::sources`] says which sources must be read right now; the runtime keeps exactly those
//! readers, so an event whose only listener was a fired `once` deactivates.

mod departures;
mod outcome;
mod outputs;
mod window;

pub use outputs::{ConnInfo, Delivery, Link, Outcome, Send, Via};
use window::WindowSignal;
pub use window::{Until, UntilWindow};

use std::collections::{BTreeMap, BTreeSet};

use crate::time::Clock;

pub use crate::response::{Cause, Sent, StatementId, HOLD};

/// Identifies a connection in a table.
pub type ConnId = u64;

/// `once` or `whenever`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// Deliver one signal.
    Once,
    /// Deliver every signal.
    Whenever,
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Conn<S, T> {
    source: S,
    target: T,
    kind: Kind,
    armed_at: i64,
    delivered: u64,
    /// A `once` that has delivered (kept only while its `until` lives).
    spent: bool,
    /// Whether the table reads its source for it (not once spent, nor once its target is lost).
    reading: bool,
    link: Link,
    /// Re-arm when a lost target comes back (rule 5).
    rearm: bool,
    /// Its target is an anonymous slot: once it ends by itself, its target is kept for
    /// [`ConnectionTable::forget`] (a call already queued must not begin after its scope ended, C4).
    call: bool,
    /// Its deliveries to the target carry the statement's cause: the target is a response's `start` (R13).
    starts: bool,
    until: Option<(Until<S, T>, UntilWindow)>,
}

/// The live connections of one manager.
///
/// A signal visits only the connections that listen to its source (an index by source), and the table keeps
/// a count of the connections that need each source and target, so a runtime learns which readers and writers
/// it may drop from [`ConnectionTable::take_released`] without scanning every connection: the cost of a
/// signal or a removal does not grow with the number of unrelated connections.
///
/// ```
/// use radar_semantics::connection::{ConnectionTable, Kind};
/// let mut t = ConnectionTable::new();
/// let id = t.arm("bumper", "dock/start", Kind::Once, None, 100);
/// assert!(t.on_signal(&"bumper", 50).is_empty(), "emitted before the statement: never delivered");
/// let d = t.on_signal(&"bumper", 150);
/// assert_eq!((d[0].id, d[0].target), (id, "dock/start"));
/// assert!(t.on_signal(&"bumper", 160).is_empty(), "a once delivers one signal");
/// assert!(!t.contains(id));
/// assert_eq!(t.take_released(), (vec!["bumper"], vec!["dock/start"]));
/// ```
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ConnectionTable<S, T> {
    next: ConnId,
    /// The high 64 bits of this table's statement ids (C6).
    base: u64,
    conns: BTreeMap<ConnId, Conn<S, T>>,
    /// Source -> the connections whose delivery or `until` window that source's signals can change.
    by_source: BTreeMap<S, BTreeSet<ConnId>>,
    /// Sources that must be read, with how many connections need each.
    reads: BTreeMap<S, usize>,
    /// Slots that live connections may deliver to, with how many connections.
    writes: BTreeMap<T, usize>,
    /// Sources and targets whose count fell to zero since the last [`ConnectionTable::take_released`].
    released: (Vec<S>, Vec<T>),
    /// The receiver's clock, as last given (T2).
    clock: Clock,
    /// Connections a signal ended (a `once` that fired, or whose run ended) since the last
    /// [`ConnectionTable::take_ended`].
    ended: Vec<ConnId>,
    /// The targets of anonymous-slot connections that ended by themselves, until their scope ends.
    ended_calls: BTreeMap<ConnId, T>,
}

impl<S, T> Default for ConnectionTable<S, T> {
    fn default() -> Self {
        ConnectionTable {
            next: 1,
            base: 0,
            conns: BTreeMap::new(),
            by_source: BTreeMap::new(),
            reads: BTreeMap::new(),
            writes: BTreeMap::new(),
            released: (Vec::new(), Vec::new()),
            clock: Clock::default(),
            ended: Vec::new(),
            ended_calls: BTreeMap::new(),
        }
    }
}

fn count_up<K: Ord>(m: &mut BTreeMap<K, usize>, k: K) {
    *m.entry(k).or_default() += 1;
}

/// Decrements `k`'s count; when it reaches zero the key is removed and pushed to `released`.
fn count_down<K: Ord + Clone>(m: &mut BTreeMap<K, usize>, k: &K, released: &mut Vec<K>) {
    if let Some(n) = m.get_mut(k) {
        *n -= 1;
        if *n == 0 {
            m.remove(k);
            released.push(k.clone());
        }
    }
}

impl<S: Clone + Ord, T: Clone + Ord> Until<S, T> {
    /// The interrupt the window decided to send at `at`, if it did.
    fn interrupt_at(&self, id: ConnId, at: Option<i64>, out: &mut Vec<Delivery<T>>) {
        if let Some(at) = at {
            out.push(Delivery {
                id,
                target: self.interrupt.clone(),
                via: Via::Until { at },
            });
        }
    }
}

impl<S: Clone + Ord, T: Clone + Ord> Conn<S, T> {
    /// The signal of `source` emitted at `emitted_at` moves this connection's `until` window (the response's
    /// `started` and `exited`, and U), adding the interrupts it decides to `out`; `mine` is the run of this
    /// connection's start that an `exited` reports, if it does. Whether the connection is over (C3: a spent
    /// `once` whose run has ended).
    fn move_window(
        &mut self,
        id: ConnId,
        source: &S,
        emitted_at: i64,
        mine: Option<u64>,
        out: &mut Vec<Delivery<T>>,
    ) -> bool {
        let Some((u, w)) = &mut self.until else {
            return false;
        };
        let mut over = false;
        if &u.started == source {
            let send = w.apply(WindowSignal::Started { at: emitted_at });
            u.interrupt_at(id, send, out);
        }
        if &u.exited == source {
            w.apply(WindowSignal::Exited {
                at: emitted_at,
                ours: mine,
            });
            over = self.spent && w.settled();
        }
        if &u.dropped == source {
            w.apply(WindowSignal::Dropped { ours: mine });
            over = self.spent && w.settled();
        }
        if &u.source == source {
            let send = w.apply(WindowSignal::U { at: emitted_at });
            u.interrupt_at(id, send, out);
        }
        over
    }

    /// Every source whose signals this connection looks at.
    fn listens(&self) -> Vec<S> {
        let mut v = vec![self.source.clone()];
        v.extend(self.until_reads());
        v
    }
    /// The `until` sources, read from arming to removal.
    fn until_reads(&self) -> Vec<S> {
        match &self.until {
            Some((u, _)) => vec![
                u.source.clone(),
                u.started.clone(),
                u.exited.clone(),
                u.dropped.clone(),
            ],
            None => Vec::new(),
        }
    }
    /// The slots it may deliver to.
    fn writes(&self) -> Vec<T> {
        let mut v = vec![self.target.clone()];
        if let Some((u, _)) = &self.until {
            v.push(u.interrupt.clone());
        }
        v
    }
}

impl<S: Clone + Ord, T: Clone + Ord> ConnectionTable<S, T> {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty table whose statements are named `base` in their ids' high 64 bits (C6): the runtime picks a
    /// `base` unique on the graph (radar_ros folds its participant's GUID prefix into it).
    pub fn with_statement_base(base: u64) -> Self {
        ConnectionTable {
            base,
            ..Self::default()
        }
    }

    /// The graph-wide id of connection `id`'s statement (C6).
    pub fn statement(&self, id: ConnId) -> StatementId {
        (u128::from(self.base) << 64) | u128::from(id)
    }

    /// The connection of this table that a cause names, if any.
    fn ours(&self, cause: Option<Cause>) -> Option<(ConnId, u64)> {
        let c = cause?;
        ((c.statement >> 64) as u64 == self.base).then_some((c.statement as u64, c.delivery))
    }

    /// The cause of delivery `n` of connection `id` (C6).
    pub fn cause(&self, id: ConnId, n: u64) -> Cause {
        Cause {
            statement: self.statement(id),
            delivery: n,
        }
    }

    /// Arms a connection from `source` to `target` at time `armed_at` (ns, same clock as signal stamps: the
    /// receiver's clock now, which the table takes as [`ConnectionTable::clock`] does).
    pub fn arm(
        &mut self,
        source: S,
        target: T,
        kind: Kind,
        until: Option<Until<S, T>>,
        armed_at: i64,
    ) -> ConnId {
        self.arm_from(source, target, kind, until, armed_at, armed_at)
    }

    /// Arms a connection at `now` (the receiver's clock, as [`ConnectionTable::arm`] takes it) for the signals
    /// emitted from `since` on (C1; a time no later than `now`): when the statement began to arm. A runtime
    /// whose readers activate the source while the statement arms (an event checks only while it is listened
    /// to, and its condition may already hold) delivers what the source emitted since the statement ran,
    /// not only since its last endpoint matched; signals older than the statement are still never delivered.
    ///
    /// ```
    /// use radar_semantics::connection::{ConnectionTable, Kind};
    /// let mut t = ConnectionTable::new();
    /// // the statement began at 100; its reader activated the event, which triggered at 120; armed at 150
    /// t.arm_from("door_open", "close/start", Kind::Once, None, 100, 150);
    /// assert!(t.on_signal(&"door_open", 90).is_empty(), "older than the statement");
    /// assert_eq!(t.on_signal(&"door_open", 120)[0].target, "close/start");
    /// ```
    pub fn arm_from(
        &mut self,
        source: S,
        target: T,
        kind: Kind,
        until: Option<Until<S, T>>,
        since: i64,
        now: i64,
    ) -> ConnId {
        self.clock(now);
        let armed_at = since.min(now);
        let id = self.next;
        self.next += 1;
        let c = Conn {
            source,
            target,
            kind,
            armed_at,
            delivered: 0,
            spent: false,
            reading: true,
            link: Link::Armed,
            rearm: false,
            call: false,
            starts: false,
            until: until.map(|u| {
                let w = UntilWindow::new(u.causes);
                (u, w)
            }),
        };
        for s in c.listens() {
            self.by_source.entry(s).or_default().insert(id);
        }
        count_up(&mut self.reads, c.source.clone());
        for s in c.until_reads() {
            count_up(&mut self.reads, s);
        }
        for t in c.writes() {
            count_up(&mut self.writes, t);
        }
        self.conns.insert(id, c);
        id
    }

    /// Removes a connection; nothing is delivered through it afterwards. Returns whether it existed.
    pub fn remove(&mut self, id: ConnId) -> bool {
        let Some(c) = self.conns.remove(&id) else {
            return false;
        };
        for s in c.listens() {
            if let Some(ids) = self.by_source.get_mut(&s) {
                ids.remove(&id);
                if ids.is_empty() {
                    self.by_source.remove(&s);
                }
            }
        }
        if c.reading {
            count_down(&mut self.reads, &c.source, &mut self.released.0);
        }
        for s in c.until_reads() {
            count_down(&mut self.reads, &s, &mut self.released.0);
        }
        for t in c.writes() {
            count_down(&mut self.writes, &t, &mut self.released.1);
        }
        true
    }

    /// Whether `id` is still live (a fired `once` without `until` is not).
    pub fn contains(&self, id: ConnId) -> bool {
        self.conns.contains_key(&id)
    }

    /// The target of connection `id`, if it is live.
    pub fn target(&self, id: ConnId) -> Option<&T> {
        self.conns.get(&id).map(|c| &c.target)
    }

    /// How many connections are live.
    pub fn len(&self) -> usize {
        self.conns.len()
    }

    /// Whether no connection is live.
    pub fn is_empty(&self) -> bool {
        self.conns.is_empty()
    }

    /// The sources that must be read now.
    pub fn sources(&self) -> BTreeSet<S> {
        self.reads.keys().cloned().collect()
    }

    /// Whether `source` must be read now.
    pub fn reads(&self, source: &S) -> bool {
        self.reads.contains_key(source)
    }

    /// The slots that live connections may deliver to (targets, and the `interrupt` slots of `until`s).
    pub fn targets(&self) -> BTreeSet<T> {
        self.writes.keys().cloned().collect()
    }

    /// Whether a live connection may deliver to `target`.
    pub fn writes(&self, target: &T) -> bool {
        self.writes.contains_key(target)
    }

    /// The sources and targets no connection needs any more, since the last call: the readers and writers
    /// the runtime may drop (unless it holds them for another reason).
    #[must_use = "the released sources and targets are to be closed"]
    pub fn take_released(&mut self) -> (Vec<S>, Vec<T>) {
        std::mem::take(&mut self.released)
    }

    /// Every live connection.
    pub fn list(&self) -> Vec<ConnInfo<S, T>> {
        self.conns
            .iter()
            .map(|(id, c)| ConnInfo {
                id: *id,
                source: c.source.clone(),
                target: c.target.clone(),
                kind: c.kind,
                delivered: c.delivered,
                until: c.until.as_ref().map(|(u, _)| u.source.clone()),
                link: c.link,
                armed_at: c.armed_at,
            })
            .collect()
    }

    /// Whether connection `id` can deliver now, if it is live.
    pub fn link(&self, id: ConnId) -> Option<Link> {
        self.conns.get(&id).map(|c| c.link)
    }

    /// The receiver's clock reads `now` (ns, the clock of the stamps). When it has stepped back since it was
    /// last given (an NTP correction), the times the table remembers (when connections were armed, the stamps
    /// in `until` windows) are brought back to it (T2): signals stamped by the stepped clock are not taken as
    /// older than them. The runtime gives the clock before each signal ([`ConnectionTable::arm`] and
    /// [`ConnectionTable::target_back`] take it themselves); costs nothing unless the clock stepped back.
    pub fn clock(&mut self, now: i64) {
        if let Some(now) = self.clock.set(now) {
            for c in self.conns.values_mut() {
                c.armed_at = c.armed_at.min(now);
                if let Some((_, w)) = &mut c.until {
                    w.step_back(now);
                }
            }
        }
    }

    /// A signal from `source`, emitted at `emitted_at` by no statement: what to deliver, in connection order.
    #[must_use = "the deliveries are what the binding must carry out"]
    pub fn on_signal(&mut self, source: &S, emitted_at: i64) -> Vec<Delivery<T>> {
        self.on_signal_with(source, emitted_at, None, |_| true)
    }

    /// Like [`ConnectionTable::on_signal`], for a signal that carries `from` (a response's `started` and
    /// `exited` carry the cause of their run: C6), with a per-connection filter (a connection property, C2): a
    /// signal that `accept(id)` refuses is not delivered through `id` and does not use up a `once`.
    #[must_use = "the deliveries are what the binding must carry out"]
    pub fn on_signal_with(
        &mut self,
        source: &S,
        emitted_at: i64,
        from: Option<Cause>,
        mut accept: impl FnMut(ConnId) -> bool,
    ) -> Vec<Delivery<T>> {
        let mut out = Vec::new();
        let mut finished = Vec::new();
        let ours = self.ours(from);
        let Some(ids) = self.by_source.get(source) else {
            return out;
        };
        for id in ids {
            let Some(c) = self.conns.get_mut(id) else {
                continue;
            };
            if emitted_at < c.armed_at {
                continue; // C1
            }
            // the response's own signals move the until window (before the connection's deliveries)
            let mine = ours.and_then(|(cid, n)| (cid == *id).then_some(n));
            if c.move_window(*id, source, emitted_at, mine, &mut out) {
                finished.push(*id);
            }
            if &c.source == source && !c.spent && c.link == Link::Armed && accept(*id) {
                c.delivered += 1;
                out.push(Delivery {
                    id: *id,
                    target: c.target.clone(),
                    via: Via::Signal { n: c.delivered },
                });
                if let Some((u, w)) = &mut c.until {
                    // C7: a signal of U read before this start, and emitted after its source, follows it
                    let send = w.apply(WindowSignal::StartDelivered {
                        n: c.delivered,
                        at: emitted_at,
                    });
                    u.interrupt_at(*id, send, &mut out);
                }
                if c.kind == Kind::Once {
                    c.spent = true;
                    // a spent `once` no longer reads its source (its `until` still does)
                    c.reading = false;
                    count_down(&mut self.reads, &c.source, &mut self.released.0);
                    if c.until.is_none() {
                        finished.push(*id);
                    }
                }
            }
        }
        for id in finished {
            self.end(id);
        }
        out
    }

    /// Connection `id` is over by itself (a `once` that fired, or whose run ended or will not come): removed,
    /// listed in [`ConnectionTable::take_ended`], its anonymous slot kept for [`ConnectionTable::forget`].
    pub(crate) fn end(&mut self, id: ConnId) {
        if let Some(c) = self.conns.get(&id) {
            if c.call {
                self.ended_calls.insert(id, c.target.clone());
            }
        }
        self.remove(id);
        self.ended.push(id);
    }
}

#[cfg(test)]
// the tests step machines into a state and look at the effects of the steps that matter
#[allow(unused_must_use)]
mod tests {
    use super::*;

    type Table = ConnectionTable<&'static str, &'static str>;

    fn targets(d: Vec<Delivery<&'static str>>) -> Vec<&'static str> {
        d.into_iter().map(|d| d.target).collect()
    }

    #[test]
    fn c1_a_statement_that_armed_slowly_counts_from_when_it_began_and_no_other_moves() {
        let mut t = Table::new();
        // B's statement began at 100 and took until 300 to arm; A's began and armed at 200 meanwhile
        let a = t.arm("E", "A.start", Kind::Whenever, None, 200);
        let b = t.arm_from("E", "B.start", Kind::Whenever, None, 100, 300);
        let d = t.on_signal(&"E", 150);
        assert_eq!(
            d.iter().map(|d| d.id).collect::<Vec<_>>(),
            [b],
            "emitted after B's statement began, before A's"
        );
        assert!(t.on_signal(&"E", 99).is_empty(), "older than both");
        assert_eq!(t.on_signal(&"E", 250).len(), 2);
        // (B's earlier start is not a step back of the clock: A still counts from 200, as the first signal showed)
        // a `since` later than now (a clock stepped back while arming) is taken as now
        t.remove(a);
        t.remove(b);
        let c = t.arm_from("E", "C.start", Kind::Whenever, None, 500, 400);
        assert!(t.on_signal(&"E", 399).is_empty());
        assert_eq!(t.on_signal(&"E", 450)[0].id, c);
    }

    #[test]
    fn t2_after_the_clock_steps_back_a_connection_delivers_signals_stamped_by_it() {
        let step = 10_000_000_000; // an NTP correction of 10 s
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Whenever, None, 100 * step);
        assert_eq!(targets(t.on_signal(&"E", 100 * step + 5)), ["R.start"]);
        // the host's clock steps back: the next signal is stamped 10 s before the arming
        let stepped = 100 * step + 10 - step;
        t.clock(stepped);
        assert_eq!(targets(t.on_signal(&"E", stepped)), ["R.start"]);
        // C1 still holds on the stepped clock: what was emitted before the step's new now is old
        assert!(t.on_signal(&"E", stepped - 1).is_empty());
        // an until window opened before the step stays open for U stamped by the stepped clock
        let mut t = Table::new();
        let until = Until {
            source: "U",
            started: "R.started",
            exited: "R.exited",
            dropped: "R.dropped",
            interrupt: "R.interrupt",
            causes: false,
        };
        t.arm("E", "R.start", Kind::Once, Some(until), 100 * step);
        assert_eq!(targets(t.on_signal(&"E", 100 * step + 10)), ["R.start"]);
        assert!(t.on_signal(&"R.started", 100 * step + 20).is_empty());
        t.clock(stepped);
        assert_eq!(targets(t.on_signal(&"U", stepped + 1)), ["R.interrupt"]);
    }

    #[test]
    fn c1_signals_emitted_before_arming_are_never_delivered() {
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Whenever, None, 100);
        assert!(t.on_signal(&"E", 99).is_empty(), "in flight or replayed");
        assert_eq!(targets(t.on_signal(&"E", 100)), ["R.start"]);
        // a once armed later ignores what the first one saw
        let once = t.arm("E", "Q.start", Kind::Once, None, 200);
        assert_eq!(targets(t.on_signal(&"E", 150)), ["R.start"]);
        assert!(t.contains(once));
    }

    #[test]
    fn c2_whenever_delivers_every_signal() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Whenever, None, 0);
        for i in 0..5 {
            assert_eq!(targets(t.on_signal(&"E", i)), ["R.start"]);
        }
        assert_eq!(t.list()[0].delivered, 5);
        assert!(t.contains(id));
        assert!(
            t.on_signal(&"F", 10).is_empty(),
            "other sources do not reach it"
        );
    }

    #[test]
    fn c2_once_delivers_exactly_one_of_a_burst_and_releases_its_source() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Once, None, 0);
        assert_eq!(t.sources(), BTreeSet::from(["E"]));
        let burst: Vec<_> = (0..100).flat_map(|i| t.on_signal(&"E", i)).collect();
        assert_eq!(burst.len(), 1);
        assert!(!t.contains(id));
        assert!(t.sources().is_empty(), "the event may deactivate");
    }

    #[test]
    fn c2_racing_onces_on_one_source_each_get_exactly_one() {
        let mut t = Table::new();
        t.arm("E", "A.start", Kind::Once, None, 0);
        t.arm("E", "B.start", Kind::Once, None, 0);
        t.arm("E", "C.start", Kind::Whenever, None, 0);
        assert_eq!(
            targets(t.on_signal(&"E", 1)),
            ["A.start", "B.start", "C.start"]
        );
        assert_eq!(targets(t.on_signal(&"E", 2)), ["C.start"]);
    }

    /// An until on R, a response that carries no causes (rclpy): the table decides the window (C7).
    fn until() -> Until<&'static str, &'static str> {
        until_with(false)
    }

    fn until_with(causes: bool) -> Until<&'static str, &'static str> {
        Until {
            source: "U",
            started: "R.started",
            exited: "R.exited",
            dropped: "R.dropped",
            interrupt: "R.interrupt",
            causes,
        }
    }

    fn vias(d: Vec<Delivery<&'static str>>) -> Vec<(&'static str, Via)> {
        d.into_iter().map(|d| (d.target, d.via)).collect()
    }

    #[test]
    fn c6_starts_carry_their_cause_and_until_interrupts_go_while_the_run_may_go_on() {
        let mut t = Table::with_statement_base(42);
        let id = t.arm("E", "R.start", Kind::Whenever, Some(until_with(true)), 0);
        let k = t.statement(id);
        assert_eq!(k >> 64, 42);
        assert!(
            t.on_signal(&"U", 1).is_empty(),
            "no start delivered: nothing to interrupt"
        );
        assert_eq!(
            vias(t.on_signal(&"E", 2)),
            [("R.start", Via::Signal { n: 1 })]
        );
        assert_eq!(
            t.cause(id, 1),
            Cause {
                statement: k,
                delivery: 1
            }
        );
        // U goes to R as soon as the start is sent, before R's `started` is read: R decides (R11-R13)
        assert_eq!(
            vias(t.on_signal(&"U", 3)),
            [("R.interrupt", Via::Until { at: 3 })]
        );
        // R's `exited` of another statement's run (or of none) changes nothing ...
        let other = Cause {
            statement: 7 << 64,
            delivery: 1,
        };
        t.on_signal_with(&"R.exited", 4, Some(other), |_| true);
        t.on_signal_with(&"R.exited", 4, None, |_| true);
        assert_eq!(targets(t.on_signal(&"U", 5)), ["R.interrupt"]);
        // ... the `exited` of this statement's run ends it
        t.on_signal_with(&"R.exited", 6, Some(t.cause(id, 1)), |_| true);
        assert!(t.on_signal(&"U", 7).is_empty());
        // a second delivery: its run may go on until its own `exited` (an older run's does not end it)
        assert_eq!(
            vias(t.on_signal(&"E", 8)),
            [("R.start", Via::Signal { n: 2 })]
        );
        t.on_signal_with(&"R.exited", 9, Some(t.cause(id, 1)), |_| true);
        assert_eq!(targets(t.on_signal(&"U", 10)), ["R.interrupt"]);
    }

    #[test]
    fn c7_a_signal_of_u_read_before_the_start_it_follows_is_sent_after_it() {
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until_with(true)), 0);
        // U emitted at 20 is read before E emitted at 10 (another topic, a faster path)
        assert!(t.on_signal(&"U", 20).is_empty());
        assert_eq!(
            vias(t.on_signal(&"E", 10)),
            [
                ("R.start", Via::Signal { n: 1 }),
                ("R.interrupt", Via::Until { at: 20 })
            ]
        );
        // U emitted before E: not sent
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until_with(true)), 0);
        t.on_signal(&"U", 5);
        assert_eq!(targets(t.on_signal(&"E", 10)), ["R.start"]);
        // nor one emitted more than HOLD after
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until_with(true)), 0);
        t.on_signal(&"U", 10 + HOLD + 1);
        assert_eq!(targets(t.on_signal(&"E", 10)), ["R.start"]);
    }

    #[test]
    fn c7_without_causes_a_start_the_busy_response_drops_opens_no_window() {
        // R is busy when the statement delivers its start, and its run ends after that: R dropped the start
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        t.on_signal(&"R.started", 1); // some other run of R
        assert_eq!(targets(t.on_signal(&"E", 2)), ["R.start"]);
        t.on_signal(&"R.exited", 3); // that run ends after the start was sent: the start was dropped
        t.on_signal(&"R.started", 4); // R's exit slot restarts it
        assert!(
            t.on_signal(&"U", 5).is_empty(),
            "R's own restart is not the run this statement started"
        );
    }

    #[test]
    fn c7_without_causes_an_exited_read_after_the_start_it_preceded_opens_the_window() {
        // R's run ended at 3; the start (emitted at 5) is read before that `exited`: R was idle and took it
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        t.on_signal(&"R.started", 1);
        t.on_signal(&"E", 5);
        t.on_signal(&"R.exited", 3);
        t.on_signal(&"R.started", 6);
        assert_eq!(targets(t.on_signal(&"U", 7)), ["R.interrupt"]);
    }

    #[test]
    fn c7_without_causes_a_signal_of_u_read_before_r_started_is_sent_when_started_is_older() {
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        t.on_signal(&"E", 1);
        assert!(
            t.on_signal(&"U", 5).is_empty(),
            "R's started (at 3) is still on its way"
        );
        assert_eq!(targets(t.on_signal(&"R.started", 3)), ["R.interrupt"]);
        // a signal of U older than R's started is not
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        t.on_signal(&"E", 1);
        t.on_signal(&"U", 2);
        assert!(t.on_signal(&"R.started", 3).is_empty());
        assert!(!t.on_signal(&"U", 4).is_empty(), "later ones are");
    }

    #[test]
    fn c3_response_signals_read_out_of_order_leave_the_window_as_emitted() {
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Whenever, Some(until()), 0);
        t.on_signal(&"E", 1);
        t.on_signal(&"R.started", 2);
        // R's run ends at 5 and another statement's start runs at 6; `started` is read first
        t.on_signal(&"R.started", 6);
        t.on_signal(&"R.exited", 5);
        assert!(
            t.on_signal(&"U", 7).is_empty(),
            "the run at 6 is not this connection's; the late `exited` did not undo that"
        );
        // and a run this connection starts opens its window as usual
        t.on_signal(&"R.exited", 8);
        t.on_signal(&"E", 9);
        t.on_signal(&"R.started", 10);
        assert_eq!(targets(t.on_signal(&"U", 11)), ["R.interrupt"]);
    }

    #[test]
    fn c3_a_spent_once_until_ends_when_its_response_does_not_take_the_start() {
        let mut t = Table::with_statement_base(3);
        let id = t.arm("E", "R.start", Kind::Once, Some(until_with(true)), 0);
        assert_eq!(targets(t.on_signal(&"E", 1)), ["R.start"]);
        // another statement's start dropped, or this one's of no delivery: still on
        let other = Cause {
            statement: 7 << 64,
            delivery: 1,
        };
        t.on_signal_with(&"R.dropped", 2, Some(other), |_| true);
        assert!(t.contains(id));
        // R did not take this statement's start: no run of it comes, the once is over and lets go of U
        let _ = t.take_released();
        t.on_signal_with(&"R.dropped", 3, Some(t.cause(id, 1)), |_| true);
        assert!(!t.contains(id));
        assert_eq!(t.take_ended(), [id]);
        let (mut s, _) = t.take_released();
        s.sort();
        assert_eq!(s, ["R.dropped", "R.exited", "R.started", "U"]);
        // a whenever ... until whose start was dropped goes on
        let mut t = Table::with_statement_base(3);
        let id = t.arm("E", "R.start", Kind::Whenever, Some(until_with(true)), 0);
        t.on_signal(&"E", 1);
        t.on_signal_with(&"R.dropped", 3, Some(t.cause(id, 1)), |_| true);
        assert!(t.contains(id));
    }

    /// C6: `whenever E start R until U` while R runs the statement's first start and drops the second (busy,
    /// `ignore`): U still interrupts the first run, which the statement began; once that run has ended, U
    /// interrupts nothing (the soak's pokes found U shut out by the dropped start, issue 69's fix).
    #[test]
    fn c6_a_dropped_later_start_does_not_end_the_window_of_the_run_going() {
        let mut t = Table::with_statement_base(3);
        let id = t.arm("E", "R.start", Kind::Whenever, Some(until_with(true)), 0);
        assert_eq!(targets(t.on_signal(&"E", 1)), ["R.start"]);
        t.on_signal_with(&"R.started", 2, Some(t.cause(id, 1)), |_| true);
        assert_eq!(targets(t.on_signal(&"E", 3)), ["R.start"]);
        t.on_signal_with(&"R.dropped", 4, Some(t.cause(id, 2)), |_| true);
        assert_eq!(
            targets(t.on_signal(&"U", 5)),
            ["R.interrupt"],
            "run 1 goes on: U reaches it"
        );
        t.on_signal_with(&"R.exited", 6, Some(t.cause(id, 1)), |_| true);
        assert!(
            t.on_signal(&"U", 7).is_empty(),
            "no run of the statement goes on"
        );
        // a `started` read after its own `exited` opens nothing
        assert_eq!(targets(t.on_signal(&"E", 8)), ["R.start"]);
        t.on_signal_with(&"R.exited", 10, Some(t.cause(id, 3)), |_| true);
        t.on_signal_with(&"R.started", 9, Some(t.cause(id, 3)), |_| true);
        assert!(t.on_signal(&"U", 11).is_empty(), "run 3 is over");
    }

    #[test]
    fn c3_c5_a_spent_once_until_ends_when_its_response_leaves() {
        for leaves in ["R.interrupt", "R.started", "R.exited"] {
            let mut t = Table::with_statement_base(3);
            let id = t.arm("E", "R.start", Kind::Once, Some(until_with(true)), 0);
            t.on_signal(&"E", 1);
            let changed = if leaves == "R.interrupt" {
                t.target_lost(&leaves)
            } else {
                t.source_lost(&leaves)
            };
            assert_eq!(changed, [id], "{leaves}");
            assert!(!t.contains(id), "{leaves}");
            assert_eq!(t.take_ended(), [id], "{leaves}");
        }
        // not spent yet: the once waits for its source's next signal, with a new R
        let mut t = Table::with_statement_base(3);
        let id = t.arm("E", "R.start", Kind::Once, Some(until_with(true)), 0);
        let _ = t.source_lost(&"R.exited");
        assert!(t.contains(id));
        assert!(t.take_ended().is_empty());
    }

    #[test]
    fn c4_an_anonymous_slot_that_fired_is_forgotten_with_its_scope() {
        let mut t = Table::new();
        let id = t.arm("E", "call", Kind::Once, None, 0);
        t.set_call(id, true);
        let out = t.signal(&"E", Sent::at(1), 1, |_| true);
        assert_eq!(out.ended, [id]);
        assert_eq!(t.target(id), None, "gone from the table");
        assert_eq!(
            t.forget(id),
            Some("call"),
            "what its scope's end must cancel"
        );
        assert_eq!(t.forget(id), None);
        // a live one is removed and named; a slot target that ended is not kept
        let id = t.arm("E", "call", Kind::Whenever, None, 2);
        t.set_call(id, true);
        assert_eq!(t.forget(id), Some("call"));
        assert!(!t.contains(id));
        let id = t.arm("E", "R.start", Kind::Once, None, 3);
        let _ = t.signal(&"E", Sent::at(4), 4, |_| true);
        assert_eq!(t.forget(id), None);
    }

    #[test]
    fn c3_until_interrupts_only_the_run_this_connection_started() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        assert_eq!(
            t.sources(),
            BTreeSet::from(["E", "U", "R.started", "R.exited", "R.dropped"])
        );
        assert!(
            t.on_signal(&"U", 1).is_empty(),
            "before any start: U is read but goes nowhere"
        );
        assert_eq!(targets(t.on_signal(&"E", 2)), ["R.start"]);
        assert_eq!(
            t.sources(),
            BTreeSet::from(["U", "R.started", "R.exited", "R.dropped"]),
            "E is released"
        );
        t.on_signal(&"R.started", 4);
        assert_eq!(targets(t.on_signal(&"U", 5)), ["R.interrupt"]);
        t.on_signal(&"R.exited", 6);
        // R's exit slot restarts it: not a start this connection delivered
        t.on_signal(&"R.started", 7);
        assert!(
            t.on_signal(&"U", 8).is_empty(),
            "the restart runs outside the window"
        );
        assert!(
            !t.contains(id),
            "the once is over: the run its start began has ended"
        );
        assert!(t.sources().is_empty(), "U and R's signals are let go");
        // a whenever's until lives as long as its scope
        let id = t.arm("E", "R.start", Kind::Whenever, Some(until()), 10);
        t.on_signal(&"E", 11);
        t.on_signal(&"R.started", 12);
        t.on_signal(&"R.exited", 13);
        assert!(t.contains(id));
        assert!(t.remove(id));
        assert!(t.sources().is_empty());
    }

    #[test]
    fn c3_whenever_until_opens_a_window_for_each_start_it_delivers() {
        for causes in [false, true] {
            let mut t = Table::new();
            let id = t.arm("E", "R.start", Kind::Whenever, Some(until_with(causes)), 0);
            for round in 0..3 {
                let base = round * 10;
                t.on_signal(&"E", base + 1);
                let run = Some(t.cause(id, round as u64 + 1));
                t.on_signal_with(&"R.started", base + 2, run, |_| true);
                assert_eq!(targets(t.on_signal(&"U", base + 3)), ["R.interrupt"]);
                t.on_signal_with(&"R.exited", base + 4, run, |_| true);
                assert!(t.on_signal(&"U", base + 5).is_empty(), "causes: {causes}");
            }
        }
    }

    #[test]
    fn c1_the_window_ignores_response_signals_from_before_arming() {
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until()), 100);
        t.on_signal(&"E", 101);
        t.on_signal(&"R.started", 50); // stale
        assert!(t.on_signal(&"U", 102).is_empty());
        t.on_signal(&"R.started", 103);
        assert_eq!(targets(t.on_signal(&"U", 104)), ["R.interrupt"]);
    }

    #[test]
    fn endpoints_are_released_when_the_last_connection_needing_them_goes() {
        let mut t = ConnectionTable::new();
        let a = t.arm("E", "R1", Kind::Whenever, None, 0);
        let b = t.arm("E", "R2", Kind::Whenever, None, 0);
        let c = t.arm("F", "R1", Kind::Once, None, 0);
        assert!(t.reads(&"E") && t.reads(&"F") && t.writes(&"R1") && t.writes(&"R2"));
        t.remove(a);
        assert_eq!(
            t.take_released(),
            (vec![], vec![]),
            "E and R1 are still needed"
        );
        t.remove(b);
        assert_eq!(t.take_released(), (vec!["E"], vec!["R2"]));
        assert!(!t.reads(&"E") && !t.writes(&"R2") && t.writes(&"R1"));
        // a `once` that fires releases its source and its target
        assert_eq!(targets(t.on_signal(&"F", 1)), ["R1"]);
        assert!(!t.contains(c));
        assert_eq!(t.take_released(), (vec!["F"], vec!["R1"]));
        assert!(t.is_empty() && t.sources().is_empty() && t.targets().is_empty());
        // signals of sources nobody listens to any more reach nothing
        assert!(t.on_signal(&"E", 2).is_empty());
    }

    #[test]
    fn c3_a_spent_once_with_until_is_over_when_its_run_has_ended() {
        for causes in [true, false] {
            let mut t = ConnectionTable::new();
            let id = t.arm(
                "E",
                "R.start",
                Kind::Once,
                Some(Until { causes, ..until() }),
                0,
            );
            t.on_signal(&"E", 1);
            let from = Some(t.cause(id, 1));
            t.on_signal_with(&"R.started", 2, from, |_| true);
            t.take_released();
            // an `exited` of another run changes nothing
            t.on_signal_with(&"R.exited", 3, None, |_| true);
            assert_eq!(
                t.contains(id),
                causes,
                "causes {causes}: C7 takes any exited after started as its run's"
            );
            if causes {
                assert!(t.reads(&"U"));
                // the exited of the run the start began: over, and U is let go
                t.on_signal_with(&"R.exited", 4, from, |_| true);
                assert!(!t.contains(id), "causes {causes}");
            }
            let (mut s, _) = t.take_released();
            s.sort();
            assert_eq!(
                s,
                ["R.dropped", "R.exited", "R.started", "U"],
                "causes {causes}"
            );
        }
        // a whenever keeps its until for as long as it lives
        let mut t = ConnectionTable::new();
        let id = t.arm("E", "R.start", Kind::Whenever, Some(until()), 0);
        t.on_signal(&"E", 1);
        let from = Some(t.cause(id, 1));
        t.on_signal_with(&"R.exited", 4, from, |_| true);
        assert!(t.contains(id) && t.reads(&"U"));
    }

    #[test]
    fn a_spent_once_with_until_keeps_reading_only_its_until_signals() {
        let mut t = ConnectionTable::new();
        let id = t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        t.on_signal(&"E", 1);
        assert!(t.contains(id));
        assert_eq!(t.take_released(), (vec!["E"], vec![]));
        assert!(t.reads(&"U") && t.reads(&"R.started") && t.reads(&"R.exited"));
        t.remove(id);
        let (mut s, mut w) = t.take_released();
        s.sort();
        w.sort();
        assert_eq!(s, ["R.dropped", "R.exited", "R.started", "U"]);
        assert_eq!(w, ["R.interrupt", "R.start"]);
    }

    #[test]
    fn c4_removed_connections_deliver_nothing() {
        let mut t = Table::new();
        let a = t.arm("E", "A.start", Kind::Whenever, None, 0);
        let b = t.arm("E", "B.start", Kind::Whenever, None, 0);
        assert!(t.remove(a));
        assert!(!t.remove(a), "removing twice is harmless");
        assert_eq!(targets(t.on_signal(&"E", 1)), ["B.start"]);
        assert_eq!(t.list().len(), 1);
        assert_eq!(t.list()[0].id, b);
    }

    #[test]
    fn c2_a_filtered_out_signal_does_not_use_up_a_once() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Once, None, 0);
        let other = t.arm("E", "Q.start", Kind::Whenever, None, 0);
        assert_eq!(
            targets(t.on_signal_with(&"E", 1, None, |c| c != id)),
            ["Q.start"]
        );
        assert!(t.contains(id), "still waiting for a signal it accepts");
        assert_eq!(
            targets(t.on_signal_with(&"E", 2, None, |_| true)),
            ["R.start", "Q.start"]
        );
        assert!(!t.contains(id) && t.contains(other));
    }

    #[test]
    fn many_arm_fire_remove_cycles_never_deliver_stale_or_twice() {
        // the no-stale stress in miniature: signals keep coming at increasing times; connections come and go
        let mut t = Table::new();
        let mut now = 0;
        let mut delivered = 0;
        for cycle in 0..1000 {
            now += 1;
            t.on_signal(&"E", now); // emitted before this cycle's arming: must not count
            now += 1;
            let id = t.arm("E", "R.start", Kind::Once, None, now);
            let stale = t.on_signal(&"E", now - 1);
            assert!(stale.is_empty(), "cycle {cycle}");
            now += 1;
            delivered += t.on_signal(&"E", now).len();
            delivered += t.on_signal(&"E", now).len();
            t.remove(id);
        }
        assert_eq!(delivered, 1000);
    }

    #[test]
    fn c5_a_source_that_leaves_is_waited_for() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Whenever, None, 0);
        assert_eq!(t.source_lost(&"E"), [id]);
        assert_eq!(t.link(id), Some(Link::WaitingForSource));
        assert!(t.reads(&"E"), "still listening for a new source");
        assert_eq!(t.source_back(&"E"), [id]);
        assert_eq!(targets(t.on_signal(&"E", 5)), ["R.start"]);
    }

    #[test]
    fn c5_a_target_that_leaves_is_lost_and_its_source_released() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Whenever, None, 0);
        assert_eq!(t.target_lost(&"R.start"), [id]);
        assert_eq!(t.link(id), Some(Link::TargetLost));
        assert!(t.on_signal(&"E", 1).is_empty());
        assert!(
            t.target_back(&"R.start", 2).is_empty(),
            "it did not ask to re-arm"
        );
        assert!(t.on_signal(&"E", 3).is_empty());
        assert_eq!(t.take_released().0, ["E"], "the event may deactivate");
        assert!(t.contains(id), "listed, as lost, until its scope ends");
        t.remove(id);
        assert!(
            t.take_released().0.is_empty(),
            "its source was released once"
        );
    }

    #[test]
    fn c5_a_rearming_connection_delivers_only_what_comes_after_the_target_is_back() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Whenever, None, 0);
        t.set_rearm(id, true);
        t.target_lost(&"R.start");
        assert_eq!(t.link(id), Some(Link::WaitingForTarget));
        assert!(t.on_signal(&"E", 10).is_empty(), "no target");
        assert_eq!(t.target_back(&"R.start", 20), [id]);
        assert!(t.on_signal(&"E", 15).is_empty(), "emitted while it waited");
        assert_eq!(targets(t.on_signal(&"E", 20)), ["R.start"]);
    }

    #[test]
    fn c5_the_until_window_closes_when_its_response_leaves() {
        let mut t = Table::new();
        let id = t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        t.on_signal(&"E", 1);
        t.on_signal(&"R.started", 2);
        assert_eq!(targets(t.on_signal(&"U", 3)), ["R.interrupt"]);
        assert_eq!(
            t.source_lost(&"R.exited"),
            [id],
            "R died: no exited will come"
        );
        assert!(t.on_signal(&"U", 4).is_empty(), "the window is closed");
        // a new R of that name runs by itself: not this statement's run
        t.on_signal(&"R.started", 5);
        assert!(t.on_signal(&"U", 6).is_empty());
        // same through the interrupt slot
        let mut t = Table::new();
        t.arm("E", "R.start", Kind::Once, Some(until()), 0);
        t.on_signal(&"E", 1);
        t.on_signal(&"R.started", 2);
        t.target_lost(&"R.interrupt");
        assert!(t.on_signal(&"U", 3).is_empty());
    }
}
