//! [`Radar`]: the handle user code holds: one DDS participant that hosts RADAR events, responses and
//! connections, configured like every ROS 2 tool (`ROS_DOMAIN_ID`, `ROS_AUTOMATIC_DISCOVERY_RANGE`).

use std::sync::Arc;

use ros2_client::{dds::rustdds::DomainParticipantBuilder, Context};

use crate::{
    error::{Error, Result},
    graph::Graph,
    manager::Manager,
    names::{validate_namespace, ComponentName},
    participant::Participant,
};

/// Parses a `ROS_DOMAIN_ID` value the way ROS 2 tools do: empty means 0, otherwise a whole number 0..=232.
pub(crate) fn parse_domain_id(value: &str) -> Result<u16> {
    let v = value.trim();
    if v.is_empty() {
        return Ok(0);
    }
    let bad = |reason: &str| {
        Error::Config {
        setting: "ROS_DOMAIN_ID",
        value: value.to_owned(),
        reason: format!(
            "{reason}; set ROS_DOMAIN_ID to a whole number from 0 to 232 (0-101 and 215-232 avoid the Linux \
             ephemeral port range), or unset it for domain 0"
        ),
    }
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

/// Reads `ROS_DOMAIN_ID` from the environment (0 when unset), as every ROS 2 tool does: for code that makes
/// its own ros2-client `Context` (whose `Context::new()` uses domain 0 whatever the variable says).
///
/// ```
/// let domain = radar_ros::domain_id_from_env()?;
/// assert!(domain <= 232);
/// # Ok::<(), radar_ros::Error>(())
/// ```
pub fn domain_id_from_env() -> Result<u16> {
    match std::env::var("ROS_DOMAIN_ID") {
        Ok(v) => parse_domain_id(&v),
        Err(std::env::VarError::NotPresent) => Ok(0),
        Err(std::env::VarError::NotUnicode(v)) => Err(Error::Config {
            setting: "ROS_DOMAIN_ID",
            value: v.to_string_lossy().into_owned(),
            reason: "it is not valid UTF-8; set it to a whole number from 0 to 232".into(),
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
pub(crate) fn discovery_range_from_env() -> Result<DiscoveryRange> {
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
        Ok(other) => Err(Error::Config {
            setting: "ROS_AUTOMATIC_DISCOVERY_RANGE",
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
pub(crate) fn lease_from_env() -> Result<std::time::Duration> {
    let value = match std::env::var("RADAR_LEASE_SECONDS") {
        Err(std::env::VarError::NotPresent) => return Ok(DEFAULT_LEASE),
        Err(std::env::VarError::NotUnicode(v)) => v.to_string_lossy().into_owned(),
        Ok(v) => v,
    };
    parse_lease(&value)
}

fn parse_lease(value: &str) -> Result<std::time::Duration> {
    let bad = |reason: &str| {
        Error::Config {
        setting: "RADAR_LEASE_SECONDS",
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
    program: Option<String>,
    /// `Some(false)`: every delivery goes over the slot's topic.
    local_delivery: Option<bool>,
    /// `Some(false)`: the program handles SIGINT/SIGTERM itself.
    signals: Option<bool>,
    shutdown_timeout: Option<std::time::Duration>,
    /// `None`: the process's own (`std::env::args`).
    ros_args: Option<crate::ros_args::RosArgs>,
    /// `None`: the `use_sim_time` parameter of the command line, else off.
    sim_time: Option<bool>,
    /// `None`: as the environment says (`ROS_SECURITY_*`); `Some(None)`: plain.
    security: Option<Option<crate::security::SecurityOptions>>,
}

impl RadarBuilder {
    /// Uses these ROS arguments instead of the process's own `--ros-args` (which [`RadarBuilder::build`] reads
    /// from `std::env::args` otherwise). `-r __ns:=` and `-r __node:=` there override
    /// [`RadarBuilder::namespace`] and [`RadarBuilder::program`], as the command line overrides code in rclcpp.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// use radar_ros::ros_args::RosArgs;
    /// let args = RosArgs::parse(["patrol", "--ros-args", "-r", "__ns:=/robot1"])?;
    /// let radar = radar_ros::Radar::builder().ros_args(args).build()?;
    /// assert_eq!(radar.namespace(), "/robot1");
    /// # Ok(()) }
    /// ```
    pub fn ros_args(mut self, args: crate::ros_args::RosArgs) -> Self {
        self.ros_args = Some(args);
        self
    }

    /// Whether components follow a simulator's `/clock` instead of the wall clock (see [`crate::clock`]).
    /// Default: the `use_sim_time` parameter of the command line (`--ros-args -p use_sim_time:=true`), else
    /// off.
    pub fn use_sim_time(mut self, on: bool) -> Self {
        self.sim_time = Some(on);
        self
    }

    /// Uses this DDS domain instead of `ROS_DOMAIN_ID`.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::builder().domain_id(42).build()?;
    /// assert_eq!(radar.domain_id(), 42);
    /// # Ok(()) }
    /// ```
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
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// use radar_ros::{DiscoveryRange, Radar};
    /// let radar = Radar::builder().discovery_range(DiscoveryRange::Subnet).build()?;
    /// # Ok(()) }
    /// ```
    pub fn discovery_range(mut self, range: DiscoveryRange) -> Self {
        self.range = Some(range);
        self
    }

    /// Uses this participant lease instead of `RADAR_LEASE_SECONDS` or [`DEFAULT_LEASE`]: how soon peers
    /// notice this process is gone when it dies without leaving (see [`DEFAULT_LEASE`] for the trade-off).
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// use std::time::Duration;
    /// let radar = radar_ros::Radar::builder().lease(Duration::from_secs(10)).build()?; // over Wi-Fi, say
    /// # Ok(()) }
    /// ```
    pub fn lease(mut self, lease: std::time::Duration) -> Self {
        self.lease = Some(lease);
        self
    }

    /// Names the program's node (default: the executable's file name, made a valid ROS name, and the process
    /// id: `count_up_4242`); see [`Radar::program_node`]. The name must not be a component's of this process.
    /// Give each process of a system its own name.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::builder().program("patrol").build()?;
    /// assert_eq!(radar.program_node().fully_qualified(), "/patrol");
    /// # Ok(()) }
    /// ```
    pub fn program(mut self, name: &str) -> Self {
        self.program = Some(name.to_owned());
        self
    }

    /// Whether connections made through this `Radar` hand their signals to the responses of this process
    /// directly (default `true`): the signal takes one DDS hop (from its source) instead of two (source ->
    /// manager -> response), and nothing of it is written on the slot's topic. With `false` every delivery is
    /// written on the slot's topic, as the manager of another process does; a connection made while its
    /// response runs in this process keeps the way it was armed with until it ends.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// // every start shows on `/<response>/start` (for `ros2 topic echo`, or a recording)
    /// let radar = radar_ros::Radar::builder().local_delivery(false).build()?;
    /// # Ok(()) }
    /// ```
    pub fn local_delivery(mut self, on: bool) -> Self {
        self.local_delivery = Some(on);
        self
    }

    /// Whether SIGINT and SIGTERM stop this `Radar`'s components (default `true`): the exit slots of running
    /// responses run, `exited` and the final states are sent, the program leaves the ROS graph, and the process
    /// exits (status 0; see [the shutdown rules](crate#when-the-program-is-told-to-stop)). The handler is the
    /// process's: the first `Radar` that asks for it installs it, and it stops every `Radar` that asked.
    ///
    /// With `false`, the program handles the signals itself (before this `Radar` is built), and calls
    /// [`Radar::shutdown`] when told to stop, so that the exit slots still run:
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::builder().handle_signals(false).build()?;
    /// // ... spawn components, make connections ...
    /// tokio::signal::ctrl_c().await.ok();
    /// radar.shutdown().await?; // exit slots run, `exited` is sent, the program leaves the graph
    /// # Ok(()) }
    /// ```
    pub fn handle_signals(mut self, on: bool) -> Self {
        self.signals = Some(on);
        self
    }

    /// How long a program told to stop waits for its components, exit slots included (default
    /// [`DEFAULT_SHUTDOWN_TIMEOUT`](crate::DEFAULT_SHUTDOWN_TIMEOUT), 5 s); after that it names what did not
    /// finish, and exits with status 1.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// use std::time::Duration;
    /// // the arm's exit slot parks it, which takes up to 10 s
    /// let radar = radar_ros::Radar::builder().shutdown_timeout(Duration::from_secs(15)).build()?;
    /// # Ok(()) }
    /// ```
    pub fn shutdown_timeout(mut self, d: std::time::Duration) -> Self {
        self.shutdown_timeout = Some(d);
        self
    }

    /// DDS Security from this enclave (`Some`), or none (`None`), instead of what `ROS_SECURITY_ENABLE`,
    /// `ROS_SECURITY_KEYSTORE`, `ROS_SECURITY_STRATEGY`, `ROS_SECURITY_ENCLAVE_OVERRIDE` and `--enclave` say
    /// (see [`crate::security`]).
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// use radar_ros::security::SecurityOptions;
    /// let radar = radar_ros::Radar::builder()
    ///     .security(Some(SecurityOptions::enforce("/etc/robot/keystore", "/robot/planner")))
    ///     .build()?;
    /// # Ok(()) }
    /// ```
    pub fn security(mut self, opts: Option<crate::security::SecurityOptions>) -> Self {
        self.security = Some(opts);
        self
    }

    /// Creates the DDS participant. Must be called inside a tokio runtime.
    pub fn build(self) -> Result<Radar> {
        let ros_args = match self.ros_args {
            Some(a) => a,
            None => crate::ros_args::RosArgs::from_env()?,
        };
        // the name node-specific rules (`node:__ns:=...`) match: the program's name before any suffix
        let rule_node = self
            .program
            .clone()
            .unwrap_or_else(crate::program::default_program_name);
        let namespace = validate_namespace(
            ros_args
                .namespace(&rule_node)
                .or(self.namespace.as_deref())
                .unwrap_or("/"),
        )?;
        let domain_id = match self.domain_id {
            Some(id) => parse_domain_id(&id.to_string())?,
            None => domain_id_from_env()?,
        };
        let rt = tokio::runtime::Handle::try_current().map_err(|_| Error::Config {
            setting: "runtime",
            value: "none".into(),
            reason: "there is no tokio runtime: create the Radar inside #[tokio::main] or Runtime::block_on"
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
        let security = match self.security {
            Some(s) => s,
            None => crate::security::SecurityOptions::from_env(&ros_args)?,
        };
        let policy_enclave = match &security {
            Some(o) => o.enclave.clone(),
            None => crate::security::enclave_name(&ros_args),
        };
        // as rmw announces it (rmw_dds_common): graph tools show each node's enclave from it
        // (`get_node_names_and_namespaces_with_enclaves`, `radar security generate_policy`)
        dpb = dpb.user_data(format!("enclave={policy_enclave};"));
        let enclave = match &security {
            Some(o) => crate::security::locate(o)?.map(|dir| (o.enclave.clone(), dir)),
            None => None,
        };
        if let Some((name, dir)) = &enclave {
            #[cfg(feature = "security")]
            {
                dpb = crate::security::secure(dpb, dir);
                tracing::info!(enclave = %name, dir = %dir.display(), "DDS Security: on");
            }
            #[cfg(not(feature = "security"))]
            {
                let _ = (name, dir);
                crate::security::unsupported(
                    security.as_ref().expect("an enclave comes from options"),
                )?;
            }
        }
        let participant = dpb.build().map_err(|e| match &enclave {
            Some((name, dir)) if cfg!(feature = "security") => Error::Config {
                setting: "enclave",
                value: name.clone(),
                reason: format!(
                    "its files in {} do not make a secure participant: {e}. Check that they come from one \
                     keystore (`radar security create_enclave`) and were not changed since they were signed",
                    dir.display()
                ),
            },
            _ => Error::transport(format!("a DDS participant in domain {domain_id}"), e),
        })?;
        let ctx = Context::from_domain_participant(participant)
            .map_err(|e| Error::transport(format!("a ROS 2 context in domain {domain_id}"), e))?;
        let shutdown_timeout = self
            .shutdown_timeout
            .unwrap_or(crate::shutdown::DEFAULT_SHUTDOWN_TIMEOUT);
        let renamed = ros_args.node_name(&rule_node).map(str::to_owned);
        let participant = Participant::start(
            ctx,
            domain_id,
            namespace,
            (Arc::new(ros_args), rule_node),
            shutdown_timeout,
            &rt,
        );
        if self.signals != Some(false) {
            let weak: std::sync::Weak<dyn crate::shutdown::Stoppable> =
                Arc::downgrade(&participant) as _;
            crate::shutdown::on_signals(weak).map_err(|e| Error::Transport {
                what: "install a SIGINT/SIGTERM handler".into(),
                source: Box::new(e),
                hint: "; or build with RadarBuilder::handle_signals(false) and call Radar::shutdown when told to stop"
                    .into(),
            })?;
        }
        let program = match renamed.or(self.program) {
            Some(p) => {
                // one valid ROS name token, as given
                let bad = |why: String| Error::Config {
                    setting: "program",
                    value: p.clone(),
                    reason: format!("{why}; a program name is one ROS name token, e.g. patrol"),
                };
                if p.contains('/') {
                    return Err(bad("it contains a `/`".into()));
                }
                crate::names::ComponentName::resolve(&p, "/").map_err(|e| bad(e.to_string()))?;
                p
            }
            None => format!(
                "{}_{}",
                crate::program::default_program_name(),
                std::process::id()
            ),
        };
        if let Some(file) = std::env::var_os("RADAR_GENERATE_POLICY").filter(|v| !v.is_empty()) {
            participant.generate_policy(
                std::path::PathBuf::from(file),
                policy_enclave.clone(),
                crate::program::default_program_name(),
            );
        }
        let program_node = participant.start_program_node(&program)?;
        let manager = Arc::new(Manager::new(
            participant.clone(),
            self.local_delivery.unwrap_or(true),
        ));
        let task = crate::program::serve_program(&participant, &manager, &program_node)?;
        let rosout = crate::rosout::start(
            participant
                .with_client_node(|node| crate::rosout::writer(participant.graph(), node))?,
            &program_node.fully_qualified(),
        );
        let sim_time = self.sim_time.unwrap_or_else(|| {
            participant
                .ros_args()
                .parameters_for(&program_node.fully_qualified())
                .get("use_sim_time")
                == Some(&crate::ros_args::ParameterValue::Boolean(true))
        });
        let sim_clock = if sim_time {
            let sub = participant
                .subscription::<crate::clock::ClockMsg>("/clock", &crate::clock::SimClock::qos())?;
            let sim = crate::clock::SimClock::start(sub);
            participant.set_clock(sim.clock());
            Some(sim)
        } else {
            None
        };
        Ok(Radar {
            program: Arc::new(ProgramNode {
                name: program_node,
                _task: task,
                _rosout: rosout,
                _sim_clock: sim_clock,
            }),
            manager,
            participant,
            policy_enclave: Arc::from(policy_enclave.as_str()),
        })
    }
}

/// A handle on one DDS participant that hosts RADAR components and connections; cheap to clone.
///
/// All events and responses spawned from one `Radar` share its participant (the embedded default), and its
/// embedded connection manager carries out the statements made through it. The same component types can run
/// in their own processes with their own `Radar`; nothing in them changes.
///
/// ```no_run
/// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
/// let radar = radar_ros::Radar::new()?; // honours ROS_DOMAIN_ID
/// println!("domain {}", radar.domain_id());
/// # Ok(()) }
/// ```
#[derive(Clone)]
pub struct Radar {
    /// First, so that it stops before the rest goes.
    program: Arc<ProgramNode>,
    participant: Arc<Participant>,
    manager: Arc<Manager>,
    /// The enclave this program runs in (or would, secured), for [`Radar::policy`].
    policy_enclave: Arc<str>,
}

/// The program node, the task that shows its connections, its `/rosout` writer, and what follows `/clock`.
struct ProgramNode {
    name: ComponentName,
    _task: crate::shutdown::ComponentTask,
    _rosout: crate::rosout::Publishing,
    _sim_clock: Option<crate::clock::SimClock>,
}

impl std::fmt::Debug for Radar {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Radar")
            .field("domain_id", &self.participant.domain_id())
            .field("namespace", &self.participant.namespace())
            .finish()
    }
}

impl Radar {
    /// A participant in the domain from `ROS_DOMAIN_ID`, namespace `/`. Must be called inside a tokio runtime.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::new()?;
    /// # Ok(()) }
    /// ```
    pub fn new() -> Result<Radar> {
        Radar::builder().build()
    }

    /// Configure before creating.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::builder().domain_id(7).namespace("/robot").build()?;
    /// # Ok(()) }
    /// ```
    pub fn builder() -> RadarBuilder {
        RadarBuilder::default()
    }

    /// The DDS domain in use.
    pub fn domain_id(&self) -> u16 {
        self.participant.domain_id()
    }

    /// The ROS arguments this `Radar` was built with (the process's `--ros-args` unless
    /// [`RadarBuilder::ros_args`] gave others): parameter overrides, the log level, the program's own arguments.
    pub fn ros_args(&self) -> &crate::ros_args::RosArgs {
        self.participant.ros_args()
    }

    /// The clock components follow: simulated time with `use_sim_time`, else the wall clock.
    pub fn clock(&self) -> crate::clock::Clock {
        self.participant.clock()
    }

    /// The namespace relative names resolve in.
    pub fn namespace(&self) -> &str {
        self.participant.namespace()
    }

    /// The program node: it shows this program's connections on `<node>/connections` and serves
    /// `<node>/list` (see the `program` module docs), and carries the program's plain publishers and
    /// subscriptions.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::new()?;
    /// println!("ros2 topic echo {}", radar.program_node().topic("connections"));
    /// # Ok(()) }
    /// ```
    pub fn program_node(&self) -> &ComponentName {
        &self.program.name
    }

    /// The underlying ros2-client context, for creating plain ROS 2 nodes on the same participant.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) {
    /// use ros2_client::{NodeName, NodeOptions};
    /// let node = radar.context().new_node(NodeName::new("/", "my_plain_node").unwrap(), NodeOptions::new());
    /// # }
    /// ```
    pub fn context(&self) -> &ros2_client::Context {
        self.participant.context()
    }

    /// Resolves and validates a component name against this participant's namespace.
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::builder().namespace("/robot").build()?;
    /// assert_eq!(radar.resolve("dock")?.fully_qualified(), "/robot/dock");
    /// # Ok(()) }
    /// ```
    pub fn resolve(&self, name: &str) -> Result<ComponentName> {
        self.participant.resolve(name)
    }

    /// Every live connection of this program's embedded manager (what a served manager lists on its
    /// `connections` topic).
    ///
    /// ```no_run
    /// # fn f(radar: radar_ros::Radar) {
    /// for c in radar.connections() {
    ///     println!("{} {} -> {} ({} delivered)", c.kind_label, c.source, c.target, c.delivered);
    /// }
    /// # }
    /// ```
    pub fn connections(&self) -> Vec<crate::msg::Connection> {
        self.manager.list()
    }

    /// Messages this participant dropped because they did not decode as their topic's type (slot messages
    /// of its responses, topic events' inputs, service requests of a served manager, payloads for
    /// anonymous slots, filters and maps), counted per topic and publisher. Each publisher is logged once
    /// per topic; the rest are only counted here (and in a response's `state`).
    ///
    /// ```no_run
    /// # fn f(radar: radar_ros::Radar) {
    /// for m in radar.malformed_messages() {
    ///     eprintln!("{} message(s) on {} from {} (expected {})", m.count, m.topic, m.publisher, m.expected);
    /// }
    /// # }
    /// ```
    pub fn malformed_messages(&self) -> Vec<crate::malformed::MalformedCount> {
        self.graph().malformed().counts()
    }

    /// Stops every component of this `Radar` and leaves the ROS graph, as a SIGINT would (without ending the
    /// process): running responses end as an `exit` signal would end them, their exit slots run, `exited` and
    /// the final states are sent and acknowledged, then the participant says goodbye. Waits at most the
    /// shutdown timeout ([`RadarBuilder::shutdown_timeout`], 5 s; `.timeout(d)` to change), then fails naming
    /// the components that did not finish. Nothing works on this `Radar` afterwards.
    ///
    /// For programs that handle signals themselves ([`RadarBuilder::handle_signals`]), or that want their
    /// components stopped before `main` ends (returning from `main` stops them too, see
    /// [the shutdown rules](crate#when-the-program-is-told-to-stop)).
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::new()?;
    /// // ...
    /// radar.shutdown().await?;
    /// # Ok(()) }
    /// ```
    pub fn shutdown(&self) -> crate::Wait<'static, ()> {
        let participant = self.participant.clone();
        let default = participant.shutdown_timeout();
        crate::Wait::new(Some(default), move |t| async move {
            let t = t.unwrap_or(default);
            let all: [Arc<dyn crate::shutdown::Stoppable>; 1] = [participant.clone()];
            let late = crate::shutdown::stop(&all, t).await;
            tokio::task::spawn_blocking(move || {
                use crate::shutdown::Stoppable;
                participant.leave()
            })
            .await
            .map_err(|e| Error::Transport {
                what: "leave the ROS graph".into(),
                source: Box::new(e),
                hint: String::new(),
            })?;
            match late.is_empty() {
                true => Ok(()),
                false => Err(Error::Timeout {
                    what: format!("{} to stop (exit slots included)", late.join(", ")),
                    after: t,
                }),
            }
        })
    }

    /// The access-control policy of what this program has declared on the ROS graph so far, in sros2's format
    /// (`radar security create_permission KEYSTORE ENCLAVE FILE` makes its enclave's permissions from it): for
    /// its enclave (`--enclave`, `ROS_SECURITY_ENCLAVE_OVERRIDE` or `/`), one profile per node of this
    /// program, each topic it publishes or subscribes, each service it serves or calls, each
    /// action it calls or serves. A response's node reads its slots and writes its signals; whoever drives it
    /// writes its slots. `RADAR_GENERATE_POLICY=FILE` writes it to FILE when the program ends. Name the program
    /// (`.program("robot")` or `--ros-args -r __node:=robot`) so that its node's name, and the policy, are the
    /// same from run to run (the default name ends with the process id).
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// let radar = radar_ros::Radar::builder().program("planner").build()?;
    /// // ... spawn components, make statements ...
    /// std::fs::write("planner_policy.xml", radar.policy()).unwrap();
    /// # Ok(()) }
    /// ```
    pub fn policy(&self) -> String {
        self.participant.policy(
            &self.policy_enclave,
            &crate::program::default_program_name(),
        )
    }

    pub(crate) fn participant(&self) -> &Arc<Participant> {
        &self.participant
    }

    pub(crate) fn manager(&self) -> &Arc<Manager> {
        &self.manager
    }

    pub(crate) fn graph(&self) -> &Graph {
        self.participant.graph()
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
