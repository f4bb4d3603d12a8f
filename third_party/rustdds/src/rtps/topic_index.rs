//! RADAR patch 53: the event loop's local endpoints by topic, so that an endpoint discovered (remote, or one of
//! this participant's own reflected by discovery) is matched against the local endpoints of its topic only,
//! not by comparing the topic name of every local endpoint.

use std::collections::{BTreeSet, HashMap};

use crate::structure::guid::EntityId;

/// Local endpoints (of one kind: readers or writers) by topic name, each topic's in entity id order (the order
/// in which a scan of the event loop's reader map visits them).
#[derive(Default)]
pub(crate) struct TopicIndex(HashMap<String, BTreeSet<EntityId>>);

impl TopicIndex {
  /// `eid` is a local endpoint of `topic`.
  pub(crate) fn add(&mut self, topic: &str, eid: EntityId) {
    self.0.entry(topic.to_owned()).or_default().insert(eid);
  }

  /// `eid` of `topic` has gone; a topic with no endpoint left is forgotten.
  pub(crate) fn remove(&mut self, topic: &str, eid: EntityId) {
    if let Some(set) = self.0.get_mut(topic) {
      set.remove(&eid);
      if set.is_empty() {
        self.0.remove(topic);
      }
    }
  }

  /// The local endpoints of `topic` (a copy: the caller goes on to change the endpoints).
  pub(crate) fn on(&self, topic: &str) -> Vec<EntityId> {
    self
      .0
      .get(topic)
      .map(|s| s.iter().copied().collect())
      .unwrap_or_default()
  }

  /// How many topics have an endpoint.
  #[cfg(test)]
  pub(crate) fn topics(&self) -> usize {
    self.0.len()
  }
}

#[cfg(test)]
mod tests {
  use super::*;

  fn eid(n: u32) -> EntityId {
    EntityId::create_custom_entity_id([(n >> 16) as u8, (n >> 8) as u8, n as u8], crate::structure::guid::EntityKind::READER_NO_KEY_USER_DEFINED)
  }

  #[test]
  fn the_endpoints_of_a_topic_are_found_as_a_scan_finds_them() {
    // an oracle that scans every endpoint, as the event loop did
    let mut all: Vec<(String, EntityId)> = Vec::new();
    let mut index = TopicIndex::default();
    let topics = ["rt/a", "rt/b", "rt/c", "rt/a/b"];
    for n in 0..400u32 {
      let t = topics[(n * 7 % 4) as usize];
      all.push((t.to_owned(), eid(n)));
      index.add(t, eid(n));
      if n % 3 == 0 {
        // and some go
        let (t, e) = all.remove((n as usize * 13) % all.len());
        index.remove(&t, e);
      }
    }
    for t in topics.iter().chain(["rt/none"].iter()) {
      let mut scanned: Vec<EntityId> = all.iter().filter(|(x, _)| x == t).map(|(_, e)| *e).collect();
      scanned.sort();
      assert_eq!(index.on(t), scanned, "topic {t}");
    }
    // every endpoint gone: nothing is kept
    for (t, e) in all.drain(..) {
      index.remove(&t, e);
    }
    assert_eq!(index.topics(), 0);
  }
}
