//! [`Radar`]: the handle user code holds: one DDS participant that hosts RADAR events, responses and
//! connections, configured like every ROS 2 tool (`ROS_DOMAIN_ID`, `ROS_AUTOMATIC_DISCOVERY_RANGE`).

mod action_clients;
mod action_servers;
mod builder;
mod find;
pub mod introspect;
pub(crate) mod manager_node;
mod once_whenever;
mod params;
mod plain_topics;
mod remote_manager;
pub(crate) mod settings;
mod spawn_event;
mod spawn_response;
mod waitfor;

use std::sync::Arc;

pub use builder::RadarBuilder;

use ros2_client::dds::{rustdds::DomainParticipantBuilder, Context};

use crate::{
    connections::manager::Manager,
    error::{Error, Result},
    graph::Graph,
    node::participant::{Ctx, Participant},
    radar::settings::{DiscoveryRange, Middleware, Settings},
    wire::names::ComponentName,
};

/// Reads `ROS_DOMAIN_ID` from the environment (0 when unset), as every ROS 2 tool does: for code that makes
/// its own ros2-client `Context` (whose `Context::new()` uses domain 0 whatever the variable says).
///
/// ```
/// let domain = radar_ros::settings::domain_id_from_env()?;
/// assert!(domain <= 232);
/// # Ok::<(), radar_ros::Error>(())
/// ```
pub fn domain_id_from_env() -> Result<u16> {
    crate::radar::settings::domain_id_in(&|k| std::env::var(k))
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
    // and its process, so that other radar_ros programs on this host tell a respawn from a second live
    // process of one name (rule C5, `graph/processes.rs`)
    dpb = dpb.user_data(format!(
        "enclave={};{}",
        s.policy_enclave,
        crate::graph::processes::user_data_entry()
    ));
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

/// The Zenoh session the settings ask for (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`), configured as rmw_zenoh's:
/// `ZENOH_SESSION_CONFIG_URI`'s file, else a peer that connects to the router at `tcp/localhost:7447`;
/// `ZENOH_CONFIG_OVERRIDE` on top; the domain's keys.
#[cfg(feature = "zenoh")]
fn zenoh_context(s: &Settings) -> Result<Ctx> {
    if let Some(o) = &s.security {
        return Err(Error::Config {
            setting: "ROS_SECURITY_ENABLE",
            value: o.enclave.clone(),
            reason: "DDS Security does not apply over Zenoh (RMW_IMPLEMENTATION=rmw_zenoh_cpp): secure the Zenoh \
                     session in ZENOH_SESSION_CONFIG_URI's file (TLS, access control) and unset ROS_SECURITY_ENABLE, \
                     or run over DDS"
                .into(),
        });
    }
    // the enclave in every token, where rmw_zenoh writes its context's: graph tools show each node's
    let ctx = ros2_client::zenoh::Context::with_options(
        ros2_client::zenoh::ContextOptions::new()
            .domain_id(s.domain_id)
            .enclave(&s.policy_enclave),
    )
    .map_err(|e| {
        Error::transport(
            format!(
                "a Zenoh session in domain {} (as rmw_zenoh's: are ZENOH_SESSION_CONFIG_URI and \
                 ZENOH_CONFIG_OVERRIDE right?)",
                s.domain_id
            ),
            e,
        )
    })?;
    tracing::info!(
        domain = s.domain_id,
        "over Zenoh (RMW_IMPLEMENTATION=rmw_zenoh_cpp)"
    );
    Ok(Ctx::Zenoh(ctx, Default::default(), s.lease))
}

/// Without the `zenoh` feature, settings never choose Zenoh (`settings::middleware_in` refuses it).
#[cfg(not(feature = "zenoh"))]
fn zenoh_context(_: &Settings) -> Result<Ctx> {
    Err(Error::Config {
        setting: "RMW_IMPLEMENTATION",
        value: "rmw_zenoh_cpp".into(),
        reason: "this build of radar_ros speaks DDS only: build it with its `zenoh` feature".into(),
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
    if s.middleware == Middleware::Dds {
        crate::node::domain::warn_if_ephemeral(s.domain_id);
    }
    let ctx = match s.middleware {
        Middleware::Dds => Ctx::Dds(
            Context::from_domain_participant(dds_participant(&s)?).map_err(|e| {
                Error::transport(format!("a ROS 2 context in domain {}", s.domain_id), e)
            })?,
        ),
        Middleware::Zenoh => zenoh_context(&s)?,
    };
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

    /// The underlying ros2-client context. Panics over Zenoh, which has no DDS context: use
    /// [`Radar::dds_context`], `None` there.
    #[deprecated(
        since = "0.2.0",
        note = "panics over Zenoh: use Radar::dds_context, which is None there"
    )]
    pub fn context(&self) -> &ros2_client::dds::Context {
        self.dds_context().expect(
            "Radar::context: this Radar runs over Zenoh (RMW_IMPLEMENTATION=rmw_zenoh_cpp) and has no DDS \
             context; use Radar::dds_context",
        )
    }

    /// The underlying ros2-client DDS context, or `None` when this `Radar` runs over Zenoh.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) {
    /// if let Some(ctx) = radar.dds_context() {
    ///     println!("DDS participant {:?}", ctx.domain_participant().domain_id());
    /// }
    /// # }
    /// ```
    pub fn dds_context(&self) -> Option<&ros2_client::dds::Context> {
        self.participant.dds_context()
    }

    /// Whether this `Radar` runs over Zenoh (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`, the `zenoh` feature) rather
    /// than DDS.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) {
    /// println!("over {}", if radar.over_zenoh() { "Zenoh" } else { "DDS" });
    /// # }
    /// ```
    pub fn over_zenoh(&self) -> bool {
        self.participant.over_zenoh()
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
