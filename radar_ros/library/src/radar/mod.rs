//! [`Radar`]: the handle user code holds: one DDS participant that hosts RADAR events, responses and
//! connections, configured like every ROS 2 tool (`ROS_DOMAIN_ID`, `ROS_AUTOMATIC_DISCOVERY_RANGE`).

mod action_clients;
mod action_servers;
mod events;
pub mod introspect;
mod lookup;
pub(crate) mod manager_node;
mod params;
mod plain;
mod remote;
mod responses;
pub(crate) mod settings;
mod statements;
mod waitfor;

use std::sync::Arc;

use ros2_client::dds::{rustdds::DomainParticipantBuilder, Context};

use crate::{
    connections::manager::Manager,
    error::{Error, Result},
    graph::Graph,
    node::participant::Participant,
    radar::settings::{DiscoveryRange, Settings},
    wire::names::ComponentName,
};

/// Reads `ROS_DOMAIN_ID` from the environment (0 when unset), as every ROS 2 tool does: for code that makes
/// its own ros2-client `Context` (whose `Context::new()` uses domain 0 whatever the variable says).
///
/// ```
/// let domain = radar_ros::domain_id_from_env()?;
/// assert!(domain <= 232);
/// # Ok::<(), radar_ros::Error>(())
/// ```
pub fn domain_id_from_env() -> Result<u16> {
    crate::radar::settings::domain_id_in(&|k| std::env::var(k))
}

/// Configures a [`Radar`].
#[derive(Clone, Debug, Default)]
#[must_use]
pub struct RadarBuilder {
    /// What the code asked for; the command line and the environment fill in the rest when it is built.
    asked: crate::radar::settings::Asked,
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
    pub fn ros_args(mut self, args: crate::node::ros_args::RosArgs) -> Self {
        self.asked.ros_args = Some(args);
        self
    }

    /// Whether components follow a simulator's `/clock` instead of the wall clock (see [`crate::node::clock`]).
    /// Default: the `use_sim_time` parameter of the command line (`--ros-args -p use_sim_time:=true`), else
    /// off.
    pub fn use_sim_time(mut self, on: bool) -> Self {
        self.asked.sim_time = Some(on);
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
        self.asked.domain_id = Some(id);
        self
    }

    /// The namespace that relative component names resolve in (default `/`).
    pub fn namespace(mut self, ns: &str) -> Self {
        self.asked.namespace = Some(ns.to_owned());
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
        self.asked.range = Some(range);
        self
    }

    /// Uses this participant lease instead of `RADAR_LEASE_SECONDS` or [`DEFAULT_LEASE`](crate::DEFAULT_LEASE): how soon peers
    /// notice this process is gone when it dies without leaving (see [`DEFAULT_LEASE`](crate::DEFAULT_LEASE) for the trade-off).
    ///
    /// ```no_run
    /// # #[tokio::main] async fn main() -> radar_ros::Result<()> {
    /// use std::time::Duration;
    /// let radar = radar_ros::Radar::builder().lease(Duration::from_secs(10)).build()?; // over Wi-Fi, say
    /// # Ok(()) }
    /// ```
    pub fn lease(mut self, lease: std::time::Duration) -> Self {
        self.asked.lease = Some(lease);
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
        self.asked.program = Some(name.to_owned());
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
        self.asked.local_delivery = Some(on);
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
        self.asked.signals = Some(on);
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
        self.asked.shutdown_timeout = Some(d);
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
        self.asked.security = Some(opts);
        self
    }

    /// Creates the DDS participant. Must be called inside a tokio runtime.
    pub fn build(self) -> Result<Radar> {
        let settings = self.asked.settle(
            &|k| std::env::var(k),
            crate::node::ros_args::RosArgs::from_env,
        )?;
        start(settings)
    }
}

/// The DDS participant the settings ask for: domain, lease, discovery range, the enclave (as rmw announces it
/// in USER_DATA) and, secured, its files.
fn dds_participant(s: &Settings) -> Result<rustdds::DomainParticipant> {
    let mut dpb = DomainParticipantBuilder::new(s.domain_id).lease_duration(s.lease);
    if s.range == DiscoveryRange::Localhost {
        tracing::warn!(
            "LOCALHOST discovery: RustDDS 0.15 restricted to loopback does not deliver between endpoints of \
             the same participant, so RADAR components in this process will not hear each other; unset \
             ROS_AUTOMATIC_DISCOVERY_RANGE (or use SUBNET) for in-process connections"
        );
        dpb = dpb.with_only_networks([std::net::Ipv4Addr::LOCALHOST]);
    }
    // as rmw announces it (rmw_dds_common): graph tools show each node's enclave from it
    // (`get_node_names_and_namespaces_with_enclaves`, `radar security generate_policy`)
    dpb = dpb.user_data(format!("enclave={};", s.policy_enclave));
    let enclave = match &s.security {
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
                s.security.as_ref().expect("an enclave comes from options"),
            )?;
        }
    }
    dpb.build().map_err(|e| match &enclave {
        Some((name, dir)) if cfg!(feature = "security") => Error::Config {
            setting: "enclave",
            value: name.clone(),
            reason: format!(
                "its files in {} do not make a secure participant: {e}. Check that they come from one \
                 keystore (`radar security create_enclave`) and were not changed since they were signed",
                dir.display()
            ),
        },
        _ => Error::transport(format!("a DDS participant in domain {}", s.domain_id), e),
    })
}

/// Starts a `Radar` from settled settings: the participant, the signal handlers, the program node with its
/// manager, services, `/rosout` and (if asked) the simulator's clock.
fn start(s: Settings) -> Result<Radar> {
    let rt = tokio::runtime::Handle::try_current().map_err(|_| Error::Config {
        setting: "runtime",
        value: "none".into(),
        reason:
            "there is no tokio runtime: create the Radar inside #[tokio::main] or Runtime::block_on"
                .into(),
    })?;
    let ctx = Context::from_domain_participant(dds_participant(&s)?)
        .map_err(|e| Error::transport(format!("a ROS 2 context in domain {}", s.domain_id), e))?;
    let participant = Participant::start(
        ctx,
        s.domain_id,
        s.namespace.clone(),
        (Arc::new(s.ros_args.clone()), s.rule_node.clone()),
        s.shutdown_timeout,
        &rt,
    );
    if s.handle_signals {
        let weak: std::sync::Weak<dyn crate::node::shutdown::Stoppable> =
            Arc::downgrade(&participant) as _;
        crate::node::shutdown::on_signals(weak).map_err(|e| Error::Transport {
            what: "install a SIGINT/SIGTERM handler".into(),
            source: Box::new(e),
            hint: "; or build with RadarBuilder::handle_signals(false) and call Radar::shutdown when told to stop"
                .into(),
        })?;
    }
    if let Some(file) = s.generate_policy.clone() {
        generate_policy(&participant, file, s.policy_enclave.clone());
    }
    let (program_node, program_name) = participant.start_program_node(&s.program)?;
    let manager = Arc::new(Manager::new(participant.clone(), s.local_delivery));
    let task = crate::connections::program::serve_program(&participant, &manager, &program_node)?;
    let rosout = crate::node::rosout::start(
        participant
            .with_client_node(|node| crate::node::rosout::writer(participant.graph(), node))?,
        &program_node.fully_qualified(),
    );
    let sim_time = s.sim_time.unwrap_or_else(|| {
        participant
            .ros_args()
            .parameters_for(&program_node.fully_qualified())
            .get("use_sim_time")
            == Some(&crate::node::ros_args::ParameterValue::Boolean(true))
    });
    let sim_clock = if sim_time {
        let sub = participant.subscription::<crate::node::clock::ClockMsg>(
            "/clock",
            &crate::node::clock::SimClock::qos(),
        )?;
        let sim = crate::node::clock::SimClock::start(sub);
        participant.set_clock(sim.clock());
        Some(sim)
    } else {
        None
    };
    Ok(Radar {
        program: Arc::new(ProgramNode {
            name: program_node,
            _claim: program_name,
            _task: task,
            _rosout: rosout,
            _sim_clock: sim_clock,
        }),
        manager,
        participant,
        policy_enclave: Arc::from(s.policy_enclave.as_str()),
    })
}

/// `RADAR_GENERATE_POLICY`: the program's policy (for `enclave`) written to `file` when `participant` ends.
fn generate_policy(participant: &Participant, file: std::path::PathBuf, enclave: String) {
    let exe = crate::connections::program::default_program_name();
    participant.generate_policy(Box::new(move |domain, nodes| {
        let xml = crate::security::program_policy(domain, nodes, &enclave, &exe);
        match std::fs::write(&file, xml) {
            Ok(()) => {
                tracing::info!(file = %file.display(), %enclave, "RADAR_GENERATE_POLICY: policy written")
            }
            Err(e) => tracing::warn!(
                file = %file.display(),
                "RADAR_GENERATE_POLICY: cannot write the policy: {e}"
            ),
        }
    }));
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
    /// Holds the name in the process until the last handle to the program goes.
    _claim: crate::node::participant::ProgramName,
    _task: crate::node::shutdown::ComponentTask,
    _rosout: crate::node::rosout::Publishing,
    _sim_clock: Option<crate::node::clock::SimClock>,
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
    pub fn ros_args(&self) -> &crate::node::ros_args::RosArgs {
        self.participant.ros_args()
    }

    /// The clock components follow: simulated time with `use_sim_time`, else the wall clock.
    pub fn clock(&self) -> crate::node::clock::Clock {
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
    pub fn context(&self) -> &ros2_client::dds::Context {
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
    pub fn connections(&self) -> Vec<crate::wire::msg::Connection> {
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
    pub fn malformed_messages(&self) -> Vec<crate::wire::malformed::MalformedCount> {
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
            let all: [Arc<dyn crate::node::shutdown::Stoppable>; 1] = [participant.clone()];
            let late = crate::node::shutdown::stop(&all, t).await;
            tokio::task::spawn_blocking(move || {
                use crate::node::shutdown::Stoppable;
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
        crate::security::program_policy(
            self.participant.domain_id(),
            &self.participant.node_names(),
            &self.policy_enclave,
            &crate::connections::program::default_program_name(),
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
