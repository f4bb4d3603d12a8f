//! Rust types generated from ROS 2 interface definitions, in a crate's build script.
//!
//! ```toml
//! # Cargo.toml
//! [dependencies]
//! radar_ros = { path = "..." }
//! [build-dependencies]
//! radar_idl = { path = "..." }
//! ```
//!
//! ```no_run
//! // build.rs: geometry_msgs from the sourced ROS 2 installation (or the copy radar_idl ships), and every
//! // package under interfaces/ (interfaces/my_robot/action/Dock.action, ...)
//! radar_idl::rust::Generator::new()
//!     .package("geometry_msgs")
//!     .dir("interfaces")
//!     .write("interfaces.rs")
//!     .unwrap_or_else(|e| panic!("{e}"));
//! ```
//!
//! ```text
//! // src/main.rs
//! mod interfaces {
//!     include!(concat!(env!("OUT_DIR"), "/interfaces.rs"));
//! }
//! use interfaces::{geometry_msgs::msg::PoseStamped, my_robot::action::Dock};
//! ```
//!
//! Each package becomes a module with `msg`, `srv` and `action` modules, as rclcpp and rclpy lay them out. A
//! message is a struct with the definition's fields in order (CDR carries no names), its comments as docs, its
//! constants as associated constants, `Default` giving the definition's default values, `Debug`, `Clone`,
//! `PartialEq` (and `Copy` and `Eq` where every field allows them), serde for the wire and
//! `radar_ros::msg::RosMessage` with its RIHS01 type hash. A service `Name` gives `Name_Request`,
//! `Name_Response` and a `Name` implementing `radar_ros::msg::RosService`; an action gives `Name_Goal`,
//! `Name_Result`, `Name_Feedback` and a `Name` implementing `radar_ros::action::Action`. Packages a generated
//! one uses are generated too, except those radar_ros ships compiled (`radar_ros::interfaces::<pkg>`): those
//! are used from there, so a generated `PoseStamped`'s `header` is radar_ros's `std_msgs::msg::Header`
//! (name a shipped package with [`Generator::package`] to generate it here instead). `TYPE_HASHES` lists every
//! generated type's hash by name.

use std::{
    collections::{BTreeMap, BTreeSet, HashMap},
    fmt::Write as _,
    path::{Path, PathBuf},
    sync::Mutex,
};

use ros2msg::{AnnotationValue, Annotations, Field, MessageSpecification, PrimitiveValue, Value};

use crate::{is_primitive, Interfaces};

/// What to generate, and from where.
pub struct Generator {
    interfaces: Interfaces,
    packages: Vec<String>,
    external: BTreeMap<String, String>,
    runtime: String,
    /// Whether a type may derive `Copy` and `Eq`, by ROS type name.
    traits: Mutex<HashMap<String, (bool, bool)>>,
}

impl std::fmt::Debug for Generator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Generator")
            .field("interfaces", &self.interfaces)
            .field("packages", &self.packages)
            .field("external", &self.external)
            .finish()
    }
}

impl Default for Generator {
    fn default() -> Self {
        Generator::new()
    }
}

impl Generator {
    /// Definitions found as ROS 2 tools find them ([`Interfaces::from_env`]); the packages radar_ros ships
    /// compiled are used from `radar_ros::interfaces` unless named with [`Generator::package`].
    pub fn new() -> Generator {
        Generator::with_interfaces(Interfaces::from_env())
    }

    /// Definitions from `interfaces` (e.g. [`Interfaces::empty`]: the shipped ones only, whatever the
    /// environment says).
    pub fn with_interfaces(interfaces: Interfaces) -> Generator {
        Generator {
            interfaces,
            packages: Vec::new(),
            external: crate::bundled::packages()
                .into_iter()
                .map(|p| (p.to_owned(), format!("::radar_ros::interfaces::{p}")))
                .collect(),
            runtime: "::radar_ros".to_owned(),
            traits: Mutex::default(),
        }
    }

    /// Generates every interface of package `pkg` (and the packages it uses).
    #[must_use]
    pub fn package(mut self, pkg: &str) -> Generator {
        self.external.remove(pkg);
        if !self.packages.iter().any(|p| p == pkg) {
            self.packages.push(pkg.to_owned());
        }
        self
    }

    /// Looks for definitions in `dir` first (`<dir>/<pkg>/msg/<Name>.msg`, `srv/`, `action/`), and generates
    /// every package found there.
    #[must_use]
    pub fn dir(mut self, dir: impl AsRef<Path>) -> Generator {
        let dir = dir.as_ref();
        self.interfaces.add_dir(dir);
        let mut found: Vec<String> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| {
                ["msg", "srv", "action"]
                    .iter()
                    .any(|k| e.path().join(k).is_dir())
            })
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        found.sort();
        for pkg in found {
            self = self.package(&pkg);
        }
        self
    }

    /// Takes package `pkg` from Rust module `path` (another crate's generated types, say) instead of
    /// generating it: `.external("my_msgs", "::my_msgs_rs")`.
    #[must_use]
    pub fn external(mut self, pkg: &str, path: &str) -> Generator {
        self.packages.retain(|p| p != pkg);
        self.external.insert(pkg.to_owned(), path.to_owned());
        self
    }

    /// Generates every package used rather than taking the shipped ones from `radar_ros::interfaces` (how
    /// radar_ros generates those), and names radar_ros as `runtime` (`"crate"` inside radar_ros).
    #[doc(hidden)]
    #[must_use]
    pub fn standalone(mut self, runtime: &str) -> Generator {
        self.external.clear();
        self.runtime = runtime.to_owned();
        self
    }

    /// The Rust code: one module per package, at the top level of the file it is written to.
    pub fn generate(&self) -> Result<String, String> {
        let mut todo: Vec<String> = self.packages.clone();
        todo.reverse();
        let mut done = BTreeSet::new();
        let mut hashes = BTreeMap::new();
        // the message types, for READERS (a service or action as a whole is none)
        let mut messages = BTreeSet::new();
        let mut out = String::from(
            "// Generated by radar_idl from ROS 2 interface definitions; do not edit.\n\n",
        );
        while let Some(pkg) = todo.pop() {
            if !done.insert(pkg.clone()) {
                continue;
            }
            let mut uses = BTreeSet::new();
            out.push_str(&self.package_code(&pkg, &mut uses)?);
            for (kind, name) in self.interfaces.interfaces_of(&pkg)? {
                let parts: &[&str] = match kind.as_str() {
                    "msg" => &[""],
                    // the service as a whole: what rmw_zenoh names in a service's key and tokens
                    "srv" => &["", "_Request", "_Response"],
                    _ => &["_Goal", "_Result", "_Feedback"],
                };
                for part in parts {
                    let ty = format!("{pkg}/{kind}/{name}{part}");
                    hashes.insert(ty.clone(), self.interfaces.type_hash(&ty)?);
                    if !(kind == "srv" && part.is_empty()) {
                        messages.insert((ty, format!("{pkg}::{kind}::{name}{part}")));
                    }
                }
            }
            for u in uses.into_iter().rev() {
                if !done.contains(&u) && !self.external.contains_key(&u) {
                    todo.push(u);
                }
            }
        }
        out.push_str(
            "/// The RIHS01 hash of every type generated here, by ROS name (`pkg/msg/Name`), sorted by name.\n\
             #[allow(dead_code)]\npub static TYPE_HASHES: &[(&str, &str)] = &[\n",
        );
        for (ty, hash) in &hashes {
            writeln!(out, "    ({ty:?}, {hash:?}),").unwrap();
        }
        out.push_str("];\n");
        out.push_str(
            "\n/// Whether some bytes are a whole message of each message type generated here (`READERS`), by ROS\n\
             /// name, sorted: what a connection manager checks before it counts a signal as delivered to a slot of\n\
             /// that type (rule C2: a payload its target cannot read is no delivery).\n\
             #[allow(dead_code, clippy::type_complexity)]\npub static READERS: &[(&str, fn(&[u8]) -> bool)] = &[\n",
        );
        for (ty, path) in &messages {
            writeln!(out, "    ({ty:?}, {}::msg::reads::<{path}>),", self.runtime).unwrap();
        }
        out.push_str("];\n");
        Ok(out)
    }

    /// Writes the code to `$OUT_DIR/<file>` (in a build script) and tells Cargo to run the build script again
    /// when a definition read or `AMENT_PREFIX_PATH` changes. Returns the path written.
    pub fn write(&self, file: &str) -> Result<PathBuf, String> {
        let out_dir = std::env::var_os("OUT_DIR")
            .ok_or("OUT_DIR is not set: call Generator::write from a build script (build.rs)")?;
        let code = self.generate()?;
        let path = Path::new(&out_dir).join(file);
        std::fs::write(&path, code).map_err(|e| format!("{}: {e}", path.display()))?;
        println!("cargo:rerun-if-env-changed=AMENT_PREFIX_PATH");
        for root in self.interfaces.roots() {
            if root.is_dir() && !root.starts_with(&out_dir) {
                for pkg in &self.packages {
                    if root.join(pkg).is_dir() {
                        println!("cargo:rerun-if-changed={}", root.join(pkg).display());
                    }
                }
            }
        }
        for f in self.interfaces.files_read() {
            println!("cargo:rerun-if-changed={}", f.display());
        }
        Ok(path)
    }

    fn package_code(&self, pkg: &str, uses: &mut BTreeSet<String>) -> Result<String, String> {
        let all = self.interfaces.interfaces_of(pkg)?;
        let mut out = String::new();
        writeln!(
            out,
            "#[doc = \"`{pkg}`: its messages, services and actions.\"]"
        )
        .unwrap();
        writeln!(
            out,
            "#[allow(dead_code, non_camel_case_types, non_snake_case, non_upper_case_globals, clippy::all, clippy::pedantic)]"
        )
        .unwrap();
        writeln!(out, "pub mod {pkg} {{").unwrap();
        for kind in ["msg", "srv", "action"] {
            let names: Vec<&str> = all
                .iter()
                .filter(|(k, _)| k == kind)
                .map(|(_, n)| n.as_str())
                .collect();
            if names.is_empty() {
                continue;
            }
            let what = match kind {
                "msg" => "messages",
                "srv" => "services and their parts",
                _ => "actions and their parts",
            };
            writeln!(out, "    #[doc = \"The {what} of `{pkg}`.\"]").unwrap();
            writeln!(out, "    pub mod {kind} {{").unwrap();
            for name in names {
                match kind {
                    "msg" => out.push_str(&self.message(&format!("{pkg}/msg/{name}"), uses)?),
                    "srv" => out.push_str(&self.service(pkg, name, uses)?),
                    _ => out.push_str(&self.action(pkg, name, uses)?),
                }
            }
            writeln!(out, "    }}").unwrap();
        }
        writeln!(out, "}}\n").unwrap();
        Ok(out)
    }

    fn service(
        &self,
        pkg: &str,
        name: &str,
        uses: &mut BTreeSet<String>,
    ) -> Result<String, String> {
        let rt = &self.runtime;
        let mut out = String::new();
        for part in ["Request", "Response"] {
            out.push_str(&self.message(&format!("{pkg}/srv/{name}_{part}"), uses)?);
        }
        let hash = self.interfaces.type_hash(&format!("{pkg}/srv/{name}"))?;
        write!(
            out,
            "        #[doc = \"`{pkg}/srv/{name}`: its request is [`{name}_Request`], its response [`{name}_Response`].\"]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        pub struct {name};
        impl {rt}::msg::RosService for {name} {{
            const PACKAGE: &'static str = \"{pkg}\";
            const NAME: &'static str = \"{name}\";
            type Request = {name}_Request;
            type Response = {name}_Response;
            const TYPE_HASH: ::core::option::Option<&'static str> = ::core::option::Option::Some(\"{hash}\");
        }}
"
        )
        .unwrap();
        Ok(out)
    }

    fn action(&self, pkg: &str, name: &str, uses: &mut BTreeSet<String>) -> Result<String, String> {
        let rt = &self.runtime;
        let mut out = String::new();
        for part in ["Goal", "Result", "Feedback"] {
            out.push_str(&self.message(&format!("{pkg}/action/{name}_{part}"), uses)?);
        }
        let hash = |made_up: &str| {
            self.interfaces
                .type_hash(&format!("{pkg}/action/{name}_{made_up}"))
        };
        let (send_goal, get_result, feedback_message) = (
            hash("SendGoal")?,
            hash("GetResult")?,
            hash("FeedbackMessage")?,
        );
        write!(
            out,
            "        #[doc = \"`{pkg}/action/{name}`: its goal is [`{name}_Goal`], its result [`{name}_Result`], its feedback [`{name}_Feedback`].\"]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        pub struct {name};
        impl {rt}::action::Action for {name} {{
            const PACKAGE: &'static str = \"{pkg}\";
            const NAME: &'static str = \"{name}\";
            type Goal = {name}_Goal;
            type Result = {name}_Result;
            type Feedback = {name}_Feedback;
            const TYPE_HASHES: ::core::option::Option<{rt}::action::ActionTypeHashes> =
                ::core::option::Option::Some({rt}::action::ActionTypeHashes {{
                    send_goal: \"{send_goal}\",
                    get_result: \"{get_result}\",
                    feedback_message: \"{feedback_message}\",
                }});
        }}
"
        )
        .unwrap();
        Ok(out)
    }

    /// One struct: `ros_type` is `pkg/msg/Name`, `pkg/srv/Name_Request`, `pkg/action/Name_Goal`, ...
    fn message(&self, ros_type: &str, uses: &mut BTreeSet<String>) -> Result<String, String> {
        let rt = &self.runtime;
        let spec = self.interfaces.definition(ros_type)?;
        let mut parts = ros_type.splitn(3, '/');
        let (pkg, kind, name) = (
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
        );
        let hash = self.interfaces.type_hash(ros_type)?;
        let (copy, eq) = self.traits_of(ros_type)?;
        let mut out = String::new();
        let mut about = comments(&spec.annotations);
        if !about.is_empty() {
            about.push(String::new());
        }
        about.push(format!("`{ros_type}` ({hash})."));
        out.push_str(&doc(&about, 8));
        writeln!(
            out,
            "        #[derive(Clone, Debug, PartialEq{}{}, {rt}::serde::Serialize, {rt}::serde::Deserialize)]",
            if copy { ", Copy" } else { "" },
            if eq { ", Eq" } else { "" }
        )
        .unwrap();
        writeln!(out, "        #[serde(crate = \"{rt}::serde\")]").unwrap();
        writeln!(out, "        pub struct {name} {{").unwrap();
        let defaults = self.fields(&spec, uses, &mut out);
        writeln!(out, "        }}").unwrap();
        self.constants(&spec, name, &mut out);
        writeln!(
            out,
            "        impl ::core::default::Default for {name} {{
            fn default() -> Self {{
                Self {{ {} }}
            }}
        }}
        impl {rt}::msg::RosMessage for {name} {{
            const PACKAGE: &'static str = \"{pkg}\";
            const NAME: &'static str = \"{name}\";
            const INTERFACE: &'static str = \"{kind}\";
            const TYPE_HASH: ::core::option::Option<&'static str> = ::core::option::Option::Some(\"{hash}\");
        }}",
            defaults.join(", ")
        )
        .unwrap();
        Ok(out)
    }

    /// The struct's fields (a placeholder byte for a message without any), written into `out`, and each field's
    /// default, as `Default` sets it.
    fn fields(
        &self,
        spec: &MessageSpecification,
        uses: &mut BTreeSet<String>,
        out: &mut String,
    ) -> Vec<String> {
        let rt = &self.runtime;
        let mut defaults = Vec::new();
        if spec.fields.is_empty() {
            out.push_str(&doc(
                &["ROS 2 puts one byte on the wire for a message without fields.".to_owned()],
                12,
            ));
            writeln!(
                out,
                "            pub structure_needs_at_least_one_member: u8,"
            )
            .unwrap();
            defaults.push("structure_needs_at_least_one_member: 0".to_owned());
        }
        for f in &spec.fields {
            let mut lines = comments(&f.annotations);
            if lines.is_empty() {
                lines.push(format!("`{}`.", f.name));
            }
            out.push_str(&doc(&lines, 12));
            let t = &f.field_type;
            if t.is_array && !t.is_upper_bound && t.array_size.is_some() {
                writeln!(
                    out,
                    "            #[serde(with = \"{rt}::msg::fixed_array\")]"
                )
                .unwrap();
            }
            let field = field_name(&f.name);
            writeln!(
                out,
                "            pub {field}: {},",
                self.field_type(f, &spec.pkg_name, uses)
            )
            .unwrap();
            defaults.push(format!("{field}: {}", self.default_of(f)));
        }
        defaults
    }

    /// The message's constants, as associated constants of `name`, written into `out` (nothing without any).
    fn constants(&self, spec: &MessageSpecification, name: &str, out: &mut String) {
        if !spec.constants.is_empty() {
            writeln!(out, "        impl {name} {{").unwrap();
            for c in &spec.constants {
                let mut lines = comments(&c.annotations);
                if lines.is_empty() {
                    lines.push(format!("`{}`.", c.name));
                }
                out.push_str(&doc(&lines, 12));
                let ty = if c.type_name.starts_with("string") || c.type_name.starts_with("wstring")
                {
                    "&'static str".to_owned()
                } else {
                    self.primitive(&c.type_name)
                };
                writeln!(
                    out,
                    "            pub const {}: {ty} = {};",
                    c.name,
                    constant(&c.type_name, &c.value)
                )
                .unwrap();
            }
            writeln!(out, "        }}").unwrap();
        }
    }

    fn primitive(&self, ty: &str) -> String {
        match ty {
            "string" => "::std::string::String".to_owned(),
            "wstring" => format!("{}::msg::WString", self.runtime),
            other => number(other).unwrap_or(other).to_owned(),
        }
    }

    fn field_type(&self, f: &Field, in_pkg: &str, uses: &mut BTreeSet<String>) -> String {
        let t = &f.field_type;
        let b = &t.base_type;
        let base = if is_primitive(&b.type_name) {
            self.primitive(&b.type_name)
        } else {
            let pkg = b.pkg_name.as_deref().unwrap_or(in_pkg);
            uses.insert(pkg.to_owned());
            match self.external.get(pkg) {
                Some(path) => format!("{path}::msg::{}", b.type_name),
                None => format!("super::super::{pkg}::msg::{}", b.type_name),
            }
        };
        match (t.is_array, t.array_size, t.is_upper_bound) {
            (false, _, _) => base,
            (true, Some(n), false) => format!("[{base}; {n}]"),
            _ => format!("::std::vec::Vec<{base}>"),
        }
    }

    fn default_of(&self, f: &Field) -> String {
        let t = &f.field_type;
        let ty = &t.base_type.type_name;
        let fixed = t.is_array && !t.is_upper_bound && t.array_size.is_some();
        match &f.default_value {
            Some(Value::Primitive(v)) => self.literal(ty, v),
            Some(Value::Array(vs)) => {
                let items: Vec<String> = vs.iter().map(|v| self.literal(ty, v)).collect();
                if fixed {
                    format!("[{}]", items.join(", "))
                } else {
                    format!("::std::vec![{}]", items.join(", "))
                }
            }
            None if fixed => {
                "::core::array::from_fn(|_| ::core::default::Default::default())".to_owned()
            }
            None => "::core::default::Default::default()".to_owned(),
        }
    }

    /// A field's default value as a Rust expression of its type.
    fn literal(&self, ty: &str, v: &PrimitiveValue) -> String {
        match ty {
            "string" => format!("::std::string::String::from({})", constant(ty, v)),
            "wstring" => format!("{}::msg::WString::from({})", self.runtime, constant(ty, v)),
            _ => constant(ty, v),
        }
    }

    /// Whether the struct of `ros_type` can derive `Copy` and `Eq`.
    fn traits_of(&self, ros_type: &str) -> Result<(bool, bool), String> {
        if let Some(t) = self.traits.lock().unwrap().get(ros_type) {
            return Ok(*t);
        }
        let spec: std::sync::Arc<MessageSpecification> = self.interfaces.definition(ros_type)?;
        let (mut copy, mut eq) = (true, true);
        for f in &spec.fields {
            let t = &f.field_type;
            let b = &t.base_type.type_name;
            if t.is_array && (t.is_upper_bound || t.array_size.is_none()) {
                copy = false;
            }
            if is_primitive(b) {
                copy &= !matches!(b.as_str(), "string" | "wstring");
                eq &= !matches!(b.as_str(), "float32" | "float64");
            } else {
                let (c, e) = self.traits_of(&self.interfaces.nested_type(f, &spec.pkg_name))?;
                copy &= c;
                eq &= e;
            }
        }
        self.traits
            .lock()
            .unwrap()
            .insert(ros_type.to_owned(), (copy, eq));
        Ok((copy, eq))
    }
}

/// The Rust type of a ROS number or `bool` (`char` and `byte` are `u8`, as rosidl maps them).
fn number(ty: &str) -> Option<&'static str> {
    Some(match ty {
        "bool" => "bool",
        "byte" | "char" | "uint8" => "u8",
        "int8" => "i8",
        "int16" => "i16",
        "uint16" => "u16",
        "int32" => "i32",
        "uint32" => "u32",
        "int64" => "i64",
        "uint64" => "u64",
        "float32" => "f32",
        "float64" => "f64",
        _ => return None,
    })
}

/// A constant's value as a Rust literal of its type (a string as a `&str` literal).
fn constant(ty: &str, v: &PrimitiveValue) -> String {
    let int = |x: i128| -> String {
        match number(ty) {
            Some(f @ ("f32" | "f64")) => format!("{x}.0_{f}"),
            Some(suffix) if suffix != "bool" => format!("{x}_{suffix}"),
            _ => x.to_string(),
        }
    };
    let float = |x: f64| -> String {
        let mut s = if ty == "float32" {
            format!("{:?}", x as f32)
        } else {
            format!("{x:?}")
        };
        if !s.contains(['.', 'e', 'E']) {
            s.push_str(".0");
        }
        format!("{s}_{}", if ty == "float32" { "f32" } else { "f64" })
    };
    match v {
        PrimitiveValue::Bool(b) => b.to_string(),
        PrimitiveValue::Int8(x) => int((*x).into()),
        PrimitiveValue::UInt8(x) => int((*x).into()),
        PrimitiveValue::Int16(x) => int((*x).into()),
        PrimitiveValue::UInt16(x) => int((*x).into()),
        PrimitiveValue::Int32(x) => int((*x).into()),
        PrimitiveValue::UInt32(x) => int((*x).into()),
        PrimitiveValue::Int64(x) => int((*x).into()),
        PrimitiveValue::UInt64(x) => int((*x).into()),
        PrimitiveValue::Float32(x) => float((*x).into()),
        PrimitiveValue::Float64(x) => float(*x),
        PrimitiveValue::String(s) => format!("{s:?}"),
    }
}

/// The comment lines the parser kept with an element, as plain text for rustdoc (no links, tags or code blocks
/// for it to read into them).
fn comments(a: &Annotations) -> Vec<String> {
    let lines = match a.get("comment") {
        Some(AnnotationValue::StringList(lines)) => lines.clone(),
        Some(AnnotationValue::String(line)) => vec![line.clone()],
        _ => Vec::new(),
    };
    lines
        .iter()
        .map(|l| {
            l.trim()
                .split(' ')
                .map(|word| {
                    if word.starts_with("http://") || word.starts_with("https://") {
                        // a link, as rustdoc wants one
                        return format!("<{word}>");
                    }
                    if word.contains("://") && !word.contains('`') {
                        // a URL inside markup (`href="..."`): shown as written
                        return format!("`{word}`");
                    }
                    let mut text = String::new();
                    for c in word.chars() {
                        if matches!(c, '[' | ']' | '<' | '>' | '`' | '*' | '_' | '#' | '|') {
                            text.push('\\');
                        }
                        text.push(c);
                    }
                    text
                })
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect()
}

/// `#[doc = "..."]` lines.
fn doc(lines: &[String], indent: usize) -> String {
    let mut out = String::new();
    for l in lines {
        writeln!(out, "{:indent$}#[doc = {:?}]", "", format!(" {l}")).unwrap();
    }
    out
}

/// A field's name as a Rust identifier.
fn field_name(name: &str) -> String {
    const KEYWORDS: &[&str] = &[
        "as", "break", "const", "continue", "else", "enum", "extern", "false", "fn", "for", "if",
        "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return",
        "static", "struct", "trait", "true", "type", "unsafe", "use", "where", "while", "async",
        "await", "dyn", "abstract", "become", "box", "do", "final", "macro", "override", "priv",
        "typeof", "unsized", "virtual", "yield", "try", "gen",
    ];
    match name {
        "self" | "super" | "crate" | "Self" => format!("{name}_"),
        n if KEYWORDS.contains(&n) => format!("r#{n}"),
        n => n.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A directory of its own (tests run in parallel threads of one process) holding `files`.
    fn package(files: &[(&str, &str)]) -> PathBuf {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        let dir = std::env::temp_dir().join(format!("radar_idl_gen_{}_{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for (path, text) in files {
            let p = dir.join(path);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        dir
    }

    #[test]
    fn the_interface_language_becomes_rust_a_person_would_write() {
        let dir = package(&[(
            "my_pkg/msg/Odd.msg",
            "# An odd message.\nint32 MAX=7\nstring NAME=\"a \\\"b\\\"\"\nstring type \"x\"\nwstring<=5 w\n\
             float64[40] big\nuint8[<=3] few [1, 2]\nstd_msgs/Header header\nbool self\n",
        )]);
        let code = Generator::with_interfaces(Interfaces::empty())
            .dir(&dir)
            .generate()
            .unwrap();
        for part in [
            "pub mod my_pkg {",
            "pub r#type: ::std::string::String,",
            "pub w: ::radar_ros::msg::WString,",
            "#[serde(with = \"::radar_ros::msg::fixed_array\")]",
            "pub big: [f64; 40],",
            "pub few: ::std::vec::Vec<u8>,",
            "pub header: ::radar_ros::interfaces::std_msgs::msg::Header,",
            "pub self_: bool,",
            "pub const MAX: i32 = 7_i32;",
            "r#type: ::std::string::String::from(\"x\")",
            "few: ::std::vec![1_u8, 2_u8]",
            "#[doc = \" An odd message.\"]",
            "const TYPE_HASH: ::core::option::Option<&'static str> = ::core::option::Option::Some(\"RIHS01_",
        ] {
            assert!(code.contains(part), "{part} in:\n{code}");
        }
        // shipped packages come from radar_ros, not generated again
        assert!(!code.contains("pub mod std_msgs"), "{code}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_generated_action_carries_the_hashes_of_the_types_rosidl_makes_up_around_it() {
        let dir = package(&[(
            "my_pkg/action/Dock.action",
            "string station\n---\nbool docked\n---\nfloat32 distance\n",
        )]);
        let types = Interfaces::empty().with_dir(&dir);
        let code = Generator::with_interfaces(Interfaces::empty())
            .dir(&dir)
            .generate()
            .unwrap();
        for (field, made_up) in [
            ("send_goal", "SendGoal"),
            ("get_result", "GetResult"),
            ("feedback_message", "FeedbackMessage"),
        ] {
            let hash = types
                .type_hash(&format!("my_pkg/action/Dock_{made_up}"))
                .unwrap();
            assert!(
                code.contains(&format!("{field}: \"{hash}\"")),
                "{field} {hash} in:\n{code}"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_package_found_nowhere_is_named_with_the_places_looked_in() {
        let e = Generator::with_interfaces(Interfaces::empty().with_dir("/nonexistent/share"))
            .package("nav2_msgs")
            .generate()
            .unwrap_err();
        assert!(
            e.contains("nav2_msgs") && e.contains("/nonexistent/share/nav2_msgs"),
            "{e}"
        );
        assert!(e.contains("AMENT_PREFIX_PATH"), "{e}");
    }
}
