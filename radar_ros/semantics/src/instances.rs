//! Which process runs a component (rule C5 for a component started again within its lease, or twice).
//!
//! A component killed and started again at once (launch's `respawn=True`, a systemd restart) is back on the
//! graph before the old process's lease runs out: its endpoints match while the dead one's are still matched,
//! so match counts cannot tell the two apart; the processes can. [`Instances`] follows the processes seen
//! running one component and says, at each look, what its connections must be told:
//!
//! - a new process beside the one the connections were made with, which is known to have died (on this host:
//!   its sockets are closed): a **replacement**, told at once (the old one is gone, the new one is back);
//! - the one the connections were made with is off the graph (its lease ran out, it said goodbye) and another
//!   runs the component: a **replacement** too (the two may have come and gone between two looks, so that no
//!   match count ever reached zero);
//! - a new process beside one that is alive, or of whose life nothing is known (another host): a **second
//!   process of one name**. Nothing changes for the connections (they stay with the process they were made
//!   with, and one program's statements do not lose a healthy component because a laptop beside the robot
//!   started the same launch file); it is reported, naming both. Once the first one goes, the second takes
//!   its place as above.

use std::collections::BTreeSet;

/// What is known of whether a process still runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Liveness {
    /// It runs (on this host, its sockets are open).
    Alive,
    /// It is gone (on this host, its sockets are closed, or another process now has them; over Zenoh, its
    /// session vanished), though its lease has not run out.
    Dead,
    /// Nothing is known (it runs on another host): only its lease will tell.
    Unknown,
}

/// What a look found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Seen<P> {
    /// Nothing to tell.
    Nothing,
    /// `new` replaced `old`: the connections made with `old` must be told it is gone, then that the component
    /// is back.
    Replaced {
        /// The process the connections were made with.
        old: P,
        /// The one that runs the component now.
        new: P,
    },
    /// `other` runs the component too, beside `current`, which is alive (or may be): two live processes of
    /// one name. The connections stay with `current`.
    Beside {
        /// The process the connections were made with.
        current: P,
        /// The second one.
        other: P,
    },
}

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

    /// Looks at `hosts`, the processes running the component on the graph now, with what is known of the life
    /// of each (`live`).
    ///
    /// ```
    /// use std::collections::BTreeSet;
    /// use radar_semantics::instances::{Instances, Liveness, Seen};
    /// let mut s = Instances::default();
    /// assert_eq!(s.look(BTreeSet::from([1]), |_| Liveness::Alive), Seen::Nothing);
    /// // killed and respawned within its lease: the old one is known to be dead
    /// assert_eq!(s.look(BTreeSet::from([1, 2]), |p| if p == 1 { Liveness::Dead } else { Liveness::Alive }),
    ///            Seen::Replaced { old: 1, new: 2 });
    /// // a second live process of that name: reported, the connections stay with 2
    /// assert_eq!(s.look(BTreeSet::from([2, 3]), |_| Liveness::Alive), Seen::Beside { current: 2, other: 3 });
    /// assert_eq!(s.current(), Some(2));
    /// ```
    pub fn look(&mut self, hosts: BTreeSet<P>, live: impl Fn(P) -> Liveness) -> Seen<P> {
        let fresh: Vec<P> = hosts.difference(&self.known).copied().collect();
        self.known = hosts;
        let Some(c) = self.current else {
            self.current = self.known.iter().next().copied();
            return Seen::Nothing;
        };
        if !self.known.contains(&c) {
            // off the graph: whichever runs it now took its place
            return match self.known.iter().next().copied() {
                Some(new) => {
                    self.current = Some(new);
                    Seen::Replaced { old: c, new }
                }
                None => Seen::Nothing,
            };
        }
        match fresh.into_iter().find(|n| *n != c) {
            Some(new) if live(c) == Liveness::Dead => {
                self.current = Some(new);
                Seen::Replaced { old: c, new }
            }
            Some(other) => Seen::Beside { current: c, other },
            None => Seen::Nothing,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dead_but(alive: u8) -> impl Fn(u8) -> Liveness {
        move |p| {
            if p == alive {
                Liveness::Alive
            } else {
                Liveness::Dead
            }
        }
    }

    #[test]
    fn c5_a_new_process_beside_a_dead_one_replaces_it_at_once() {
        let mut s = Instances::default();
        assert_eq!(
            s.look(BTreeSet::new(), dead_but(1)),
            Seen::Nothing,
            "not running yet"
        );
        assert_eq!(
            s.look(BTreeSet::from([1]), dead_but(1)),
            Seen::Nothing,
            "first seen"
        );
        assert_eq!(
            s.look(BTreeSet::from([1]), dead_but(1)),
            Seen::Nothing,
            "no change"
        );
        // respawned within the lease: the old one still shows, and is known to be dead
        assert_eq!(
            s.look(BTreeSet::from([1, 2]), dead_but(2)),
            Seen::Replaced { old: 1, new: 2 }
        );
        // the old one's lease runs out: nothing more to tell
        assert_eq!(s.look(BTreeSet::from([2]), dead_but(2)), Seen::Nothing);
        assert_eq!(s.current(), Some(2));
    }

    #[test]
    fn c5_the_one_in_use_gone_off_the_graph_is_replaced_by_the_one_there() {
        let mut s = Instances::default();
        let _ = s.look(BTreeSet::from([1]), dead_but(1));
        // killed, its lease ran out and a new one came, all between two looks
        assert_eq!(
            s.look(BTreeSet::from([2]), dead_but(2)),
            Seen::Replaced { old: 1, new: 2 }
        );
        // gone with none to take its place: the match counts tell that, not this
        assert_eq!(s.look(BTreeSet::new(), dead_but(9)), Seen::Nothing);
        assert_eq!(s.current(), Some(2), "kept until another comes");
        assert_eq!(
            s.look(BTreeSet::from([3]), dead_but(3)),
            Seen::Replaced { old: 2, new: 3 }
        );
    }

    #[test]
    fn c5_a_second_live_process_of_one_name_is_told_and_changes_nothing() {
        for life in [Liveness::Alive, Liveness::Unknown] {
            let mut s = Instances::default();
            let _ = s.look(BTreeSet::from([1]), |_| life);
            assert_eq!(
                s.look(BTreeSet::from([1, 2]), |_| life),
                Seen::Beside {
                    current: 1,
                    other: 2
                },
                "{life:?}"
            );
            assert_eq!(
                s.look(BTreeSet::from([1, 2]), |_| life),
                Seen::Nothing,
                "told once"
            );
            assert_eq!(s.current(), Some(1));
            // the first one goes: the second takes its place
            assert_eq!(
                s.look(BTreeSet::from([2]), |_| life),
                Seen::Replaced { old: 1, new: 2 },
                "{life:?}"
            );
        }
    }
}
