//! Message types for ROS 2 Discovery
//!
//! For background, see
//! [Node to Participant mapping](https://design.ros2.org/articles/Node_to_Participant_mapping.html)

use std::convert::TryFrom;

use log::error;
use serde::{Deserialize, Serialize};

use crate::{
  gid::Gid,
  names::{NameError, NodeName},
};

// Each time a Node adds/removes a Reader or Writer (Publisher / Subscrption in
// ROS terms) is must publish a new ParticipantEntitiesInfo that describes its
// current composition. This overwrites the previsous ParticipantEntitiesInfo.

/// Information structure for other DomainParticipants in a ROS 2 network
///
/// See [ParticipantEntitiesInfo](https://github.com/ros2/rmw_dds_common/blob/master/rmw_dds_common/msg/ParticipantEntitiesInfo.msg) in ROS2.
///
/// Gives a list of ROS 2 nodes that are represented by a DDS DomainParticipant
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ParticipantEntitiesInfo {
  pub(crate) gid: Gid, // GUID of a DomainParticipant
  pub(crate) node_entities_info_seq: Vec<NodeEntitiesInfo>,
  // ^ ROS 2 Nodes implemented by the DomainParticipant.
}

impl ParticipantEntitiesInfo {
  pub fn new(gid: Gid, node_entities_info_seq: Vec<NodeEntitiesInfo>) -> ParticipantEntitiesInfo {
    ParticipantEntitiesInfo {
      gid,
      node_entities_info_seq,
    }
  }

  pub fn gid(&self) -> Gid {
    self.gid
  }

  pub fn nodes(&self) -> &Vec<NodeEntitiesInfo> {
    &self.node_entities_info_seq
  }
}

/// Information about a node in ROS2 network
///
/// See [NodeEntitiesInfo](https://github.com/ros2/rmw_dds_common/blob/master/rmw_dds_common/msg/NodeEntitiesInfo.msg)
///
/// Defines a ROS 2 Node and how it is mapped to DDS entities.
///
/// Consists of name and namespace definitions, and lists of
/// Reader and Writer ids that belong to this Node.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "repr::NodeEntitiesInfo", into = "repr::NodeEntitiesInfo")]
pub struct NodeEntitiesInfo {
  name: NodeName,
  reader_gid_seq: Vec<Gid>,
  writer_gid_seq: Vec<Gid>,
}

impl NodeEntitiesInfo {
  pub fn new(name: NodeName) -> NodeEntitiesInfo {
    NodeEntitiesInfo {
      name,
      reader_gid_seq: Vec::new(),
      writer_gid_seq: Vec::new(),
    }
  }

  pub fn namespace(&self) -> &str {
    self.name.namespace()
  }

  pub fn name(&self) -> &str {
    self.name.base_name()
  }

  /// Full name of the node namespace + name eg. /some_node
  pub fn fully_qualified_name(&self) -> String {
    self.name.fully_qualified_name()
  }

  /// The node's writers. (radar_ros patch 3: to check what `ros_discovery_info` says.)
  pub fn writers(&self) -> &[Gid] {
    &self.writer_gid_seq
  }

  /// The node's readers. (radar_ros patch 3.)
  pub fn readers(&self) -> &[Gid] {
    &self.reader_gid_seq
  }

  /// A node's info with these readers and writers, each once, in the order given. (radar_ros patch 7: in time
  /// linear in their number; `add_reader`/`add_writer` look through the list each time.)
  pub fn with_entities(
    name: NodeName,
    readers: impl IntoIterator<Item = Gid>,
    writers: impl IntoIterator<Item = Gid>,
  ) -> NodeEntitiesInfo {
    ENTRIES_MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let once = |gids: &mut dyn Iterator<Item = Gid>| {
      let mut seen = std::collections::HashSet::new();
      gids.filter(|g| seen.insert(*g)).collect::<Vec<_>>()
    };
    NodeEntitiesInfo {
      name,
      reader_gid_seq: once(&mut readers.into_iter()),
      writer_gid_seq: once(&mut writers.into_iter()),
    }
  }

  pub fn add_writer(&mut self, gid: Gid) {
    if !self.writer_gid_seq.contains(&gid) {
      self.writer_gid_seq.push(gid);
    }
  }

  pub fn add_reader(&mut self, gid: Gid) {
    if !self.reader_gid_seq.contains(&gid) {
      self.reader_gid_seq.push(gid);
    }
  }
}

static ENTRIES_MADE: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// How many node entries [`NodeEntitiesInfo::with_entities`] has made in this process, for tests of how often
/// a node's entry is made (radar_ros patch 8).
#[doc(hidden)]
pub fn entries_made() -> u64 {
  ENTRIES_MADE.load(std::sync::atomic::Ordering::Relaxed)
}

/// A node's readers and writers as they are now, shared by the node (which adds to them) and its context
/// (which makes the node's `ros_discovery_info` entry from them when it sends). (radar_ros patch 8: the entry
/// was made again, in O(N), at every endpoint the node created, O(N^2) for a node of N endpoints, though it is
/// sent at most once per 50 ms since patch 3.)
#[derive(Debug)]
pub(crate) struct NodeEntities {
  name: NodeName,
  readers: std::collections::BTreeSet<Gid>,
  writers: std::collections::BTreeSet<Gid>,
  /// Writers listed before `writers`, in this order (parameter events, rosout), as the node has always
  /// listed them.
  first_writers: Vec<Gid>,
  /// The entry as last made, until a change: a participant's list is sent whole, and most of its nodes
  /// (a RADAR component is a node) have not changed since the last time.
  made: Option<(Gid, NodeEntitiesInfo)>,
}

impl NodeEntities {
  pub(crate) fn new(name: NodeName) -> NodeEntities {
    NodeEntities {
      name,
      readers: Default::default(),
      writers: Default::default(),
      first_writers: Vec::new(),
      made: None,
    }
  }

  pub(crate) fn fully_qualified_name(&self) -> String {
    self.name.fully_qualified_name()
  }

  /// Adds a writer listed before the others (parameter events, then rosout).
  pub(crate) fn add_first_writer(&mut self, gid: Gid) {
    self.first_writers.push(gid);
    self.made = None;
  }

  /// Adds (`true`) or takes off (`false`) a reader or writer; whether that changed the list.
  pub(crate) fn set(&mut self, gid: Gid, writer: bool, listed: bool) -> bool {
    let set = if writer {
      &mut self.writers
    } else {
      &mut self.readers
    };
    let changed = if listed {
      set.insert(gid)
    } else {
      set.remove(&gid)
    };
    if changed {
      self.made = None;
    }
    changed
  }

  /// The node's entry, with `extra_writer` (the context's `ros_discovery_info` writer, which every node
  /// lists) last unless already listed.
  pub(crate) fn info(&mut self, extra_writer: Gid) -> NodeEntitiesInfo {
    match &self.made {
      Some((extra, made)) if *extra == extra_writer => made.clone(),
      _ => {
        let made = NodeEntitiesInfo::with_entities(
          self.name.clone(),
          self.readers.iter().copied(),
          self
            .first_writers
            .iter()
            .chain(self.writers.iter())
            .copied()
            .chain(std::iter::once(extra_writer)),
        );
        self.made = Some((extra_writer, made.clone()));
        made
      }
    }
  }
}

impl TryFrom<repr::NodeEntitiesInfo> for NodeEntitiesInfo {
  type Error = NameError;

  fn try_from(r: repr::NodeEntitiesInfo) -> Result<NodeEntitiesInfo, NameError> {
    let name = NodeName::new(&r.node_namespace, &r.node_name).inspect_err(|_e| {
      error!(
        "Offending node name:  namespace={:?} name={:?}",
        r.node_namespace, r.node_name
      )
    })?;
    Ok(NodeEntitiesInfo {
      name,
      reader_gid_seq: r.reader_gid_seq,
      writer_gid_seq: r.writer_gid_seq,
    })
  }
}

impl From<NodeEntitiesInfo> for repr::NodeEntitiesInfo {
  fn from(n: NodeEntitiesInfo) -> repr::NodeEntitiesInfo {
    repr::NodeEntitiesInfo {
      node_namespace: n.name.namespace().to_owned(),
      node_name: n.name.base_name().to_owned(),
      reader_gid_seq: n.reader_gid_seq,
      writer_gid_seq: n.writer_gid_seq,
    }
  }
}

pub(crate) mod repr {
  use serde::{Deserialize, Serialize};

  use crate::gid::Gid;

  #[derive(Clone, Serialize, Deserialize)]
  pub(crate) struct NodeEntitiesInfo {
    // Field names are from .msg definition
    pub node_namespace: String, // original .msg specifies .len() <= 256
    pub node_name: String,      // original .msg specifies .len() <= 256
    pub reader_gid_seq: Vec<Gid>,
    pub writer_gid_seq: Vec<Gid>,
  }
}
