//! Endpoints over Zenoh: [`ZenohSignals`] (issue 37; docs/zenoh.md, step 3's first half), and how a `Radar`
//! on Zenoh makes its topic endpoints (step 3's second half).

use std::sync::Arc;

use ros2_client::{
    zenoh::{register_type_hash, Context, ContextOptions, Topic},
    EntityKind, MessageTypeName, NodeName, NodeOptions, QosProfile,
};

use crate::{
    error::{Error, Result},
    node::topics::{RawPublisher, RawSubscription, SignalPublisher, SignalSubscription},
    node::transport::{Publisher, Subscription, ZenohNode},
    node::watched::{over_zenoh, peers_of, topic_name, Watched},
    wire::msg::{RosMessage, TypeName},
    wire::qos::{signal_qos, state_qos},
    wire::raw::RawMessage,
};

/// Signal endpoints over Zenoh, as a ROS 2 program under `RMW_IMPLEMENTATION=rmw_zenoh_cpp` has them (issue 37,
/// the first half of docs/zenoh.md's step 3): a Zenoh session and a node on it, making the same [`SignalPublisher`],
/// [`SignalSubscription`], [`RawPublisher`] and [`RawSubscription`] a `Radar` makes over DDS,
/// with the same waits (`wait_for_subscribers` counts matched peers from the liveliness tokens as rmw_zenoh
/// does) and the same names, types, type hashes and QoS on the wire. What a program that only injects into
/// slots or listens to signals needs, across a router, where DDS discovery does not reach, without a `Radar`
/// (components and connections over Zenoh: a [`Radar`](crate::Radar) built with `RMW_IMPLEMENTATION=rmw_zenoh_cpp`).
/// A peer's departure is believed once it has lasted the lease (`RADAR_LEASE_SECONDS`, default 3 s): a router
/// restart, which makes every peer vanish for a moment, is not one.
///
/// ```no_run
/// # async fn f() -> radar_ros::Result<()> {
/// use radar_ros::{msg::Empty, topics::ZenohSignals};
/// // the session as rmw_zenoh's: ROS_DOMAIN_ID, ZENOH_SESSION_CONFIG_URI, ZENOH_CONFIG_OVERRIDE, else a peer
/// // that connects to the router at tcp/localhost:7447
/// let zenoh = ZenohSignals::open("cloud_planner")?;
/// let start = zenoh.signal_publisher::<Empty>("/robot3/back_off/start")?;
/// start.wait_for_subscribers(1).await?;
/// start.publish(Empty::default())?;
/// let exited = zenoh.signal_subscription::<Empty>("/robot3/back_off/exited")?;
/// exited.recv().await?;
/// # Ok(()) }
/// ```
///
/// Endpoints are made inside a tokio runtime (each keeps its matched count current from a small task).
pub struct ZenohSignals {
    node: ZenohNode,
    // after the node: the session closes when the last handle goes
    _ctx: Context,
}

impl ZenohSignals {
    /// Opens a Zenoh session configured as rmw_zenoh configures one (`ZENOH_SESSION_CONFIG_URI`'s file, else
    /// rmw_zenoh's default session: a peer that connects to the router at `tcp/localhost:7447`;
    /// `ZENOH_CONFIG_OVERRIDE` on top), on `ROS_DOMAIN_ID`'s domain, with a node `node_name` in the root
    /// namespace.
    ///
    /// ```no_run
    /// # fn f() -> radar_ros::Result<()> {
    /// let zenoh = radar_ros::topics::ZenohSignals::open("cloud_planner")?;
    /// # Ok(()) }
    /// ```
    pub fn open(node_name: &str) -> Result<ZenohSignals> {
        let domain = crate::node::domain::domain_id_in(&|k| std::env::var(k))?;
        let name = NodeName::new("/", node_name).map_err(|e| Error::InvalidName {
            name: node_name.to_owned(),
            reason: format!("{e}"),
        })?;
        let ctx = Context::with_options(ContextOptions::new().domain_id(domain))
            .map_err(|e| Error::transport("a Zenoh session (as rmw_zenoh's: is ZENOH_SESSION_CONFIG_URI or ZENOH_CONFIG_OVERRIDE right?)", e))?;
        let options = NodeOptions::new()
            .enable_rosout(false)
            .start_parameter_services(false);
        let node = ctx
            .new_node(name, options)
            .map_err(|e| Error::transport(format!("node /{node_name} over Zenoh"), e))?;
        Ok(ZenohSignals {
            node: ZenohNode {
                node,
                domain_id: domain,
                malformed: Arc::default(),
                grace: crate::node::domain::lease_in(&|k| std::env::var(k))?,
                ctx: ctx.clone(),
            },
            _ctx: ctx,
        })
    }

    /// A publisher on `topic` (relative names resolve in the root namespace), with signal QoS.
    ///
    /// ```no_run
    /// # fn f(zenoh: radar_ros::topics::ZenohSignals) -> radar_ros::Result<()> {
    /// let p = zenoh.signal_publisher::<radar_ros::msg::Empty>("/dock/interrupt")?;
    /// # Ok(()) }
    /// ```
    pub fn signal_publisher<M: RosMessage>(&self, topic: &str) -> Result<SignalPublisher<M>> {
        self.publisher(topic, TypeName::of::<M>(), &signal_qos())
    }

    /// A subscription to `topic`, with signal QoS.
    ///
    /// ```no_run
    /// # fn f(zenoh: radar_ros::topics::ZenohSignals) -> radar_ros::Result<()> {
    /// let s = zenoh.signal_subscription::<radar_ros::msg::Empty>("/dock/exited")?;
    /// # Ok(()) }
    /// ```
    pub fn signal_subscription<M: RosMessage>(&self, topic: &str) -> Result<SignalSubscription<M>> {
        self.subscription(topic, TypeName::of::<M>(), &signal_qos())
    }

    /// A subscription to a component's transient-local `state` topic: gets the current state on subscribing
    /// (from the publisher's cache, as rmw_zenoh's latched topics).
    ///
    /// ```no_run
    /// # fn f(zenoh: radar_ros::topics::ZenohSignals) -> radar_ros::Result<()> {
    /// let s = zenoh.state_subscription::<radar_ros::msg::ResponseState>("/dock/state")?;
    /// # Ok(()) }
    /// ```
    pub fn state_subscription<M: RosMessage>(&self, topic: &str) -> Result<SignalSubscription<M>> {
        self.subscription(topic, TypeName::of::<M>(), &state_qos())
    }

    /// A publisher of `ros_type` (e.g. `std_msgs/msg/String`) on `topic` that sends message bodies unchanged
    /// (signal QoS).
    ///
    /// ```no_run
    /// # fn f(zenoh: radar_ros::topics::ZenohSignals) -> radar_ros::Result<()> {
    /// let p = zenoh.raw_publisher("/say/start", "std_msgs/msg/String")?;
    /// # Ok(()) }
    /// ```
    pub fn raw_publisher(&self, topic: &str, ros_type: &str) -> Result<RawPublisher> {
        let ty = crate::wire::raw::parse_type_name(ros_type)?;
        self.publisher::<RawMessage>(topic, ty, &signal_qos())
    }

    /// A subscription to `ros_type` on `topic` that yields message bodies unchanged (signal QoS).
    ///
    /// ```no_run
    /// # fn f(zenoh: radar_ros::topics::ZenohSignals) -> radar_ros::Result<()> {
    /// let s = zenoh.raw_subscription("/say/exited", "std_msgs/msg/String")?;
    /// # Ok(()) }
    /// ```
    pub fn raw_subscription(&self, topic: &str, ros_type: &str) -> Result<RawSubscription> {
        let ty = crate::wire::raw::parse_type_name(ros_type)?;
        self.subscription::<RawMessage>(topic, ty, &signal_qos())
    }

    fn publisher<M: serde::Serialize + Send + Sync + 'static>(
        &self,
        topic: &str,
        ty: TypeName,
        qos: &QosProfile,
    ) -> Result<SignalPublisher<M>> {
        let abs = absolute(topic);
        let p = publisher(&self.node, &abs, &ty, qos)?;
        Ok(SignalPublisher::new(abs, ty.ros, p))
    }

    fn subscription<M: serde::de::DeserializeOwned + Send + Sync + 'static>(
        &self,
        topic: &str,
        ty: TypeName,
        qos: &QosProfile,
    ) -> Result<SignalSubscription<M>> {
        let abs = absolute(topic);
        let s = subscription(&self.node, &abs, &ty, qos, false)?;
        Ok(SignalSubscription::new(abs, ty.ros, s))
    }
}

/// `topic`, absolute (a relative name in the root namespace).
fn absolute(topic: &str) -> String {
    if topic.starts_with('/') {
        topic.to_owned()
    } else {
        format!("/{topic}")
    }
}

/// A publisher of `M` on the absolute `topic_abs` of node `z`, announced as type `ty` with QoS `qos`, its
/// matched count from the liveliness tokens (ros2-client patch 14).
pub(crate) fn publisher<M: serde::Serialize + Send + Sync + 'static>(
    z: &ZenohNode,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
) -> Result<Watched<Publisher<M>>> {
    let t = topic(z, topic_abs, ty, qos)?;
    let p = z
        .node
        .create_publisher::<M>(&t, None)
        .map_err(|e| Error::transport(format!("a publisher on {topic_abs} over Zenoh"), e))?;
    let counts = p.watch_matched(&z.node);
    let peers = peers_of(z.ctx.clone(), topic_abs, EntityKind::Subscription);
    over_zenoh(
        Publisher::Zenoh(p),
        counts,
        z.malformed.clone(),
        z.grace,
        peers,
    )
}

/// A subscription of `M` to the absolute `topic_abs` of node `z` (see [`publisher`]); with `observer`, one that
/// only observes: it declares no liveliness token, so no publisher counts it (an event does not take it for a
/// listener; ros2-client patch 18), and the graph does not show it.
pub(crate) fn subscription<M: serde::de::DeserializeOwned + Send + Sync + 'static>(
    z: &ZenohNode,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
    observer: bool,
) -> Result<Watched<Subscription<M>>> {
    let t = topic(z, topic_abs, ty, qos)?;
    let made = if observer {
        z.node.create_unlisted_subscription::<M>(&t, None)
    } else {
        z.node.create_subscription::<M>(&t, None)
    };
    let s =
        made.map_err(|e| Error::transport(format!("a subscription to {topic_abs} over Zenoh"), e))?;
    let counts = s.watch_matched(&z.node);
    let peers = peers_of(z.ctx.clone(), topic_abs, EntityKind::Publisher);
    over_zenoh(
        Subscription::Zenoh(s),
        counts,
        z.malformed.clone(),
        z.grace,
        peers,
    )
}

/// The Zenoh topic of type `ty` on the absolute `abs`, its hash given to the backend (what rmw_zenoh peers
/// match on). A type this process knows no hash of (a relay or a raw endpoint of a type only the user's
/// other programs generated) takes the one its peers on `abs` announce in their tokens, if they agree.
fn topic(z: &ZenohNode, abs: &str, ty: &TypeName, qos: &QosProfile) -> Result<Topic> {
    let name = topic_name(abs)?;
    let (package, rest) = ty.ros.split_once('/').unwrap_or(("", &ty.ros));
    let (kind, base) = rest.split_once('/').unwrap_or(("msg", rest));
    if !matches!(kind, "msg" | "action") {
        return Err(Error::InvalidName {
            name: ty.ros.clone(),
            reason:
                "a topic over Zenoh carries a message type (package/msg/Name) or an action's part \
                     (package/action/Name_Feedback)"
                    .into(),
        });
    }
    match ty.hash {
        Some(hash) => register_type_hash(&ty.dds, hash).map_err(|reason| Error::InvalidName {
            name: ty.ros.clone(),
            reason,
        })?,
        None => {
            if let Some(hash) = announced_hash(&z.ctx, abs, &ty.dds) {
                // known already under another hash (a type radar_ros ships, or one registered before):
                // that peer runs another definition, which rmw_zenoh does not match either
                if let Err(reason) = register_type_hash(&ty.dds, &hash) {
                    tracing::warn!(
                        topic = abs,
                        %reason,
                        "a peer on this topic announces another definition of its type: it is not matched; \
                         build every program against the same interface package"
                    );
                }
            }
        }
    }
    let ty = MessageTypeName::new_prefix(package, base, kind.to_owned());
    Ok(z.node.create_topic(&name, ty, qos))
}

/// The hash the endpoints of `dds_type` on `abs` announce (their liveliness tokens), when they all announce
/// one and the same; a warning when they disagree (two definitions under one name: none is taken).
pub(crate) fn announced_hash(ctx: &Context, abs: &str, dds_type: &str) -> Option<String> {
    let hashes: std::collections::BTreeSet<String> = ctx
        .graph_entities()
        .into_iter()
        .filter(|(_, e)| {
            e.topic_name.as_deref() == Some(abs) && e.type_name.as_deref() == Some(dds_type)
        })
        .filter_map(|(_, e)| e.type_hash)
        .filter(|h| h.starts_with("RIHS01_") && h.len() == 71)
        .collect();
    if hashes.len() > 1 {
        tracing::warn!(
            topic = abs,
            r#type = dds_type,
            ?hashes,
            "peers announce different definitions of one type on this topic: none is taken; \
             build every program against the same interface package"
        );
    }
    (hashes.len() == 1).then(|| hashes.into_iter().next().expect("one"))
}

/// Waits (until `deadline`) until this process knows the type hash of `ros_type` (shipped, registered by a
/// typed endpoint, or announced by a peer on `abs`, which is then registered): over Zenoh a key is made with
/// its hash, and one made with none matches no rmw_zenoh peer. What a relay of a type the program has no Rust
/// type for waits for before it makes its endpoints.
pub(crate) async fn learn_type_hash(
    ctx: &Context,
    abs: &str,
    ros_type: &str,
    deadline: std::time::Instant,
) -> Result<()> {
    let ty = crate::wire::raw::parse_type_name(ros_type)?;
    if ty.hash.is_some() || ros2_client::zenoh::known_type_hash(&ty.dds).is_some() {
        return Ok(());
    }
    let events = ctx.graph_event_stream();
    loop {
        if let Some(hash) = announced_hash(ctx, abs, &ty.dds) {
            return register_type_hash(&ty.dds, &hash).map_err(|reason| Error::InvalidName {
                name: ros_type.to_owned(),
                reason,
            });
        }
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        if tokio::time::timeout(left, events.recv()).await.is_err() {
            return Err(Error::Timeout {
                what: format!(
                    "a peer on {abs} that announces the type hash of {ros_type} (this program has no Rust type for \
                     it, and over Zenoh peers match on the hash: is the component running? or generate the type \
                     in this program with radar_idl)"
                ),
                after: std::time::Duration::ZERO,
            });
        }
    }
}
