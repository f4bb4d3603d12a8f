//! In-memory ROS 2 graph cache built from liveliness tokens.
//!
//! A [`Context`](super::context::Context) declares a liveliness subscriber over
//! `@ros2_lv/<domain>/**`; each PUT/DELETE sample is fed to [`GraphCache`],
//! which parses the token key ([`parse_liveliness_key`]) and maintains the set
//! of live entities. Queries (entity counts, node names) read this set — the
//! Zenoh analogue of the DDS `ros_discovery_info` graph.
//!
//! The parsing/query logic is backend-neutral (no `zenoh` crate), so it is
//! unit-tested on any build.

use std::{collections::HashMap, sync::Mutex};

use async_channel::{Receiver, Sender};

use super::{
  keyexpr::{ParsedEntity, parse_liveliness_key},
  qos_encoding::{compatible, decode_qos},
};
use crate::{
  graph::{EntityKind, GraphEntity, GraphEvent},
  qos::QosProfile,
};

/// A publisher or subscription as matching sees it: what its liveliness token says of it (rmw_zenoh's
/// `TopicInfo`). [`Publisher::endpoint`](crate::zenoh::Publisher::endpoint) and
/// [`Subscription::endpoint`](crate::zenoh::Subscription::endpoint) give an endpoint's own.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MatchInfo {
  /// [`EntityKind::Publisher`] or [`EntityKind::Subscription`].
  pub kind: EntityKind,
  /// The fully-qualified topic name.
  pub topic: String,
  /// The DDS-form type name (`pkg::msg::dds_::Name_`).
  pub type_name: String,
  /// The type hash its token names (`RIHS01_...`).
  pub type_hash: String,
  /// Its QoS.
  pub qos: QosProfile,
}

impl From<&ParsedEntity> for GraphEntity {
  fn from(e: &ParsedEntity) -> Self {
    GraphEntity {
      kind: e.kind,
      node_name: join_fqn(&e.namespace, &e.node_name),
      name: e.topic_name.clone(),
      type_name: e.type_name.clone(),
    }
  }
}

/// A thread-safe cache of discovered ROS 2 entities, keyed by their liveliness
/// token key expression.
#[derive(Default)]
pub struct GraphCache {
  entities: Mutex<HashMap<String, ParsedEntity>>,
  // Fan-out event subscribers (one unbounded channel per `subscribe()` caller),
  // mirroring the DDS backend's `status_event_senders`.
  subscribers: Mutex<Vec<Sender<GraphEvent>>>,
  // Live matched counts (`watch_matched`), recounted when a token of their
  // topic comes or goes. Locked before `entities` wherever both are held.
  watches: Mutex<Vec<MatchWatch>>,
}

/// One [`GraphCache::watch_matched`]: the endpoint, the count it was last
/// sent, and where to.
struct MatchWatch {
  me: MatchInfo,
  last: usize,
  tx: Sender<usize>,
}

impl GraphCache {
  /// Record an entity from a liveliness-token PUT. Non-token keys are ignored.
  pub fn apply_put(&self, key: &str) {
    if let Some(entity) = parse_liveliness_key(key) {
      let event = GraphEvent::EntityDeclared(GraphEntity::from(&entity));
      let topic = entity.topic_name.clone();
      self.entities.lock().unwrap().insert(key.to_owned(), entity);
      self.recount(topic.as_deref());
      self.broadcast(event);
    }
  }

  /// Remove an entity on a liveliness-token DELETE.
  pub fn apply_delete(&self, key: &str) {
    let removed = self.entities.lock().unwrap().remove(key);
    if let Some(entity) = removed {
      self.recount(entity.topic_name.as_deref());
      self.broadcast(GraphEvent::EntityUndeclared(GraphEntity::from(&entity)));
    }
  }

  /// Register a new event stream. Each subscriber receives every subsequent
  /// [`GraphEvent`]; drop the receiver to unsubscribe.
  pub fn subscribe(&self) -> Receiver<GraphEvent> {
    let (tx, rx) = async_channel::unbounded();
    self.subscribers.lock().unwrap().push(tx);
    rx
  }

  fn broadcast(&self, event: GraphEvent) {
    let mut subs = self.subscribers.lock().unwrap();
    // Drop closed receivers; deliver to the rest (unbounded => only fails if
    // closed).
    subs.retain(|s| !s.is_closed());
    for s in subs.iter() {
      let _ = s.try_send(event.clone());
    }
  }

  pub(crate) fn count_kind_on_topic(&self, kind: EntityKind, topic: &str) -> usize {
    self
      .entities
      .lock()
      .unwrap()
      .values()
      .filter(|e| e.kind == kind && e.topic_name.as_deref() == Some(topic))
      .count()
  }

  /// The number of live endpoints that match `me`, as rmw_zenoh's graph cache counts them for
  /// `rmw_publisher_count_matched_subscriptions` and `rmw_subscription_count_matched_publishers`: those
  /// of the other kind on the same topic and type whose QoS is compatible with `me`'s (rmw's rules,
  /// [`compatible`]), this session's own included. Stricter than rmw_zenoh's count in one way: the type
  /// hash must be the same too, since an rmw_zenoh subscription of another hash listens on another key and
  /// never hears `me` (rmw_zenoh keys its count by the type name only). An endpoint whose token's QoS does
  /// not parse is not counted.
  pub fn matched(&self, me: &MatchInfo) -> usize {
    let other = match me.kind {
      EntityKind::Publisher => EntityKind::Subscription,
      EntityKind::Subscription => EntityKind::Publisher,
      _ => return 0,
    };
    let guard = self.entities.lock().unwrap();
    guard
      .values()
      .filter(|e| {
        e.kind == other
          && e.topic_name.as_deref() == Some(me.topic.as_str())
          && e.type_name.as_deref() == Some(me.type_name.as_str())
          && e.type_hash.as_deref() == Some(me.type_hash.as_str())
      })
      .filter_map(|e| decode_qos(e.qos.as_deref()?).ok())
      .filter(|theirs| match other {
        EntityKind::Subscription => compatible(&me.qos, theirs),
        _ => compatible(theirs, &me.qos),
      })
      .count()
  }

  /// The number of endpoints matching `me` ([`GraphCache::matched`]) now and
  /// as it changes: the receiver gets the count at once, then each new one
  /// when a token of `me`'s topic comes or goes and the count changes. Drop
  /// the receiver to stop watching.
  pub fn watch_matched(&self, me: MatchInfo) -> Receiver<usize> {
    let (tx, rx) = async_channel::unbounded();
    // counted under the watches' lock: a token that arrives meanwhile is
    // recounted after this watch is in the list
    let mut watches = self.watches.lock().unwrap();
    let last = self.matched(&me);
    let _ = tx.try_send(last);
    watches.push(MatchWatch { me, last, tx });
    rx
  }

  /// Recounts the watches of `topic` and sends those that changed.
  fn recount(&self, topic: Option<&str>) {
    let Some(topic) = topic else { return };
    let mut watches = self.watches.lock().unwrap();
    watches.retain(|w| !w.tx.is_closed());
    for w in watches.iter_mut().filter(|w| w.me.topic == topic) {
      let n = self.matched(&w.me);
      if n != w.last {
        w.last = n;
        let _ = w.tx.try_send(n);
      }
    }
  }

  /// Number of discovered publishers on a topic (by fully-qualified name).
  pub fn publisher_count(&self, topic: &str) -> usize {
    self.count_kind_on_topic(EntityKind::Publisher, topic)
  }

  /// Number of discovered subscriptions on a topic.
  pub fn subscription_count(&self, topic: &str) -> usize {
    self.count_kind_on_topic(EntityKind::Subscription, topic)
  }

  /// Fully-qualified names of all discovered nodes, sorted and de-duplicated.
  pub fn node_names(&self) -> Vec<String> {
    let guard = self.entities.lock().unwrap();
    let mut names: Vec<String> = guard
      .values()
      .filter(|e| e.kind == EntityKind::Node)
      .map(|e| join_fqn(&e.namespace, &e.node_name))
      .collect();
    names.sort();
    names.dedup();
    names
  }

  /// Every live entity, as its token names it (this session's own included), with its GID as rmw_zenoh
  /// derives it from the token (what its samples' and requests' attachments carry): a snapshot, for a graph
  /// that needs more than counts and names (the session, node and entity ids that tell processes apart).
  /// (radar_ros patch 17.)
  pub fn entities(&self) -> Vec<(crate::Gid, ParsedEntity)> {
    self
      .entities
      .lock()
      .unwrap()
      .iter()
      .map(|(key, e)| (crate::Gid::from(super::gid::gid_from_liveliness_key(key)), e.clone()))
      .collect()
  }

  /// Total number of cached entities (all kinds).
  #[cfg(test)]
  pub fn len(&self) -> usize {
    self.entities.lock().unwrap().len()
  }
}

fn join_fqn(namespace: &str, name: &str) -> String {
  if namespace.is_empty() || namespace == "/" {
    format!("/{name}")
  } else {
    format!("{namespace}/{name}")
  }
}

// ---------------------------------------------------------------------------

#[cfg(test)]
mod tests {
  use super::*;
  use crate::zenoh_backend::keyexpr::{
    EntityIds, entity_liveliness_keyexpr, node_liveliness_keyexpr,
  };

  fn ids(entity_id: u64) -> EntityIds<'static> {
    EntityIds {
      session_id: "aac3178e146ba6f1fc6e6a4085e77f21",
      node_id: 0,
      entity_id,
      enclave: "",
      namespace: "",
      node_name: "talker",
    }
  }

  #[test]
  fn tracks_entities_and_counts() {
    let cache = GraphCache::default();
    let node_key = node_liveliness_keyexpr(0, &ids(0));
    let pub_key = entity_liveliness_keyexpr(
      0,
      &ids(1),
      EntityKind::Publisher,
      "/chatter",
      "std_msgs::msg::dds_::String_",
      "RIHS01_x",
      "::,7:,:,:,,",
    );

    cache.apply_put(&node_key);
    cache.apply_put(&pub_key);
    // A non-token key is ignored.
    cache.apply_put("0/chatter/std_msgs::msg::dds_::String_/hash");

    assert_eq!(cache.publisher_count("/chatter"), 1);
    assert_eq!(cache.subscription_count("/chatter"), 0);
    assert_eq!(cache.node_names(), vec!["/talker".to_string()]);
    assert_eq!(cache.len(), 2);

    // DELETE removes the publisher.
    cache.apply_delete(&pub_key);
    assert_eq!(cache.publisher_count("/chatter"), 0);
    assert_eq!(cache.len(), 1);
  }

  /// A token of entity `id` of `kind` on `topic` with type hash `hash` and compact QoS `qos`, as rmw_zenoh
  /// writes them (the QoS strings below are the design document's format: reliability, durability,
  /// history and depth, deadline, lifespan, liveliness; empty is the default).
  fn token(id: u64, kind: EntityKind, topic: &str, hash: &str, qos: &str) -> String {
    entity_liveliness_keyexpr(0, &ids(id), kind, topic, "std_msgs::msg::dds_::String_", hash, qos)
  }

  fn me(kind: EntityKind, qos: &str) -> MatchInfo {
    MatchInfo {
      kind,
      topic: "/chatter".into(),
      type_name: "std_msgs::msg::dds_::String_".into(),
      type_hash: "RIHS01_x".into(),
      qos: decode_qos(qos).unwrap(),
    }
  }

  #[test]
  fn counts_matched_endpoints_as_rmw_zenoh_does() {
    use EntityKind::{Publisher as P, Subscription as S};
    const RELIABLE: &str = "::,10:,:,:,,";
    const BEST_EFFORT: &str = "2::,10:,:,:,,";
    const LATCHED: &str = ":1:,1:,:,:,,";
    // requests a deadline of 1 s; a publisher offering none (infinite) does not meet it
    const DEADLINE: &str = "::,10:1,0:,:,,";
    let cache = GraphCache::default();
    let subs = [
      token(1, S, "/chatter", "RIHS01_x", RELIABLE),
      token(2, S, "/chatter", "RIHS01_x", BEST_EFFORT),
      token(3, S, "/chatter", "RIHS01_x", LATCHED),
      token(4, S, "/chatter", "RIHS01_y", RELIABLE),
      token(5, S, "/other", "RIHS01_x", RELIABLE),
      token(6, S, "/chatter", "RIHS01_x", DEADLINE),
      token(7, P, "/chatter", "RIHS01_x", RELIABLE),
    ];
    for k in &subs {
      cache.apply_put(k);
    }
    // a reliable volatile publisher serves the reliable and the best-effort subscriptions of its topic, type
    // and hash: not the transient-local one, not another hash or topic, not one that asks for a deadline,
    // not a publisher
    assert_eq!(cache.matched(&me(P, RELIABLE)), 2);
    // a best-effort publisher only the best-effort one
    assert_eq!(cache.matched(&me(P, BEST_EFFORT)), 1);
    // a transient-local publisher all three of those
    assert_eq!(cache.matched(&me(P, LATCHED)), 3);
    // a reliable subscription is served by the reliable publisher; a best-effort one too
    assert_eq!(cache.matched(&me(S, RELIABLE)), 1);
    cache.apply_put(&token(8, P, "/chatter", "RIHS01_x", BEST_EFFORT));
    assert_eq!(cache.matched(&me(S, RELIABLE)), 1);
    assert_eq!(cache.matched(&me(S, BEST_EFFORT)), 2);
    // a token that goes is no longer counted
    cache.apply_delete(&subs[1]);
    assert_eq!(cache.matched(&me(P, RELIABLE)), 1);
  }

  #[test]
  fn a_watch_gets_the_count_at_once_then_each_change_of_it() {
    use EntityKind::{Publisher as P, Subscription as S};
    const RELIABLE: &str = "::,10:,:,:,,";
    let cache = GraphCache::default();
    let first = token(1, S, "/chatter", "RIHS01_x", RELIABLE);
    cache.apply_put(&first);
    let counts = cache.watch_matched(me(P, RELIABLE));
    assert_eq!(counts.try_recv(), Ok(1), "the count at once");
    let second = token(2, S, "/chatter", "RIHS01_x", RELIABLE);
    cache.apply_put(&second);
    // a token on another topic, or of another hash, changes nothing: nothing sent
    cache.apply_put(&token(3, S, "/other", "RIHS01_x", RELIABLE));
    cache.apply_put(&token(4, S, "/chatter", "RIHS01_y", RELIABLE));
    cache.apply_delete(&first);
    cache.apply_delete(&second);
    let sent: Vec<usize> = std::iter::from_fn(|| counts.try_recv().ok()).collect();
    assert_eq!(sent, [2, 1, 0]);
    // a dropped receiver is forgotten at the next change of its topic
    drop(counts);
    cache.apply_put(&first);
    assert!(cache.watches.lock().unwrap().is_empty());
  }

  #[test]
  fn emits_declared_and_undeclared_events() {
    let cache = GraphCache::default();
    let stream = cache.subscribe();
    let pub_key = entity_liveliness_keyexpr(
      0,
      &ids(1),
      EntityKind::Publisher,
      "/chatter",
      "std_msgs::msg::dds_::String_",
      "RIHS01_x",
      "::,7:,:,:,,",
    );

    cache.apply_put(&pub_key);
    cache.apply_delete(&pub_key);
    // A non-token key produces no event.
    cache.apply_put("0/chatter/not-a-token");

    let declared = stream.try_recv().expect("a declared event");
    match declared {
      GraphEvent::EntityDeclared(e) => {
        assert_eq!(e.kind, EntityKind::Publisher);
        assert_eq!(e.name.as_deref(), Some("/chatter"));
        assert_eq!(e.node_name, "/talker");
      }
      other => panic!("expected EntityDeclared, got {:?}", other),
    }
    match stream.try_recv().expect("an undeclared event") {
      GraphEvent::EntityUndeclared(e) => assert_eq!(e.kind, EntityKind::Publisher),
      other => panic!("expected EntityUndeclared, got {:?}", other),
    }
    // No third event (the non-token PUT was ignored).
    assert!(stream.try_recv().is_err());
  }
}
