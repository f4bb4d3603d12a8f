//! Components told apart by the process they run in (rule C5 for a component restarted within its lease).
//!
//! A component killed and started again at once (launch's `respawn=True`, a systemd restart) is back on the
//! graph before the old process's lease runs out: its endpoints match while the dead one's are still matched,
//! so the match counts a relay or an outlet watches never reach zero. Counts cannot tell the two apart; the
//! participants can. Every RADAR component writes its `state` topic, so the participants with a writer on
//! `<component>/state` are the processes it runs in. When a new one appears beside the one a connection was
//! made with, the old instance is gone (ROS 2 node names are unique on a graph): the manager tells the table
//! the component left (its connections lose their target, or wait for their source; an `until` window closes;
//! `departed()` resolves, naming [`LossCause::Replaced`]) and then that one is back (a source delivers again,
//! a re-arming connection re-arms). Components without a `state` topic (rclpy ones) keep the counts alone.

use std::{
    collections::{BTreeSet, HashMap},
    sync::{Arc, Weak},
    time::Duration,
};

use crate::node::transport::EndpointId as GUID;

use super::{End, Manager, Target};
use crate::{
    departure::{Departure, LossCause},
    endpoint::Endpoint,
};

/// How often at most the processes of the watched components are looked at while discovery changes.
const EVERY: Duration = Duration::from_millis(100);

/// What the watcher knows of one component.
#[derive(Default)]
struct Seen {
    /// The process its connections were made with, once seen.
    current: Option<GUID>,
    /// The processes seen running it, at the last look.
    known: BTreeSet<GUID>,
}

impl Seen {
    /// Looks at `hosts`, the processes running the component now: whether one appeared beside (or after) the
    /// one its connections were made with, which it then takes as current. `vanished` says whether a process
    /// is off the graph but not yet taken as gone ([`crate::graph::Graph::vanished_within_lease`]: over Zenoh
    /// a killed process's tokens vanish at once, and the new process's may come after that): one that has
    /// is replaced by a new one as if it were still there.
    fn replaced(&mut self, hosts: BTreeSet<GUID>, vanished: impl Fn(GUID) -> bool) -> bool {
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

impl Manager {
    /// Starts, once, the task that watches which processes run the components of this manager's relays and
    /// outlets; it ends with the manager.
    pub(super) fn watch_instances(self: &Arc<Self>) {
        if self
            .instances_watched
            .swap(true, std::sync::atomic::Ordering::SeqCst)
        {
            return;
        }
        let me = Arc::downgrade(self);
        let mut changes = self.graph().changes();
        // and when the table changes: a connection made while the graph is still is looked at then, not at
        // the next change of the graph (which may be its target's death: too late to know which process ran it)
        let mut table = self.changes();
        tokio::spawn(async move {
            let mut seen: HashMap<String, Seen> = HashMap::new();
            // a first look now: the processes the first connections were made with
            if !Manager::look_at_instances(&me, &mut seen) {
                return;
            }
            loop {
                let changed = tokio::select! {
                    r = changes.changed() => r.is_ok(),
                    r = table.changed() => r.is_ok(),
                };
                if !changed || !Manager::look_at_instances(&me, &mut seen) {
                    break;
                }
                tokio::time::sleep(EVERY).await;
            }
        });
    }

    /// One look: every component a relay or outlet reaches, the processes running it, and for each component
    /// now running in a new one, its departure and return. False once the manager is gone.
    fn look_at_instances(me: &Weak<Manager>, seen: &mut HashMap<String, Seen>) -> bool {
        let Some(m) = me.upgrade() else {
            return false;
        };
        // the ends by component, as the table knows them now
        let mut ends: HashMap<String, Vec<End>> = HashMap::new();
        {
            let st = m.state();
            let sources = st.relays.keys().map(|k| End::Source(k.clone()));
            let slots = st
                .outlets
                .keys()
                .map(|k| End::Target(Target::Slot(k.clone())));
            for end in sources.chain(slots) {
                let topic = match &end {
                    End::Source(k) | End::Target(Target::Slot(k)) => &k.topic,
                    End::Target(Target::Anon(_)) => continue,
                };
                if let Some((component, _)) = Endpoint::of_topic(topic) {
                    ends.entry(component.to_owned()).or_default().push(end);
                }
            }
        }
        seen.retain(|c, _| ends.contains_key(c));
        for (component, ends) in ends {
            let hosts = m.graph().writer_participants(&format!("{component}/state"));
            let vanished = |p| m.graph().vanished_within_lease(p);
            if !seen
                .entry(component.clone())
                .or_default()
                .replaced(hosts, vanished)
            {
                continue;
            }
            tracing::warn!(
                component = %component,
                "{component} was started again in another process while the old one was still on the graph \
                 (respawned?): the old one is taken as gone"
            );
            for end in &ends {
                let d = match end {
                    End::Source(k) => Departure::of_publisher(&k.topic, LossCause::Replaced),
                    End::Target(Target::Slot(k)) => {
                        Departure::of_subscriber(&k.topic, LossCause::Replaced)
                    }
                    End::Target(Target::Anon(_)) => continue,
                };
                m.peers_gone(end, d);
                m.peers_back(end);
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(n: u8) -> GUID {
        let mut bytes = [0u8; 16];
        bytes[0] = n;
        GUID::from_bytes(bytes)
    }

    #[test]
    fn a_new_process_beside_the_one_in_use_replaces_it_and_others_do_not() {
        let on_graph = |_| false;
        let mut s = Seen::default();
        assert!(!s.replaced(BTreeSet::new(), on_graph), "not running yet");
        assert!(!s.replaced(BTreeSet::from([p(1)]), on_graph), "first seen");
        assert!(!s.replaced(BTreeSet::from([p(1)]), on_graph), "no change");
        // respawned within the lease: the old one still shows
        assert!(s.replaced(BTreeSet::from([p(1), p(2)]), on_graph));
        // the old one's lease runs out: nothing more to tell
        assert!(!s.replaced(BTreeSet::from([p(2)]), on_graph));
        // it exits (counts tell that), then starts again: a return, not a replacement
        assert!(!s.replaced(BTreeSet::new(), on_graph));
        assert!(!s.replaced(BTreeSet::from([p(3)]), on_graph));
        assert_eq!(s.current, Some(p(3)));
    }

    #[test]
    fn a_process_that_vanished_within_its_lease_is_replaced_by_the_next() {
        // over Zenoh: p(1) is killed, its tokens vanish at once, p(2) comes after that
        let vanished = |g| g == p(1);
        let mut s = Seen::default();
        assert!(!s.replaced(BTreeSet::from([p(1)]), vanished));
        assert!(
            !s.replaced(BTreeSet::new(), vanished),
            "gone from the graph"
        );
        assert!(s.replaced(BTreeSet::from([p(2)]), vanished), "replaced");
        assert_eq!(s.current, Some(p(2)));
        // a look between the tokens of one death (its session not yet vanished as a whole) forgets nothing
        let later = |g| g == p(2);
        assert!(!s.replaced(BTreeSet::new(), |_| false));
        assert!(
            s.replaced(BTreeSet::from([p(3)]), later),
            "judged when p(3) comes"
        );
        // one that left for good (or still runs elsewhere on the graph) is not replaced: a return
        assert!(!s.replaced(BTreeSet::new(), |_| false));
        assert!(!s.replaced(BTreeSet::from([p(4)]), |_| false));
        assert_eq!(s.current, Some(p(4)));
    }
}
