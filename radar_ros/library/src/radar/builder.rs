//! [`RadarBuilder`]: what code asks of a [`Radar`] before it is built; the command line and the environment fill
//! in the rest (`settings.rs`).

use crate::{error::Result, radar::settings::DiscoveryRange, radar::Radar};

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
    /// use radar_ros::{settings::DiscoveryRange, Radar};
    /// let radar = Radar::builder().discovery_range(DiscoveryRange::Subnet).build()?;
    /// # Ok(()) }
    /// ```
    pub fn discovery_range(mut self, range: DiscoveryRange) -> Self {
        self.asked.range = Some(range);
        self
    }

    /// Uses this participant lease instead of `RADAR_LEASE_SECONDS` or [`DEFAULT_LEASE`](crate::settings::DEFAULT_LEASE): how soon peers
    /// notice this process is gone when it dies without leaving (see [`DEFAULT_LEASE`](crate::settings::DEFAULT_LEASE) for the trade-off).
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

    /// Creates the DDS participant (or, with `RMW_IMPLEMENTATION=rmw_zenoh_cpp` in a build with the `zenoh`
    /// feature, the Zenoh session). Must be called inside a tokio runtime.
    pub fn build(self) -> Result<Radar> {
        let settings = self.asked.settle(
            &|k| std::env::var(k),
            crate::node::ros_args::RosArgs::from_env,
        )?;
        super::start(settings)
    }
}
