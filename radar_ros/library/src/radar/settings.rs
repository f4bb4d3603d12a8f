//! What a [`Radar`](crate::Radar) is built from, settled before anything starts: the builder's choices over the
//! command line (`--ros-args`) and the environment (`RMW_IMPLEMENTATION`, `ROS_DOMAIN_ID`,
//! `ROS_AUTOMATIC_DISCOVERY_RANGE`, `RADAR_LEASE_SECONDS`, `ROS_SECURITY_*`, `RADAR_GENERATE_POLICY`), read and checked with no DDS and no I/O
//! beyond the lookups given. [`RadarBuilder::build`](crate::RadarBuilder::build) settles them, then starts the
//! participant from them.
//!
//! Precedence, as in rclcpp: the command line over the code over the environment for the namespace and the
//! program's name (`-r __ns:=`, `-r __node:=`); the code over the environment for the rest.

use std::time::Duration;

use crate::{
    error::{Error, Result},
    node::ros_args::RosArgs,
    security::SecurityOptions,
    wire::names::{validate_namespace, ComponentName},
};

/// How far DDS discovery reaches, as ROS 2's `ROS_AUTOMATIC_DISCOVERY_RANGE`.
///
/// Known limitation: with [`DiscoveryRange::Localhost`], RustDDS 0.15 does not deliver messages between a
/// writer and a reader of the *same* participant (its own reader proxy never gets a loopback route), so
/// components in one process cannot signal each other. Processes on the same host still can.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum DiscoveryRange {
    /// Only this host: DDS uses the loopback interface only.
    Localhost,
    /// The host and its subnets (ROS 2's default).
    Subnet,
}

pub(crate) use crate::node::domain::lease_in;
#[cfg(test)]
use crate::node::domain::parse_lease;
pub use crate::node::domain::DEFAULT_LEASE;
pub(crate) use crate::node::domain::{domain_id_in, parse_domain_id, Env};

/// What the builder says, before the command line and the environment are read.
#[derive(Clone, Debug, Default)]
pub(crate) struct Asked {
    pub(crate) domain_id: Option<u16>,
    pub(crate) namespace: Option<String>,
    pub(crate) range: Option<DiscoveryRange>,
    pub(crate) lease: Option<Duration>,
    pub(crate) program: Option<String>,
    pub(crate) local_delivery: Option<bool>,
    pub(crate) signals: Option<bool>,
    pub(crate) shutdown_timeout: Option<Duration>,
    pub(crate) ros_args: Option<RosArgs>,
    pub(crate) sim_time: Option<bool>,
    pub(crate) security: Option<Option<SecurityOptions>>,
}

/// Everything a `Radar` starts from, settled.
#[derive(Clone, Debug)]
pub(crate) struct Settings {
    pub(crate) ros_args: RosArgs,
    /// The name node-specific command-line rules (`node:__ns:=...`) match: the program's name as given
    /// (or the executable's), before any remapping or suffix.
    pub(crate) rule_node: String,
    pub(crate) namespace: String,
    pub(crate) domain_id: u16,
    pub(crate) range: DiscoveryRange,
    pub(crate) lease: Duration,
    /// The enclave to secure the participant with, if any.
    pub(crate) security: Option<SecurityOptions>,
    /// The enclave the program runs in or would run in (announced in the participant's USER_DATA, and what a
    /// generated policy names).
    pub(crate) policy_enclave: String,
    /// The program node's name (before a `_2` suffix if another program of this process has it).
    pub(crate) program: String,
    pub(crate) local_delivery: bool,
    pub(crate) handle_signals: bool,
    pub(crate) shutdown_timeout: Duration,
    /// `None`: as the `use_sim_time` parameter of the program node says.
    pub(crate) sim_time: Option<bool>,
    /// `RADAR_GENERATE_POLICY`: where to write the policy of what the program declares.
    pub(crate) generate_policy: Option<std::path::PathBuf>,
    /// The transport `RMW_IMPLEMENTATION` chose.
    pub(crate) middleware: Middleware,
}

/// The transport a `Radar` runs on, as `RMW_IMPLEMENTATION` chooses it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Middleware {
    /// DDS (unset, empty, or a DDS middleware).
    Dds,
    /// Zenoh (`rmw_zenoh_cpp`, in a build with the `zenoh` feature).
    Zenoh,
}

impl Asked {
    /// Settles what was asked against `args` (the command line, read only if the builder was given none) and
    /// `env`.
    pub(crate) fn settle(
        self,
        env: Env<'_>,
        args: impl FnOnce() -> Result<RosArgs>,
    ) -> Result<Settings> {
        let ros_args = match self.ros_args {
            Some(a) => a,
            None => args()?,
        };
        let rule_node = self
            .program
            .clone()
            .unwrap_or_else(crate::connections::program::default_program_name);
        let namespace = validate_namespace(
            ros_args
                .namespace(&rule_node)
                .or(self.namespace.as_deref())
                .unwrap_or("/"),
        )?;
        let middleware = middleware_in(env)?;
        let domain_id = match self.domain_id {
            Some(id) => parse_domain_id(&id.to_string())?,
            None => domain_id_in(env)?,
        };
        let range = match self.range {
            Some(r) => r,
            None => discovery_range_in(env)?,
        };
        let lease = match self.lease {
            Some(l) => l,
            None => lease_in(env)?,
        };
        let security = match self.security {
            Some(s) => s,
            None => SecurityOptions::from_lookup(env, &ros_args)?,
        };
        let policy_enclave = match &security {
            Some(o) => o.enclave.clone(),
            None => crate::security::enclave_name_in(env, &ros_args),
        };
        let program = match ros_args
            .node_name(&rule_node)
            .map(str::to_owned)
            .or(self.program)
        {
            Some(p) => program_name(p)?,
            None => format!(
                "{}_{}",
                crate::connections::program::default_program_name(),
                std::process::id()
            ),
        };
        let generate_policy = env("RADAR_GENERATE_POLICY")
            .ok()
            .filter(|v| !v.is_empty())
            .map(std::path::PathBuf::from);
        Ok(Settings {
            ros_args,
            rule_node,
            namespace,
            domain_id,
            range,
            lease,
            security,
            policy_enclave,
            program,
            local_delivery: self.local_delivery.unwrap_or(true),
            handle_signals: self.signals != Some(false),
            shutdown_timeout: self
                .shutdown_timeout
                .unwrap_or(crate::node::shutdown::DEFAULT_SHUTDOWN_TIMEOUT),
            sim_time: self.sim_time,
            generate_policy,
            middleware,
        })
    }
}

/// A program name as given: one valid ROS name token.
fn program_name(p: String) -> Result<String> {
    let bad = |why: String| Error::Config {
        setting: "program",
        value: p.clone(),
        reason: format!("{why}; a program name is one ROS name token, e.g. patrol"),
    };
    if p.contains('/') {
        return Err(bad("it contains a `/`".into()));
    }
    ComponentName::resolve(&p, "/").map_err(|e| bad(e.to_string()))?;
    Ok(p)
}

/// `ROS_AUTOMATIC_DISCOVERY_RANGE` (and the older `ROS_LOCALHOST_ONLY=1`) as ROS 2 Jazzy reads them. Unset or
/// `SUBNET`/`SYSTEM_DEFAULT` give [`DiscoveryRange::Subnet`]; `LOCALHOST` and `OFF` give
/// [`DiscoveryRange::Localhost`] (RADAR needs same-host discovery, so `OFF` is taken as `LOCALHOST`).
pub(crate) fn discovery_range_in(env: Env<'_>) -> Result<DiscoveryRange> {
    if env("ROS_LOCALHOST_ONLY").as_deref() == Ok("1") {
        return Ok(DiscoveryRange::Localhost);
    }
    match env("ROS_AUTOMATIC_DISCOVERY_RANGE").as_deref() {
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

/// The ROS 2 middlewares whose wire this build speaks: every DDS one (RTPS is one wire protocol).
const DDS_MIDDLEWARES: [&str; 5] = [
    "rmw_fastrtps_cpp",
    "rmw_fastrtps_dynamic_cpp",
    "rmw_cyclonedds_cpp",
    "rmw_connextdds",
    "rmw_gurumdds_cpp",
];

/// `RMW_IMPLEMENTATION` as ROS 2 reads it to choose its middleware. Unset, empty or a DDS one: this build's DDS,
/// which talks to every DDS middleware. `rmw_zenoh_cpp`: Zenoh, in a build with the `zenoh` feature (without it,
/// an error that says to build with it). Any other: an error that says so before anything starts, as rcl
/// refuses a middleware it cannot load; a program that ran on DDS among peers on Zenoh would see none of them
/// and say nothing.
pub(crate) fn middleware_in(env: Env<'_>) -> Result<Middleware> {
    let value = match env("RMW_IMPLEMENTATION") {
        Err(std::env::VarError::NotPresent) => return Ok(Middleware::Dds),
        Err(std::env::VarError::NotUnicode(v)) => v.to_string_lossy().into_owned(),
        Ok(v) => v,
    };
    let name = value.trim();
    if name.is_empty() || DDS_MIDDLEWARES.contains(&name) {
        return Ok(Middleware::Dds);
    }
    if name == "rmw_zenoh_cpp" && cfg!(feature = "zenoh") {
        return Ok(Middleware::Zenoh);
    }
    let then = "; unset RMW_IMPLEMENTATION or set a DDS one (rmw_fastrtps_cpp, rmw_cyclonedds_cpp) for this \
                program and its ROS 2 peers";
    let reason = if name == "rmw_zenoh_cpp" {
        format!(
            "this build of radar_ros speaks DDS only: build it with its `zenoh` feature to run over Zenoh \
             (docs/zenoh.md); over DDS, this program would see none of its peers on Zenoh{then}"
        )
    } else {
        format!(
            "it is not a ROS 2 middleware radar_ros knows (it speaks DDS: {}){then}",
            DDS_MIDDLEWARES.join(", ")
        )
    };
    Err(Error::Config {
        setting: "RMW_IMPLEMENTATION",
        value,
        reason,
    })
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;

    fn env(
        vars: &[(&str, &str)],
    ) -> impl Fn(&str) -> std::result::Result<String, std::env::VarError> {
        let m: HashMap<String, String> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k: &str| m.get(k).cloned().ok_or(std::env::VarError::NotPresent)
    }

    fn args(a: &[&str]) -> RosArgs {
        RosArgs::parse(a.iter().copied()).unwrap()
    }

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

    #[test]
    fn the_environment_gives_what_the_code_does_not() {
        let e = env(&[
            ("ROS_DOMAIN_ID", "42"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST"),
            ("RMW_IMPLEMENTATION", "rmw_cyclonedds_cpp"),
            ("RADAR_LEASE_SECONDS", "1.5"),
            ("RADAR_GENERATE_POLICY", "/tmp/p.xml"),
        ]);
        let s = Asked {
            ros_args: Some(args(&["patrol"])),
            program: Some("patrol".into()),
            ..Asked::default()
        }
        .settle(&e, || unreachable!("the builder gave the arguments"))
        .unwrap();
        assert_eq!(s.domain_id, 42);
        assert_eq!(s.range, DiscoveryRange::Localhost);
        assert_eq!(s.lease, Duration::from_millis(1500));
        assert_eq!(s.namespace, "/");
        assert_eq!(s.program, "patrol");
        assert_eq!(s.policy_enclave, "/");
        assert!(s.security.is_none());
        assert!(s.local_delivery && s.handle_signals);
        assert_eq!(
            s.generate_policy.as_deref(),
            Some(std::path::Path::new("/tmp/p.xml"))
        );
    }

    #[test]
    fn the_code_over_the_environment_and_the_command_line_over_the_code() {
        let e = env(&[("ROS_DOMAIN_ID", "42"), ("RADAR_LEASE_SECONDS", "9")]);
        let s = Asked {
            domain_id: Some(7),
            lease: Some(Duration::from_secs(2)),
            namespace: Some("/code".into()),
            program: Some("patrol".into()),
            local_delivery: Some(false),
            signals: Some(false),
            ros_args: Some(args(&[
                "patrol",
                "--ros-args",
                "-r",
                "__ns:=/robot1",
                "-r",
                "__node:=scout",
            ])),
            ..Asked::default()
        }
        .settle(&e, || unreachable!())
        .unwrap();
        assert_eq!((s.domain_id, s.lease), (7, Duration::from_secs(2)));
        assert_eq!(s.namespace, "/robot1");
        assert_eq!(s.program, "scout");
        assert_eq!(
            s.rule_node, "patrol",
            "rules match the name the program was given"
        );
        assert!(!s.local_delivery && !s.handle_signals);
    }

    #[test]
    fn bad_settings_are_named_with_what_to_do() {
        let settle = |vars: &[(&str, &str)], program: Option<&str>| {
            Asked {
                ros_args: Some(args(&["p"])),
                program: program.map(str::to_owned),
                ..Asked::default()
            }
            .settle(&env(vars), || unreachable!())
            .map(|_| ())
            .unwrap_err()
            .to_string()
        };
        let e = settle(&[("ROS_DOMAIN_ID", "300")], Some("p"));
        assert!(e.contains("ROS_DOMAIN_ID") && e.contains("0 to 232"), "{e}");
        let e = settle(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "MARS")], Some("p"));
        assert!(e.contains("SUBNET, LOCALHOST"), "{e}");
        #[cfg(not(feature = "zenoh"))]
        {
            let e = settle(&[("RMW_IMPLEMENTATION", "rmw_zenoh_cpp")], Some("p"));
            assert!(
                e.contains("RMW_IMPLEMENTATION")
                    && e.contains("rmw_zenoh_cpp")
                    && e.contains("DDS only")
                    && e.contains("`zenoh` feature")
                    && e.contains("unset RMW_IMPLEMENTATION"),
                "{e}"
            );
        }
        let e = settle(&[("RMW_IMPLEMENTATION", "rmw_nothing")], Some("p"));
        assert!(
            e.contains("rmw_nothing") && e.contains("rmw_cyclonedds_cpp"),
            "{e}"
        );
        let e = settle(&[("RADAR_LEASE_SECONDS", "0")], Some("p"));
        assert!(e.contains("from 0.1 up"), "{e}");
        let e = settle(&[], Some("a/b"));
        assert!(e.contains("one ROS name token"), "{e}");
        let e = settle(
            &[
                ("ROS_SECURITY_ENABLE", "true"),
                ("ROS_SECURITY_ENCLAVE_OVERRIDE", "x"),
            ],
            Some("p"),
        );
        assert!(e.contains("absolute"), "{e}");
    }

    #[test]
    fn the_command_line_is_read_only_when_the_builder_gave_none() {
        let s = Asked::default()
            .settle(&env(&[]), || {
                Ok(args(&["prog", "--ros-args", "-r", "__ns:=/x"]))
            })
            .unwrap();
        assert_eq!(s.namespace, "/x");
        assert!(s.program.ends_with(&format!("_{}", std::process::id())));
        let e = Asked::default()
            .settle(&env(&[]), || {
                RosArgs::parse(["prog", "--ros-args", "--bogus"])
            })
            .unwrap_err();
        assert!(e.to_string().contains("--ros-args"), "{e}");
    }

    #[test]
    fn a_secured_program_runs_in_the_enclave_the_environment_names() {
        let e = env(&[
            ("ROS_SECURITY_ENABLE", "true"),
            ("ROS_SECURITY_KEYSTORE", "/ks"),
            ("ROS_SECURITY_STRATEGY", "Enforce"),
        ]);
        let s = Asked {
            ros_args: Some(args(&["p", "--ros-args", "--enclave", "/robot/planner"])),
            program: Some("p".into()),
            ..Asked::default()
        }
        .settle(&e, || unreachable!())
        .unwrap();
        assert_eq!(s.policy_enclave, "/robot/planner");
        let sec = s.security.expect("secured");
        assert_eq!(sec.enclave, "/robot/planner");
        // a plain program still says which enclave it would run in
        let s = Asked {
            ros_args: Some(args(&["p", "--ros-args", "-e", "/robot/planner"])),
            program: Some("p".into()),
            ..Asked::default()
        }
        .settle(&env(&[]), || unreachable!())
        .unwrap();
        assert!(s.security.is_none());
        assert_eq!(s.policy_enclave, "/robot/planner");
    }
}
