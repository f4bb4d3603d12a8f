//! Which process runs a component (rule C5 for a component started again within its lease).
//!
//! A component killed and started again at once (launch's `respawn=True`, a systemd restart) is back on the
//! graph before the old process's lease runs out: its endpoints match while the dead one's are still matched,
//! so match counts cannot tell the two apart; the processes can. [`Instances`] follows the processes seen
//! running one component and says when its connections must take the one they were made with as gone.

use std::collections::BTreeSet;

/// What is known of the processes running one component; `P` names a process (its participant).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Instances<P> {
    /// The process its connections were made with, once seen.
    current: Option<P>,
    /// The processes seen running it, at the last look.
    known: BTreeSet<P>,
}

impl<P> Default for Instances<P> {
    fn default() -> Self {
        Instances {
            current: None,
            known: BTreeSet::new(),
        }
    }
}

impl<P: Ord + Copy> Instances<P> {
    /// The process the component's connections were made with, once seen.
    pub fn current(&self) -> Option<P> {
        self.current
    }

    /// Looks at `hosts`, the processes running the component now: whether one appeared beside (or after) the
    /// one its connections were made with, which it then takes as current. `vanished` says whether a process
    /// is off the graph but not yet taken as gone (over Zenoh a killed process's tokens vanish at once, and the
    /// new process's may come after that): one that has is replaced by a new one as if it were still there.
    ///
    /// ```
    /// use std::collections::BTreeSet;
    /// use radar_semantics::instances::Instances;
    /// let mut s = Instances::default();
    /// assert!(!s.replaced(BTreeSet::from([1]), |_| false), "first seen");
    /// assert!(s.replaced(BTreeSet::from([1, 2]), |_| false), "respawned within the lease");
    /// assert_eq!(s.current(), Some(2));
    /// ```
    pub fn replaced(&mut self, hosts: BTreeSet<P>, vanished: impl Fn(P) -> bool) -> bool {
        let fresh = hosts.difference(&self.known).next().copied();
        self.known = hosts;
        match (self.current, fresh) {
            (Some(c), Some(new)) if new != c && (self.known.contains(&c) || vanished(c)) => {
                self.current = Some(new);
                true
            }
            _ => {
                // not seen yet, or gone (the counts tell that): take whichever runs it now; one that went away
                // is kept until another comes (then judged above), so that a look between the tokens of one
                // death does not forget which process it was
                if self.current.is_none_or(|c| !self.known.contains(&c)) {
                    if let Some(now) = self.known.iter().next().copied() {
                        self.current = Some(now);
                    }
                }
                false
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_new_process_beside_the_one_in_use_replaces_it_and_others_do_not() {
        let on_graph = |_| false;
        let mut s = Instances::default();
        assert!(!s.replaced(BTreeSet::new(), on_graph), "not running yet");
        assert!(!s.replaced(BTreeSet::from([1]), on_graph), "first seen");
        assert!(!s.replaced(BTreeSet::from([1]), on_graph), "no change");
        // respawned within the lease: the old one still shows
        assert!(s.replaced(BTreeSet::from([1, 2]), on_graph));
        // the old one's lease runs out: nothing more to tell
        assert!(!s.replaced(BTreeSet::from([2]), on_graph));
        // it exits (counts tell that), then starts again: a return, not a replacement
        assert!(!s.replaced(BTreeSet::new(), on_graph));
        assert!(!s.replaced(BTreeSet::from([3]), on_graph));
        assert_eq!(s.current, Some(3));
    }

    #[test]
    fn a_process_that_vanished_within_its_lease_is_replaced_by_the_next() {
        // over Zenoh: 1 is killed, its tokens vanish at once, 2 comes after that
        let vanished = |g| g == 1;
        let mut s = Instances::default();
        assert!(!s.replaced(BTreeSet::from([1]), vanished));
        assert!(
            !s.replaced(BTreeSet::new(), vanished),
            "gone from the graph"
        );
        assert!(s.replaced(BTreeSet::from([2]), vanished), "replaced");
        assert_eq!(s.current, Some(2));
        // a look between the tokens of one death (its session not yet vanished as a whole) forgets nothing
        let later = |g| g == 2;
        assert!(!s.replaced(BTreeSet::new(), |_| false));
        assert!(
            s.replaced(BTreeSet::from([3]), later),
            "judged when 3 comes"
        );
        // one that left for good (or still runs elsewhere on the graph) is not replaced: a return
        assert!(!s.replaced(BTreeSet::new(), |_| false));
        assert!(!s.replaced(BTreeSet::from([4]), |_| false));
        assert_eq!(s.current, Some(4));
    }
}
