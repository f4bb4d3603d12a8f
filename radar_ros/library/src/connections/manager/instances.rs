//! Components told apart by the process they run in (rule C5 for a component restarted within its lease, or
//! run twice).
//!
//! A component killed and started again at once (launch's `respawn=True`, a systemd restart) is back on the
//! graph before the old process's lease runs out: its endpoints match while the dead one's are still matched,
//! so the match counts a relay or an outlet watches never reach zero. Counts cannot tell the two apart; the
//! participants can. Every RADAR component writes its `state` topic, so the participants with a writer on
//! `<component>/state` are the processes it runs in, and each radar_ros participant says which process it is
//! (`graph/processes.rs`). The decision is `radar_semantics::instances`: a new process beside one known dead
//! (or one gone off the graph between two looks) replaces it, and the manager tells the table the component
//! left (its connections lose their target, or wait for their source; an `until` window closes, a spent `once
//! ... until` ends; `departed()` resolves, naming [`LossCause::Replaced`]) and then that it is back (a source
//! delivers again, a re-arming connection re-arms). A new process beside a live one (a second terminal, a
//! laptop running the same launch file) changes nothing for the connections: it is reported once, naming both
//! processes, and the response signals of the second carry no cause to this manager's table (they close no
//! `until` window of its statements). Components without a `state` topic (rclpy ones) keep the counts alone.
//!
//! A replacement is told only to the ends whose count did not tell it: a component that quits cleanly and is
//! started again may be seen by one look as gone off the graph and replaced, while its ends' counts went to
//! zero and back in between (each told its connections then). Telling those again would re-arm a re-arming
//! connection a second time, and what was emitted between the two re-arms would be lost (C1: a failed CI run,
//! `tests/failure.rs`). The graph remembers whose going left an endpoint without peers
//! (`Graph::emptied_by`); over Zenoh it cannot say, and such an end is told twice.

use std::{
    collections::HashMap,
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

use radar_semantics::instances::{Instances, Seen};

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
            let mut seen: HashMap<String, Instances<GUID>> = HashMap::new();
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
    fn look_at_instances(me: &Weak<Manager>, seen: &mut HashMap<String, Instances<GUID>>) -> bool {
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
            let instances = seen.entry(component.clone()).or_default();
            let found = instances.look(hosts, |p| m.graph().liveness(p));
            if let Some(current) = instances.current() {
                m.state().following.insert(component.clone(), current);
            }
            match found {
                Seen::Nothing => {}
                Seen::Beside { current, other } => {
                    let (current, other) = (
                        m.graph().describe_process(current),
                        m.graph().describe_process(other),
                    );
                    tracing::warn!(
                        component = %component,
                        "{component} runs in two live processes, {current} and {other}: ROS 2 names are meant to \
                         be unique on a graph. This program's connections stay with the first; the topics of that \
                         name carry both processes' signals. Stop one, or give it another name or namespace"
                    )
                }
                Seen::Replaced { old, new } => {
                    let (old_named, new_named) = (
                        m.graph().describe_process(old),
                        m.graph().describe_process(new),
                    );
                    tracing::warn!(
                        component = %component,
                        "{component} was started again in {new_named}, and the one in {old_named} is gone (respawned?): its \
                         connections take it as gone"
                    );
                    for end in &ends {
                        // an end whose count reached zero as the old process went has told its connections
                        // (and told them of the new one's return): a second departure would re-arm a
                        // re-arming connection once more, dropping what was emitted in between (C1)
                        if m.counted_departure_of(end, old) {
                            continue;
                        }
                        let d = match end {
                            End::Source(k) => {
                                Departure::of_publisher(&k.topic, LossCause::Replaced)
                            }
                            End::Target(Target::Slot(k)) => {
                                Departure::of_subscriber(&k.topic, LossCause::Replaced)
                            }
                            End::Target(Target::Anon(_)) => continue,
                        };
                        m.peers_gone(end, d);
                        m.peers_back(end);
                    }
                }
            }
        }
        true
    }

    /// Whether `end`'s match count reached zero as process `old` went (so its connections were told then).
    fn counted_departure_of(&self, end: &End, old: GUID) -> bool {
        let st = self.state();
        match end {
            End::Source(k) => st.relays.get(k).is_some_and(|r| r.sub.emptied_by(old)),
            End::Target(Target::Slot(k)) => st
                .outlets
                .get(k)
                .and_then(|o| o.dds.as_ref())
                .is_some_and(|p| p.emptied_by(old)),
            End::Target(Target::Anon(_)) => false,
        }
    }
}
