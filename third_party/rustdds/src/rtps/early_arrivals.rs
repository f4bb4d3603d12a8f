//! Writer submessages that arrive before their writer is matched.
//!
//! Discovery completes on each side separately. A remote writer often matches
//! one of our readers (it has processed our SEDP subscription) a moment before
//! we have processed its SEDP publication. Whatever it sends in that moment —
//! DATA, DATA_FRAG, HEARTBEAT, GAP — reaches a reader that has no proxy for the
//! writer yet, and a stateful reader drops it. A reliable writer repairs the
//! loss only after its next periodic HEARTBEAT (3 s in Fast DDS), and a
//! short-lived writer never does: `ros2 topic pub --once` publishes as soon as
//! it counts one matched subscription, stays 0.1 s and exits, so its only
//! sample was lost every time.
//!
//! [`EarlyArrivals`] keeps such submessages, with the receiver state they came
//! with, for a short while ([`HOLD`]), bounded in count and bytes, and hands
//! them back when a reader matches their writer, so that they are processed as
//! if they had arrived just after the match. Only submessages a stateful reader
//! would drop are kept: DATA/DATA_FRAG from user-defined writers (built-in
//! readers accept DATA from unknown writers already) and HEARTBEAT/GAP from any
//! writer.

use std::{
  collections::VecDeque,
  time::{Duration, Instant},
};

use crate::{
  messages::submessages::submessages::WriterSubmessage,
  structure::{
    guid::{EntityId, GuidPrefix, GUID},
    locator::Locator,
    time::Timestamp,
  },
};

/// How long a submessage from a not-yet-matched writer is kept. Discovery of a
/// new participant's endpoints normally completes within milliseconds of its
/// first user traffic; this leaves room for a loaded machine.
pub(crate) const HOLD: Duration = Duration::from_secs(2);
/// At most this many submessages are kept per participant (oldest dropped).
pub(crate) const LIMIT: usize = 256;
/// At most this many payload bytes are kept per participant (oldest dropped).
pub(crate) const BYTE_LIMIT: usize = 1 << 20;

/// The part of the message receiver's state a held submessage needs again.
#[derive(Clone, Debug)]
pub(crate) struct ReceiverSnapshot {
  pub source_guid_prefix: GuidPrefix,
  pub dest_guid_prefix: GuidPrefix,
  pub unicast_reply_locator_list: Vec<Locator>,
  pub source_timestamp: Option<Timestamp>,
}

struct Held {
  writer: GUID,
  /// The reader it was addressed to; `None` when addressed to every reader
  /// (ENTITYID_UNKNOWN), so any reader that matches the writer gets it.
  target: Option<EntityId>,
  /// Readers that already got it (only used when `target` is `None`).
  delivered: Vec<EntityId>,
  submessage: WriterSubmessage,
  snapshot: ReceiverSnapshot,
  bytes: usize,
  received: Instant,
}

/// Submessages from writers not matched yet, per participant.
#[derive(Default)]
pub(crate) struct EarlyArrivals {
  held: VecDeque<Held>,
  bytes: usize,
}

/// Whether a reader without a proxy for `writer` would drop this submessage,
/// so that it is worth keeping until the writer is matched.
pub(crate) fn worth_holding(submessage: &WriterSubmessage, writer: GUID) -> bool {
  if writer.entity_id == EntityId::SPDP_BUILTIN_PARTICIPANT_WRITER
    || writer.entity_id == EntityId::P2P_BUILTIN_PARTICIPANT_STATELESS_WRITER
  {
    // read without writer proxies
    return false;
  }
  match submessage {
    // Built-in readers take DATA from unknown writers (discovery traffic).
    WriterSubmessage::Data(..) | WriterSubmessage::DataFrag(..) => {
      writer.entity_id.entity_kind.is_user_defined()
    }
    WriterSubmessage::Heartbeat(..)
    | WriterSubmessage::Gap(..)
    | WriterSubmessage::HeartbeatFrag(..) => true,
  }
}

fn payload_len(submessage: &WriterSubmessage) -> usize {
  match submessage {
    WriterSubmessage::Data(d, _) => d.serialized_payload.as_ref().map_or(0, |p| p.len()),
    WriterSubmessage::DataFrag(d, _) => d.serialized_payload.len(),
    _ => 0,
  }
}

impl EarlyArrivals {
  /// Keeps `submessage` from `writer`, addressed to `target` (`None`: to all
  /// readers), until a reader matches the writer or [`HOLD`] has passed.
  pub fn hold(
    &mut self,
    writer: GUID,
    target: Option<EntityId>,
    submessage: WriterSubmessage,
    snapshot: ReceiverSnapshot,
  ) {
    let now = Instant::now();
    self.expire(now);
    let bytes = payload_len(&submessage);
    if bytes > BYTE_LIMIT {
      return;
    }
    while self.held.len() >= LIMIT || self.bytes + bytes > BYTE_LIMIT {
      match self.held.pop_front() {
        Some(old) => self.bytes -= old.bytes,
        None => break,
      }
    }
    self.bytes += bytes;
    self.held.push_back(Held {
      writer,
      target,
      delivered: Vec::new(),
      submessage,
      snapshot,
      bytes,
      received: now,
    });
  }

  /// What `reader` should process now that it has matched `writer`, oldest
  /// first. Submessages addressed to that reader are removed; those addressed
  /// to all readers stay (another reader may match the same writer) but are
  /// not handed to this reader again.
  pub fn take_for(
    &mut self,
    writer: GUID,
    reader: EntityId,
  ) -> Vec<(WriterSubmessage, ReceiverSnapshot)> {
    self.expire(Instant::now());
    let mut out = Vec::new();
    let mut bytes_freed = 0;
    self.held.retain_mut(|h| {
      if h.writer != writer {
        return true;
      }
      match h.target {
        Some(t) if t == reader => {
          out.push((h.submessage.clone(), h.snapshot.clone()));
          bytes_freed += h.bytes;
          false
        }
        Some(_) => true,
        None => {
          if !h.delivered.contains(&reader) {
            h.delivered.push(reader);
            out.push((h.submessage.clone(), h.snapshot.clone()));
          }
          true
        }
      }
    });
    self.bytes -= bytes_freed;
    out
  }

  /// Number of submessages kept now.
  #[cfg(test)]
  pub fn len(&self) -> usize {
    self.held.len()
  }

  fn expire(&mut self, now: Instant) {
    while let Some(front) = self.held.front() {
      if now.duration_since(front.received) <= HOLD {
        break;
      }
      self.bytes -= front.bytes;
      self.held.pop_front();
    }
  }

  #[cfg(test)]
  fn age_all_by(&mut self, d: Duration) {
    for h in &mut self.held {
      h.received -= d;
    }
  }
}

#[cfg(test)]
mod tests {
  use bytes::Bytes;
  use enumflags2::BitFlags;

  use super::*;
  use crate::{
    messages::submessages::submessages::{Data, Heartbeat, DATA_Flags},
    structure::{guid::EntityKind, sequence_number::SequenceNumber},
  };

  fn snapshot(prefix: GuidPrefix) -> ReceiverSnapshot {
    ReceiverSnapshot {
      source_guid_prefix: prefix,
      dest_guid_prefix: GuidPrefix::UNKNOWN,
      unicast_reply_locator_list: vec![],
      source_timestamp: None,
    }
  }

  fn data(writer: GUID, sn: i64, len: usize) -> WriterSubmessage {
    WriterSubmessage::Data(
      Data {
        writer_id: writer.entity_id,
        writer_sn: SequenceNumber::new(sn),
        serialized_payload: Some(Bytes::from(vec![0u8; len])),
        ..Data::default()
      },
      BitFlags::from_flag(DATA_Flags::Data),
    )
  }

  fn heartbeat(writer: GUID) -> WriterSubmessage {
    WriterSubmessage::Heartbeat(
      Heartbeat {
        reader_id: EntityId::UNKNOWN,
        writer_id: writer.entity_id,
        first_sn: SequenceNumber::new(1),
        last_sn: SequenceNumber::new(1),
        count: 1,
      },
      BitFlags::empty(),
    )
  }

  fn sn_of(s: &WriterSubmessage) -> i64 {
    match s {
      WriterSubmessage::Data(d, _) => i64::from(d.writer_sn),
      _ => -1,
    }
  }

  #[test]
  fn held_submessages_are_handed_to_the_reader_that_matches_their_writer_in_order() {
    let w = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let other = GUID::new(GuidPrefix::new(&[7; 12]), w.entity_id);
    let r = EntityId::new([0, 0, 3], EntityKind::READER_NO_KEY_USER_DEFINED);
    let mut e = EarlyArrivals::default();
    e.hold(w, Some(r), data(w, 1, 4), snapshot(w.prefix));
    e.hold(other, Some(r), data(other, 1, 4), snapshot(other.prefix));
    e.hold(w, Some(r), heartbeat(w), snapshot(w.prefix));
    e.hold(w, Some(r), data(w, 2, 4), snapshot(w.prefix));

    let got: Vec<i64> = e.take_for(w, r).iter().map(|(s, _)| sn_of(s)).collect();
    assert_eq!(got, vec![1, -1, 2]);
    assert!(e.take_for(w, r).is_empty(), "handed over once");
    assert_eq!(e.len(), 1, "the other writer's sample stays");
  }

  #[test]
  fn submessages_addressed_to_all_readers_go_to_each_matching_reader_once() {
    let w = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let r1 = EntityId::new([0, 0, 3], EntityKind::READER_NO_KEY_USER_DEFINED);
    let r2 = EntityId::new([0, 0, 4], EntityKind::READER_NO_KEY_USER_DEFINED);
    let mut e = EarlyArrivals::default();
    e.hold(w, None, data(w, 1, 4), snapshot(w.prefix));
    e.hold(w, Some(r2), data(w, 2, 4), snapshot(w.prefix));
    assert_eq!(e.take_for(w, r1).len(), 1);
    assert!(e.take_for(w, r1).is_empty());
    assert_eq!(e.take_for(w, r2).len(), 2);
  }

  #[test]
  fn held_submessages_expire_and_are_bounded() {
    let w = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let r = EntityId::new([0, 0, 3], EntityKind::READER_NO_KEY_USER_DEFINED);
    let mut e = EarlyArrivals::default();
    e.hold(w, Some(r), data(w, 1, 4), snapshot(w.prefix));
    e.age_all_by(HOLD + Duration::from_millis(1));
    assert!(e.take_for(w, r).is_empty(), "older than HOLD");

    for sn in 1..=(LIMIT as i64 + 10) {
      e.hold(w, Some(r), data(w, sn, 4), snapshot(w.prefix));
    }
    assert_eq!(e.len(), LIMIT);
    let got = e.take_for(w, r);
    assert_eq!(sn_of(&got[0].0), 11, "the oldest were dropped");

    let big = BYTE_LIMIT / 2 + 1;
    e.hold(w, Some(r), data(w, 1, big), snapshot(w.prefix));
    e.hold(w, Some(r), data(w, 2, big), snapshot(w.prefix));
    assert_eq!(e.len(), 1, "byte limit");
    e.hold(w, Some(r), data(w, 3, BYTE_LIMIT + 1), snapshot(w.prefix));
    assert_eq!(e.len(), 1, "a submessage over the byte limit is not kept");
  }

  #[test]
  fn only_what_a_reader_would_drop_is_worth_holding() {
    let user = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let sedp = GUID::new(user.prefix, EntityId::SEDP_BUILTIN_PUBLICATIONS_WRITER);
    let spdp = GUID::new(user.prefix, EntityId::SPDP_BUILTIN_PARTICIPANT_WRITER);
    assert!(worth_holding(&data(user, 1, 1), user));
    assert!(worth_holding(&heartbeat(user), user));
    assert!(!worth_holding(&data(sedp, 1, 1), sedp));
    assert!(worth_holding(&heartbeat(sedp), sedp));
    assert!(!worth_holding(&heartbeat(spdp), spdp));
  }
}
