//! Zenoh `Publisher` and `Subscription`.
//!
//! A publisher `put`s a CDR payload (see [`super::cdr`]) with an
//! [`AttachmentData`] carrying `(sequence, source_timestamp, source_gid)` — the
//! `rmw_zenoh` message shape. A subscription declares a Zenoh subscriber on its
//! type's hash when it is known (as rmw_zenoh's), else with a wildcard
//! type-hash (liberal receive, ADR-0007), and yields decoded messages plus
//! their [`MessageInfo`].
//!
//! TRANSIENT_LOCAL durability is carried as rmw_zenoh carries it (since its
//! 0.2.2, "Introduce the advanced publisher and subscriber", ros2/rmw_zenoh#469):
//! such a publisher is a zenoh-ext `AdvancedPublisher` with a cache of the QoS
//! depth and publisher detection, such a subscription an `AdvancedSubscriber`
//! with subscriber detection and a history query (late publishers detected)
//! of the same depth, so a late subscriber gets the publisher's last samples.
//! Volatile endpoints stay plain Zenoh ones.

use std::{
  future::Future,
  marker::PhantomData,
  sync::atomic::{AtomicI64, Ordering},
  time::{SystemTime, UNIX_EPOCH},
};

use futures::stream::{self, FusedStream, StreamExt};
use serde::{Serialize, de::DeserializeOwned};
use zenoh::{
  Wait,
  liveliness::LivelinessToken,
  pubsub::{Publisher as ZenohPublisher, Subscriber},
  sample::Sample,
};
use zenoh_ext::{AdvancedPublisher, AdvancedSubscriber};

use super::{attachment::AttachmentData, cdr, graph_cache::MatchInfo, node::Node};
use crate::{
  error::{ReadError, ReadResult, WriteResult, write_middleware, write_serialization},
  gid::Gid,
  message_info::MessageInfo,
  request_id::RmwRequestId,
  ros_time::ROSTime,
};

fn now_nanos() -> i64 {
  SystemTime::now()
    .duration_since(UNIX_EPOCH)
    .map(|d| d.as_nanos() as i64)
    .unwrap_or(0)
}

/// What a [`Publisher`] puts through: a plain Zenoh publisher (volatile), or
/// an advanced one whose cache late subscribers query (transient local).
pub(crate) enum Sender {
  Plain(ZenohPublisher<'static>),
  Cached(AdvancedPublisher<'static>),
}

impl From<ZenohPublisher<'static>> for Sender {
  fn from(p: ZenohPublisher<'static>) -> Sender {
    Sender::Plain(p)
  }
}

/// What a [`Subscription`] takes from: a plain Zenoh subscriber (volatile), or
/// an advanced one that first asks matching publishers' caches (transient local).
/// Both deliver into a [`QuietFifo`](super::quiet_fifo::QuietFifo) (patch 22): samples that come after the
/// subscription is dropped are dropped without an error line.
pub(crate) enum Receiver {
  Plain(Subscriber<Samples>),
  History(AdvancedSubscriber<Samples>),
}

/// The channel a subscription reads its samples from.
pub(crate) type Samples = async_channel::Receiver<Sample>;

impl From<Subscriber<Samples>> for Receiver {
  fn from(s: Subscriber<Samples>) -> Receiver {
    Receiver::Plain(s)
  }
}

impl Receiver {
  fn samples(&self) -> &Samples {
    match self {
      Receiver::Plain(s) => s,
      Receiver::History(s) => s,
    }
  }
}

/// A ROS 2 publisher over Zenoh.
pub struct Publisher<M> {
  zenoh_publisher: Sender,
  seq: AtomicI64,
  source_gid: [u8; 16],
  // Kept alive so the entity stays discoverable; dropped => token undeclared.
  _liveliness_token: Option<LivelinessToken>,
  // What its token says of it (topic, type, hash, QoS), for the `Node`-scoped
  // count/wait helpers below (mirrors the DDS backend, which looks these up
  // via GUID on the owning `Node` instead).
  endpoint: MatchInfo,
  phantom: PhantomData<fn() -> M>,
}

impl<M: Serialize> Publisher<M> {
  pub(crate) fn new(
    zenoh_publisher: impl Into<Sender>,
    source_gid: [u8; 16],
    liveliness_token: Option<LivelinessToken>,
    endpoint: MatchInfo,
  ) -> Self {
    Self {
      zenoh_publisher: zenoh_publisher.into(),
      seq: AtomicI64::new(0),
      source_gid,
      _liveliness_token: liveliness_token,
      endpoint,
      phantom: PhantomData,
    }
  }

  fn encode(
    &self,
    msg: &M,
    source_timestamp: i64,
    related: Option<RmwRequestId>,
  ) -> Result<(Vec<u8>, zenoh::bytes::ZBytes), cdr::CdrError> {
    let payload = cdr::to_cdr(msg)?;
    let sequence_number = self.seq.fetch_add(1, Ordering::Relaxed) + 1; // start
    // at 1
    let attachment = AttachmentData {
      sequence_number,
      source_timestamp,
      source_gid: self.source_gid,
    }
    .to_zbytes_related(related);
    Ok((payload, attachment))
  }

  /// Publish a message (async).
  pub async fn async_publish(&self, msg: M) -> WriteResult<(), M> {
    let (payload, attachment) = match self.encode(&msg, now_nanos(), None) {
      Ok(encoded) => encoded,
      Err(e) => return Err(write_serialization(e.to_string(), msg)),
    };
    let sent = match &self.zenoh_publisher {
      Sender::Plain(p) => p.put(payload).attachment(attachment).await,
      Sender::Cached(p) => p.put(payload).attachment(attachment).await,
    };
    sent.map_err(|e| write_middleware(e.to_string(), msg))
  }

  /// Publish a message (blocking).
  pub fn publish(&self, msg: M) -> WriteResult<(), M> {
    self.publish_stamped(msg, ROSTime::from_nanos(now_nanos()))
  }

  /// Publish a message (blocking) whose attachment carries `source_timestamp`
  /// as its source time, not the time of this call: what a relay that
  /// forwards a sample needs, as the DDS backend's `publish_with_options`
  /// with a source timestamp. Subscribers read it as
  /// `MessageInfo::source_timestamp`.
  pub fn publish_stamped(&self, msg: M, source_timestamp: ROSTime) -> WriteResult<(), M> {
    self.publish_related(msg, source_timestamp, None)
  }

  /// Publish a message (blocking) as [`Self::publish_stamped`] does, and, when `related` is given, with
  /// that related sample identity after the attachment's three fields (radar_ros patch 19; rmw_zenoh's
  /// readers do not look past the three): what the DDS backend's `related_sample_identity` write option
  /// carries. Subscribers of this crate read it as `MessageInfo::related_request_id`.
  pub fn publish_related(
    &self,
    msg: M,
    source_timestamp: ROSTime,
    related: Option<RmwRequestId>,
  ) -> WriteResult<(), M> {
    let (payload, attachment) = match self.encode(&msg, source_timestamp.to_nanos(), related) {
      Ok(encoded) => encoded,
      Err(e) => return Err(write_serialization(e.to_string(), msg)),
    };
    let sent = match &self.zenoh_publisher {
      Sender::Plain(p) => p.put(payload).attachment(attachment).wait(),
      Sender::Cached(p) => p.put(payload).attachment(attachment).wait(),
    };
    sent.map_err(|e| write_middleware(e.to_string(), msg))
  }

  /// This publisher's source [`Gid`].
  pub fn gid(&self) -> Gid {
    Gid::from(self.source_gid)
  }

  /// Returns the count of currently discovered subscriptions on this
  /// publisher's topic.
  ///
  /// `node` must be the [`Node`] that created this Publisher (or at least
  /// share its [`Context`](crate::Context)), or the result is undefined.
  pub fn get_subscription_count(&self, node: &Node) -> usize {
    node.subscription_count(&self.endpoint.topic)
  }

  /// The number of subscriptions that match this publisher now, as rmw_zenoh's
  /// `rmw_publisher_count_matched_subscriptions` counts them (same topic,
  /// type and hash, compatible QoS; see [`GraphCache::matched`]), from the
  /// liveliness tokens `node`'s context has seen. The context's
  /// [`graph_event_stream`](crate::zenoh::Context::graph_event_stream) says
  /// when it may have changed.
  ///
  /// [`GraphCache::matched`]: super::graph_cache::GraphCache::matched
  pub fn matched_subscription_count(&self, node: &Node) -> usize {
    node.matched(&self.endpoint)
  }

  /// [`Publisher::matched_subscription_count`] now and as it changes: the
  /// receiver gets the count at once, then each new one (recounted when a
  /// token of this topic comes or goes, no polling). Drop it to stop.
  pub fn watch_matched(&self, node: &Node) -> async_channel::Receiver<usize> {
    node.watch_matched(self.endpoint.clone())
  }

  /// What this publisher's liveliness token says of it.
  pub fn endpoint(&self) -> &MatchInfo {
    &self.endpoint
  }

  /// Waits until there is at least one matched subscription on this topic,
  /// possibly forever.
  ///
  /// `node` must be the [`Node`] that created this Publisher (or at least
  /// share its [`Context`](crate::Context)), or the length of the wait is
  /// undefined.
  pub fn wait_for_subscription<'a>(&'a self, node: &'a Node) -> impl Future<Output = ()> + 'a {
    node.wait_for_subscription(&self.endpoint.topic)
  }
}

/// A ROS 2 subscription over Zenoh.
pub struct Subscription<M> {
  zenoh_subscriber: Receiver,
  // Kept alive so the entity stays discoverable; dropped => token undeclared.
  _liveliness_token: Option<LivelinessToken>,
  // See `Publisher::endpoint`.
  endpoint: MatchInfo,
  phantom: PhantomData<fn() -> M>,
}

impl<M: DeserializeOwned> Subscription<M> {
  pub(crate) fn new(
    zenoh_subscriber: impl Into<Receiver>,
    liveliness_token: Option<LivelinessToken>,
    endpoint: MatchInfo,
  ) -> Self {
    Self {
      zenoh_subscriber: zenoh_subscriber.into(),
      _liveliness_token: liveliness_token,
      endpoint,
      phantom: PhantomData,
    }
  }

  fn decode(sample: &Sample) -> ReadResult<(M, MessageInfo)> {
    let payload = sample.payload().to_bytes();
    let msg = cdr::from_cdr::<M>(&payload)?;
    let info = match sample.attachment() {
      Some(zbytes) => {
        let a = AttachmentData::from_zbytes(zbytes).map_err(|_| ReadError::Malformed)?;
        MessageInfo::new(
          None,
          Some(ROSTime::from_nanos(a.source_timestamp)),
          a.sequence_number,
          Gid::from(a.source_gid),
          AttachmentData::related_from_zbytes(zbytes),
        )
      }
      None => MessageInfo::new(None, None, 0, Gid::default(), None),
    };
    Ok((msg, info))
  }

  /// Await the next message and its metadata.
  pub async fn async_take(&self) -> ReadResult<(M, MessageInfo)> {
    let sample = self
      .zenoh_subscriber
      .samples()
      .recv()
      .await
      .map_err(|_| ReadError::Closed)?;
    Self::decode(&sample)
  }

  /// Take a message if one is immediately available (non-blocking).
  pub fn try_take(&self) -> ReadResult<Option<(M, MessageInfo)>> {
    match self.zenoh_subscriber.samples().try_recv() {
      Ok(sample) => Self::decode(&sample).map(Some),
      Err(async_channel::TryRecvError::Empty) => Ok(None),
      Err(async_channel::TryRecvError::Closed) => Err(ReadError::Closed),
    }
  }

  /// An async `Stream` of messages with `MessageInfo` metadata (mirrors the
  /// DDS backend's `Subscription::async_stream`), built by repeatedly calling
  /// [`Self::async_take`]. The stream never ends on its own.
  pub fn async_stream(&self) -> impl FusedStream<Item = ReadResult<(M, MessageInfo)>> + '_ {
    stream::unfold(self, |sub| async move {
      let item = sub.async_take().await;
      Some((item, sub))
    })
    .fuse()
  }

  /// Returns the count of currently discovered publishers on this
  /// subscription's topic.
  ///
  /// `node` must be the [`Node`] that created this Subscription (or at least
  /// share its [`Context`](crate::Context)), or the result is undefined.
  pub fn get_publisher_count(&self, node: &Node) -> usize {
    node.publisher_count(&self.endpoint.topic)
  }

  /// The number of publishers that match this subscription now, as rmw_zenoh's
  /// `rmw_subscription_count_matched_publishers` counts them (see
  /// [`Publisher::matched_subscription_count`]).
  pub fn matched_publisher_count(&self, node: &Node) -> usize {
    node.matched(&self.endpoint)
  }

  /// [`Subscription::matched_publisher_count`] now and as it changes (see
  /// [`Publisher::watch_matched`]).
  pub fn watch_matched(&self, node: &Node) -> async_channel::Receiver<usize> {
    node.watch_matched(self.endpoint.clone())
  }

  /// What this subscription's liveliness token says of it.
  pub fn endpoint(&self) -> &MatchInfo {
    &self.endpoint
  }

  /// Waits until there is at least one matched publisher on this topic,
  /// possibly forever.
  ///
  /// `node` must be the [`Node`] that created this Subscription (or at least
  /// share its [`Context`](crate::Context)), or the length of the wait is
  /// undefined.
  pub fn wait_for_publisher<'a>(&'a self, node: &'a Node) -> impl Future<Output = ()> + 'a {
    node.wait_for_publisher(&self.endpoint.topic)
  }
}

// ---------------------------------------------------------------------------

#[cfg(test)]
mod tests {
  use std::time::{Duration, Instant};

  use zenoh::Config;

  use super::{Publisher, Subscription};
  use crate::{
    Gid, MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
    zenoh_backend::{
      context::{Context, ContextOptions},
      node::Node,
    },
  };

  // Build a peer config on IPv4 loopback with multicast off. `listen`/`connect`
  // pin explicit ports so two in-process peers connect directly — no router
  // (matches Tier B in docs/zenoh_study/test_plan.md).
  fn make_config(listen_port: u16, connect_port: Option<u16>) -> Config {
    let mut c = Config::default();
    c.insert_json5("mode", "\"peer\"").unwrap();
    c.insert_json5("scouting/multicast/enabled", "false")
      .unwrap();
    // an advanced (transient-local) publisher needs timestamps, as in rmw_zenoh's session
    c.insert_json5("timestamping/enabled", "true").unwrap();
    c.insert_json5(
      "listen/endpoints",
      &format!("[\"tcp/127.0.0.1:{listen_port}\"]"),
    )
    .unwrap();
    if let Some(p) = connect_port {
      c.insert_json5("connect/endpoints", &format!("[\"tcp/127.0.0.1:{p}\"]"))
        .unwrap();
    }
    c
  }

  #[test]
  fn pub_sub_roundtrip_in_process() {
    // Distinct fixed ports (CI runs zenoh tests with --test-threads=1).
    let sub_port = 17513;
    let pub_port = 17514;

    let sub_ctx =
      Context::with_options(ContextOptions::new().zenoh_config(make_config(sub_port, None)))
        .expect("open subscriber context");
    let pub_ctx = Context::with_options(
      ContextOptions::new().zenoh_config(make_config(pub_port, Some(sub_port))),
    )
    .expect("open publisher context");

    let sub_node = sub_ctx
      .new_node(NodeName::new("/", "test_sub").unwrap(), NodeOptions::new())
      .unwrap();
    let pub_node = pub_ctx
      .new_node(NodeName::new("/", "test_pub").unwrap(), NodeOptions::new())
      .unwrap();

    let make_topic = |n: &Node| {
      n.create_topic(
        &Name::new("/", "chatter").unwrap(),
        MessageTypeName::new("std_msgs", "String"),
        &QosProfile::default(),
      )
    };
    let sub: Subscription<String> = sub_node
      .create_subscription(&make_topic(&sub_node), None)
      .expect("create subscription");
    let publisher: Publisher<String> = pub_node
      .create_publisher(&make_topic(&pub_node), None)
      .expect("create publisher");

    // Publish repeatedly until the peers have connected and a sample arrives.
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut got = None;
    while Instant::now() < deadline {
      publisher
        .publish("hello zenoh!".to_string())
        .expect("publish");
      if let Some(m) = sub.try_take().expect("try_take") {
        got = Some(m);
        break;
      }
      std::thread::sleep(Duration::from_millis(100));
    }

    let (msg, info) = got.expect("no message received within timeout");
    assert_eq!(msg, "hello zenoh!");
    assert!(info.sequence_number() >= 1);
    assert_ne!(info.publisher_gid(), Gid::default());
  }

  // Matched counts (RADAR patch 14): a publisher counts a subscription of
  // another session from its liveliness token once it arrives, one of its own
  // session too, and stops counting one that is dropped; a subscription
  // counts the publisher back.
  #[test]
  fn a_publisher_counts_the_subscriptions_that_match_it() {
    let (a_port, b_port) = (17541, 17542);
    let a = Context::with_options(ContextOptions::new().zenoh_config(make_config(a_port, None)))
      .expect("open context a");
    let b = Context::with_options(
      ContextOptions::new().zenoh_config(make_config(b_port, Some(a_port))),
    )
    .expect("open context b");
    let node = |c: &Context, n| c.new_node(NodeName::new("/", n).unwrap(), NodeOptions::new()).unwrap();
    let (a_node, b_node) = (node(&a, "count_a"), node(&b, "count_b"));
    let topic = |n: &Node| {
      n.create_topic(
        &Name::new("/", "counted").unwrap(),
        MessageTypeName::new("std_msgs", "String"),
        &QosProfile::default(),
      )
    };
    let until = |what: &str, f: &dyn Fn() -> bool| {
      let deadline = Instant::now() + Duration::from_secs(10);
      while !f() {
        assert!(Instant::now() < deadline, "{what}");
        std::thread::sleep(Duration::from_millis(5));
      }
    };
    let publisher: Publisher<String> = a_node.create_publisher(&topic(&a_node), None).unwrap();
    assert_eq!(publisher.matched_subscription_count(&a_node), 0);
    let remote: Subscription<String> = b_node.create_subscription(&topic(&b_node), None).unwrap();
    until("the other session's subscription counted", &|| {
      publisher.matched_subscription_count(&a_node) == 1
    });
    until("the publisher counted back", &|| {
      remote.matched_publisher_count(&b_node) == 1
    });
    let local: Subscription<String> = a_node.create_subscription(&topic(&a_node), None).unwrap();
    until("this session's own subscription counted", &|| {
      publisher.matched_subscription_count(&a_node) == 2
    });
    drop(remote);
    drop(local);
    until("dropped subscriptions no longer counted", &|| {
      publisher.matched_subscription_count(&a_node) == 0
    });
  }

  // An unlisted subscription (RADAR patch 18) receives what the topic's
  // publishers send and counts them, but declares no liveliness token: no
  // publisher counts it; a listed one beside it is counted.
  #[test]
  fn an_unlisted_subscription_receives_without_being_counted() {
    let (a_port, b_port) = (17545, 17546);
    let a = Context::with_options(ContextOptions::new().zenoh_config(make_config(a_port, None)))
      .expect("open context a");
    let b = Context::with_options(
      ContextOptions::new().zenoh_config(make_config(b_port, Some(a_port))),
    )
    .expect("open context b");
    let node = |c: &Context, n| c.new_node(NodeName::new("/", n).unwrap(), NodeOptions::new()).unwrap();
    let (a_node, b_node) = (node(&a, "unlisted_a"), node(&b, "unlisted_b"));
    let topic = |n: &Node| {
      n.create_topic(
        &Name::new("/", "observed").unwrap(),
        MessageTypeName::new("std_msgs", "String"),
        &QosProfile::default(),
      )
    };
    let publisher: Publisher<String> = a_node.create_publisher(&topic(&a_node), None).unwrap();
    let unlisted: Subscription<String> = b_node
      .create_unlisted_subscription(&topic(&b_node), None)
      .unwrap();
    let deadline = Instant::now() + Duration::from_secs(15);
    while unlisted.matched_publisher_count(&b_node) == 0 {
      assert!(Instant::now() < deadline, "the unlisted subscription counts the publisher");
      std::thread::sleep(Duration::from_millis(5));
    }
    let got = loop {
      assert!(Instant::now() < deadline, "the unlisted subscription receives");
      publisher.publish("seen".to_string()).unwrap();
      if let Some((m, _)) = unlisted.try_take().unwrap() {
        break m;
      }
      std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(got, "seen");
    assert_eq!(
      publisher.matched_subscription_count(&a_node),
      0,
      "the publisher does not count the unlisted subscription"
    );
    let listed: Subscription<String> = b_node.create_subscription(&topic(&b_node), None).unwrap();
    while publisher.matched_subscription_count(&a_node) == 0 {
      assert!(Instant::now() < deadline, "a listed subscription is counted");
      std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(publisher.matched_subscription_count(&a_node), 1);
    drop(listed);
  }

  // radar_ros patch 22: a subscription dropped while samples still come (a slow reader whose channel is
  // full, a reader dropped at a program's stop) logs no error; Zenoh's FIFO handler logged `sending on a
  // closed channel` at ERROR for each sample it was handed after the drop. Volatile and transient local.
  #[test]
  fn a_subscription_dropped_while_samples_arrive_logs_no_error() {
    use std::sync::atomic::{AtomicBool, Ordering};

    use crate::qos::Durability;

    crate::zenoh_backend::logged_errors::install();
    let (a_port, b_port) = (17555, 17556);
    let a = Context::with_options(ContextOptions::new().zenoh_config(make_config(a_port, None)))
      .expect("open context a");
    let b = Context::with_options(
      ContextOptions::new().zenoh_config(make_config(b_port, Some(a_port))),
    )
    .expect("open context b");
    let node = |c: &Context, n| c.new_node(NodeName::new("/", n).unwrap(), NodeOptions::new()).unwrap();
    let (a_node, b_node) = (node(&a, "flood_a"), node(&b, "flood_b"));
    let before = crate::zenoh_backend::logged_errors::handler_errors();
    for durability in [Durability::Volatile, Durability::TransientLocal] {
      let qos = QosProfile {
        durability,
        ..QosProfile::publisher_default()
      };
      for n in 0..20 {
        // a topic of its own each time, and the flood starts once the subscription exists: zenoh-ext's
        // advanced subscriber calls its handler with its state locked, and deadlocks when more samples than
        // the channel holds come while it is being made (with Zenoh's own FIFO as with this one; not patched,
        // RADAR_PATCHES.md, patch 22), as the last flood's samples still in flight would
        let topic = |node: &Node| {
          node.create_topic(
            &Name::new("/", &format!("flooded_{n}")).unwrap(),
            MessageTypeName::new("std_msgs", "String"),
            &qos,
          )
        };
        let publisher: Publisher<String> = a_node.create_publisher(&topic(&a_node), None).unwrap();
        let sub: Subscription<String> = b_node.create_subscription(&topic(&b_node), None).unwrap();
        let stop = AtomicBool::new(false);
        std::thread::scope(|s| {
          s.spawn(|| {
            while !stop.load(Ordering::Relaxed) {
              let _ = publisher.publish("flood".to_string());
            }
          });
          let deadline = Instant::now() + Duration::from_secs(10);
          while sub.try_take().unwrap().is_none() {
            assert!(Instant::now() < deadline, "no sample in 10 s");
            std::thread::sleep(Duration::from_millis(1));
          }
          // unread: its channel fills
          std::thread::sleep(Duration::from_millis(20));
          drop(sub);
          stop.store(true, Ordering::Relaxed);
        });
      }
    }
    std::thread::sleep(Duration::from_millis(200));
    let after = crate::zenoh_backend::logged_errors::handler_errors();
    assert_eq!(after, before, "ERROR lines from subscriptions dropped while samples arrived");
  }

  // TRANSIENT_LOCAL (RADAR patch 12): a subscription made after the
  // publisher has published gets the last `depth` samples from the
  // publisher's cache; a volatile one made alongside gets none of them.
  #[test]
  fn a_late_transient_local_subscription_gets_the_cached_samples() {
    use crate::qos::{Durability, History};
    let pub_port = 17531;
    let sub_port = 17532;
    let pub_ctx =
      Context::with_options(ContextOptions::new().zenoh_config(make_config(pub_port, None)))
        .expect("open publisher context");
    let pub_node = pub_ctx
      .new_node(NodeName::new("/", "latch_pub").unwrap(), NodeOptions::new())
      .unwrap();
    let latched = QosProfile::default()
      .durability(Durability::TransientLocal)
      .history(History::KeepLast { depth: 2 });
    let topic = |n: &Node, qos: &QosProfile| {
      n.create_topic(
        &Name::new("/", "latched").unwrap(),
        MessageTypeName::new("std_msgs", "String"),
        qos,
      )
    };
    let publisher: Publisher<String> = pub_node
      .create_publisher(&topic(&pub_node, &latched), None)
      .expect("create publisher");
    for m in ["one", "two", "three"] {
      publisher.publish(m.to_string()).expect("publish");
    }

    // the subscriber's session only now connects to the publisher's
    let sub_ctx = Context::with_options(
      ContextOptions::new().zenoh_config(make_config(sub_port, Some(pub_port))),
    )
    .expect("open subscriber context");
    let sub_node = sub_ctx
      .new_node(NodeName::new("/", "latch_sub").unwrap(), NodeOptions::new())
      .unwrap();
    let late: Subscription<String> = sub_node
      .create_subscription(&topic(&sub_node, &latched), None)
      .expect("create the transient-local subscription");
    let volatile: Subscription<String> = sub_node
      .create_subscription(&topic(&sub_node, &QosProfile::default()), None)
      .expect("create the volatile subscription");

    let deadline = Instant::now() + Duration::from_secs(15);
    let mut got = Vec::new();
    while got.len() < 2 && Instant::now() < deadline {
      match late.try_take().expect("try_take") {
        Some((m, info)) => got.push((m, info.sequence_number())),
        None => std::thread::sleep(Duration::from_millis(20)),
      }
    }
    assert_eq!(
      got,
      vec![("two".to_string(), 2), ("three".to_string(), 3)],
      "the last two (the depth) of the samples published before the subscription"
    );
    std::thread::sleep(Duration::from_millis(300));
    assert!(late.try_take().expect("try_take").is_none(), "no more");
    assert!(
      volatile.try_take().expect("try_take").is_none(),
      "a volatile subscription gets nothing published before it"
    );
  }
}
