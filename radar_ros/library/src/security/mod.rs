//! DDS Security, configured as ROS 2 configures it (SROS2): authentication, access control and encryption of
//! a program's participant from an *enclave* in a keystore.
//!
//! | variable / argument | meaning |
//! |---|---|
//! | `ROS_SECURITY_ENABLE=true` | secure this program's participant (anything else: plain) |
//! | `ROS_SECURITY_KEYSTORE=DIR` | the keystore (`radar security create_keystore DIR`) |
//! | `ROS_SECURITY_STRATEGY=Enforce` | a program whose enclave cannot be found does not start (default `Permissive`: it runs plain, with a warning) |
//! | `--ros-args --enclave /NAME` (`-e`) | the enclave to use (default `/`) |
//! | `ROS_SECURITY_ENCLAVE_OVERRIDE=/NAME` | the enclave, whatever the command line says |
//!
//! An enclave is the directory `KEYSTORE/enclaves/NAME/` with `identity_ca.cert.pem`, `cert.pem`, `key.pem`,
//! `permissions_ca.cert.pem`, `governance.p7s` and `permissions.p7s`, as `ros2 security create_enclave` (and
//! `radar security create_enclave`) make it. Files that exist but do not verify (a tampered permissions file, a
//! certificate from another CA) stop the program under either strategy, as rmw does.
//!
//! Secure participants need the `security` feature (OpenSSL); without it, `ROS_SECURITY_ENABLE=true` is refused
//! under `Enforce` and warned about under `Permissive`. See `docs/security.md`.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

#[cfg(feature = "security")]
pub mod keystore;
pub(crate) mod model;
#[cfg(feature = "security")]
pub mod policy;

/// What `ROS_SECURITY_STRATEGY` asks when the enclave cannot be found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Strategy {
    /// The program does not start.
    Enforce,
    /// The program runs without security, saying so (rcl's default).
    Permissive,
}

/// The files of an enclave, in the order RustDDS reads them.
pub const ENCLAVE_FILES: [&str; 6] = [
    "identity_ca.cert.pem",
    "cert.pem",
    "key.pem",
    "permissions_ca.cert.pem",
    "governance.p7s",
    "permissions.p7s",
];

/// The security a program asks for: an enclave of a keystore, and what to do if it is missing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SecurityOptions {
    /// The keystore's directory.
    pub keystore: PathBuf,
    /// The enclave's name (`/`, `/robot/planner`, ...).
    pub enclave: String,
    /// What to do when the enclave cannot be found.
    pub strategy: Strategy,
}

impl SecurityOptions {
    /// The enclave `enclave` of `keystore`, enforced.
    pub fn enforce(keystore: impl Into<PathBuf>, enclave: &str) -> SecurityOptions {
        SecurityOptions {
            keystore: keystore.into(),
            enclave: enclave.to_owned(),
            strategy: Strategy::Enforce,
        }
    }

    /// The enclave's directory: `KEYSTORE/enclaves/NAME`.
    pub fn enclave_dir(&self) -> PathBuf {
        enclave_dir(&self.keystore, &self.enclave)
    }

    /// What the environment and the command line's `--enclave` ask for: `None` without
    /// `ROS_SECURITY_ENABLE=true`.
    pub fn from_env(ros_args: &crate::node::ros_args::RosArgs) -> Result<Option<SecurityOptions>> {
        Self::from_lookup(&|k| std::env::var(k), ros_args)
    }

    /// [`SecurityOptions::from_env`] with the environment's variables looked up in `env`.
    pub(crate) fn from_lookup(
        env: &dyn Fn(&str) -> std::result::Result<String, std::env::VarError>,
        ros_args: &crate::node::ros_args::RosArgs,
    ) -> Result<Option<SecurityOptions>> {
        let var = |k: &str| env(k).ok().filter(|v| !v.is_empty());
        from_vars(
            var("ROS_SECURITY_ENABLE").as_deref(),
            var("ROS_SECURITY_STRATEGY").as_deref(),
            var("ROS_SECURITY_KEYSTORE").as_deref(),
            var("ROS_SECURITY_ENCLAVE_OVERRIDE").as_deref(),
            ros_args.enclave(),
        )
    }
}

/// The enclave a program runs in, or would run in when secured: `ROS_SECURITY_ENCLAVE_OVERRIDE`, else the
/// command line's `--enclave`, else `/` (rcl's order).
pub(crate) fn enclave_name_in(
    env: &dyn Fn(&str) -> std::result::Result<String, std::env::VarError>,
    ros_args: &crate::node::ros_args::RosArgs,
) -> String {
    env("ROS_SECURITY_ENCLAVE_OVERRIDE")
        .ok()
        .filter(|v| !v.is_empty())
        .or_else(|| ros_args.enclave().map(str::to_owned))
        .unwrap_or_else(|| "/".to_owned())
}

/// `KEYSTORE/enclaves/NAME` for the enclave `NAME` (`/` is the keystore's `enclaves/` itself).
pub fn enclave_dir(keystore: &Path, enclave: &str) -> PathBuf {
    let mut d = keystore.join("enclaves");
    for part in enclave.split('/').filter(|p| !p.is_empty()) {
        d.push(part);
    }
    d
}

/// [`SecurityOptions::from_env`] over the values given (rcl's rules, `rcl/security.c`).
fn from_vars(
    enable: Option<&str>,
    strategy: Option<&str>,
    keystore: Option<&str>,
    enclave_override: Option<&str>,
    enclave_arg: Option<&str>,
) -> Result<Option<SecurityOptions>> {
    if enable != Some("true") {
        return Ok(None);
    }
    let strategy = match strategy {
        Some("Enforce") => Strategy::Enforce,
        _ => Strategy::Permissive,
    };
    let enclave = enclave_override.or(enclave_arg).unwrap_or("/").to_owned();
    if !enclave.starts_with('/') {
        return Err(Error::Config {
            setting: "enclave",
            value: enclave,
            reason: "an enclave name is absolute, like a fully qualified node name: /robot/planner"
                .into(),
        });
    }
    let Some(keystore) = keystore else {
        return match strategy {
            Strategy::Enforce => Err(Error::Config {
                setting: "ROS_SECURITY_KEYSTORE",
                value: String::new(),
                reason: "ROS_SECURITY_ENABLE=true and ROS_SECURITY_STRATEGY=Enforce need a keystore: set \
                         ROS_SECURITY_KEYSTORE to one (`radar security create_keystore DIR`)"
                    .into(),
            }),
            Strategy::Permissive => {
                tracing::warn!(
                    "ROS_SECURITY_ENABLE=true but ROS_SECURITY_KEYSTORE is not set: running WITHOUT security \
                     (ROS_SECURITY_STRATEGY=Enforce refuses to)"
                );
                Ok(None)
            }
        };
    };
    Ok(Some(SecurityOptions {
        keystore: PathBuf::from(keystore),
        enclave,
        strategy,
    }))
}

/// The enclave's directory if every file is there; else, under `Enforce`, an error naming the first one
/// missing, and under `Permissive` `None` (with a warning).
pub(crate) fn locate(opts: &SecurityOptions) -> Result<Option<PathBuf>> {
    let dir = opts.enclave_dir();
    let missing = ENCLAVE_FILES
        .iter()
        .map(|f| dir.join(f))
        .find(|p| !p.is_file());
    match (missing, opts.strategy) {
        (None, _) => Ok(Some(dir)),
        (Some(p), Strategy::Enforce) => Err(Error::Config {
            setting: "enclave",
            value: opts.enclave.clone(),
            reason: format!(
                "{} is missing (ROS_SECURITY_STRATEGY=Enforce): make the enclave with `radar security \
                 create_enclave {} {}`, or point ROS_SECURITY_KEYSTORE at the keystore that has it",
                p.display(),
                opts.keystore.display(),
                opts.enclave
            ),
        }),
        (Some(p), Strategy::Permissive) => {
            tracing::warn!(
                enclave = %opts.enclave,
                "{} is missing: running WITHOUT security (ROS_SECURITY_STRATEGY=Enforce refuses to)",
                p.display()
            );
            Ok(None)
        }
    }
}

/// Adds the enclave at `dir` to a participant's builder.
#[cfg(feature = "security")]
pub(crate) fn secure(
    dpb: rustdds::DomainParticipantBuilder,
    dir: &Path,
) -> rustdds::DomainParticipantBuilder {
    dpb.builtin_security(
        rustdds::DomainParticipantSecurityConfigFiles::with_ros_default_names(dir, String::new()),
    )
}

/// Without the `security` feature: an error under `Enforce`, a warning otherwise.
#[cfg(not(feature = "security"))]
pub(crate) fn unsupported(opts: &SecurityOptions) -> Result<()> {
    match opts.strategy {
        Strategy::Enforce => Err(Error::Config {
            setting: "ROS_SECURITY_ENABLE",
            value: "true".into(),
            reason:
                "this program was built without DDS Security: build radar_ros with the `security` \
                     feature (needs OpenSSL), or unset ROS_SECURITY_ENABLE"
                    .into(),
        }),
        Strategy::Permissive => {
            tracing::warn!(
                "ROS_SECURITY_ENABLE=true but this program was built without DDS Security (radar_ros's \
                 `security` feature): running WITHOUT security"
            );
            Ok(())
        }
    }
}

/// The policy of what the nodes `nodes` (a program's, fully qualified) of domain `domain` declared, for
/// `enclave` ([`crate::Radar::policy`], `RADAR_GENERATE_POLICY`). The default program name is `exe` followed by
/// the process id (`count_up_1234`), so names under it are written as a pattern (`count_up_*`) that the next
/// run's also match.
pub(crate) fn program_policy(
    domain: u16,
    nodes: &BTreeSet<String>,
    enclave: &str,
    exe: &str,
) -> String {
    declared_policy(domain, nodes, enclave).replace(
        &format!("{exe}_{}", std::process::id()),
        &format!("{exe}_*"),
    )
}

/// The policy (sros2's format 0.2.0, `radar security create_permission` reads it) granting the enclave
/// `enclave` what the nodes `nodes` of domain `domain` declared so far, one profile per node, every name
/// absolute.
fn declared_policy(domain: u16, nodes: &BTreeSet<String>, enclave: &str) -> String {
    use crate::node::declared::{uses, Access};
    use model::{Kind, Policy, Rule};
    let mut policy = Policy::default();
    // what the ROS 2 context makes for every participant (ros2-client's /rosout and /parameter_events topics)
    for access in ["publish", "subscribe"] {
        for t in ["/rosout", "/parameter_events"] {
            policy.add(
                enclave,
                "/",
                "_ros_context",
                Rule::allow(Kind::Topics, access),
                t,
            );
        }
    }
    for (node, uses) in uses(domain, nodes) {
        let (ns, base) = match node.rsplit_once('/') {
            Some(("", b)) => ("/", b),
            Some((ns, b)) => (ns, b),
            None => ("/", node.as_str()),
        };
        let profile = policy.profile(enclave, ns, base);
        for (access, name) in uses {
            let rule = match access {
                Access::Publish => Rule::allow(Kind::Topics, "publish"),
                Access::Subscribe => Rule::allow(Kind::Topics, "subscribe"),
                Access::Reply => Rule::allow(Kind::Services, "reply"),
                Access::Request => Rule::allow(Kind::Services, "request"),
                Access::Call => Rule::allow(Kind::Actions, "call"),
                Access::Execute => Rule::allow(Kind::Actions, "execute"),
            };
            profile.entry(rule).or_default().insert(name);
        }
    }
    policy.to_xml("what the program declared (radar_ros, RADAR_GENERATE_POLICY)")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_environment_is_read_as_rcl_reads_it() {
        assert_eq!(from_vars(None, None, Some("/k"), None, None).unwrap(), None);
        assert_eq!(
            from_vars(Some("false"), None, Some("/k"), None, None).unwrap(),
            None
        );
        let o = from_vars(
            Some("true"),
            Some("Enforce"),
            Some("/k"),
            None,
            Some("/robot/planner"),
        )
        .unwrap()
        .unwrap();
        assert_eq!(o.strategy, Strategy::Enforce);
        assert_eq!(o.enclave, "/robot/planner");
        assert_eq!(o.enclave_dir(), PathBuf::from("/k/enclaves/robot/planner"));
        let o = from_vars(
            Some("true"),
            Some("enforce"),
            Some("/k"),
            Some("/x"),
            Some("/y"),
        )
        .unwrap()
        .unwrap();
        assert_eq!(
            (o.strategy, o.enclave.as_str()),
            (Strategy::Permissive, "/x"),
            "only `Enforce` enforces; the override wins over --enclave"
        );
        let root = from_vars(Some("true"), None, Some("/k"), None, None)
            .unwrap()
            .unwrap();
        assert_eq!(root.enclave_dir(), PathBuf::from("/k/enclaves"));
        let e = from_vars(Some("true"), Some("Enforce"), None, None, None).unwrap_err();
        assert!(e.to_string().contains("ROS_SECURITY_KEYSTORE"), "{e}");
        assert_eq!(
            from_vars(Some("true"), None, None, None, None).unwrap(),
            None
        );
        let e = from_vars(Some("true"), None, Some("/k"), None, Some("planner")).unwrap_err();
        assert!(e.to_string().contains("absolute"), "{e}");
    }

    #[test]
    fn a_missing_enclave_file_is_named_under_enforce_and_tolerated_under_permissive() {
        let dir = std::env::temp_dir().join(format!("radar_sec_{}", std::process::id()));
        let enclave = dir.join("enclaves/robot");
        std::fs::create_dir_all(&enclave).unwrap();
        for f in &ENCLAVE_FILES[..5] {
            std::fs::write(enclave.join(f), "x").unwrap();
        }
        let mut o = SecurityOptions::enforce(&dir, "/robot");
        let e = locate(&o).unwrap_err().to_string();
        assert!(e.contains("permissions.p7s is missing"), "{e}");
        assert!(e.contains("radar security create_enclave"), "{e}");
        o.strategy = Strategy::Permissive;
        assert_eq!(locate(&o).unwrap(), None);
        std::fs::write(enclave.join("permissions.p7s"), "x").unwrap();
        assert_eq!(locate(&o).unwrap(), Some(enclave));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
