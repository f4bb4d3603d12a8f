//! Components that leave and come back (rule C5): what happens to the connections from a source whose
//! publishers all left, or to a slot whose subscribers all left, and when they are back.

use super::{count_down, ConnId, ConnectionTable, Link};

impl<S: Clone + Ord, T: Clone + Ord> ConnectionTable<S, T> {
    /// Makes connection `id` re-arm when its target comes back after leaving (rule 5); by default a
    /// connection whose target left delivers nothing more.
    pub fn set_rearm(&mut self, id: ConnId, rearm: bool) {
        if let Some(c) = self.conns.get_mut(&id) {
            c.rearm = rearm;
        }
    }

    /// Every publisher of `source` left the graph (rule 5): connections from it wait for it, and `until`
    /// windows whose response's `started` or `exited` it is close (a spent `once ... until` is then over:
    /// [`ConnectionTable::take_ended`]). Returns the connections whose state changed. (Looks at every
    /// connection: components leave rarely.)
    #[must_use = "the connections whose state changed are to be reported"]
    pub fn source_lost(&mut self, source: &S) -> Vec<ConnId> {
        let mut changed = Vec::new();
        let mut over = Vec::new();
        for (id, c) in self.conns.iter_mut() {
            let mut hit = false;
            if &c.source == source && !c.spent && c.link == Link::Armed {
                c.link = Link::WaitingForSource;
                hit = true;
            }
            if let Some((u, w)) = &mut c.until {
                if &u.started == source || &u.exited == source {
                    hit |= w.response_lost();
                    // C3, C5: its response left, and with it the run of a spent `once`'s start
                    if c.spent {
                        over.push(*id);
                    }
                }
            }
            if hit {
                changed.push(*id);
            }
        }
        for id in over {
            self.end(id);
        }
        changed
    }

    /// A publisher of `source` is back: connections waiting for it are armed again. Returns them.
    #[must_use = "the connections whose state changed are to be reported"]
    pub fn source_back(&mut self, source: &S) -> Vec<ConnId> {
        let mut changed = Vec::new();
        for (id, c) in self.conns.iter_mut() {
            if &c.source == source && c.link == Link::WaitingForSource {
                c.link = Link::Armed;
                changed.push(*id);
            }
        }
        changed
    }

    /// Every subscriber of slot `target` left the graph (rule 5): connections to it are lost (or wait for it,
    /// if they re-arm), and `until` windows whose response's `interrupt` it is close (a spent `once ... until`
    /// is then over: [`ConnectionTable::take_ended`]). Returns the connections whose state changed.
    #[must_use = "the connections whose state changed are to be reported"]
    pub fn target_lost(&mut self, target: &T) -> Vec<ConnId> {
        let mut changed = Vec::new();
        let mut over = Vec::new();
        for (id, c) in self.conns.iter_mut() {
            let mut hit = false;
            if &c.target == target && matches!(c.link, Link::Armed | Link::WaitingForSource) {
                if c.rearm {
                    c.link = Link::WaitingForTarget;
                } else {
                    c.link = Link::TargetLost;
                    if c.reading {
                        c.reading = false;
                        count_down(&mut self.reads, &c.source, &mut self.released.0);
                    }
                }
                hit = true;
            }
            if let Some((u, w)) = &mut c.until {
                if &u.interrupt == target {
                    hit |= w.response_lost();
                    // C3, C5: its response left, and with it the run of a spent `once`'s start
                    if c.spent {
                        over.push(*id);
                    }
                }
            }
            if hit {
                changed.push(*id);
            }
        }
        for id in over {
            self.end(id);
        }
        changed
    }

    /// A subscriber of slot `target` is back at `now`: connections waiting for it are armed again, for
    /// signals emitted from `now` on. Returns them.
    #[must_use = "the connections whose state changed are to be reported"]
    pub fn target_back(&mut self, target: &T, now: i64) -> Vec<ConnId> {
        self.clock(now);
        let mut changed = Vec::new();
        for (id, c) in self.conns.iter_mut() {
            if &c.target == target && c.link == Link::WaitingForTarget {
                c.link = Link::Armed;
                c.armed_at = c.armed_at.max(now);
                changed.push(*id);
            }
        }
        changed
    }
}
