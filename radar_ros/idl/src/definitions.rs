//! Interface definitions found as every ROS 2 tool finds them (`AMENT_PREFIX_PATH`:
//! `<prefix>/share/<pkg>/msg/<Name>.msg`, `srv/<Name>.srv`, `action/<Name>.action`), or in directories given
//! (`<dir>/<pkg>/msg/<Name>.msg`), then in the ones radar_idl ships; read with the `ros2msg` parser, with their
//! nested types across packages.
//!
//! ```
//! use radar_idl::Interfaces;
//! let types = Interfaces::empty();
//! let header = types.definition("std_msgs/msg/Header").unwrap();
//! assert_eq!(types.nested_type(&header.fields[0], "std_msgs"), "builtin_interfaces/msg/Time");
//! ```

use std::{
    collections::HashMap,
    path::PathBuf,
    sync::{Arc, Mutex},
};

use ros2msg::{Field, MessageSpecification};

use crate::is_primitive;

/// Where definitions are looked for, and those read so far.
pub struct Interfaces {
    /// Directories holding `<pkg>/msg/<Name>.msg` (and `srv/`, `action/`), in the order looked in.
    roots: std::sync::RwLock<Vec<PathBuf>>,
    /// Each type read so far: its definition, and its text as written (for schemas).
    read: Mutex<HashMap<String, Read>>,
    /// The files read so far (a build script reruns when one changes).
    files: Mutex<std::collections::BTreeSet<PathBuf>>,
}

/// A type read: its definition, and its text as written.
type Read = (Arc<MessageSpecification>, Arc<str>);

impl std::fmt::Debug for Interfaces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Interfaces")
            .field("roots", &*self.roots.read().unwrap())
            .finish()
    }
}

/// A type name taken apart: `pkg/msg/Name`, `pkg/srv/Name_Request`, `pkg/action/Name_Goal`, or a field's
/// `pkg/Name` (a message).
struct TypeName<'a> {
    pkg: &'a str,
    kind: &'a str,
    name: &'a str,
}

fn split(ros_type: &str) -> Result<TypeName<'_>, String> {
    let parts: Vec<&str> = ros_type.split('/').collect();
    match parts[..] {
        [pkg, kind @ ("msg" | "srv" | "action"), name] => Ok(TypeName { pkg, kind, name }),
        [pkg, name] => Ok(TypeName {
            pkg,
            kind: "msg",
            name,
        }),
        _ => Err(format!(
            "{ros_type} is no ROS type name: write it as pkg/msg/Name (or pkg/srv/Name_Request, pkg/action/Name_Goal)"
        )),
    }
}

impl Interfaces {
    /// Definitions looked for as ROS 2 tools look: in `share/` of every prefix of `AMENT_PREFIX_PATH`, then in
    /// the interfaces radar_ros ships (std_msgs, builtin_interfaces, geometry_msgs, sensor_msgs, nav_msgs,
    /// std_srvs, action_msgs, unique_identifier_msgs, diagnostic_msgs, service_msgs).
    pub fn from_env() -> Interfaces {
        let roots = std::env::var_os("AMENT_PREFIX_PATH")
            .map(|p| {
                std::env::split_paths(&p)
                    .map(|prefix| prefix.join("share"))
                    .collect()
            })
            .unwrap_or_default();
        Interfaces {
            roots: std::sync::RwLock::new(roots),
            read: Mutex::new(HashMap::new()),
            files: Mutex::default(),
        }
    }

    /// Definitions of the interfaces radar_ros ships only, whatever the environment says.
    pub fn empty() -> Interfaces {
        Interfaces {
            roots: std::sync::RwLock::new(Vec::new()),
            read: Mutex::new(HashMap::new()),
            files: Mutex::default(),
        }
    }

    /// Also looks in `dir` (holding `<pkg>/msg/<Name>.msg`, ...), before the others.
    #[must_use]
    pub fn with_dir(self, dir: impl Into<PathBuf>) -> Interfaces {
        self.add_dir(dir);
        self
    }

    /// Looks in `dir` too (holding `<pkg>/msg/<Name>.msg`, ...), before the others, from now on. Types read
    /// already stay as they were read.
    pub fn add_dir(&self, dir: impl Into<PathBuf>) {
        self.roots.write().unwrap().insert(0, dir.into());
    }

    /// The interfaces of package `pkg` as `(kind, Name)` (`("msg", "Point")`, `("srv", "Trigger")`,
    /// `("action", "Fibonacci")`), sorted: from the first directory that has the package, else from the ones
    /// shipped. An error names every place looked in.
    pub fn interfaces_of(&self, pkg: &str) -> Result<Vec<(String, String)>, String> {
        let roots = self.roots.read().unwrap().clone();
        for root in &roots {
            let dir = root.join(pkg);
            if !dir.is_dir() {
                continue;
            }
            let mut found = Vec::new();
            for kind in ["msg", "srv", "action"] {
                let Ok(entries) = std::fs::read_dir(dir.join(kind)) else {
                    continue;
                };
                for e in entries.flatten() {
                    let p = e.path();
                    if p.extension().is_some_and(|x| x == kind) {
                        if let Some(stem) = p.file_stem() {
                            found.push((kind.to_owned(), stem.to_string_lossy().into_owned()));
                        }
                    }
                }
            }
            if !found.is_empty() {
                found.sort();
                return Ok(found);
            }
        }
        let shipped = crate::bundled::interfaces_of(pkg);
        if shipped.is_empty() {
            return Err(format!(
                "no interface package {pkg}: looked in {} and in the interfaces radar_ros ships ({}) (source the \
                 ROS 2 installation that has it, set AMENT_PREFIX_PATH, or give the directory that holds {pkg}/msg/)",
                if roots.is_empty() {
                    "no directory (AMENT_PREFIX_PATH is not set)".to_owned()
                } else {
                    roots
                        .iter()
                        .map(|p| p.join(pkg).display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                },
                crate::bundled::packages().join(", ")
            ));
        }
        Ok(shipped)
    }

    /// The definition files read from disk so far (not those shipped), for a build script's
    /// `cargo:rerun-if-changed`.
    pub fn files_read(&self) -> Vec<PathBuf> {
        self.files.lock().unwrap().iter().cloned().collect()
    }

    /// The directories looked in, in order (then the interfaces shipped).
    pub fn roots(&self) -> Vec<PathBuf> {
        self.roots.read().unwrap().clone()
    }

    /// The definition of `ros_type`, read once.
    pub fn definition(&self, ros_type: &str) -> Result<Arc<MessageSpecification>, String> {
        self.read_once(ros_type).map(|(spec, _)| spec)
    }

    fn read_once(&self, ros_type: &str) -> Result<Read, String> {
        if let Some(s) = self.read.lock().unwrap().get(ros_type) {
            return Ok(s.clone());
        }
        let t = split(ros_type)?;
        let (spec, text) = self.read_definition(ros_type, &t)?;
        let read = (Arc::new(spec), Arc::<str>::from(text));
        self.read
            .lock()
            .unwrap()
            .insert(ros_type.to_owned(), read.clone());
        Ok(read)
    }

    /// The `ros2msg` schema of `ros_type` as rosbag2 stores it in MCAP: its definition as written, then each
    /// type it uses (at any depth, once), after a separator line and `MSG: pkg/Name`.
    pub fn schema(&self, ros_type: &str) -> Result<String, String> {
        const SEPARATOR: &str =
            "================================================================================";
        let (_, text) = self.read_once(ros_type)?;
        let mut out = text.to_string();
        let mut seen = std::collections::BTreeSet::new();
        let mut todo = self.nested_of(ros_type)?;
        while let Some(t) = todo.pop() {
            if !seen.insert(t.clone()) {
                continue;
            }
            let (_, text) = self.read_once(&t)?;
            let short = t.replacen("/msg/", "/", 1);
            out.push_str(&format!("{SEPARATOR}\nMSG: {short}\n{text}"));
            let mut more = self.nested_of(&t)?;
            more.reverse();
            todo.extend(more);
        }
        Ok(out)
    }

    /// The message types the fields of `ros_type` use, in field order (last first, to pop).
    fn nested_of(&self, ros_type: &str) -> Result<Vec<String>, String> {
        let spec = self.definition(ros_type)?;
        let mut v: Vec<String> = spec
            .fields
            .iter()
            .filter(|f| !is_primitive(&f.field_type.base_type.type_name))
            .map(|f| self.nested_type(f, &spec.pkg_name))
            .collect();
        v.reverse();
        Ok(v)
    }

    fn read_definition(
        &self,
        ros_type: &str,
        t: &TypeName<'_>,
    ) -> Result<(MessageSpecification, String), String> {
        let (file, part) = match t.kind {
            "srv" => split_part(t.name, &["_Request", "_Response"], "srv", ros_type)?,
            "action" => split_part(
                t.name,
                &["_Goal", "_Result", "_Feedback"],
                "action",
                ros_type,
            )?,
            _ => (format!("{}.msg", t.name), ""),
        };
        let looked: Vec<PathBuf> = self
            .roots
            .read()
            .unwrap()
            .iter()
            .map(|r| r.join(t.pkg).join(t.kind).join(&file))
            .collect();
        let bundled_path = format!("{}/{}/{file}", t.pkg, t.kind);
        let (text, origin) = match looked.iter().find(|p| p.is_file()) {
            Some(path) => {
                self.files.lock().unwrap().insert(path.clone());
                (
                    std::fs::read_to_string(path)
                        .map_err(|e| format!("{}: {e}", path.display()))?,
                    path.display().to_string(),
                )
            }
            None => match crate::bundled::find(&bundled_path) {
                Some(text) => (
                    text.to_owned(),
                    format!("radar_ros's bundled {bundled_path}"),
                ),
                None => return Err(not_found(ros_type, t, &file, &looked)),
            },
        };
        let bad = |e: ros2msg::ParseError| format!("{origin}: {e}");
        let base = file.rsplit_once('.').map_or(file.as_str(), |(b, _)| b);
        let section = |i: usize| {
            text.split("\n---")
                .nth(i)
                .map(|s| s.trim_start_matches('\n').to_owned())
                .unwrap_or_default()
        };
        Ok(match (t.kind, part) {
            ("srv", p) => {
                let s = ros2msg::parse_service_string(t.pkg, base, &text).map_err(bad)?;
                if p == "_Request" {
                    (s.request, section(0))
                } else {
                    (s.response, section(1))
                }
            }
            ("action", p) => {
                let a = ros2msg::parse_action_string(t.pkg, base, &text).map_err(bad)?;
                match p {
                    "_Goal" => (a.goal, section(0)),
                    "_Result" => (a.result, section(1)),
                    _ => (a.feedback, section(2)),
                }
            }
            _ => (
                ros2msg::parse_message_string(t.pkg, t.name, &text).map_err(bad)?,
                text.clone(),
            ),
        })
    }

    /// The ROS name (`pkg/msg/Name`) of the message type of `field`, a field of a type of `in_pkg`.
    pub fn nested_type(&self, field: &Field, in_pkg: &str) -> String {
        let b = &field.field_type.base_type;
        format!(
            "{}/msg/{}",
            b.pkg_name.as_deref().unwrap_or(in_pkg),
            b.type_name
        )
    }
}

/// What to do when `ros_type`'s definition is nowhere: every place looked in, and the bundled packages.
fn not_found(ros_type: &str, t: &TypeName<'_>, file: &str, looked: &[PathBuf]) -> String {
    format!(
        "no definition of {ros_type}: looked in {} and in the interfaces radar_ros ships ({}) (source the ROS 2 \
         installation that has {}, set AMENT_PREFIX_PATH, or give the directory that holds {}/{}/{file})",
        if looked.is_empty() {
            "no directory (AMENT_PREFIX_PATH is not set)".to_owned()
        } else {
            looked
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        },
        crate::bundled::packages().join(", "),
        t.pkg,
        t.pkg,
        t.kind
    )
}

/// `Name_Request` -> (`Name.srv`, `_Request`).
fn split_part<'a>(
    name: &str,
    parts: &[&'a str],
    ext: &str,
    ros_type: &str,
) -> Result<(String, &'a str), String> {
    parts
        .iter()
        .find_map(|p| {
            name.strip_suffix(p)
                .map(|base| (format!("{base}.{ext}"), *p))
        })
        .ok_or_else(|| {
            format!(
                "{ros_type}: a {ext} type is one of its parts ({})",
                parts.join(", ")
            )
        })
}
