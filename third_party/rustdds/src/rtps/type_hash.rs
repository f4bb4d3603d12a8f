//! RADAR patch 70: endpoints that announce different ROS 2 type hashes do not
//! match.
//!
//! ROS 2 (Jazzy on) announces each topic endpoint's type hash in its USER_DATA
//! (`typehash=RIHS01_<64 hex>;`, REP 2011; RADAR patch 43 announces and reads
//! it). Two definitions under one type name (a peer built against another
//! version of a message package) then announce different hashes, yet DDS matches
//! them by the type's name alone, so a reader takes the other definition's bytes
//! for its own: a sample too short for it, or one whose fields mean something
//! else. rmw_zenoh refuses such a peer (the hash is part of its key
//! expressions); here the match is refused likewise, with one warning per
//! remote endpoint that names the topic, the type and both hashes. An endpoint
//! that announces no hash (another vendor's plain DDS, a ROS 2 before Jazzy) or
//! the unset hash (all zeros) matches as before.

use std::collections::BTreeSet;

use log::warn;

use crate::{dds::qos::QosPolicies, structure::guid::GUID};

/// The ROS 2 type hash a USER_DATA announces (`RIHS01_...`), unless none or
/// the unset one (all zeros).
pub(crate) fn ros_type_hash(user_data: &[u8]) -> Option<&str> {
  let text = std::str::from_utf8(user_data).ok()?;
  let hash = text
    .split(';')
    .find_map(|entry| entry.trim().strip_prefix("typehash="))?;
  let digits = hash.split_once('_').map_or(hash, |(_, d)| d);
  (!hash.is_empty() && digits.bytes().any(|b| b != b'0')).then_some(hash)
}

/// The remote endpoints of one local endpoint refused for their type hash, so
/// that each is warned about once.
#[derive(Default)]
pub(crate) struct TypeHashRefusals {
  warned: BTreeSet<GUID>,
}

impl TypeHashRefusals {
  /// Whether the remote endpoint `remote` (of `type_name`, with QoS `theirs`)
  /// must not be matched to the local endpoint `local` of `topic` (QoS `ours`):
  /// both announce a ROS 2 type hash, and they differ.
  pub fn refuses(
    &mut self,
    topic: &str,
    type_name: &str,
    (local, ours): (GUID, &QosPolicies),
    (remote, theirs): (GUID, &QosPolicies),
  ) -> bool {
    let ours = ours.user_data().and_then(ros_type_hash);
    let theirs = theirs.user_data().and_then(ros_type_hash);
    let (Some(ours), Some(theirs)) = (ours, theirs) else {
      return false;
    };
    if ours == theirs {
      return false;
    }
    if self.warned.insert(remote) {
      warn!(
        "Topic {topic:?}: {remote:?} announces type {type_name} with hash {theirs}, but {local:?} has \
         {ours}: another definition of the type under the same name, so they are not matched (and exchange \
         nothing). Build both sides against the same version of the interface package."
      );
    }
    true
  }

  /// The remote endpoint left: a new one of the same GUID is warned about again.
  pub fn forget(&mut self, remote: GUID) {
    self.warned.remove(&remote);
  }
}

#[cfg(test)]
mod tests {
  use super::*;
  use crate::structure::guid::EntityKind;

  const A: &str = "RIHS01_a9c6f8ea4e1c7c8d6b1f1f5bd0bdc4b3a0a5d1a1e1d6b5a2f3c4d5e6f7a8b9c0";
  const B: &str = "RIHS01_b9c6f8ea4e1c7c8d6b1f1f5bd0bdc4b3a0a5d1a1e1d6b5a2f3c4d5e6f7a8b9c0";
  const UNSET: &str = "RIHS01_0000000000000000000000000000000000000000000000000000000000000000";

  fn qos(user_data: Option<String>) -> QosPolicies {
    match user_data {
      Some(u) => QosPolicies::qos_none().with_user_data(u),
      None => QosPolicies::qos_none(),
    }
  }

  #[test]
  fn the_hash_is_read_from_rosidl_user_data() {
    assert_eq!(ros_type_hash(format!("typehash={A};").as_bytes()), Some(A));
    assert_eq!(
      ros_type_hash(format!("typehash={A};radar_observe=1;").as_bytes()),
      Some(A)
    );
    assert_eq!(ros_type_hash(b"radar_observe=1;"), None);
    assert_eq!(ros_type_hash(format!("typehash={UNSET};").as_bytes()), None);
    assert_eq!(ros_type_hash(b"typehash=;"), None);
    assert_eq!(ros_type_hash(&[0xff, 0xfe]), None);
  }

  #[test]
  fn only_two_different_announced_hashes_refuse_a_match_and_each_remote_is_warned_about_once() {
    let local = GUID::dummy_test_guid(EntityKind::READER_NO_KEY_USER_DEFINED);
    let remote = GUID::dummy_test_guid(EntityKind::WRITER_NO_KEY_USER_DEFINED);
    let with = |h: &str| qos(Some(format!("typehash={h};")));
    let mut refusals = TypeHashRefusals::default();
    let mut refuses = |ours: &QosPolicies, theirs: &QosPolicies| {
      refusals.refuses("rt/t", "p::msg::dds_::T_", (local, ours), (remote, theirs))
    };
    assert!(!refuses(&with(A), &with(A)), "the same hash");
    assert!(!refuses(&with(A), &qos(None)), "a peer that announces none");
    assert!(!refuses(&qos(None), &with(B)), "this side announces none");
    assert!(!refuses(&with(A), &with(UNSET)), "the unset hash");
    assert!(refuses(&with(A), &with(B)), "another definition");
    assert!(refuses(&with(B), &with(A)), "either way round");
    assert_eq!(refusals.warned.len(), 1, "warned once for one remote");
    refusals.forget(remote);
    assert!(refusals.warned.is_empty());
  }
}
