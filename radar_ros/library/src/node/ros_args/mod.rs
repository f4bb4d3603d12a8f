//! ROS 2 command-line arguments (`--ros-args ... [--]`), read as rcl reads them, so that a radar_ros program
//! started by `ros2 run` or `ros2 launch` takes its namespace, name, remappings, parameters and log level
//! from where every ROS 2 node takes them.
//!
//! ```text
//! my_program [own args] --ros-args -r __ns:=/robot1 -r __node:=patrol -r dock:=dock_left \
//!     -p period:=0.5 --params-file robot.yaml --log-level debug [-- more own args]
//! ```
//!
//! What each one does in radar_ros:
//! - `-r __ns:=/ns`: the namespace relative component and topic names resolve in (every component spawned with a
//!   relative name becomes a node under it; absolute names stay where they point, as absolute topics do in ROS).
//! - `-r __node:=name` (or `__name`): the program node's name (the node that shows the program's connections).
//!   Components keep their own names: each is a node of its own.
//! - `-r from:=to`: a name remapped: component names (spawned and looked up) and plain topic names, after
//!   expansion against the namespace (`~` is the program node). The first matching rule wins, as in rcl. A rule
//!   `node:from:=to` applies only when `node` is the program node's name. A component's endpoints follow its
//!   name: remap `/dock:=/left/dock`, not `/dock/start`.
//! - `-p name:=value` (YAML value) and `--params-file file.yaml` (`/**:`, `node:`, `/ns/node:` keys with
//!   `ros__parameters:`; `*` one token, `**` any): parameter overrides, in command-line order, the later winning.
//!   [`RosArgs::parameters_for`] gives those of one node.
//! - `--log-level [logger:=]level`: [`RosArgs::log_level`].
//! - `-e`/`--enclave`, `--log-file-name`, `--{enable,disable}-{stdout,rosout,external-lib}-logs`: accepted
//!   (security enclaves are not supported yet; logs always go to stderr through `tracing`). `--log-config-file`
//!   is refused, as rcl's default logging backend refuses it.
//! - Anything else after `--ros-args`: an error naming it (rclcpp and rclpy refuse unknown ROS arguments too).
//!
//! Arguments outside `--ros-args ... --` are the program's own: [`RosArgs::program_args`].

use std::collections::BTreeMap;

pub use ros2_client::ParameterValue;

use crate::error::{Error, Result};

mod values;

pub(crate) use values::valid_param_name;
use values::{absolute, check_param_name, node_matches, parse_value, read_params_file};

/// One remapping rule `[node:]from:=to`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Remap {
    /// The node it is limited to (`node:` prefix), if any.
    pub node: Option<String>,
    /// What it replaces: `__ns`, `__node`, or a name (relative, absolute or `~`).
    pub from: String,
    /// What it replaces it with.
    pub to: String,
}

/// A log severity as `--log-level` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum LogLevel {
    /// `unset`: the logger's parent decides.
    Unset,
    /// `debug`
    Debug,
    /// `info`
    Info,
    /// `warn`
    Warn,
    /// `error`
    Error,
    /// `fatal`
    Fatal,
}

impl LogLevel {
    fn parse(s: &str) -> Option<LogLevel> {
        Some(match s.to_ascii_lowercase().as_str() {
            "unset" => LogLevel::Unset,
            "debug" => LogLevel::Debug,
            "info" => LogLevel::Info,
            "warn" => LogLevel::Warn,
            "error" => LogLevel::Error,
            "fatal" => LogLevel::Fatal,
            _ => return None,
        })
    }

    /// The level's name as `tracing`'s `EnvFilter` reads it (`fatal` is `error`, `unset` is `info`).
    pub fn as_filter(self) -> &'static str {
        match self {
            LogLevel::Debug => "debug",
            LogLevel::Unset | LogLevel::Info => "info",
            LogLevel::Warn => "warn",
            LogLevel::Error | LogLevel::Fatal => "error",
        }
    }
}

/// A parameters file's entries: a node pattern and the parameters it sets.
type FileEntries = Vec<(String, Vec<(String, ParameterValue)>)>;

/// Where a parameter override came from, in command-line order.
#[derive(Clone, Debug)]
enum Source {
    /// `-p [node:]name:=value`: every node, or those the node pattern names.
    Param(Option<String>, String, ParameterValue),
    /// `--params-file`: the file's node patterns and their parameters.
    File(FileEntries),
}

/// The ROS arguments of a process (see the [module docs](self)).
#[derive(Clone, Debug, Default)]
pub struct RosArgs {
    remaps: Vec<Remap>,
    params: Vec<Source>,
    log_levels: Vec<(Option<String>, LogLevel)>,
    enclave: Option<String>,
    program_args: Vec<String>,
}

/// `-p [node:]name:=value`.
fn param_arg(v: &str) -> Result<Source> {
    let (lhs, val) = v
        .split_once(":=")
        .ok_or_else(|| bad(v, "a parameter is [node:]name:=value (e.g. -p period:=0.5)"))?;
    let (node, name) = match lhs.split_once(':') {
        Some((n, p)) => (Some(absolute(n)), p),
        None => (None, lhs),
    };
    check_param_name(name, v)?;
    Ok(Source::Param(node, name.to_owned(), parse_value(val, v)?))
}

/// `--log-level [logger:=]level`.
fn log_level_arg(v: &str) -> Result<(Option<String>, LogLevel)> {
    let (logger, level) = match v.split_once(":=") {
        Some((l, lv)) => (Some(l.to_owned()), lv),
        None => (None, v),
    };
    let level = LogLevel::parse(level)
        .ok_or_else(|| bad(v, "a log level is debug, info, warn, error, fatal or unset"))?;
    Ok((logger, level))
}

fn bad(arg: &str, reason: impl Into<String>) -> Error {
    Error::Config {
        setting: "--ros-args",
        value: arg.to_owned(),
        reason: reason.into(),
    }
}

impl RosArgs {
    /// The ROS arguments of this process (`std::env::args`).
    pub fn from_env() -> Result<RosArgs> {
        RosArgs::parse(std::env::args())
    }

    /// Reads `args` (the program's name first, as `std::env::args` gives it).
    ///
    /// ```
    /// use radar_ros::ros_args::RosArgs;
    /// let a = RosArgs::parse(["prog", "--fast", "--ros-args", "-r", "__ns:=/robot1", "--", "x"])?;
    /// assert_eq!(a.namespace("prog"), Some("/robot1"));
    /// assert_eq!(a.program_args(), ["prog", "--fast", "x"]);
    /// assert!(RosArgs::parse(["prog", "--ros-args", "--verbose"]).is_err());
    /// # Ok::<(), radar_ros::Error>(())
    /// ```
    pub fn parse<I, S>(args: I) -> Result<RosArgs>
    where
        I: IntoIterator<Item = S>,
        S: AsRef<str>,
    {
        let args: Vec<String> = args.into_iter().map(|s| s.as_ref().to_owned()).collect();
        let mut out = RosArgs::default();
        let mut i = 0;
        let mut in_ros = false;
        let mut unknown = Vec::new();
        while i < args.len() {
            let a = args[i].as_str();
            i += 1;
            if !in_ros {
                if a == "--ros-args" {
                    in_ros = true;
                } else {
                    out.program_args.push(a.to_owned());
                }
                continue;
            }
            let mut value = |flag: &str| -> Result<String> {
                let v = args
                    .get(i)
                    .cloned()
                    .ok_or_else(|| bad(flag, format!("{flag} needs a value after it")))?;
                i += 1;
                Ok(v)
            };
            match a {
                "--" => in_ros = false,
                "--ros-args" => {}
                "-r" | "--remap" => {
                    let v = value(a)?;
                    out.remaps.push(parse_remap(&v)?);
                }
                "-p" | "--param" => out.params.push(param_arg(&value(a)?)?),
                "--params-file" => {
                    let path = value(a)?;
                    out.params.push(Source::File(read_params_file(&path)?));
                }
                "--log-level" => out.log_levels.push(log_level_arg(&value(a)?)?),
                "-e" | "--enclave" => out.enclave = Some(value(a)?),
                "--log-config-file" => {
                    let f = value(a)?;
                    return Err(bad(
                        &f,
                        "--log-config-file is not supported: radar_ros logs through `tracing` (RUST_LOG, \
                         --log-level); rcl's default spdlog backend refuses a config file as well",
                    ));
                }
                "--log-file-name" => {
                    value(a)?;
                }
                "--enable-stdout-logs"
                | "--disable-stdout-logs"
                | "--enable-rosout-logs"
                | "--disable-rosout-logs"
                | "--enable-external-lib-logs"
                | "--disable-external-lib-logs" => {}
                other => unknown.push(other.to_owned()),
            }
        }
        if !unknown.is_empty() {
            return Err(bad(
                &unknown.join(" "),
                "unknown ROS arguments: after --ros-args come only -r/--remap, -p/--param, --params-file, \
                 --log-level, -e/--enclave, --log-config-file and --enable-/--disable-*-logs; put the \
                 program's own arguments before --ros-args or after a closing --",
            ));
        }
        Ok(out)
    }

    /// The arguments that are the program's own (its name first), without any ROS argument.
    pub fn program_args(&self) -> &[String] {
        &self.program_args
    }

    /// The remapping rules, in order.
    pub fn remaps(&self) -> &[Remap] {
        &self.remaps
    }

    /// The enclave given with `-e`/`--enclave`.
    pub fn enclave(&self) -> Option<&str> {
        self.enclave.as_deref()
    }

    /// The level `--log-level` sets for all loggers (the last one without a logger name).
    pub fn log_level(&self) -> Option<LogLevel> {
        self.log_levels
            .iter()
            .rev()
            .find(|(l, _)| l.is_none())
            .map(|(_, lv)| *lv)
    }

    /// The `--log-level` settings as a `tracing_subscriber::EnvFilter` directive (`debug,radar_ros=warn`: a
    /// logger `a.b` is the tracing target `a::b`), or `None` when none was given.
    ///
    /// ```
    /// use radar_ros::ros_args::RosArgs;
    /// let a = RosArgs::parse(["p", "--ros-args", "--log-level", "debug", "--log-level", "radar_ros.event:=error"])?;
    /// assert_eq!(a.tracing_filter().as_deref(), Some("debug,radar_ros::event=error"));
    /// # Ok::<(), radar_ros::Error>(())
    /// ```
    pub fn tracing_filter(&self) -> Option<String> {
        if self.log_levels.is_empty() {
            return None;
        }
        let mut parts: Vec<String> = self
            .log_level()
            .map(|l| l.as_filter().to_owned())
            .into_iter()
            .collect();
        parts.extend(
            self.logger_levels()
                .map(|(l, lv)| format!("{}={}", l.replace('.', "::"), lv.as_filter())),
        );
        Some(parts.join(","))
    }

    /// The levels `--log-level logger:=level` sets for named loggers.
    pub fn logger_levels(&self) -> impl Iterator<Item = (&str, LogLevel)> {
        self.log_levels
            .iter()
            .filter_map(|(l, lv)| l.as_deref().map(|l| (l, *lv)))
    }

    fn special(&self, node: &str, key: &str) -> Option<&str> {
        self.remaps
            .iter()
            .filter(|r| r.from == key && r.node.as_deref().is_none_or(|n| n == node))
            .map(|r| r.to.as_str())
            .next()
    }

    /// The namespace `-r __ns:=` gives the node named `node` (the first rule that applies).
    pub fn namespace(&self, node: &str) -> Option<&str> {
        self.special(node, "__ns")
    }

    /// The name `-r __node:=` (or `__name:=`) gives the node named `node`.
    pub fn node_name(&self, node: &str) -> Option<&str> {
        self.remaps
            .iter()
            .filter(|r| {
                (r.from == "__node" || r.from == "__name")
                    && r.node.as_deref().is_none_or(|n| n == node)
            })
            .map(|r| r.to.as_str())
            .next()
    }

    /// The name the fully qualified `name` is remapped to, seen from the node `node_name` in `node_ns` (the
    /// first rule whose expanded `from` is `name`), or `None` when no rule applies.
    ///
    /// ```
    /// use radar_ros::ros_args::RosArgs;
    /// let a = RosArgs::parse(["p", "--ros-args", "-r", "dock:=/left/dock"])?;
    /// assert_eq!(a.remap_name("/robot/dock", "p", "/robot").as_deref(), Some("/left/dock"));
    /// assert_eq!(a.remap_name("/dock", "p", "/robot"), None);
    /// # Ok::<(), radar_ros::Error>(())
    /// ```
    pub fn remap_name(&self, name: &str, node_name: &str, node_ns: &str) -> Option<String> {
        self.remaps
            .iter()
            .filter(|r| !r.from.starts_with("__"))
            .filter(|r| r.node.as_deref().is_none_or(|n| n == node_name))
            .find(|r| expand(&r.from, node_ns, node_name) == name)
            .map(|r| expand(&r.to, node_ns, node_name))
    }

    /// `name` as the node `node_name` in `node_ns` would use it: expanded (`~`, relative names) and remapped.
    ///
    /// ```
    /// use radar_ros::ros_args::RosArgs;
    /// let a = RosArgs::parse(["p", "--ros-args", "-r", "cmd:=/base/cmd"])?;
    /// assert_eq!(a.resolve_name("cmd", "p", "/robot"), "/base/cmd");
    /// assert_eq!(a.resolve_name("~/status", "p", "/robot"), "/robot/p/status");
    /// # Ok::<(), radar_ros::Error>(())
    /// ```
    pub fn resolve_name(&self, name: &str, node_name: &str, node_ns: &str) -> String {
        let fq = expand(name, node_ns, node_name);
        self.remap_name(&fq, node_name, node_ns).unwrap_or(fq)
    }

    /// The parameter overrides of the node with the fully qualified name `node_fq`: every `-p`, and every
    /// `--params-file` entry whose key matches it, in command-line order (a later one wins).
    pub fn parameters_for(&self, node_fq: &str) -> BTreeMap<String, ParameterValue> {
        let mut out = BTreeMap::new();
        for s in &self.params {
            match s {
                Source::Param(node, n, v) => {
                    if node.as_deref().is_none_or(|p| node_matches(p, node_fq)) {
                        out.insert(n.clone(), v.clone());
                    }
                }
                Source::File(nodes) => {
                    for (pattern, params) in nodes {
                        if node_matches(pattern, node_fq) {
                            for (n, v) in params {
                                out.insert(n.clone(), v.clone());
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

/// `name` made absolute as rcl expands names: `~` is the node's fully qualified name, a relative name goes in
/// the node's namespace; `rostopic://` and `rosservice://` prefixes are dropped.
fn expand(name: &str, ns: &str, node: &str) -> String {
    let name = name
        .strip_prefix("rostopic://")
        .or_else(|| name.strip_prefix("rosservice://"))
        .unwrap_or(name);
    let ns = ns.trim_end_matches('/');
    if name.starts_with('/') {
        name.to_owned()
    } else if name == "~" {
        format!("{ns}/{node}")
    } else if let Some(rest) = name.strip_prefix("~/") {
        format!("{ns}/{node}/{rest}")
    } else {
        format!("{ns}/{name}")
    }
}

fn parse_remap(rule: &str) -> Result<Remap> {
    let (lhs, to) = rule.split_once(":=").ok_or_else(|| {
        bad(
            rule,
            "a remapping rule is [node:]from:=to (e.g. -r __ns:=/robot1)",
        )
    })?;
    // a `node:` prefix, but not a URL scheme's `rostopic://`
    let (node, from) = match lhs.split_once(':') {
        Some((n, f)) if !f.starts_with("//") => (Some(n.to_owned()), f.to_owned()),
        _ => (None, lhs.to_owned()),
    };
    if from.is_empty() || to.is_empty() {
        return Err(bad(rule, "a remapping rule needs both sides: from:=to"));
    }
    let token = |s: &str| {
        !s.is_empty()
            && !s.starts_with(|c: char| c.is_ascii_digit())
            && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    match from.as_str() {
        "__ns" => {
            if !to.starts_with('/') {
                return Err(bad(rule, "a namespace is absolute: __ns:=/robot1"));
            }
            if to != "/" && (to.ends_with('/') || !to[1..].split('/').all(token)) {
                return Err(bad(
                    rule,
                    "a namespace is /name[/name...] with letters, digits and _ (not starting with a digit)",
                ));
            }
        }
        "__node" | "__name" if !token(to) => {
            return Err(bad(
                rule,
                "a node name is one token of letters, digits and _ (not starting with a digit)",
            ));
        }
        "__node" | "__name" => {}
        f if f.starts_with("__") => {
            return Err(bad(
                rule,
                "only __ns, __node and __name are special names to remap",
            ));
        }
        _ => {}
    }
    if let Some(n) = &node {
        if !token(n) {
            return Err(bad(rule, "the node a rule is limited to is one name token"));
        }
    }
    Ok(Remap {
        node,
        from,
        to: to.to_owned(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(args: &[&str]) -> RosArgs {
        let mut v = vec!["prog"];
        v.extend_from_slice(args);
        RosArgs::parse(v).unwrap()
    }

    #[test]
    fn sections_split_program_and_ros_arguments() {
        let a = p(&[
            "a",
            "--ros-args",
            "-r",
            "__ns:=/r1",
            "--",
            "b",
            "--ros-args",
            "-p",
            "x:=1",
        ]);
        assert_eq!(a.program_args(), ["prog", "a", "b"]);
        assert_eq!(a.namespace("prog"), Some("/r1"));
        assert_eq!(
            a.parameters_for("/r1/prog").get("x"),
            Some(&ParameterValue::Integer(1))
        );
        // no --ros-args: everything is the program's, `--` included
        assert_eq!(p(&["--", "-r"]).program_args(), ["prog", "--", "-r"]);
    }

    #[test]
    fn unknown_and_malformed_arguments_are_errors_that_say_what_is_allowed() {
        for bad in [
            vec!["--ros-args", "--verbose"],
            vec!["--ros-args", "-r"],
            vec!["--ros-args", "-r", "nope"],
            vec!["--ros-args", "-r", "__ns:=relative"],
            vec!["--ros-args", "-r", "__node:=a/b"],
            vec!["--ros-args", "-r", "__foo:=x"],
            vec!["--ros-args", "-p", "novalue"],
            vec!["--ros-args", "-p", "x:=[1, a]"],
            vec!["--ros-args", "-p", "x:=[1, 2.5]"],
            vec!["--ros-args", "--log-config-file", "log.conf"],
            vec!["--ros-args", "--log-level", "loud"],
            vec!["--ros-args", "--params-file", "/nonexistent/radar.yaml"],
        ] {
            let mut v = vec!["prog"];
            v.extend(bad.iter());
            let e = RosArgs::parse(v).unwrap_err().to_string();
            assert!(e.contains("--ros-args"), "{bad:?}: {e}");
        }
    }

    #[test]
    fn node_specific_rules_apply_to_their_node_only_and_the_first_rule_wins() {
        let a = p(&[
            "--ros-args",
            "-r",
            "other:__ns:=/o",
            "-r",
            "__ns:=/all",
            "-r",
            "__ns:=/late",
            "-r",
            "prog:__node:=renamed",
        ]);
        assert_eq!(a.namespace("other"), Some("/o"));
        assert_eq!(a.namespace("prog"), Some("/all"));
        assert_eq!(a.node_name("prog"), Some("renamed"));
        assert_eq!(a.node_name("other"), None);
    }

    #[test]
    fn names_are_remapped_after_expansion() {
        let a = p(&[
            "--ros-args",
            "-r",
            "dock:=left/dock",
            "-r",
            "~/status:=/status",
            "-r",
            "rostopic:///cmd:=/robot/cmd",
            "-r",
            "other:/x:=/y",
        ]);
        assert_eq!(
            a.remap_name("/r/dock", "prog", "/r").as_deref(),
            Some("/r/left/dock")
        );
        assert_eq!(a.remap_name("/dock", "prog", "/r"), None);
        assert_eq!(
            a.remap_name("/r/prog/status", "prog", "/r").as_deref(),
            Some("/status")
        );
        assert_eq!(
            a.remap_name("/cmd", "prog", "/").as_deref(),
            Some("/robot/cmd")
        );
        assert_eq!(a.remap_name("/x", "prog", "/"), None, "limited to `other`");
        assert_eq!(a.remap_name("/x", "other", "/").as_deref(), Some("/y"));
    }

    #[test]
    fn parameter_values_are_read_as_rcl_reads_them() {
        use ParameterValue as V;
        let cases: &[(&str, V)] = &[
            ("1", V::Integer(1)),
            ("-3", V::Integer(-3)),
            ("0.5", V::Double(0.5)),
            ("1e3", V::Double(1000.0)),
            ("true", V::Boolean(true)),
            ("yes", V::Boolean(true)),
            ("Off", V::Boolean(false)),
            ("'yes'", V::String("yes".into())),
            ("hello", V::String("hello".into())),
            ("'1'", V::String("1".into())),
            ("[1, 2]", V::IntegerArray(vec![1, 2])),
            ("[1.0, 2.5]", V::DoubleArray(vec![1.0, 2.5])),
            ("[a, b]", V::StringArray(vec!["a".into(), "b".into()])),
            ("[true, false]", V::BooleanArray(vec![true, false])),
        ];
        for (text, want) in cases {
            assert_eq!(&parse_value(text, text).unwrap(), want, "{text}");
        }
    }

    #[test]
    fn params_file_keys_match_nodes_with_wildcards_and_later_sources_win() {
        let dir = std::env::temp_dir().join(format!("radar_ros_args_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("p.yaml");
        std::fs::write(
            &f,
            "/**:\n  ros__parameters:\n    period: 0.5\n    limits: {low: 1, high: 9}\n\
             count_up:\n  ros__parameters:\n    limit: 10\n\
             /robot1/*:\n  ros__parameters:\n    robot: one\n\
             /**/timer:\n  ros__parameters:\n    interval: 2\n",
        )
        .unwrap();
        let a = p(&[
            "--ros-args",
            "-p",
            "limit:=3",
            "--params-file",
            f.to_str().unwrap(),
            "-p",
            "period:=0.25",
        ]);
        let cu = a.parameters_for("/count_up");
        assert_eq!(
            cu.get("limit"),
            Some(&ParameterValue::Integer(10)),
            "the file came after -p"
        );
        assert_eq!(
            cu.get("period"),
            Some(&ParameterValue::Double(0.25)),
            "the -p after the file"
        );
        assert_eq!(cu.get("limits.high"), Some(&ParameterValue::Integer(9)));
        assert_eq!(cu.get("robot"), None);
        let r1 = a.parameters_for("/robot1/count_up");
        assert_eq!(r1.get("robot"), Some(&ParameterValue::String("one".into())));
        assert_eq!(
            r1.get("limit"),
            Some(&ParameterValue::Integer(3)),
            "count_up: is /count_up only"
        );
        assert_eq!(
            a.parameters_for("/a/b/timer").get("interval"),
            Some(&ParameterValue::Integer(2))
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn log_levels_global_and_per_logger() {
        let a = p(&[
            "--ros-args",
            "--log-level",
            "DEBUG",
            "--log-level",
            "radar:=warn",
        ]);
        assert_eq!(a.log_level(), Some(LogLevel::Debug));
        assert_eq!(
            a.logger_levels().collect::<Vec<_>>(),
            [("radar", LogLevel::Warn)]
        );
        assert_eq!(p(&[]).log_level(), None);
    }
}
