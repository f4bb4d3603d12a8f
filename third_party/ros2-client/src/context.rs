use std::{
  collections::HashMap,
  sync::{Arc, Mutex},
};
//use futures::{pin_mut, StreamExt};
#[cfg(feature = "security")]
use std::path::{Path, PathBuf};

#[allow(unused_imports)]
use log::{debug, error, info, trace, warn};
//use rustdds::mio::Evented;
use serde::Serialize;
use rustdds::{
  no_key::{DeserializerAdapter, SerializerAdapter},
  *,
};

use crate::{
  NodeOptions, builtin_topics,
  entities_info::{NodeEntities, ParticipantEntitiesInfo},
  error::CreateResult,
  gid::Gid,
  graph::DiscoveredTopic,
  names::*,
  node::{Node, NodeCreateError},
  pubsub::{Publisher, Subscription},
  qos::QosProfile,
};

/// Basic BestEffort QoS for subscribers (same as
/// [`QosProfile::subscription_default`]).
///
/// Note: If you want Reliable communication, both Publisher and Subscription
/// must specify [`Reliability::Reliable`](crate::qos::Reliability::Reliable)
/// (including `when_full`).
pub const DEFAULT_SUBSCRIPTION_QOS: QosProfile = QosProfile::subscription_default();

/// Basic Reliable QoS for publishing (same as
/// [`QosProfile::publisher_default`]).
pub const DEFAULT_PUBLISHER_QOS: QosProfile = QosProfile::publisher_default();

#[cfg(feature = "security")]
struct SecurityConfig {
  /// Path to a directory of configuration files.
  security_config_dir: PathBuf,
  /// Password used for decryption the private key file.
  private_key_password: String,
}

/// Builder for configuring a `Context`
pub struct ContextOptions {
  domain_id: u16,
  #[cfg(feature = "security")]
  security_config: Option<SecurityConfig>,
}

impl ContextOptions {
  pub fn new() -> Self {
    Self {
      domain_id: 0,
      #[cfg(feature = "security")]
      security_config: None,
    }
  }

  /// Set the DDS Domain Id.
  ///
  /// Please refer to the
  /// [ROS_DOMAIN_ID](https://docs.ros.org/en/iron/Concepts/Intermediate/About-Domain-ID.html)
  /// or DDS documentation.
  pub fn domain_id(mut self, domain_id: u16) -> Self {
    self.domain_id = domain_id;
    self
  }

  /// Enable DDS security features.
  ///
  /// Using security requires providing appropriate configuration files.
  ///
  /// [Security in RustDDS](https://github.com/jhelovuo/RustDDS/blob/master/SECURITY.md)
  #[cfg(feature = "security")]
  pub fn enable_security(
    mut self,
    security_config_dir: impl AsRef<Path>,
    private_key_password: String,
  ) -> Self {
    self.security_config = Some(SecurityConfig {
      security_config_dir: security_config_dir.as_ref().to_path_buf(),
      private_key_password,
    });
    self
  }
}

impl Default for ContextOptions {
  fn default() -> Self {
    Self::new()
  }
}

/// [Context] communicates with other
/// participants information in ROS2 network. It keeps track of
/// [`NodeEntitiesInfo`](crate::entities_info::NodeEntitiesInfo)s. Also acts as a wrapper for a RustDDS instance.
///
/// Context is shut down by dropping it, and all of its RosNodes.
/// There should be no need for `ok()` or `shutdown()` methods.
#[derive(Clone)]
pub struct Context {
  // radar_ros patch 6: declared first, so that the last handle stops and joins the `ros_discovery_info`
  // thread before it lets go of `inner` (which then drops here, in the application's thread)
  _broadcast_thread: Arc<BroadcastThread>,
  inner: Arc<Mutex<ContextInner>>,
}

impl Context {
  /// Create a new Context with default settings.
  pub fn new() -> CreateResult<Context> {
    Self::from_domain_participant(DomainParticipant::new(0)?)
  }

  /// Create a new Context.
  pub fn with_options(opt: ContextOptions) -> CreateResult<Context> {
    #[cfg_attr(not(feature = "security"), allow(unused_mut))]
    let mut dpb = DomainParticipantBuilder::new(opt.domain_id);

    #[cfg(feature = "security")]
    {
      if let Some(sc) = opt.security_config {
        dpb = dpb.builtin_security(
          DomainParticipantSecurityConfigFiles::with_ros_default_names(
            sc.security_config_dir,
            sc.private_key_password,
          ),
        );
      }
    }

    Self::from_domain_participant(dpb.build()?)
  }

  /// Create a new Context from an existing [`DomainParticipant`].
  pub fn from_domain_participant(domain_participant: DomainParticipant) -> CreateResult<Context> {
    // Check the runtime ROS_DISTRO against the distribution we were compiled
    // for. Guarded so it logs only once per process even with many Contexts.
    static ROS_DISTRO_CHECK: std::sync::Once = std::sync::Once::new();
    ROS_DISTRO_CHECK.call_once(crate::distributions::verify_ros_distro_env);

    let i = ContextInner::from_domain_participant(domain_participant)?;
    let inner = Arc::new(Mutex::new(i));
    // radar_ros patch 3: `ros_discovery_info` is sent from a thread of its own, coalesced
    let broadcaster = inner.lock().unwrap().broadcaster.clone();
    let weak = Arc::downgrade(&inner);
    let thread_broadcaster = broadcaster.clone();
    let handle = std::thread::Builder::new()
      .name("ros2-discovery-info".into())
      .spawn(move || thread_broadcaster.run(weak))
      .map_err(crate::error::CreateError::Io)?;
    Ok(Context {
      _broadcast_thread: Arc::new(BroadcastThread {
        broadcaster,
        handle: Mutex::new(Some(handle)),
      }),
      inner,
    })
  }

  /// Create a new ROS2 [`Node`]
  pub fn new_node(
    &self,
    node_name: NodeName,
    options: NodeOptions,
  ) -> Result<Node, NodeCreateError> {
    Node::new(node_name, options, self.clone())
  }

  /// Query which DDS Domain Id we are using.
  pub fn domain_id(&self) -> u16 {
    self.inner.lock().unwrap().domain_participant.domain_id()
  }

  /// Which topics have been discovered? Owned, backend-neutral view (ADR-0010).
  /// For the raw RustDDS data, see [`Self::discovered_topics_raw`].
  pub fn discovered_topics(&self) -> Vec<DiscoveredTopic> {
    self
      .discovered_topics_raw()
      .iter()
      .map(|t| DiscoveredTopic {
        name: t.topic_name().clone(),
        type_name: t.type_name().clone(),
      })
      .collect()
  }

  /// Which topics have been discovered? Raw RustDDS escape hatch (ADR-0010 §5);
  /// prefer [`Self::discovered_topics`] on the stable public surface.
  pub fn discovered_topics_raw(&self) -> Vec<rustdds::discovery::DiscoveredTopicData> {
    self.domain_participant().discovered_topics()
  }

  /// Gets the ParticipantEntitiesInfo describing the current state of
  /// this Context. This is what we send to ROS Discovery.
  pub fn participant_entities_info(&self) -> ParticipantEntitiesInfo {
    self.inner.lock().unwrap().participant_entities_info()
  }

  /// Get a (handle to) the ROSOut logging Topic.
  pub fn get_parameter_events_topic(&self) -> Topic {
    self
      .inner
      .lock()
      .unwrap()
      .ros_parameter_events_topic
      .clone()
  }

  /// Get a (handle to) the ROSOut logging Topic.
  ///
  /// Note: The recommended way to write log messages to ROSOut is via the
  /// [`crate::rosout!`] macro.
  pub fn get_rosout_topic(&self) -> Topic {
    self.inner.lock().unwrap().ros_rosout_topic.clone()
  }

  /// Get the contained DDS [`DomainParticipant`].
  ///
  /// The return value is owned, but it is just a cloned smart pointer.
  pub fn domain_participant(&self) -> DomainParticipant {
    self.inner.lock().unwrap().domain_participant.clone()
  }

  // pub fn ros_discovery_stream(&self) -> impl Stream<Item =
  // ReadResult<(ParticipantEntitiesInfo, MessageInfo)>> + FusedStream + '_ {
  //   self.inner.lock().unwrap().node_reader.async_stream()
  // }

  // -----------------------------------------------------------------------

  pub fn create_topic(
    &self,
    topic_dds_name: String,
    type_name: MessageTypeName,
    qos: &QosProfile,
  ) -> CreateResult<Topic> {
    info!("Creating topic, DDS name: {topic_dds_name}");
    let dds_qos: QosPolicies = qos.into();
    let topic = self.domain_participant().create_topic(
      topic_dds_name,
      type_name.dds_msg_type(),
      &dds_qos,
      TopicKind::NoKey,
    )?;
    // ROS2 does not use WithKey topics, so always NoKey
    info!("Created topic");
    Ok(topic)
  }

  pub(crate) fn create_publisher<M>(
    &self,
    topic: &Topic,
    qos: Option<QosProfile>,
  ) -> CreateResult<Publisher<M>>
  where
    M: Serialize,
  {
    let dds_qos = qos.map(QosPolicies::from);
    let datawriter = self
      .get_ros_default_publisher()
      .create_datawriter_no_key(topic, dds_qos)?;

    Ok(Publisher::new(datawriter))
  }

  pub(crate) fn create_subscription<M>(
    &self,
    topic: &Topic,
    qos: Option<QosProfile>,
  ) -> CreateResult<Subscription<M>>
  where
    M: 'static,
  {
    let dds_qos = qos.map(QosPolicies::from);
    let datareader = self
      .get_ros_default_subscriber()
      .create_simple_datareader_no_key(topic, dds_qos)?;
    Ok(Subscription::new(datareader))
  }

  pub(crate) fn create_datawriter<M, SA>(
    &self,
    topic: &Topic,
    qos: Option<QosProfile>,
  ) -> CreateResult<no_key::DataWriter<M, SA>>
  where
    SA: SerializerAdapter<M>,
  {
    let dds_qos = qos.map(QosPolicies::from);
    Ok(
      self
        .get_ros_default_publisher()
        .create_datawriter_no_key(topic, dds_qos)?,
    )
  }

  pub(crate) fn create_simpledatareader<M, DA>(
    &self,
    topic: &Topic,
    qos: Option<QosProfile>,
  ) -> CreateResult<no_key::SimpleDataReader<M, DA>>
  where
    M: 'static,
    DA: 'static + DeserializerAdapter<M>,
  {
    let dds_qos = qos.map(QosPolicies::from);
    Ok(
      self
        .get_ros_default_subscriber()
        .create_simple_datareader_no_key(topic, dds_qos)?,
    )
  }

  /// The node's readers or writers changed: its entry is sent with the next `ros_discovery_info`, made from
  /// `entities` then (radar_ros patch 8).
  /// What a [`Listing`] asks for a broadcast with (radar_ros patch 9).
  pub(crate) fn broadcaster(&self) -> std::sync::Weak<Broadcaster> {
    Arc::downgrade(&self._broadcast_thread.broadcaster)
  }

  pub(crate) fn update_node(&mut self, entities: &Arc<Mutex<NodeEntities>>) {
    self.inner.lock().unwrap().update_node(entities);
  }

  pub(crate) fn remove_node(&mut self, node_name: &str) {
    self.inner.lock().unwrap().remove_node(node_name);
  }

  fn get_ros_default_publisher(&self) -> rustdds::Publisher {
    self.inner.lock().unwrap().ros_default_publisher.clone()
  }

  fn get_ros_default_subscriber(&self) -> rustdds::Subscriber {
    self.inner.lock().unwrap().ros_default_subscriber.clone()
  }

  pub(crate) fn ros_discovery_topic(&self) -> Topic {
    self.inner.lock().unwrap().ros_discovery_topic.clone()
  }
}

struct ContextInner {
  local_nodes: HashMap<String, Arc<Mutex<NodeEntities>>>,

  // ROS Discovery: topic, reader and writer
  ros_discovery_topic: Topic,
  node_writer: Publisher<ParticipantEntitiesInfo>,
  // Corresponding ParticipantEntitiesInfo Subscriber is
  // (optionally) in Node --> Spinner, if it is
  // activated. Context does not have its own thread of control, so
  // it cannot do reading.
  domain_participant: DomainParticipant,
  // DDS Requires Publisher and Subscriber to create (and group)
  // DataWriters and DataReaders, so we create one of each.
  ros_default_publisher: rustdds::Publisher,
  ros_default_subscriber: rustdds::Subscriber,

  ros_parameter_events_topic: Topic,
  ros_rosout_topic: Topic,

  // radar_ros patch 3: coalesces `ros_discovery_info` updates
  broadcaster: Arc<Broadcaster>,
}

/// How soon after a broadcast of `ros_discovery_info` the next one may follow. Changes made meanwhile (a node
/// that creates its endpoints, a program that spawns a thousand components) go out together in the next one.
/// (radar_ros patch 3.)
const DISCOVERY_INFO_INTERVAL: std::time::Duration = std::time::Duration::from_millis(50);

/// Sends the participant's `ros_discovery_info` when it changed, at most once per
/// [`DISCOVERY_INFO_INTERVAL`]: the first change after a quiet spell at once, the rest together at the end of
/// the interval. Every endpoint a node creates used to send the whole participant's entity list, so creating
/// N endpoints cost O(N^2). (radar_ros patch 3.)
pub(crate) struct Broadcaster {
  state: Mutex<BroadcastState>,
  wake: std::sync::Condvar,
}

/// The `ros_discovery_info` thread as the context's handles see it: the last handle to go stops it and waits
/// for it. The thread holds the context only while it broadcasts; if the application let go of its last handle
/// then, the context (and its DDS participant, whose drop says goodbye to the graph) would be dropped in that
/// thread, and a process ending right after would leave without the goodbye: its peers would see it go only
/// when its lease ran out. (radar_ros patch 6.)
struct BroadcastThread {
  broadcaster: Arc<Broadcaster>,
  handle: Mutex<Option<std::thread::JoinHandle<()>>>,
}

impl Drop for BroadcastThread {
  fn drop(&mut self) {
    self.broadcaster.stop();
    let handle = self.handle.get_mut().map(Option::take).unwrap_or(None);
    if let Some(handle) = handle {
      if handle.thread().id() != std::thread::current().id() {
        let _ = handle.join();
      }
    }
  }
}

#[derive(Default)]
struct BroadcastState {
  pending: bool,
  last: Option<std::time::Instant>,
  stop: bool,
}

/// A reader or writer listed in its node's `ros_discovery_info` entry, for as long as the endpoint lives: its
/// drop takes it off the list and has the list sent again. (radar_ros patch 9: endpoints were never taken off,
/// so a node that makes and drops endpoints, as a RADAR manager does with each scope's connections, announced
/// a list that only grew, every GID it ever had, sent whole at every change.) Holds neither the node nor the
/// context alive.
pub(crate) struct Listing {
  pub(crate) entities: std::sync::Weak<Mutex<NodeEntities>>,
  pub(crate) broadcaster: std::sync::Weak<Broadcaster>,
  pub(crate) gid: Gid,
  pub(crate) writer: bool,
}

impl Drop for Listing {
  fn drop(&mut self) {
    let Some(entities) = self.entities.upgrade() else {
      return;
    };
    let removed = entities.lock().unwrap().set(self.gid, self.writer, false);
    if removed {
      if let Some(b) = self.broadcaster.upgrade() {
        b.request();
      }
    }
  }
}

impl Broadcaster {
  fn request(&self) {
    let mut st = self.state.lock().unwrap();
    st.pending = true;
    self.wake.notify_one();
  }

  fn stop(&self) {
    self.state.lock().unwrap().stop = true;
    self.wake.notify_one();
  }

  fn run(&self, inner: std::sync::Weak<Mutex<ContextInner>>) {
    let mut st = self.state.lock().unwrap();
    loop {
      while !st.pending && !st.stop {
        st = self.wake.wait(st).unwrap();
      }
      if st.stop {
        return;
      }
      // at most one broadcast per interval: what changes meanwhile goes out with it
      if let Some(due) = st.last.map(|t| t + DISCOVERY_INFO_INTERVAL) {
        while !st.stop {
          let now = std::time::Instant::now();
          if now >= due {
            break;
          }
          st = self.wake.wait_timeout(st, due - now).unwrap().0;
        }
        if st.stop {
          return;
        }
      }
      st.pending = false;
      st.last = Some(std::time::Instant::now());
      drop(st);
      match inner.upgrade() {
        Some(inner) => {
          inner.lock().unwrap().broadcast_node_infos();
          hold_for_tests();
        }
        None => return,
      }
      st = self.state.lock().unwrap();
    }
  }
}

/// A test hook (radar_ros patch 6): `RADAR_TEST_HOLD_BROADCAST_MS=n` makes the `ros_discovery_info` thread keep
/// the context n ms after each broadcast, so that a test can drop the application's last handle in that window
/// every time. Read once; off (no wait) unless set.
fn hold_for_tests() {
  static HOLD: std::sync::OnceLock<Option<std::time::Duration>> = std::sync::OnceLock::new();
  let hold = HOLD.get_or_init(|| {
    std::env::var("RADAR_TEST_HOLD_BROADCAST_MS")
      .ok()
      .and_then(|v| v.parse().ok())
      .map(std::time::Duration::from_millis)
  });
  if let Some(d) = hold {
    std::thread::sleep(*d);
  }
}

impl ContextInner {
  // "new"
  pub fn from_domain_participant(
    domain_participant: DomainParticipant,
  ) -> CreateResult<ContextInner> {
    let ros_default_publisher =
      domain_participant.create_publisher(&QosPolicies::from(DEFAULT_PUBLISHER_QOS))?;
    let ros_default_subscriber =
      domain_participant.create_subscriber(&QosPolicies::from(DEFAULT_SUBSCRIPTION_QOS))?;

    // This is for tracking (ROS) Node to (DDS) Participant mapping
    let ros_discovery_topic = domain_participant.create_topic(
      builtin_topics::ros_discovery::TOPIC_NAME.to_string(),
      builtin_topics::ros_discovery::TYPE_NAME.to_string(),
      &builtin_topics::ros_discovery::QOS_PUB,
      TopicKind::NoKey,
    )?;

    let ros_parameter_events_topic = domain_participant.create_topic(
      builtin_topics::parameter_events::TOPIC_NAME.to_string(),
      builtin_topics::parameter_events::TYPE_NAME.to_string(),
      &builtin_topics::parameter_events::QOS,
      TopicKind::NoKey,
    )?;

    let ros_rosout_topic = domain_participant.create_topic(
      builtin_topics::rosout::TOPIC_NAME.to_string(),
      builtin_topics::rosout::TYPE_NAME.to_string(),
      &builtin_topics::rosout::QOS,
      TopicKind::NoKey,
    )?;

    let node_writer =
      Publisher::new(ros_default_publisher.create_datawriter_no_key(&ros_discovery_topic, None)?);

    Ok(ContextInner {
      local_nodes: HashMap::new(),
      node_writer,
      broadcaster: Arc::new(Broadcaster {
        state: Mutex::new(BroadcastState::default()),
        wake: std::sync::Condvar::new(),
      }),

      domain_participant,
      ros_discovery_topic,
      ros_default_publisher,
      ros_default_subscriber,
      ros_parameter_events_topic,
      ros_rosout_topic,
    })
  }

  /// Gets our current participant info we have sent to ROS2 network
  pub fn participant_entities_info(&self) -> ParticipantEntitiesInfo {
    ParticipantEntitiesInfo::new(
      Gid::from(self.domain_participant.guid()),
      self
        .local_nodes
        .values()
        .map(|node| {
          node
            .lock()
            .unwrap()
            .info(Gid::from(self.node_writer.guid()))
        })
        .collect(),
    )
  }

  // Adds new NodeEntitiesInfo and updates our ContextInfo to ROS2 network
  // (Each node lists the ROS discovery topic's writer too: added when the entry is made.)
  fn update_node(&mut self, entities: &Arc<Mutex<NodeEntities>>) {
    let fqn = entities.lock().unwrap().fully_qualified_name();
    match self.local_nodes.get(&fqn) {
      Some(known) if Arc::ptr_eq(known, entities) => {}
      _ => {
        self.local_nodes.insert(fqn, Arc::clone(entities));
      }
    }
    self.broadcaster.request();
  }

  /// Removes NodeEntitiesInfo and updates our ContextInfo to ROS2 network
  fn remove_node(&mut self, node_fqn: &str) {
    self.local_nodes.remove(node_fqn);
    self.broadcaster.request();
  }

  fn broadcast_node_infos(&self) {
    let pei = self.participant_entities_info();
    debug!("ROS discovery publish: {pei:?}");
    self
      .node_writer
      .publish(pei)
      .unwrap_or_else(|e| error!("Failed to write into node_writer {e:?}"));
  }
} // impl ContextInner

impl Drop for ContextInner {
  fn drop(&mut self) {
    // Clears all nodes and updates our ContextInfo to ROS2 network
    self.broadcaster.stop();
    self.local_nodes.clear();
    self.broadcast_node_infos();
  }
}

// -------------------------------------------------------------------------------------
// -------------------------------------------------------------------------------------

#[test]
fn test_node_create() {
  use crate::ParameterValue;

  let context = Context::new().unwrap();
  let _node = context
    .new_node(
      NodeName::new("/rustdds", "test_node").unwrap(),
      NodeOptions::new().declare_parameter("foo", ParameterValue::Boolean(true)),
    )
    .is_ok();
}
