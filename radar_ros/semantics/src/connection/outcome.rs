//! What one signal read on a source makes the table do ([`ConnectionTable::signal`]), and the marks the
//! runtime sets on a connection that decide how its sends are tagged (a start's cause, C6) and what its scope's
//! end cancels (an anonymous slot's call, C4).

use std::collections::BTreeSet;

use super::{ConnId, ConnectionTable, Outcome, Send, Sent, Via};

impl<S: Clone + Ord, T: Clone + Ord> ConnectionTable<S, T> {
    /// Marks connection `id`'s target as an anonymous slot (see [`ConnectionTable::forget`]).
    pub fn set_call(&mut self, id: ConnId, call: bool) {
        if let Some(c) = self.conns.get_mut(&id) {
            c.call = call;
        }
    }

    /// The statement's scope ended (its guard dropped, C4): removes connection `id` if it is live, and returns
    /// its target: also that of an anonymous-slot connection that had ended by itself (a `once` that fired,
    /// whose call may still wait in the runtime's queue: it must not begin now).
    ///
    /// ```
    /// use radar_semantics::connection::{ConnectionTable, Kind};
    /// let mut t = ConnectionTable::new();
    /// let id = t.arm("tick", "call 1", Kind::Once, None, 0);
    /// t.set_call(id, true);
    /// let _ = t.signal(&"tick", radar_semantics::response::Sent::at(5), 5, |_| true);
    /// assert!(!t.contains(id), "the once fired");
    /// assert_eq!(t.forget(id), Some("call 1"), "its queued call is cancelled");
    /// assert_eq!(t.forget(id), None);
    /// ```
    pub fn forget(&mut self, id: ConnId) -> Option<T> {
        if let Some(t) = self.ended_calls.remove(&id) {
            return Some(t);
        }
        let target = self.conns.get(&id).map(|c| c.target.clone());
        self.remove(id);
        target
    }

    /// Marks connection `id`'s target as a response's `start` slot: each delivery to it carries the statement's
    /// cause ([`ConnectionTable::signal`], R13, C6).
    pub fn set_starts(&mut self, id: ConnId, starts: bool) {
        if let Some(c) = self.conns.get_mut(&id) {
            c.starts = starts;
        }
    }

    /// One signal read on `source`, sent as `sent` (its stamp as this host takes it, T1, and the cause it
    /// carries: a response's `started` and `exited` carry their run's, C6), at `now` by the receiver's clock
    /// (T2): everything the runtime must do for it. `accept(id)` is connection `id`'s property (C2): a signal
    /// it refuses is not delivered through `id` and does not use up a `once`. The sends come tagged as they go
    /// on the wire: the stamp of the signal they carry, a start with the statement's cause, an `until`'s
    /// interrupt naming its statement (C6).
    ///
    /// ```
    /// use radar_semantics::connection::{ConnectionTable, Kind};
    /// use radar_semantics::response::Sent;
    /// let mut t = ConnectionTable::new();
    /// let id = t.arm("bumper", "dock/start", Kind::Once, None, 100);
    /// t.set_starts(id, true);
    /// let out = t.signal(&"bumper", Sent::at(150), 150, |_| true);
    /// assert_eq!(out.sends[0].sent, Sent::by(150, t.cause(id, 1)));
    /// assert_eq!((out.ended, out.released), (vec![id], (vec!["bumper"], vec!["dock/start"])));
    /// ```
    #[must_use = "the outcome is what the binding must carry out"]
    pub fn signal(
        &mut self,
        source: &S,
        sent: Sent,
        now: i64,
        accept: impl FnMut(ConnId) -> bool,
    ) -> Outcome<S, T> {
        self.clock(now);
        // (a connection the signal ends is gone from the table once it has been delivered through)
        let starts: BTreeSet<ConnId> =
            self.by_source
                .get(source)
                .map_or_else(BTreeSet::new, |ids| {
                    ids.iter()
                        .copied()
                        .filter(|id| self.conns.get(id).is_some_and(|c| c.starts))
                        .collect()
                });
        let deliveries = self.on_signal_with(source, sent.at, sent.by, accept);
        let sends = deliveries
            .into_iter()
            .map(|d| {
                let tagged = match d.via {
                    Via::Signal { n } => Sent {
                        at: sent.at,
                        by: starts.contains(&d.id).then(|| self.cause(d.id, n)),
                    },
                    Via::Until { at } => Sent::by(at, self.cause(d.id, 0)),
                };
                Send {
                    id: d.id,
                    target: d.target,
                    sent: tagged,
                    via: d.via,
                }
            })
            .collect();
        Outcome {
            sends,
            ended: self.take_ended(),
            released: self.take_released(),
        }
    }

    /// The connections that signals ended since the last call (a `once` that fired, or whose `until` is over:
    /// C2, C3), for the runtime to forget what it kept for them. [`ConnectionTable::remove`] does not add to
    /// it.
    pub fn take_ended(&mut self) -> Vec<ConnId> {
        std::mem::take(&mut self.ended)
    }
}
