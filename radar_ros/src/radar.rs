//! [`Radar`]: one DDS participant that hosts RADAR events and responses, honouring `ROS_DOMAIN_ID`.

use std::{
    collections::HashSet,
    sync::{Arc, Mutex},
};

use ros2_client::{dds::rustdds::DomainParticipantBuilder, Context, Node, NodeName, NodeOptions};

use crate::{
    error::{Error, Result},
    graph::Graph,
    names::{validate_namespace, ComponentName},
};

/// Parses a `ROS_DOMAIN_ID` value the way ROS 2 tools do: empty means 0, otherwise a whole number 0..=232.
pub fn parse_domain_id(value: &str) -> Result<u16> {
    let v = value.trim();
    if v.is_empty() {
        return Ok(0);
    }
    let bad = |reason: &str| Error::InvalidDomainId {
        value: value.to_owned(),
        reason: reason.to_owned(),
    };
    let n: u64 = v.parse().map_err(|_| bad("it is not a whole number"))?;
    if n > 232 {
        return Err(bad(
            "it is above 232, the largest domain whose UDP ports fit in 16 bits",
        ));
    }
    if (102..=214).contains(&n) {
        tracing::warn!(
            domain = n,
            "ROS_DOMAIN_ID {n} maps to UDP ports in the Linux ephemeral range; prefer 0-101 or 215-232"
        );
    }
    Ok(n as u16)
}

/// Reads `ROS_DOMAIN_ID` from the environment (0 when unset), as every ROS 2 tool does.
pub fn domain_id_from_env() -> Result<u16> {
    match std::env::var("ROS_DOMAIN_ID") {
        Ok(v) => parse_domain_id(&v),
        Err(std::env::VarError::NotPresent) => Ok(0),
        Err(std::env::VarError::NotUnicode(v)) => Err(Error::InvalidDomainId {
            value: v.to_string_lossy().into_owned(),
            reason: "it is not valid UTF-8".into(),
        }),
    }
}

/// How far DDS discovery reaches, as ROS 2's `ROS_AUTOMATIC_DISCOVERY_RANGE`.
///
/// Known limitation: with [`DiscoveryRange::Localhost`], RustDDS 0.15 does not deliver messages between a
/// writer and a reader of the *same* participant (its own reader proxy never gets a loopback route), so
/// components in one process cannot signal each other. Processes on the same host still can.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// Only this host: DDS uses the loopback interface only.
    Localhost,
    /// The host and its subnets (ROS 2's default).
    Subnet,
}

/// Reads `ROS_AUTOMATIC_DISCOVERY_RANGE` (and the older `ROS_LOCALHOST_ONLY=1`) like ROS 2 Jazzy does.
/// Unset or `SUBNET`/`SYSTEM_DEFAULT` give [`DiscoveryRange::Subnet`]; `LOCALHOST` and `OFF` give
/// [`DiscoveryRange::Localhost`] (RADAR needs same-host discovery, so `OFF` is treated as `LOCALHOST`).
pub fn discovery_range_from_env() -> Result<DiscoveryRange> {
    if std::env::var("ROS_LOCALHOST_ONLY").as_deref() == Ok("1") {
        return Ok(DiscoveryRange::Localhost);
    }
    match std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").as_deref() {
        Err(_) | Ok("") | Ok("SUBNET") | Ok("SYSTEM_DEFAULT") => Ok(DiscoveryRange::Subnet),
        Ok("LOCALHOST") => Ok(DiscoveryRange::Localhost),
        Ok("OFF") => {
            tracing::warn!("ROS_AUTOMATIC_DISCOVERY_RANGE=OFF treated as LOCALHOST");
            Ok(DiscoveryRange::Localhost)
        }
        Ok(other) => Err(Error::InvalidEnv {
            var: "ROS_AUTOMATIC_DISCOVERY_RANGE",
            value: other.to_owned(),
            reason: "it is not one of SUBNET, LOCALHOST, OFF, SYSTEM_DEFAULT".into(),
        }),
    }
}

/// How long other participants keep a radar_ros participant alive after its last announcement, unless
/// [`RadarBuilder::lease`] or `RADAR_LEASE_SECONDS` says otherwise.
///
/// A RADAR program that is killed (`SIGKILL`, a crash, power loss) cannot say goodbye; its peers notice it when
/// its lease runs out. With 3 s a dead deliberative program's connections are removed, and the events it
/// listened to stop checking, within about 3.6 s (lease plus one check period of 0.6 s) in radar_ros peers and
/// about 3 s in Fast DDS (rclpy) peers. The price: each participant announces itself every 0.6 s instead of
/// every 10 s. Measured (tcpdump, one idle participant): an announcement is one 292-byte SPDP datagram to the
/// multicast group, about 490 bytes/s per participant on the network (29 bytes/s with a 50 s lease), plus 11
/// copies to the same-host discovery ports on loopback. RustDDS's own default lease is 50 s; Fast DDS's is
/// 20 s. Peers keep their own lease; this sets only the one this participant announces. On a lossy network
/// (Wi-Fi) raise it, so that a few lost announcements in a row do not declare a live program dead.
pub const DEFAULT_LEASE: std::time::Duration = std::time::Duration::from_secs(3);

/// Reads `RADAR_LEASE_SECONDS` (seconds, may have a fraction; unset: [`DEFAULT_LEASE`]).
pub fn lease_from_env() -> Result<std::time::Duration> {
    let value = match std::env::var("RADAR_LEASE_SECONDS") {
        Err(std::env::VarError::NotPresent) => return Ok(DEFAULT_LEASE),
        Err(std::env::VarError::NotUnicode(v)) => v.to_string_lossy().into_owned(),
        Ok(v) => v,
    };
    parse_lease(&value)
}

fn parse_lease(value: &str) -> Result<std::time::Duration> {
    let bad = |reason: &str| {
        Error::InvalidEnv {
        var: "RADAR_LEASE_SECONDS",
        value: value.to_owned(),
        reason: format!(
            "{reason}; give the lease in seconds, from 0.1 up (e.g. 3, or 1.5), or unset it for {}s",
            DEFAULT_LEASE.as_secs_f64()
        ),
    }
    };
    let secs: f64 = value
        .trim()
        .parse()
        .map_err(|_| bad("it is not a number"))?;
    if !secs.is_finite() || secs < 0.1 {
        return Err(bad("it is below 0.1 s"));
    }
    if secs > 86_400.0 {
        return Err(bad("it is above a day"));
    }
    Ok(std::time::Duration::from_secs_f64(secs))
}

/// Configures a [`Radar`].
#[derive(Clone, Debug, Default)]
#[must_use]
pub struct RadarBuilder {
    domain_id: Option<u16>,
    namespace: Option<String>,
    range: Option<DiscoveryRange>,
    lease: Option<std::time::Duration>,
}

impl RadarBuilder {
    /// Uses this DDS domain instead of `ROS_DOMAIN_ID`.
    pub fn domain_id(mut self, id: u16) -> Self {
        self.domain_id = Some(id);
        self
    }

    /// The namespace that relative component names resolve in (default `/`).
    pub fn namespace(mut self, ns: &str) -> Self {
        self.namespace = Some(ns.to_owned());
        self
    }

    /// Uses this discovery range instead of `ROS_AUTOMATIC_DISCOVERY_RANGE`.
    pub fn discovery_range(mut self, range: DiscoveryRange) -> Self {
        self.range = Some(range);
        self
    }

    /// Uses this participant lease instead of `RADAR_LEASE_SECONDS` or [`DEFAULT_LEASE`]: how soon peers
    /// notice this process is gone when it dies without leaving (see [`DEFAULT_LEASE`] for the trade-off).
    pub fn lease(mut self, lease: std::time::Duration) -> Self {
        self.lease = Some(lease);
        self
    }

    /// Creates the DDS participant. Must be called inside a tokio runtime.
    pub fn build(self) -> Result<Radar> {
        let namespace = validate_namespace(self.namespace.as_deref().unwrap_or("/"))?;
        let domain_id = match self.domain_id {
            Some(id) => parse_domain_id(&id.to_string())?,
            None => domain_id_from_env()?,
        };
        let rt = tokio::runtime::Handle::try_current().map_err(|_| Error::Dds {
            what: "the RADAR participant".into(),
            detail: "no tokio runtime: create Radar inside #[tokio::main] or Runtime::block_on"
                .into(),
        })?;
        let range = match self.range {
            Some(r) => r,
            None => discovery_range_from_env()?,
        };
        let lease = match self.lease {
            Some(l) => l,
            None => lease_from_env()?,
        };
        let mut dpb = DomainParticipantBuilder::new(domain_id).lease_duration(lease);
        if range == DiscoveryRange::Localhost {
            tracing::warn!(
                "LOCALHOST discovery: RustDDS 0.15 restricted to loopback does not deliver between endpoints of \
                 the same participant, so RADAR components in this process will not hear each other; unset \
                 ROS_AUTOMATIC_DISCOVERY_RANGE (or use SUBNET) for in-process connections"
            );
            dpb = dpb.with_only_networks([std::net::Ipv4Addr::LOCALHOST]);
        }
        let participant = dpb
            .build()
            .map_err(|e| Error::dds(format!("a DDS participant in domain {domain_id}"), e))?;
        let ctx = Context::from_domain_participant(participant)
            .map_err(|e| Error::dds(format!("a ROS 2 context in domain {domain_id}"), e))?;
        let graph = Graph::default();
        graph.set_participant(ctx.domain_participant());
        let (stop, stop_rx) = tokio::sync::oneshot::channel();
        rt.spawn(graph.clone().run(ctx.domain_participant(), stop_rx));
        Ok(Radar {
            inner: Arc::new(Inner {
                ctx,
                domain_id,
                namespace,
                graph,
                names: Mutex::new(HashSet::new()),
                client: Mutex::new(None),
                manager: std::sync::OnceLock::new(),
                stop_graph: Mutex::new(Some(stop)),
            }),
        })
    }
}

struct Inner {
    ctx: Context,
    domain_id: u16,
    namespace: String,
    graph: Graph,
    names: Mutex<HashSet<String>>,
    /// The embedded connection manager, made on first use.
    manager: std::sync::OnceLock<Arc<crate::connect::Manager>>,
    /// A plain node for this participant's publishers and subscriptions that belong to no component.
    client: Mutex<Option<Node>>,
    stop_graph: Mutex<Option<tokio::sync::oneshot::Sender<()>>>,
}

impl Drop for Inner {
    fn drop(&mut self) {
        if let Some(stop) = self.stop_graph.lock().unwrap().take() {
            let _ = stop.send(());
        }
    }
}

/// A handle on one DDS participant that hosts RADAR components; cheap to clone.
///
/// All events and responses spawned from one `Radar` share its participant (the embedded default). The same
/// component types can run in their own processes with their own `Radar`; nothing in them changes.
///
/// ```no_run
/// # async fn f() -> radar_ros::Result<()> {
/// let radar = radar_ros::Radar::new()?; // honours ROS_DOMAIN_ID
/// # Ok(()) }
/// ```
#[derive(Clone)]
pub struct Radar {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for Radar {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Radar")
            .field("domain_id", &self.inner.domain_id)
            .field("namespace", &self.inner.namespace)
            .finish()
    }
}

impl Radar {
    /// A participant in the domain from `ROS_DOMAIN_ID`, namespace `/`.
    pub fn new() -> Result<Radar> {
        Radar::builder().build()
    }

    /// Configure before creating.
    pub fn builder() -> RadarBuilder {
        RadarBuilder::default()
    }

    /// The DDS domain in use.
    pub fn domain_id(&self) -> u16 {
        self.inner.domain_id
    }

    /// The namespace relative names resolve in.
    pub fn namespace(&self) -> &str {
        &self.inner.namespace
    }

    /// The underlying ros2-client context, for creating plain ROS 2 nodes on the same participant.
    pub fn context(&self) -> &Context {
        &self.inner.ctx
    }

    /// Resolves and validates a component name against this participant's namespace.
    pub fn resolve(&self, name: &str) -> Result<ComponentName> {
        ComponentName::resolve(name, &self.inner.namespace)
    }

    /// The embedded connection manager.
    pub(crate) fn manager(&self) -> Arc<crate::connect::Manager> {
        self.inner
            .manager
            .get_or_init(|| {
                Arc::new(crate::connect::Manager::new(WeakRadar(Arc::downgrade(
                    &self.inner,
                ))))
            })
            .clone()
    }

    pub(crate) fn graph(&self) -> &Graph {
        &self.inner.graph
    }

    /// Creates a plain node: no rosout, no parameter services (a RADAR node's endpoints are its signals and
    /// its state).
    fn new_node(&self, namespace: &str, base: &str) -> Result<Node> {
        let fq = ComponentName::resolve(base, namespace)?.fully_qualified();
        let name = NodeName::new(namespace, base).map_err(|e| Error::InvalidName {
            name: fq.clone(),
            reason: format!("{e}"),
        })?;
        let options = NodeOptions::new()
            .enable_rosout(false)
            .start_parameter_services(false);
        self.inner
            .ctx
            .new_node(name, options)
            .map_err(|e| Error::dds(format!("node {fq}"), e))
    }

    /// Runs `f` with this participant's client node, creating it on first use (named
    /// `radar_client_<pid>_<n>`, so several participants in one process stay distinct on the graph).
    pub(crate) fn with_client_node<T>(&self, f: impl FnOnce(&mut Node) -> Result<T>) -> Result<T> {
        static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let mut guard = self.inner.client.lock().unwrap();
        if guard.is_none() {
            let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let base = format!("radar_client_{}_{k}", std::process::id());
            *guard = Some(self.new_node(&self.inner.namespace, &base)?);
        }
        f(guard.as_mut().expect("client node was just created"))
    }

    /// Claims a name for a component in this process and creates its node.
    pub(crate) fn claim_node(&self, name: &ComponentName) -> Result<(Node, NameClaim)> {
        let fq = name.fully_qualified();
        if !self.inner.names.lock().unwrap().insert(fq.clone()) {
            return Err(Error::DuplicateName(fq));
        }
        let claim = NameClaim {
            radar: self.clone(),
            name: fq,
        };
        let node = self.new_node(name.namespace(), name.base())?;
        Ok((node, claim))
    }
}

/// A [`Radar`] that does not keep the participant alive.
#[derive(Clone)]
pub(crate) struct WeakRadar(std::sync::Weak<Inner>);

impl WeakRadar {
    pub(crate) fn upgrade(&self) -> Option<Radar> {
        self.0.upgrade().map(|inner| Radar { inner })
    }
}

/// Frees a claimed component name when the component stops.
pub(crate) struct NameClaim {
    radar: Radar,
    name: String,
}

impl Drop for NameClaim {
    fn drop(&mut self) {
        self.radar.inner.names.lock().unwrap().remove(&self.name);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domain_ids_parse_like_ros2_tools() {
        assert_eq!(parse_domain_id("").unwrap(), 0);
        assert_eq!(parse_domain_id("42").unwrap(), 42);
        assert_eq!(parse_domain_id(" 7 ").unwrap(), 7);
        assert_eq!(parse_domain_id("232").unwrap(), 232);
        let e = parse_domain_id("abc").unwrap_err().to_string();
        assert!(
            e.contains("\"abc\"") && e.contains("not a whole number") && e.contains("0 to 232"),
            "{e}"
        );
        let e = parse_domain_id("233").unwrap_err().to_string();
        assert!(e.contains("above 232"), "{e}");
        assert!(parse_domain_id("-1").is_err());
    }

    #[test]
    fn leases_parse_in_seconds_and_bad_values_say_what_to_set() {
        assert_eq!(parse_lease("3").unwrap(), std::time::Duration::from_secs(3));
        assert_eq!(
            parse_lease(" 1.5 ").unwrap(),
            std::time::Duration::from_millis(1500)
        );
        for bad in ["", "abc", "0", "0.05", "-2", "inf", "NaN", "100000"] {
            let e = parse_lease(bad).unwrap_err().to_string();
            assert!(
                e.contains("RADAR_LEASE_SECONDS") && e.contains("in seconds"),
                "{bad}: {e}"
            );
        }
    }
}
