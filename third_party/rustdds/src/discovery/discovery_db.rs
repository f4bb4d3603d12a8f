use std::{
  collections::{BTreeMap, BTreeSet, HashMap},
  sync::{Arc, RwLock, RwLockReadGuard, RwLockWriteGuard},
  time::Instant,
};

use chrono::Utc;
#[allow(unused_imports)]
use log::{debug, error, info, trace, warn};

use crate::{
  dds::{
    participant::DomainParticipant,
    qos::HasQoSPolicy,
    statusevents::{DomainParticipantStatusEvent, LostReason, StatusChannelSender},
    topic::{Topic, TopicDescription},
  },
  rtps::{
    reader::ReaderIngredients, rtps_reader_proxy::RtpsReaderProxy,
    rtps_writer_proxy::RtpsWriterProxy,
  },
  structure::{
    duration::Duration,
    entity::RTPSEntity,
    guid::{EntityId, GuidPrefix, GUID},
  },
};
use super::{
  sedp_messages::{
    topics_inconsistent, DiscoveredReaderData, DiscoveredTopicData, DiscoveredWriterData,
    ParticipantMessageData, ReaderProxy, SubscriptionBuiltinTopicData, TopicBuiltinTopicData,
    WriterProxy,
  },
  spdp_participant_data::SpdpDiscoveredParticipantData,
};
#[cfg(not(feature = "security"))]
use crate::no_security::EndpointSecurityInfo;
#[cfg(feature = "security")]
use crate::{discovery::secure_discovery::AuthenticationStatus, security::EndpointSecurityInfo};

// If remote participant does not specify lease duration, how long silence
// until we pronounce it dead.
const DEFAULT_PARTICIPANT_LEASE_DURATION: Duration = Duration::from_secs(60);

// How much longer to wait than lease duration before pronouncing lost.
const PARTICIPANT_LEASE_DURATION_TOLERANCE: Duration = Duration::from_secs(0);

// TODO: Let DiscoveryDB itself become thread-safe and support smaller-scope
// lock
/// What one sender (an endpoint or participant) said of a topic (RADAR patch 51: boxed, see `topics`).
type TopicSent = Box<(DiscoveredVia, DiscoveredTopicData)>;

pub(crate) struct DiscoveryDB {
  my_guid: GUID,
  participant_proxies: BTreeMap<GuidPrefix, SpdpDiscoveredParticipantData>,
  participant_last_life_signs: BTreeMap<GuidPrefix, Instant>,

  // Authentication statuses of participants
  #[cfg(feature = "security")]
  authentication_statuses: BTreeMap<GuidPrefix, AuthenticationStatus>,

  // local writer proxies for topics (topic name acts as key)
  local_topic_writers: BTreeMap<GUID, DiscoveredWriterData>,
  /// Bumped whenever `local_topic_writers` changes (RADAR patch 16: what is derived from every local writer
  /// is recomputed only then).
  local_writers_generation: u64,
  // local reader proxies for topics (topic name acts as key)
  local_topic_readers: BTreeMap<GUID, DiscoveredReaderData>,

  // remote readers and writers (via discovery)
  external_topic_readers: BTreeMap<GUID, DiscoveredReaderData>,
  external_topic_writers: BTreeMap<GUID, DiscoveredWriterData>,

  // These are "attic" storages for readers and writers whose participant
  // was lost due to time-out. If we have a
  external_topic_readers_attic: BTreeMap<GUID, DiscoveredReaderData>,
  external_topic_writers_attic: BTreeMap<GUID, DiscoveredWriterData>,
  // The participants in the attic, oldest first (RADAR patch 35): at most `ATTIC_PARTICIPANTS` are kept, so
  // that a system whose processes are killed and restarted for days does not keep every dead one's endpoints.
  attic_order: std::collections::VecDeque<GuidPrefix>,

  // Database of topic updates:
  // Outer level key is topic name
  // Inner key is topic data sender.
  // (RADAR patch 51: the inner value is boxed. Most topics have one or two senders, and a BTreeMap's first
  // node has room for 11 values: unboxed, each topic held about 3 KiB, most of it empty.)
  topics: BTreeMap<String, BTreeMap<GUID, TopicSent>>,
  // The topics each sender described (RADAR patch 45): an endpoint that goes is taken out of its own topics,
  // not looked for in every topic.
  topics_by_sender: BTreeMap<GUID, BTreeSet<String>>,
  // The type names the senders of each topic gave, with how many gave each (RADAR patch 57): a sender new to a
  // topic is checked against these, not against every sender of the topic (`rt/parameter_events` has one per
  // node, so each node made cost as much as the nodes before it).
  // (Almost every topic has one type: a short list, not a map, keeps this to a few dozen bytes per topic.)
  topic_types: HashMap<String, Vec<(String, usize)>>,
  // The readers and the writers, local and remote, of each topic (RADAR patch 49): a superset (an endpoint is
  // added when stored, taken out when removed by GUID, and what is left of participants that went is pruned by
  // `topic_cleanup`), so `readers_on_topic` and `writers_on_topic` look up a topic's endpoints instead of
  // comparing every endpoint's topic name, once per endpoint made.
  readers_by_topic: HashMap<String, BTreeSet<GUID>>,
  writers_by_topic: HashMap<String, BTreeSet<GUID>>,

  // sender for notifying (potential) waiters in participant.find_topic() call
  topic_updated_sender: std::sync::mpsc::SyncSender<()>,

  participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,
}

// How did we discover this topic
#[derive(PartialEq, Eq, Clone, Copy, Debug)]
pub(crate) enum DiscoveredVia {
  Topic,        // explicitly, via the topic topic (does this actually occur?)
  Publication,  // we discovered there is a writer on this topic
  Subscription, // we discovered a reader on this topic
  SelfDefined,  // not discovered, but defined by the local DomainParticipant
}

/// How many lost participants' endpoints the attic keeps (RADAR patch 35): one that comes back after more
/// than this many others were lost is discovered again from its announcements instead.
pub(crate) const ATTIC_PARTICIPANTS: usize = 64;

fn move_by_guid_prefix<D>(
  guid_prefix: GuidPrefix,
  from: &mut BTreeMap<GUID, D>,
  to: &mut BTreeMap<GUID, D>,
) {
  let to_move: Vec<GUID> = from.range(guid_prefix.range()).map(|(g, _)| *g).collect();
  for guid in to_move {
    from.remove(&guid).map(|d| to.insert(guid, d));
  }
}

/// Counts one sender more (`add`) or less of `topic` giving `type_name` (RADAR patch 57).
fn count_type(
  types: &mut HashMap<String, Vec<(String, usize)>>,
  topic: &str,
  type_name: &str,
  add: bool,
) {
  if add {
    let by_type = match types.get_mut(topic) {
      Some(by_type) => by_type,
      None => types.entry(topic.to_owned()).or_insert_with(|| Vec::with_capacity(1)),
    };
    match by_type.iter_mut().find(|(ty, _)| ty == type_name) {
      Some((_, n)) => *n += 1,
      None => by_type.push((type_name.to_owned(), 1)),
    }
  } else if let Some(by_type) = types.get_mut(topic) {
    if let Some(i) = by_type.iter().position(|(ty, _)| ty == type_name) {
      by_type[i].1 -= 1;
      if by_type[i].1 == 0 {
        by_type.swap_remove(i);
      }
    }
  }
}

/// Notes endpoint `guid` on `topic` in a topic index (RADAR patch 49).
fn index(by_topic: &mut HashMap<String, BTreeSet<GUID>>, topic: &str, guid: GUID) {
  match by_topic.get_mut(topic) {
    Some(guids) => {
      guids.insert(guid);
    }
    None => {
      by_topic.insert(topic.to_string(), BTreeSet::from([guid]));
    }
  }
}

/// Takes endpoint `guid` on `topic` out of a topic index.
fn unindex(by_topic: &mut HashMap<String, BTreeSet<GUID>>, topic: &str, guid: GUID) {
  if let Some(guids) = by_topic.get_mut(topic) {
    guids.remove(&guid);
    if guids.is_empty() {
      by_topic.remove(topic);
    }
  }
}

/// Removes every entry of `map` whose GUID has `guid_prefix`.
fn remove_by_guid_prefix<D>(guid_prefix: GuidPrefix, map: &mut BTreeMap<GUID, D>) {
  let gone: Vec<GUID> = map.range(guid_prefix.range()).map(|(g, _)| *g).collect();
  for guid in gone {
    map.remove(&guid);
  }
}

pub(crate) fn discovery_db_read(
  discovery_db: &Arc<RwLock<DiscoveryDB>>,
) -> RwLockReadGuard<'_, DiscoveryDB> {
  match discovery_db.read() {
    Ok(db) => db,
    Err(e) => panic!("RustDDS internal bug: DiscoveryDB is poisoned after a prior panic: {e:?}."),
  }
}

pub(crate) fn discovery_db_write(
  discovery_db: &Arc<RwLock<DiscoveryDB>>,
) -> RwLockWriteGuard<'_, DiscoveryDB> {
  match discovery_db.write() {
    Ok(db) => db,
    Err(e) => panic!("RustDDS internal bug: DiscoveryDB is poisoned after a prior panic: {e:?}."),
  }
}

impl DiscoveryDB {
  pub fn new(
    my_guid: GUID,
    topic_updated_sender: std::sync::mpsc::SyncSender<()>,
    participant_status_sender: StatusChannelSender<DomainParticipantStatusEvent>,
  ) -> Self {
    Self {
      my_guid,
      participant_proxies: BTreeMap::new(),
      participant_last_life_signs: BTreeMap::new(),
      #[cfg(feature = "security")]
      authentication_statuses: BTreeMap::new(),
      local_topic_writers: BTreeMap::new(),
      local_writers_generation: 0,
      local_topic_readers: BTreeMap::new(),
      external_topic_readers: BTreeMap::new(),
      external_topic_writers: BTreeMap::new(),
      external_topic_readers_attic: BTreeMap::new(),
      external_topic_writers_attic: BTreeMap::new(),
      attic_order: std::collections::VecDeque::new(),
      topics: BTreeMap::new(),
      topics_by_sender: BTreeMap::new(),
      topic_types: HashMap::new(),
      readers_by_topic: HashMap::new(),
      writers_by_topic: HashMap::new(),
      topic_updated_sender,
      participant_status_sender,
    }
  }

  fn send_participant_status(&self, event: DomainParticipantStatusEvent) {
    self
      .participant_status_sender
      .try_send(event)
      .unwrap_or_else(|e| error!("Cannot report participant status: {e:?}"));
  }

  // Returns if participant was previously unknown
  pub fn update_participant(&mut self, data: &SpdpDiscoveredParticipantData) -> bool {
    debug!("update_participant: {:?}", data);
    let guid = data.participant_guid;

    // sanity check
    if guid.entity_id != EntityId::PARTICIPANT {
      error!("Discovered participant GUID entity_id is not for participant: {guid:?}");
      // Maybe we should discard the participant here?
      return false;
    }

    // We allow discovery to discover self, since our discovery readers
    // will receive our own announcements via broadcast. If we do not recognize
    // our own participant, there is confusion about unknown writers on the
    // discovery topics.
    //
    // if guid == self.my_guid {
    //   debug!("DiscoveryDB discovered self. Skipping.");
    //   return
    // }

    let mut new_participant = false;
    if !self.participant_proxies.contains_key(&guid.prefix) {
      info!("New remote participant: {:?}", data);
      new_participant = true;
      if guid == self.my_guid {
        info!("Remote participant {guid:?} is myself, but some reflection is good.");
        new_participant = false;
      }

      // This may be a rediscovery: Participant lease time timed out, but then
      // came back, e.g. by network outage. We then restore readers/writers from
      // attic to discovery DB.
      move_by_guid_prefix(
        guid.prefix,
        &mut self.external_topic_readers_attic,
        &mut self.external_topic_readers,
      );
      move_by_guid_prefix(
        guid.prefix,
        &mut self.external_topic_writers_attic,
        &mut self.external_topic_writers,
      );
      self.attic_order.retain(|p| *p != guid.prefix);
      // their topic data, forgotten when they went to the attic (RADAR patch 35)
      let restored: Vec<(GUID, DiscoveredTopicData, DiscoveredVia)> = self
        .external_topic_readers
        .range(guid.prefix.range())
        .map(|(g, r)| {
          let t = r.subscription_topic_data.to_topic_data();
          (*g, DiscoveredTopicData::new(Utc::now(), t), DiscoveredVia::Subscription)
        })
        .chain(
          self
            .external_topic_writers
            .range(guid.prefix.range())
            .map(|(g, w)| {
              let t = w.publication_topic_data.to_topic_data();
              (*g, DiscoveredTopicData::new(Utc::now(), t), DiscoveredVia::Publication)
            }),
        )
        .collect();
      for (g, t, via) in restored {
        self.update_topic_data(&t, g, via);
      }
      // RADAR patch 37: endpoints announced before their participant was known (its SEDP data overtook its
      // SPDP data, or came while it was lost and not yet back) were stored without addresses, and a reader
      // matched with such a writer had nowhere to send its ACKNACKs: what it missed was never repaired, and
      // every later sample waited behind it. They get the participant's default locators now (the caller
      // matches every endpoint of a participant that is new again).
      let (unicast, multicast) = (&data.default_unicast_locators, &data.default_multicast_locators);
      for w in self.external_topic_writers.range_mut(guid.prefix.range()).map(|(_, w)| w) {
        let proxy = &mut w.writer_proxy;
        if proxy.unicast_locator_list.is_empty() && proxy.multicast_locator_list.is_empty() {
          proxy.unicast_locator_list.clone_from(unicast);
          proxy.multicast_locator_list.clone_from(multicast);
        }
      }
      for r in self.external_topic_readers.range_mut(guid.prefix.range()).map(|(_, r)| r) {
        let proxy = &mut r.reader_proxy;
        if proxy.unicast_locator_list.is_empty() && proxy.multicast_locator_list.is_empty() {
          proxy.unicast_locator_list.clone_from(unicast);
          proxy.multicast_locator_list.clone_from(multicast);
        }
      }
    }

    // In any case:
    // Update SpdpDiscoveredParticipantData to DB
    self.participant_proxies.insert(guid.prefix, data.clone());
    // Timestamp last life sign fro participant
    self
      .participant_last_life_signs
      .insert(guid.prefix, Instant::now());

    new_participant
  }

  pub fn participant_is_alive(&mut self, guid_prefix: GuidPrefix) {
    if let Some(ts) = self.participant_last_life_signs.get_mut(&guid_prefix) {
      let now = Instant::now();
      if now.duration_since(*ts) > std::time::Duration::from_secs(1) {
        debug!("Participant alive update for {guid_prefix:?}, but no full update.");
      }
      *ts = now;
    } else {
      info!(
        "Participant alive update for unknown {guid_prefix:?}. This is normal, if the message \
         does not repeat."
      );
    }
  }

  // active_disposal means that we received a discovery message announcing the
  // disposal of the participant. active_disposal=false means that the
  // participant timed out.
  pub fn remove_participant(&mut self, guid_prefix: GuidPrefix, active_disposal: bool) {
    info!("removing participant {guid_prefix:?}");
    self.participant_proxies.remove(&guid_prefix);
    self.participant_last_life_signs.remove(&guid_prefix);
    #[cfg(feature = "security")]
    self.authentication_statuses.remove(&guid_prefix);

    if active_disposal {
      self.remove_topic_reader_with_prefix(guid_prefix);
      self.remove_topic_writer_with_prefix(guid_prefix);
    } else {
      // move to attic
      move_by_guid_prefix(
        guid_prefix,
        &mut self.external_topic_readers,
        &mut self.external_topic_readers_attic,
      );
      move_by_guid_prefix(
        guid_prefix,
        &mut self.external_topic_writers,
        &mut self.external_topic_writers_attic,
      );
      self.attic_order.retain(|p| *p != guid_prefix);
      self.attic_order.push_back(guid_prefix);
      while self.attic_order.len() > ATTIC_PARTICIPANTS {
        if let Some(oldest) = self.attic_order.pop_front() {
          info!("forgetting the endpoints of {oldest:?}: the attic keeps {ATTIC_PARTICIPANTS} participants");
          remove_by_guid_prefix(oldest, &mut self.external_topic_readers_attic);
          remove_by_guid_prefix(oldest, &mut self.external_topic_writers_attic);
        }
      }
    }
    // what its endpoints said about their topics goes with them (RADAR patch 35: it was kept for ever)
    let senders: Vec<GUID> = self
      .topics_by_sender
      .range(guid_prefix.range())
      .map(|(g, _)| *g)
      .collect();
    for g in senders {
      self.forget_topic_data_from(g);
    }
  }

  /// Forgets the topic data sent by `gone`, and topics nobody describes any more. It costs what `gone`
  /// described (RADAR patch 45: every topic was scanned, and a process of 10,000 endpoints that left cost
  /// 10,000 scans of 10,000 topics).
  fn forget_topic_data_from(&mut self, gone: GUID) {
    for topic in self.topics_by_sender.remove(&gone).unwrap_or_default() {
      if let Some(senders) = self.topics.get_mut(&topic) {
        if let Some(sent) = senders.remove(&gone) {
          count_type(&mut self.topic_types, &topic, &sent.1.topic_data.type_name, false);
        }
        if senders.is_empty() {
          self.topics.remove(&topic);
          self.topic_types.remove(&topic);
        }
      }
    }
  }

  /// Topic names known, with how many endpoints or participants described each (tests).
  #[cfg(test)]
  pub(crate) fn topic_senders(&self) -> BTreeMap<String, usize> {
    self
      .topics
      .iter()
      .map(|(t, s)| (t.clone(), s.len()))
      .collect()
  }

  /// The type names the senders of `topic` gave, with how many gave each (tests).
  #[cfg(test)]
  pub(crate) fn topic_type_counts(&self, topic: &str) -> BTreeMap<String, usize> {
    self
      .topic_types
      .get(topic)
      .map(|by_type| by_type.iter().cloned().collect())
      .unwrap_or_default()
  }

  /// How many senders the topic index holds (tests).
  #[cfg(test)]
  pub(crate) fn topic_index_len(&self) -> usize {
    self.topics_by_sender.len()
  }

  /// Endpoints kept in the attic (tests).
  #[cfg(test)]
  pub(crate) fn attic_len(&self) -> usize {
    self.external_topic_readers_attic.len() + self.external_topic_writers_attic.len()
  }

  /// Every remote participant known, and this one (RADAR patch 29).
  pub fn all_participants(&self) -> impl Iterator<Item = &SpdpDiscoveredParticipantData> {
    self.participant_proxies.values()
  }

  pub fn find_participant_proxy(
    &self,
    guid_prefix: GuidPrefix,
  ) -> Option<&SpdpDiscoveredParticipantData> {
    self.participant_proxies.get(&guid_prefix)
  }

  fn remove_topic_reader_with_prefix(&mut self, guid_prefix: GuidPrefix) {
    remove_by_guid_prefix(guid_prefix, &mut self.external_topic_readers);
  }


  pub fn remove_topic_reader(&mut self, guid: GUID) {
    info!("remove_topic_reader {guid:?}");
    if let Some(r) = self.external_topic_readers.remove(&guid) {
      unindex(&mut self.readers_by_topic, r.subscription_topic_data.topic_name(), guid);
    }
    self.forget_topic_data_from(guid);
  }

  #[cfg(feature = "security")]
  pub fn get_topic_reader(&self, guid: &GUID) -> Option<&DiscoveredReaderData> {
    self.external_topic_readers.get(guid)
  }

  #[cfg(feature = "security")]
  pub fn get_topic_writer(&self, guid: &GUID) -> Option<&DiscoveredWriterData> {
    self.external_topic_writers.get(guid)
  }

  fn remove_topic_writer_with_prefix(&mut self, guid_prefix: GuidPrefix) {
    remove_by_guid_prefix(guid_prefix, &mut self.external_topic_writers);
  }


  pub fn remove_topic_writer(&mut self, guid: GUID) {
    if let Some(w) = self.external_topic_writers.remove(&guid) {
      unindex(&mut self.writers_by_topic, &w.publication_topic_data.topic_name, guid);
    }
    self.forget_topic_data_from(guid);
  }

  // Delete participant proxies, if we have not heard of them within
  // lease_duration
  pub fn participant_cleanup(&mut self) -> Vec<(GuidPrefix, LostReason)> {
    let inow = Instant::now();

    let mut to_remove = Vec::new();
    // TODO: We are not cleaning up liast_life_signs table, but that should not be a
    // problem, except for a slight memory leak.
    for (&guid, sp) in &self.participant_proxies {
      let lease_duration = sp
        .lease_duration
        .unwrap_or(DEFAULT_PARTICIPANT_LEASE_DURATION);
      // let lease_duration = lease_duration + lease_duration; // double it
      match self.participant_last_life_signs.get(&guid) {
        Some(&last_life) => {
          // keep, if duration not exceeded
          let elapsed = Duration::from_std(inow.duration_since(last_life));
          if elapsed <= lease_duration + PARTICIPANT_LEASE_DURATION_TOLERANCE {
            // No timeout yet, we keep this, so do nothing.
          } else {
            info!(
              "participant cleanup - deleting participant proxy {guid:?}. lease_duration = \
               {lease_duration:?} elapsed = {elapsed:?}"
            );
            to_remove.push((
              guid,
              LostReason::Timeout {
                lease: lease_duration,
                elapsed,
              },
            ));
          }
        }
        None => {
          error!("Participant {guid:?} not in last_life_signs table?");
        }
      } // match
    } // for

    for (guid, _) in &to_remove {
      self.remove_participant(*guid, false); // false = removed due to timeout
    }

    to_remove
  }

  /// Removes the topics that no endpoint, local or remote, is on. The topics in use are gathered once (RADAR
  /// patch 45: every topic was compared with every endpoint, a stall of the discovery thread every minute in a
  /// large system).
  pub fn topic_cleanup(&mut self) {
    let in_use: BTreeSet<&str> = self
      .local_topic_readers
      .values()
      .map(|p| p.subscription_topic_data.topic_name().as_str())
      .chain(
        self
          .external_topic_readers
          .values()
          .map(|p| p.subscription_topic_data.topic_name().as_str()),
      )
      .chain(
        self
          .local_topic_writers
          .values()
          .chain(self.external_topic_writers.values())
          .map(|p| p.publication_topic_data.topic_name.as_str()),
      )
      .collect();
    // the endpoint index keeps what is stored, in the attic too (RADAR patch 49)
    let (readers, readers_attic) = (&self.local_topic_readers, &self.external_topic_readers_attic);
    let external_readers = &self.external_topic_readers;
    self.readers_by_topic.retain(|_, guids| {
      guids.retain(|g| {
        readers.contains_key(g) || external_readers.contains_key(g) || readers_attic.contains_key(g)
      });
      !guids.is_empty()
    });
    let (writers, writers_attic) = (&self.local_topic_writers, &self.external_topic_writers_attic);
    let external_writers = &self.external_topic_writers;
    self.writers_by_topic.retain(|_, guids| {
      guids.retain(|g| {
        writers.contains_key(g) || external_writers.contains_key(g) || writers_attic.contains_key(g)
      });
      !guids.is_empty()
    });
    let dead_topics: Vec<String> = self
      .topics
      .keys()
      .filter(|tn| !in_use.contains(tn.as_str()))
      .cloned()
      .collect();
    for dt in dead_topics {
      self.topic_types.remove(&dt);
      if let Some(senders) = self.topics.remove(&dt) {
        for g in senders.keys() {
          if let Some(described) = self.topics_by_sender.get_mut(g) {
            described.remove(&dt);
            if described.is_empty() {
              self.topics_by_sender.remove(g);
            }
          }
        }
      }
    }
  }

  pub fn update_local_topic_writer(&mut self, writer: DiscoveredWriterData) {
    self.local_writers_generation += 1;
    index(
      &mut self.writers_by_topic,
      &writer.publication_topic_data.topic_name,
      writer.writer_proxy.remote_writer_guid,
    );
    self
      .local_topic_writers
      .insert(writer.writer_proxy.remote_writer_guid, writer);
  }

  pub fn remove_local_topic_writer(&mut self, guid: GUID) {
    self.local_writers_generation += 1;
    if let Some(w) = self.local_topic_writers.remove(&guid) {
      unindex(&mut self.writers_by_topic, &w.publication_topic_data.topic_name, guid);
    }
  }

  /// Changes whenever a local writer is added, updated or removed.
  pub fn local_writers_generation(&self) -> u64 {
    self.local_writers_generation
  }

  // TODO: This is silly. Returns one of the parameters cloned, or None
  // TODO: Why are we here checking if discovery db already has this? What about
  // reader proxies in writers?

  // Here we make updates when a new Reader is found via Discovery.
  // * It may be one of our own.
  // * We may have seen it before.
  //
  // In case DiscoveredReaderData does not have locators, we try to get
  // them from the remote participant.
  //
  // The topic is updated to the topics table.
  pub fn update_subscription(&mut self, data: &DiscoveredReaderData) -> DiscoveredReaderData {
    let guid = data.reader_proxy.remote_reader_guid;

    // fill in the default locators from participant, in case DRD did not provide
    // any
    let default_locator_lists = self
      .find_participant_proxy(guid.prefix)
      .map(|pp| {
        debug!("Added participant locators to Reader {guid:?}");
        (
          pp.default_unicast_locators.clone(),
          pp.default_multicast_locators.clone(),
        )
      })
      .unwrap_or_else(|| {
        if guid.prefix != GuidPrefix::UNKNOWN {
          // This is normal, since we might not know about the participant yet.
          debug!(
            "No remote participant known for {:?}\nSearched with {:?} in {:?}",
            data,
            guid.prefix,
            self.participant_proxies.keys()
          );
        }
        (Vec::default(), Vec::default())
      });

    // Build enriched data with participant's default locators filled in, so that
    // later lookups via readers_on_topic() return usable locator information.
    let enriched = DiscoveredReaderData {
      reader_proxy: ReaderProxy::from(RtpsReaderProxy::from_discovered_reader_data(
        data,
        &default_locator_lists.0,
        &default_locator_lists.1,
      )),
      ..data.clone()
    };

    index(&mut self.readers_by_topic, enriched.subscription_topic_data.topic_name(), guid);
    self.external_topic_readers.insert(guid, enriched.clone());
    debug!("External reader: {enriched:?}");

    // Now the topic update:
    let dtd = data.subscription_topic_data.to_topic_data();
    self.update_topic_data(
      &DiscoveredTopicData::new(Utc::now(), dtd),
      guid,
      DiscoveredVia::Subscription,
    );

    // TODO: Lookup the topic in DB, data sent by the same participant that sent the
    // reader update. If there is a DiscoveredVia::Topic record, use QosPolicies
    // from that record and modify by QoS given in the DRD.

    enriched
  }

  // TODO: This is silly. Returns one of the parameters cloned, or None
  pub fn update_publication(&mut self, data: &DiscoveredWriterData) -> DiscoveredWriterData {
    let guid = data.writer_proxy.remote_writer_guid;

    // fill in the default locators from participant, in case DRD did not provide
    // any
    let default_locator_lists = self
      .find_participant_proxy(guid.prefix)
      .map(|pp| {
        debug!("Added participant locators to Writer {guid:?}");
        (
          pp.default_unicast_locators.clone(),
          pp.default_multicast_locators.clone(),
        )
      })
      .unwrap_or_else(|| {
        if guid.prefix != GuidPrefix::UNKNOWN {
          // This is normal, since we might not know about the participant yet.
          debug!(
            "No remote participant known for {:?}\nSearched with {:?} in {:?}",
            data,
            guid.prefix,
            self.participant_proxies.keys()
          );
        }
        (Vec::default(), Vec::default())
      });

    // Build enriched data with participant's default locators filled in, so that
    // later lookups via writers_on_topic() return usable locator information.
    let enriched = DiscoveredWriterData {
      writer_proxy: WriterProxy::from(RtpsWriterProxy::from_discovered_writer_data(
        data,
        &default_locator_lists.0,
        &default_locator_lists.1,
      )),
      ..data.clone()
    };

    index(&mut self.writers_by_topic, &enriched.publication_topic_data.topic_name, guid);
    self.external_topic_writers.insert(guid, enriched.clone());
    debug!("External writer: {enriched:?}");

    // Now the topic update:
    let dtd = data.publication_topic_data.to_topic_data();
    self.update_topic_data(
      &DiscoveredTopicData::new(Utc::now(), dtd),
      guid,
      DiscoveredVia::Publication,
    );

    enriched
  }

  // This is for local participant updating the topic table
  pub fn update_topic_data_p(&mut self, topic: &Topic) {
    let topic_data = DiscoveredTopicData::new(
      Utc::now(),
      TopicBuiltinTopicData::new(
        None,
        topic.name(),
        topic.get_type().name().to_owned(),
        &topic.qos(),
      ),
    );
    self.update_topic_data(&topic_data, self.my_guid, DiscoveredVia::SelfDefined);
  }

  // Topic update sends notifications, in case someone was waiting to find a
  // topic.
  /// Records `dtd` from `updater`. Returns whether that changed what is known: the
  /// topic or this source of it was new, or its data (type, QoS) differed from what
  /// this source said before, or it came from the Topic topic for the first time.
  /// A participant announces a topic again with every writer or reader it makes on
  /// it (every node's `rt/parameter_events` writer): an unchanged repeat changes
  /// nothing (RADAR patch 57).
  pub fn update_topic_data(
    &mut self,
    dtd: &DiscoveredTopicData,
    updater: GUID,
    discovered_via: DiscoveredVia,
  ) -> bool {
    trace!("Update topic data: {:?}", dtd);
    let topic_name = dtd.topic_data.name.clone();
    let mut notify = false;
    let mut changed = true;
    let mut inconsistency_event_to_send = None;

    if let Some(t) = self.topics.get_mut(&dtd.topic_data.name) {
      if let Some(old_dtd) = t.get_mut(&updater) {
        // already have it from the same source, do some checking(?) and merging
        if !topics_inconsistent(&dtd.topic_data, &old_dtd.1.topic_data) {
          // If this discovery was from Topic topic and the old was not, then update
          // TODO: Why do we have this logic? Where is the spec? Or ant reason for it?
          // Is it even triggered ever?
          if discovered_via == DiscoveredVia::Topic {
            changed =
              old_dtd.0 != DiscoveredVia::Topic || old_dtd.1.topic_data != dtd.topic_data;
            **old_dtd = (discovered_via, dtd.clone()); // update QoS
            notify = true;
          } else {
            changed = false;
            debug!(
              "Topic {:?} update ignored from {:?}. Already have this.",
              topic_name, updater
            );
            // TODO: Here we could warn about QoS changes.
            //
            // It is normal to have different (but compatible) QoS policies
            // for Reader and Writer. We end up here if the same Participant has
            // both Reader and Writer with different QoS. Also
            // different Readers could have different QoS,
            // as could Writers.
          }
        } else {
          error!(
            "Inconsistent topic update from {:?}: type was: {:?} new type: {:?}",
            updater, old_dtd.1.topic_data.type_name, dtd.topic_data.type_name,
          );
          inconsistency_event_to_send = Some(DomainParticipantStatusEvent::InconsistentTopic {
            previous_topic_data: Box::new((&old_dtd.1.topic_data).into()),
            previous_source: updater,
            discovered_topic_data: Box::new((&dtd.topic_data).into()),
            discovery_source: updater,
          });
        }
      } else {
        // only when a sender gave another type is there one to find (patch 57); the last found is reported
        let others = self
          .topic_types
          .get(&topic_name)
          .is_some_and(|types| types.iter().any(|(ty, _)| *ty != dtd.topic_data.type_name));
        let previous = others
          .then(|| {
            t.iter()
              .rev()
              .find(|(_, sent)| topics_inconsistent(&sent.1.topic_data, &dtd.topic_data))
          })
          .flatten();
        if let Some((source_guid, sent)) = previous {
          inconsistency_event_to_send = Some(DomainParticipantStatusEvent::InconsistentTopic {
            previous_topic_data: Box::new((&sent.1.topic_data).into()),
            previous_source: *source_guid,
            discovered_topic_data: Box::new((&dtd.topic_data).into()),
            discovery_source: updater,
          });
        }
        // We have to topic, but not from this participant
        // TODO: Check that there is agreement about topic type name (at least)
        t.insert(updater, Box::new((discovered_via, dtd.clone()))); // this should return None
        count_type(&mut self.topic_types, &topic_name, &dtd.topic_data.type_name, true);
        self
          .topics_by_sender
          .entry(updater)
          .or_default()
          .insert(topic_name.clone());
        notify = true;
      }
    } else {
      // new topic to us
      let mut b = BTreeMap::new();
      b.insert(updater, Box::new((discovered_via, dtd.clone())));
      self
        .topics_by_sender
        .entry(updater)
        .or_default()
        .insert(topic_name.clone());
      count_type(&mut self.topic_types, &topic_name, &dtd.topic_data.type_name, true);
      self.topics.insert(topic_name, b);
      self.send_participant_status(DomainParticipantStatusEvent::TopicDetected {
        name: dtd.topic_data.name.clone(),
        type_name: dtd.topic_data.type_name.clone(),
      });
    };
    if let Some(ev) = inconsistency_event_to_send {
      self.send_participant_status(ev);
    }
    if notify {
      self
        .topic_updated_sender
        .try_send(())
        // It is quite normal for this to fail due to channel full,
        // because usually there is no-one at the other end receiving.
        .unwrap_or_else(|e| trace!("update_topic_data: Notification send failed: {e:?}"));
    }
    changed
  }

  // local topic readers

  /// Builds the discovery record of a local reader.
  ///
  /// This locks the participant (`dpi`, for its locators and GUID), so it is
  /// a separate step from [`Self::update_local_topic_reader`]: build the record
  /// first, then take the Discovery DB lock and insert it. The two locks are
  /// not held together. Calling this while holding `discovery_db` could
  /// deadlock against `DomainParticipant::find_topic()`, which holds `dpi`
  /// while reading the DB.
  pub fn local_topic_reader_data(
    domain_participant: &DomainParticipant,
    topic: &Topic,
    reader: &ReaderIngredients,
    sec_info_opt: Option<EndpointSecurityInfo>,
  ) -> DiscoveredReaderData {
    let reader_guid = reader.guid;

    let reader_proxy = RtpsReaderProxy::from_reader(reader, domain_participant);

    let subscription_data = SubscriptionBuiltinTopicData::new(
      reader_guid,
      Some(domain_participant.guid()),
      topic.name(),
      topic.get_type().name().to_string(),
      &reader.qos_policy,
      sec_info_opt,
    );

    // TODO: possibly change content filter to dynamic value
    let content_filter = None;

    DiscoveredReaderData {
      reader_proxy: ReaderProxy::from(reader_proxy),
      subscription_topic_data: subscription_data,
      content_filter,
      user_data: Vec::new(),
    }
  }

  /// Inserts a record built by [`Self::local_topic_reader_data`].
  pub fn update_local_topic_reader(&mut self, discovered_reader_data: DiscoveredReaderData) {
    index(
      &mut self.readers_by_topic,
      discovered_reader_data.subscription_topic_data.topic_name(),
      discovered_reader_data.reader_proxy.remote_reader_guid,
    );
    self.local_topic_readers.insert(
      discovered_reader_data.reader_proxy.remote_reader_guid,
      discovered_reader_data,
    );
  }

  pub fn remove_local_topic_reader(&mut self, guid: GUID) {
    if let Some(r) = self.local_topic_readers.remove(&guid) {
      unindex(&mut self.readers_by_topic, r.subscription_topic_data.topic_name(), guid);
    }
  }

  pub fn get_local_topic_reader(&self, guid: GUID) -> Option<&DiscoveredReaderData> {
    self.local_topic_readers.get(&guid)
  }

  pub fn get_local_topic_writer(&self, guid: GUID) -> Option<&DiscoveredWriterData> {
    self.local_topic_writers.get(&guid)
  }

  pub fn get_all_local_topic_readers(&self) -> impl Iterator<Item = &DiscoveredReaderData> {
    self.local_topic_readers.values()
  }

  pub fn get_all_local_topic_writers(&self) -> impl Iterator<Item = &DiscoveredWriterData> {
    self.local_topic_writers.values()
  }

  pub fn get_all_external_topic_readers(&self) -> impl Iterator<Item = &DiscoveredReaderData> {
    self.external_topic_readers.values()
  }

  pub fn get_all_external_topic_writers(&self) -> impl Iterator<Item = &DiscoveredWriterData> {
    self.external_topic_writers.values()
  }

  // Note:
  // If multiple participants announce the same topic, this will
  // return duplicates, one per announcing participant.
  // The duplicates are not necessarily identical, but may have different QoS.
  pub fn all_user_topics(&self) -> impl Iterator<Item = &DiscoveredTopicData> {
    self
      .topics
      .iter()
      .filter(|(s, _)| !s.starts_with("DCPS"))
      .flat_map(|(_, gm)| gm.values().map(|dtd| &dtd.1))
  }

  // a Topic may have multiple definitions, because there may be multiple
  // participants publishing the topic information.
  // At least the QoS details may be different.
  // This just returns the first one found in the database, which is indexed by
  // GUID.
  pub fn get_topic(&self, topic_name: &str) -> Option<&DiscoveredTopicData> {
    self
      .topics
      .get(topic_name)
      .and_then(|m| m.values().next().map(|t| &t.1))
  }

  /// The writers of `participant` on `topic_name`, in GUID order (through the topic index, RADAR patch 53: a
  /// scan of the participant's writers made each topic heard of cost as much as the participant had writers).
  pub fn writers_on_topic_and_participant(
    &self,
    topic_name: &str,
    participant: GuidPrefix,
  ) -> Vec<DiscoveredWriterData> {
    let guids = self.writers_by_topic.get(topic_name).into_iter().flatten();
    guids
      .filter(|g| g.prefix == participant)
      .filter_map(|g| self.external_topic_writers.get(g))
      .filter(|dwd| dwd.publication_topic_data.topic_name == topic_name)
      .cloned()
      .collect()
  }

  /// The readers of `participant` on `topic_name`, in GUID order (through the topic index, RADAR patch 53).
  pub fn readers_on_topic_and_participant(
    &self,
    topic_name: &str,
    participant: GuidPrefix,
  ) -> Vec<DiscoveredReaderData> {
    let guids = self.readers_by_topic.get(topic_name).into_iter().flatten();
    guids
      .filter(|g| g.prefix == participant)
      .filter_map(|g| self.external_topic_readers.get(g))
      .filter(|drd| drd.subscription_topic_data.topic_name() == topic_name)
      .cloned()
      .collect()
  }

  /// The writers, remote then local, on `topic_name` (through the topic index, RADAR patch 49).
  pub fn writers_on_topic(&self, topic_name: &str) -> Vec<&DiscoveredWriterData> {
    let guids = self.writers_by_topic.get(topic_name).into_iter().flatten();
    let on_topic = |wd: &&DiscoveredWriterData| wd.publication_topic_data.topic_name() == topic_name;
    let mut all: Vec<&DiscoveredWriterData> = guids
      .clone()
      .filter_map(|g| self.external_topic_writers.get(g))
      .filter(on_topic)
      .collect();
    all.extend(
      guids
        .filter_map(|g| self.local_topic_writers.get(g))
        .filter(on_topic),
    );
    all
  }

  /// The readers, remote then local, on `topic_name` (through the topic index, RADAR patch 49).
  pub fn readers_on_topic(&self, topic_name: &str) -> Vec<&DiscoveredReaderData> {
    let guids = self.readers_by_topic.get(topic_name).into_iter().flatten();
    let on_topic =
      |rd: &&DiscoveredReaderData| rd.subscription_topic_data.topic_name() == topic_name;
    let mut all: Vec<&DiscoveredReaderData> = guids
      .clone()
      .filter_map(|g| self.external_topic_readers.get(g))
      .filter(on_topic)
      .collect();
    all.extend(
      guids
        .filter_map(|g| self.local_topic_readers.get(g))
        .filter(on_topic),
    );
    all
  }

  // // TODO: return iterator somehow?
  #[cfg(test)] // used only for testing
  pub fn get_local_topic_readers<T: TopicDescription>(
    &self,
    topic: &T,
  ) -> Vec<&DiscoveredReaderData> {
    let topic_name = topic.name();
    self
      .local_topic_readers
      .iter()
      .filter(|(_, p)| *p.subscription_topic_data.topic_name() == topic_name)
      .map(|(_, p)| p)
      .collect()
  }

  pub fn update_lease_duration(&mut self, data: &ParticipantMessageData) {
    let now = Instant::now();
    let prefix = data.guid;
    self
      .external_topic_writers
      .range_mut(prefix.range())
      .for_each(|(_guid, p)| p.last_updated = now);
  }

  #[cfg(feature = "security")]
  pub fn get_authentication_status(&self, guid_prefix: GuidPrefix) -> Option<AuthenticationStatus> {
    self.authentication_statuses.get(&guid_prefix).copied()
  }

  #[cfg(feature = "security")]
  pub fn update_authentication_status(
    &mut self,
    guid_prefix: GuidPrefix,
    status: AuthenticationStatus,
  ) {
    self.authentication_statuses.insert(guid_prefix, status);
  }
}

#[cfg(test)]
mod tests {
  use std::{sync::Mutex, time::Duration as StdDuration};

  use byteorder::LittleEndian;

  use super::*;
  use crate::{
    dds::{
      qos::QosPolicies,
      statusevents::{sync_status_channel, DataReaderStatus},
      topic::TopicKind,
      with_key::simpledatareader::ReaderCommand,
    },
    mio_source,
    polling::{wake_channel, LoopWaker},
    serialization::CDRSerializerAdapter,
    structure::guid::*,
    test::{
      random_data::RandomData,
      test_data::{
        publication_builtin_topic_data, reader_proxy_data, spdp_participant_data,
        subscription_builtin_topic_data, writer_proxy_data,
      },
      test_domain::test_domain_id,
    },
  };

  /// RADAR patch 51: a topic's senders map holds pointers, not topic data. Most topics have one or two
  /// senders, and a BTreeMap's first node has room for 11 values: unboxed, 11 whole topic data per topic were
  /// allocated (about 3 KiB; heaptrack of 300 responses, 7 topics each: 21.4 KiB per response, 10.7 boxed).
  #[test]
  fn a_topics_senders_are_held_by_pointer() {
    assert_eq!(
      std::mem::size_of::<TopicSent>(),
      std::mem::size_of::<usize>()
    );
    // what a pointer stands for: a node of 11 of these would be kilobytes
    assert!(std::mem::size_of::<(DiscoveredVia, DiscoveredTopicData)>() > 150);
  }

  #[test]
  fn discdb_participant_operations() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();

    let mut discoverydb = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let mut data = spdp_participant_data().unwrap();
    data.lease_duration = Some(Duration::from(StdDuration::from_secs(1)));

    discoverydb.update_participant(&data);
    assert_eq!(discoverydb.participant_proxies.len(), 1);

    discoverydb.update_participant(&data);
    assert_eq!(discoverydb.participant_proxies.len(), 1);

    std::thread::sleep(StdDuration::from_secs(2));
    discoverydb.participant_cleanup();
    assert!(discoverydb.participant_proxies.is_empty());

    // TODO: more operations tests
  }

  // RADAR patch 35: what a participant's endpoints said about their topics goes with the participant (it
  // was kept for ever: ~7 KB per short-lived peer process), and the attic keeps the last 64 lost ones.
  #[test]
  fn a_participant_that_leaves_takes_its_topic_data_and_the_attic_is_bounded() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(1024);
    let (status_sender, _status_receiver) = sync_status_channel(1024).unwrap();
    let mut db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let n = ATTIC_PARTICIPANTS + 6;
    let prefix = |i: usize| GuidPrefix::new(&[i as u8 + 1; 12]);
    let topic = subscription_builtin_topic_data().unwrap().topic_name().clone();
    for i in 0..n {
      let mut p = spdp_participant_data().unwrap();
      p.participant_guid = GUID::new(prefix(i), EntityId::PARTICIPANT);
      db.update_participant(&p);
      let reader = GUID::new(
        prefix(i),
        EntityId::new([0, 0, 1], EntityKind::READER_NO_KEY_USER_DEFINED),
      );
      let mut proxy = reader_proxy_data().unwrap();
      proxy.remote_reader_guid = reader;
      let sub = SubscriptionBuiltinTopicData::new(
        reader,
        None,
        topic.clone(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        None,
      );
      db.update_subscription(&DiscoveredReaderData {
        reader_proxy: proxy,
        subscription_topic_data: sub,
        content_filter: None,
        user_data: Vec::new(),
      });
    }
    assert_eq!(db.topic_senders().get(&topic), Some(&n));
    // one says goodbye, the others' leases run out
    db.remove_participant(prefix(0), true);
    assert_eq!(db.topic_senders().get(&topic), Some(&(n - 1)));
    for i in 1..n {
      db.remove_participant(prefix(i), false);
    }
    assert_eq!(db.topic_senders().get(&topic), None, "nobody describes the topic any more");
    assert_eq!(db.attic_len(), ATTIC_PARTICIPANTS, "the attic keeps the last lost ones only");
    // the last one lost comes back: its reader and what it said about the topic too
    let mut p = spdp_participant_data().unwrap();
    p.participant_guid = GUID::new(prefix(n - 1), EntityId::PARTICIPANT);
    db.update_participant(&p);
    assert_eq!(db.topic_senders().get(&topic), Some(&1));
    assert_eq!(db.attic_len(), ATTIC_PARTICIPANTS - 1);
    assert_eq!(db.get_all_external_topic_readers().count(), 1);
  }

  // RADAR patch 45: an endpoint that goes is taken out of the topics it described, found through the index
  #[test]
  fn an_endpoint_that_goes_takes_its_own_topic_data_and_the_index_empties() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(1024);
    let (status_sender, _status_receiver) = sync_status_channel(1024).unwrap();
    let mut db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let reader_on = |db: &mut DiscoveryDB, prefix: u8, entity: u8, topic: &str| {
      let guid = GUID::new(
        GuidPrefix::new(&[prefix; 12]),
        EntityId::new([0, 0, entity], EntityKind::READER_NO_KEY_USER_DEFINED),
      );
      let mut proxy = reader_proxy_data().unwrap();
      proxy.remote_reader_guid = guid;
      let sub = SubscriptionBuiltinTopicData::new(
        guid,
        None,
        topic.to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        None,
      );
      db.update_subscription(&DiscoveredReaderData {
        reader_proxy: proxy,
        subscription_topic_data: sub,
        content_filter: None,
        user_data: Vec::new(),
      });
      guid
    };
    // P has readers on a and b, Q on a and c
    let pa = reader_on(&mut db, 1, 1, "a");
    let pb = reader_on(&mut db, 1, 2, "b");
    let qa = reader_on(&mut db, 2, 1, "a");
    let _qc = reader_on(&mut db, 2, 2, "c");
    let senders = |db: &DiscoveryDB| db.topic_senders().into_iter().collect::<Vec<_>>();
    let s = |v: &[(&str, usize)]| {
      v.iter()
        .map(|(t, n)| (t.to_string(), *n))
        .collect::<Vec<_>>()
    };
    assert_eq!(senders(&db), s(&[("a", 2), ("b", 1), ("c", 1)]));
    assert_eq!(db.topic_index_len(), 4);
    db.remove_topic_reader(pa);
    assert_eq!(senders(&db), s(&[("a", 1), ("b", 1), ("c", 1)]));
    db.remove_topic_reader(pb);
    assert_eq!(senders(&db), s(&[("a", 1), ("c", 1)]), "b: nobody describes it");
    // a reader removed twice, or never known, changes nothing
    db.remove_topic_reader(pb);
    db.remove_topic_reader(GUID::new(
      GuidPrefix::new(&[7; 12]),
      EntityId::new([0, 0, 9], EntityKind::READER_NO_KEY_USER_DEFINED),
    ));
    assert_eq!(senders(&db), s(&[("a", 1), ("c", 1)]));
    assert_eq!(db.topic_index_len(), 2);
    // Q leaves by goodbye: everything it described goes, and the index with it
    db.remove_participant(qa.prefix, true);
    assert_eq!(senders(&db), s(&[]));
    assert_eq!(db.topic_index_len(), 0);
    // a topic whose endpoints went without taking their data (kept by another store) is cleaned up with
    // its senders' index entries
    let r = reader_on(&mut db, 3, 1, "d");
    db.external_topic_readers.remove(&r);
    db.topic_cleanup();
    assert_eq!(senders(&db), s(&[]));
    assert_eq!(db.topic_index_len(), 0);
  }

  // RADAR patch 57: a participant says what it knows of a topic again with every endpoint it makes on it.
  // A repeat that changes nothing says so (Discovery then tells the event loop nothing: before, every endpoint
  // of the topic was told again, once per endpoint made), and a sender new to a topic is checked against the
  // type names its senders gave, not against each sender: an inconsistent type is still reported exactly when
  // a sender of the topic gave another type (against the test's own record of who gave what), through
  // senders added and taken away.
  #[test]
  fn a_repeated_topic_changes_nothing_and_types_are_checked_against_what_senders_gave() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(1024);
    let (status_sender, status) = sync_status_channel(4096).unwrap();
    let mut db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let inconsistent = |status: &crate::dds::statusevents::StatusChannelReceiver<
      DomainParticipantStatusEvent,
    >| {
      let mut n = 0;
      while let Ok(e) = status.try_recv() {
        n += usize::from(matches!(
          e,
          DomainParticipantStatusEvent::InconsistentTopic { .. }
        ));
      }
      n
    };

    // the same participant's topic data, through the Topic topic
    let p = GUID::new(GuidPrefix::new(&[9; 12]), EntityId::PARTICIPANT);
    let topic = |qos: &QosPolicies| {
      DiscoveredTopicData::new(
        Utc::now(),
        TopicBuiltinTopicData::new(
          None,
          "rt/parameter_events".to_string(),
          "rcl_interfaces::msg::dds_::ParameterEvent_".to_string(),
          qos,
        ),
      )
    };
    let plain = QosPolicies::qos_none();
    let latched = QosPolicies::builder()
      .durability(crate::dds::qos::policy::Durability::TransientLocal)
      .build();
    assert!(db.update_topic_data(&topic(&plain), p, DiscoveredVia::Topic), "new");
    assert!(!db.update_topic_data(&topic(&plain), p, DiscoveredVia::Topic), "a repeat");
    assert!(db.update_topic_data(&topic(&latched), p, DiscoveredVia::Topic), "its QoS changed");
    assert!(!db.update_topic_data(&topic(&latched), p, DiscoveredVia::Topic));
    let q = GUID::new(GuidPrefix::new(&[8; 12]), EntityId::PARTICIPANT);
    assert!(db.update_topic_data(&topic(&plain), q, DiscoveredVia::Publication), "a new sender");
    assert!(!db.update_topic_data(&topic(&plain), q, DiscoveredVia::Publication));
    assert!(db.update_topic_data(&topic(&plain), q, DiscoveredVia::Topic), "first via Topic");
    assert!(!db.update_topic_data(&topic(&plain), q, DiscoveredVia::Topic));
    assert_eq!(inconsistent(&status), 0);

    // readers of one topic with type A or B, added and taken away in a fixed pseudo-random order
    let reader = |db: &mut DiscoveryDB, i: u32, ty: &str| {
      let guid = GUID::new(
        GuidPrefix::new(&[(i % 200) as u8 + 1; 12]),
        EntityId::new(
          [(i / 200) as u8, 0, 1],
          EntityKind::READER_NO_KEY_USER_DEFINED,
        ),
      );
      let mut proxy = reader_proxy_data().unwrap();
      proxy.remote_reader_guid = guid;
      let sub = SubscriptionBuiltinTopicData::new(
        guid,
        None,
        "shared".to_string(),
        ty.to_string(),
        &QosPolicies::qos_none(),
        None,
      );
      db.update_subscription(&DiscoveredReaderData {
        reader_proxy: proxy,
        subscription_topic_data: sub,
        content_filter: None,
        user_data: Vec::new(),
      });
      guid
    };
    let mut held: Vec<(GUID, &str)> = Vec::new();
    let mut x: u32 = 12345;
    let mut reported = 0;
    for i in 0..2000 {
      x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
      if x % 5 == 0 && !held.is_empty() {
        let (g, _) = held.remove((x as usize / 7) % held.len());
        db.remove_topic_reader(g);
        continue;
      }
      let ty = if x % 97 < 3 { "B" } else { "A" };
      let expected = held.iter().any(|(_, t)| *t != ty);
      let g = reader(&mut db, i, ty);
      held.push((g, ty));
      let n = inconsistent(&status);
      assert_eq!(n, usize::from(expected), "reader {i} of type {ty}, held {}", held.len());
      reported += n;
    }
    assert!(reported > 10, "the order makes both cases: {reported} reported");
    // the counts are what is held (a count left behind would send every new sender to the scan)
    let mut model = BTreeMap::new();
    for (_, ty) in &held {
      *model.entry(ty.to_string()).or_insert(0) += 1;
    }
    assert_eq!(db.topic_type_counts("shared"), model);
    for (g, _) in held {
      db.remove_topic_reader(g);
    }
    assert!(db.topic_type_counts("shared").is_empty());
  }

  // RADAR patch 49: the endpoints of a topic, found through the topic index, are those a scan of every
  // endpoint finds, through endpoints added, removed, their participants lost (to the attic) and back
  #[test]
  fn the_endpoints_of_a_topic_are_found_as_a_scan_finds_them() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(1024);
    let (status_sender, _status_receiver) = sync_status_channel(1024).unwrap();
    let mut db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let topics = ["a", "b", "c"];
    let participant = |db: &mut DiscoveryDB, p: u8| {
      let mut d = spdp_participant_data().unwrap();
      d.participant_guid = GUID::new(GuidPrefix::new(&[p; 12]), EntityId::PARTICIPANT);
      db.update_participant(&d);
    };
    let reader = |db: &mut DiscoveryDB, p: u8, e: u8, topic: &str| {
      let guid = GUID::new(
        GuidPrefix::new(&[p; 12]),
        EntityId::new([0, 1, e], EntityKind::READER_NO_KEY_USER_DEFINED),
      );
      let mut proxy = reader_proxy_data().unwrap();
      proxy.remote_reader_guid = guid;
      let sub = SubscriptionBuiltinTopicData::new(
        guid,
        None,
        topic.to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        None,
      );
      db.update_subscription(&DiscoveredReaderData {
        reader_proxy: proxy,
        subscription_topic_data: sub,
        content_filter: None,
        user_data: Vec::new(),
      });
      guid
    };
    let writer = |db: &mut DiscoveryDB, p: u8, e: u8, topic: &str, local: bool| {
      let guid = GUID::new(
        GuidPrefix::new(&[p; 12]),
        EntityId::new([0, 2, e], EntityKind::WRITER_NO_KEY_USER_DEFINED),
      );
      let mut wp = writer_proxy_data().unwrap();
      wp.remote_writer_guid = guid;
      let mut publication = publication_builtin_topic_data().unwrap();
      publication.key = guid;
      publication.topic_name = topic.to_string();
      let w = DiscoveredWriterData {
        last_updated: Instant::now(),
        writer_proxy: wp,
        publication_topic_data: publication,
        user_data: Vec::new(),
      };
      if local {
        db.update_local_topic_writer(w);
      } else {
        db.update_publication(&w);
      }
      guid
    };
    // the oracle: every endpoint stored, filtered by its topic name
    let check = |db: &DiscoveryDB, step: &str| {
      for t in topics {
        let scan_r: Vec<GUID> = db
          .get_all_external_topic_readers()
          .chain(db.get_all_local_topic_readers())
          .filter(|r| r.subscription_topic_data.topic_name() == t)
          .map(|r| r.reader_proxy.remote_reader_guid)
          .collect();
        let scan_w: Vec<GUID> = db
          .get_all_external_topic_writers()
          .chain(db.get_all_local_topic_writers())
          .filter(|w| w.publication_topic_data.topic_name() == t)
          .map(|w| w.writer_proxy.remote_writer_guid)
          .collect();
        let found_r: Vec<GUID> = db
          .readers_on_topic(t)
          .iter()
          .map(|r| r.reader_proxy.remote_reader_guid)
          .collect();
        let found_w: Vec<GUID> = db
          .writers_on_topic(t)
          .iter()
          .map(|w| w.writer_proxy.remote_writer_guid)
          .collect();
        assert_eq!(found_r, scan_r, "{step}: readers of {t}");
        assert_eq!(found_w, scan_w, "{step}: writers of {t}");
        // RADAR patch 53: a participant's, against a scan of the remote ones in GUID order
        for p in [1u8, 2, 7] {
          let prefix = GuidPrefix::new(&[p; 12]);
          let mut scan_r: Vec<GUID> = db
            .get_all_external_topic_readers()
            .filter(|r| r.subscription_topic_data.topic_name() == t)
            .map(|r| r.reader_proxy.remote_reader_guid)
            .filter(|g| g.prefix == prefix)
            .collect();
          scan_r.sort();
          let mut scan_w: Vec<GUID> = db
            .get_all_external_topic_writers()
            .filter(|w| w.publication_topic_data.topic_name() == t)
            .map(|w| w.writer_proxy.remote_writer_guid)
            .filter(|g| g.prefix == prefix)
            .collect();
          scan_w.sort();
          let found_r: Vec<GUID> = db
            .readers_on_topic_and_participant(t, prefix)
            .iter()
            .map(|r| r.reader_proxy.remote_reader_guid)
            .collect();
          let found_w: Vec<GUID> = db
            .writers_on_topic_and_participant(t, prefix)
            .iter()
            .map(|w| w.writer_proxy.remote_writer_guid)
            .collect();
          assert_eq!(found_r, scan_r, "{step}: readers of participant {p} on {t}");
          assert_eq!(found_w, scan_w, "{step}: writers of participant {p} on {t}");
        }
      }
    };
    participant(&mut db, 1);
    participant(&mut db, 2);
    let r1a = reader(&mut db, 1, 1, "a");
    reader(&mut db, 1, 2, "b");
    reader(&mut db, 2, 1, "a");
    reader(&mut db, 1, 3, "a");
    writer(&mut db, 1, 2, "a", false);
    let w1a = writer(&mut db, 1, 1, "a", false);
    writer(&mut db, 2, 1, "c", false);
    let local = writer(&mut db, 7, 1, "a", true);
    check(&db, "added");
    assert_eq!(db.readers_on_topic("a").len(), 3);
    assert_eq!(db.writers_on_topic("a").len(), 3);
    db.remove_topic_reader(r1a);
    db.remove_topic_writer(w1a);
    db.remove_local_topic_writer(local);
    check(&db, "removed by GUID");
    db.remove_participant(GuidPrefix::new(&[2; 12]), false);
    check(&db, "participant 2 lost (its endpoints to the attic)");
    participant(&mut db, 2);
    check(&db, "participant 2 back");
    db.remove_participant(GuidPrefix::new(&[1; 12]), true);
    db.topic_cleanup();
    check(&db, "participant 1 gone, cleaned up");
    assert!(db.readers_by_topic.values().flatten().all(|g| g.prefix != GuidPrefix::new(&[1; 12])));
  }

  // RADAR patch 37: a writer and a reader announced before their participant get its addresses when it comes
  #[test]
  fn endpoints_heard_of_before_their_participant_get_its_locators_when_it_comes() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(1024);
    let (status_sender, _status_receiver) = sync_status_channel(1024).unwrap();
    let mut db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let prefix = GuidPrefix::new(&[9; 12]);
    let writer = GUID::new(
      prefix,
      EntityId::new([0, 0, 1], EntityKind::WRITER_NO_KEY_USER_DEFINED),
    );
    let reader = GUID::new(
      prefix,
      EntityId::new([0, 0, 2], EntityKind::READER_NO_KEY_USER_DEFINED),
    );
    let mut wp = writer_proxy_data().unwrap();
    wp.remote_writer_guid = writer;
    wp.unicast_locator_list.clear();
    wp.multicast_locator_list.clear();
    let mut publication = publication_builtin_topic_data().unwrap();
    publication.key = writer;
    let dwd = DiscoveredWriterData {
      last_updated: Instant::now(),
      writer_proxy: wp,
      publication_topic_data: publication,
      user_data: Vec::new(),
    };
    assert!(db.update_publication(&dwd).writer_proxy.unicast_locator_list.is_empty());
    let mut rp = reader_proxy_data().unwrap();
    rp.remote_reader_guid = reader;
    rp.unicast_locator_list.clear();
    rp.multicast_locator_list.clear();
    let topic = subscription_builtin_topic_data().unwrap().topic_name().clone();
    db.update_subscription(&DiscoveredReaderData {
      reader_proxy: rp,
      subscription_topic_data: SubscriptionBuiltinTopicData::new(
        reader,
        None,
        topic,
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        None,
      ),
      content_filter: None,
      user_data: Vec::new(),
    });
    let mut p = spdp_participant_data().unwrap();
    p.participant_guid = GUID::new(prefix, EntityId::PARTICIPANT);
    assert!(!p.default_unicast_locators.is_empty());
    assert!(db.update_participant(&p), "a new participant");
    let w = db.get_all_external_topic_writers().next().unwrap();
    assert_eq!(w.writer_proxy.unicast_locator_list, p.default_unicast_locators);
    assert_eq!(w.writer_proxy.multicast_locator_list, p.default_multicast_locators);
    let r = db.get_all_external_topic_readers().next().unwrap();
    assert_eq!(r.reader_proxy.unicast_locator_list, p.default_unicast_locators);
  }

  #[test]
  fn discdb_writer_proxies() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();
    let _discoverydb = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );
    let topic_name = String::from("some_topic");
    let type_name = String::from("RandomData");
    let _dreader = DiscoveredReaderData::default(topic_name, type_name);

    // TODO: more tests :)
  }

  #[test]
  fn discdb_subscription_operations() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();

    let mut discovery_db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );

    let domain_participant =
      DomainParticipant::new(test_domain_id(0)).expect("Failed to create publisher");
    let topic = domain_participant
      .create_topic(
        "Foobar".to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();
    let topic2 = domain_participant
      .create_topic(
        "Barfoo".to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();

    let publisher1 = domain_participant
      .create_publisher(&QosPolicies::qos_none())
      .unwrap();
    let dw = publisher1
      .create_datawriter::<RandomData, CDRSerializerAdapter<RandomData, LittleEndian>>(&topic, None)
      .unwrap();

    let writer_data = DiscoveredWriterData::new(&dw, &topic, &domain_participant, None);

    discovery_db.update_local_topic_writer(writer_data);
    assert_eq!(discovery_db.local_topic_writers.len(), 1);

    let publisher2 = domain_participant
      .create_publisher(&QosPolicies::qos_none())
      .unwrap();
    let dw2 = publisher2
      .create_datawriter::<RandomData, CDRSerializerAdapter<RandomData, LittleEndian>>(
        &topic2, None,
      )
      .unwrap();
    let writer_data2 = DiscoveredWriterData::new(&dw2, &topic2, &domain_participant, None);
    discovery_db.update_local_topic_writer(writer_data2);
    assert_eq!(discovery_db.local_topic_writers.len(), 2);

    // creating data
    let reader1 = reader_proxy_data().unwrap();
    let reader1sub = subscription_builtin_topic_data().unwrap();
    // reader1sub.set_key(reader1.remote_reader_guid);
    // reader1sub.set_topic_name(&topic.name());
    let dreader1 = DiscoveredReaderData {
      reader_proxy: reader1.clone(),
      subscription_topic_data: reader1sub.clone(),
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader1);

    let reader2 = reader_proxy_data().unwrap();
    let reader2sub = subscription_builtin_topic_data().unwrap();
    // reader2sub.set_key(reader2.remote_reader_guid);
    // reader2sub.set_topic_name(&topic2.name());
    let dreader2 = DiscoveredReaderData {
      reader_proxy: reader2,
      subscription_topic_data: reader2sub,
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader2);

    let reader3 = reader1;
    let reader3sub = reader1sub;
    let dreader3 = DiscoveredReaderData {
      reader_proxy: reader3,
      subscription_topic_data: reader3sub,
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader3);

    // TODO: there might be a need for different scenarios
  }

  #[test]
  fn discdb_external_endpoint_snapshots() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();

    let mut discovery_db = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );

    // Nothing discovered yet.
    assert_eq!(discovery_db.get_all_external_topic_readers().count(), 0);
    assert_eq!(discovery_db.get_all_external_topic_writers().count(), 0);

    // Discover one external Reader via SEDP subscription data.
    let reader = reader_proxy_data().unwrap();
    let reader_sub = subscription_builtin_topic_data().unwrap();
    let dreader = DiscoveredReaderData {
      reader_proxy: reader,
      subscription_topic_data: reader_sub,
      content_filter: None,
      user_data: Vec::new(),
    };
    discovery_db.update_subscription(&dreader);

    // Discover one external Writer via SEDP publication data.
    let domain_participant =
      DomainParticipant::new(test_domain_id(0)).expect("Failed to create participant");
    let topic = domain_participant
      .create_topic(
        "Foobar".to_string(),
        "RandomData".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();
    let publisher = domain_participant
      .create_publisher(&QosPolicies::qos_none())
      .unwrap();
    let dw = publisher
      .create_datawriter::<RandomData, CDRSerializerAdapter<RandomData, LittleEndian>>(&topic, None)
      .unwrap();
    let writer_data = DiscoveredWriterData::new(&dw, &topic, &domain_participant, None);
    discovery_db.update_publication(&writer_data);

    // Both accessors return the discovered endpoints as a snapshot.
    let readers = discovery_db
      .get_all_external_topic_readers()
      .cloned()
      .collect::<Vec<_>>();
    let writers = discovery_db
      .get_all_external_topic_writers()
      .cloned()
      .collect::<Vec<_>>();
    assert_eq!(readers.len(), 1);
    assert_eq!(writers.len(), 1);
    assert_eq!(
      readers[0].reader_proxy.remote_reader_guid,
      dreader.reader_proxy.remote_reader_guid
    );
    assert_eq!(
      writers[0].writer_proxy.remote_writer_guid,
      writer_data.writer_proxy.remote_writer_guid
    );
  }

  #[test]
  fn discdb_local_topic_reader() {
    let (discovery_db_event_sender, _discovery_db_event_receiver) =
      std::sync::mpsc::sync_channel::<()>(4);

    let dp = DomainParticipant::new(test_domain_id(0)).expect("Failed to create participant");
    let topic = dp
      .create_topic(
        "some topic name".to_string(),
        "Wazzup".to_string(),
        &QosPolicies::qos_none(),
        TopicKind::WithKey,
      )
      .unwrap();
    let (status_sender, _status_receiver) = sync_status_channel(16).unwrap();
    let mut discoverydb = DiscoveryDB::new(
      GUID::new_participant_guid(),
      discovery_db_event_sender,
      status_sender,
    );

    // Create reader ingredients
    let (notification_sender1, _notification_receiver1) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source1, notification_event_sender1) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker1 = Arc::new(Mutex::new(None));

    let (status_sender1, _status_receiver1) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (_reader_commander1, reader_command_receiver1) =
      wake_channel::<ReaderCommand>(100, &LoopWaker::new());

    let topic_cache =
      dp.dds_cache()
        .write()
        .unwrap()
        .add_new_topic(topic.name(), topic.get_type(), &topic.qos());

    let reader1_ing = ReaderIngredients {
      guid: GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED),
      notification_sender: notification_sender1,
      status_sender: status_sender1,
      topic_name: topic.name(),
      topic_cache_handle: topic_cache.clone(),
      like_stateless: false,
      qos_policy: QosPolicies::qos_none(),
      data_reader_command_receiver: reader_command_receiver1,
      data_reader_waker: data_reader_waker1,
      poll_event_sender: notification_event_sender1,
      security_plugins: None,
      discovery_notify: None,
    };

    // Add the reader to the database and verify the info is updated
    discoverydb.update_local_topic_reader(DiscoveryDB::local_topic_reader_data(
      &dp,
      &topic,
      &reader1_ing,
      None,
    ));
    assert_eq!(discoverydb.local_topic_readers.len(), 1);
    assert_eq!(discoverydb.get_local_topic_readers(&topic).len(), 1);

    // Verify that the info does not change if the reader is added a second time
    discoverydb.update_local_topic_reader(DiscoveryDB::local_topic_reader_data(
      &dp,
      &topic,
      &reader1_ing,
      None,
    ));
    assert_eq!(discoverydb.local_topic_readers.len(), 1);
    assert_eq!(discoverydb.get_local_topic_readers(&topic).len(), 1);

    // Create second reader ingredients for the same topic
    let (notification_sender2, _notification_receiver2) =
      crate::mio_source::notification_channel(100);
    let (_notification_event_source2, notification_event_sender2) =
      mio_source::make_poll_channel().unwrap();
    let data_reader_waker2 = Arc::new(Mutex::new(None));

    let (status_sender2, _status_receiver2) = sync_status_channel::<DataReaderStatus>(4).unwrap();
    let (_reader_commander2, reader_command_receiver2) =
      wake_channel::<ReaderCommand>(100, &LoopWaker::new());

    let mut guid2 = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    guid2.prefix = GuidPrefix::new(b"Another fake"); // GUID needs to be different in order to be added

    let reader2_ing = ReaderIngredients {
      guid: guid2,
      notification_sender: notification_sender2,
      status_sender: status_sender2,
      topic_name: topic.name(),
      topic_cache_handle: topic_cache,
      like_stateless: false,
      qos_policy: QosPolicies::qos_none(),
      data_reader_command_receiver: reader_command_receiver2,
      data_reader_waker: data_reader_waker2,
      poll_event_sender: notification_event_sender2,
      security_plugins: None,
      discovery_notify: None,
    };

    // Add the second reader to the database and verify the info is updated
    discoverydb.update_local_topic_reader(DiscoveryDB::local_topic_reader_data(
      &dp,
      &topic,
      &reader2_ing,
      None,
    ));
    assert_eq!(discoverydb.get_local_topic_readers(&topic).len(), 2);
    assert_eq!(discoverydb.get_all_local_topic_readers().count(), 2);
  }
}
