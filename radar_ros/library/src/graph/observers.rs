//! Readers that only observe: a reader whose USER_DATA says `radar_observe=1;` (radar_ros's `radar record`,
//! `radar watch`, [`Radar::observe_raw`](crate::Radar::observe_raw)) sees an event's `triggered` signals without
//! being a listener: events count only the other subscribers when deciding to check. Any other subscriber (rclpy,
//! `ros2 topic echo`) is a listener, as before.

use ros2_client::dds::rustdds::GUID;
use tokio::sync::watch;

use super::{Graph, Table};

/// The USER_DATA entry an observing reader announces (ROS 2's `key=value;` form, as `typehash=...;`).
pub(crate) const OBSERVER_USER_DATA: &str = "radar_observe=1;";

/// Whether a reader's USER_DATA says it only observes.
pub(super) fn observes(user_data: &[u8]) -> bool {
    std::str::from_utf8(user_data).is_ok_and(|s| {
        s.split(';')
            .any(|kv| kv.trim() == OBSERVER_USER_DATA.trim_end_matches(';'))
    })
}

impl Graph {
    /// Watches the number of readers matched with local writer `writer` that do not only observe: who an
    /// event's `triggered` has as listeners. The writer must be watched already ([`Graph::watch_writer`]).
    pub(crate) fn watch_listeners(&self, writer: GUID) -> watch::Receiver<usize> {
        let mut t = self.table.lock().unwrap();
        let e = t.writers.entry(writer).or_default();
        match &e.listeners_tx {
            Some(tx) => tx.subscribe(),
            None => {
                let (tx, rx) = watch::channel(e.peers.len() - e.observing.len());
                e.listeners_tx = Some(tx);
                rx
            }
        }
    }

    /// Notes that local reader `reader` only observes (its USER_DATA says so for other participants).
    pub(crate) fn mark_observer(&self, reader: GUID) {
        let mut t = self.table.lock().unwrap();
        Self::mark_observer_in(&mut t, reader);
    }

    /// Notes an observing reader, also among the readers already matched with local writers.
    pub(super) fn mark_observer_in(t: &mut Table, reader: GUID) {
        // forgotten when the reader is lost, its participant is lost, or it is deleted (`mod.rs`)
        if !t.observers.insert(reader) {
            return;
        }
        for w in t.holders(&reader, super::Side::Writer) {
            if let Some(e) = t.writers.get_mut(&w) {
                if e.peers.contains(&reader) && e.observing.insert(reader) {
                    e.notify();
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_observer_is_told_by_its_user_data_entry() {
        assert!(super::observes(b"typehash=RIHS01_00;radar_observe=1;"));
        assert!(super::observes(b"radar_observe=1;"));
        assert!(!super::observes(b"typehash=RIHS01_00;"));
        assert!(!super::observes(b"radar_observe=0;"));
        assert!(!super::observes(b""));
        assert!(!super::observes(&[0xff, 0xfe]));
    }
}
