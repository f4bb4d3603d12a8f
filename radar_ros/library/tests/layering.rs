//! The crate's modules form layers: no module uses (`crate::...`, or an item the crate root re-exports from a
//! module) a module that uses it back, directly or through others. Reads the sources, so a new import circle
//! fails here, naming it. The same holds file by file in every crate under `radar_ros/` (the library, the
//! semantics, the tools), folders included.

use std::collections::{BTreeMap, BTreeSet};

/// The items `lib.rs` re-exports at the root (`pub use module::{A, B}`), by the module they come from: a
/// `crate::Radar` is an import of `radar` as much as `crate::radar::Radar` is.
fn root_exports(src: &std::path::Path) -> BTreeMap<String, String> {
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    // each `pub use` whole, also when rustfmt folded it over lines
    let mut uses: Vec<String> = Vec::new();
    let mut open: Option<String> = None;
    for line in lib.lines() {
        match open.as_mut() {
            Some(u) => u.push_str(line.trim()),
            None if line.starts_with("pub use ") => open = Some(line.to_owned()),
            None => continue,
        }
        if line.trim_end().ends_with(';') {
            uses.extend(open.take());
        }
    }
    let mut items = BTreeMap::new();
    for line in &uses {
        let path = line["pub use ".len()..].trim_end_matches(';');
        let Some((module, rest)) = path.split_once("::") else {
            continue;
        };
        let names = rest.rsplit("::").next().unwrap_or_default();
        for name in names.trim_matches(|c| c == '{' || c == '}').split(',') {
            let name = name.trim();
            if !name.is_empty() {
                items.insert(name.to_owned(), module.to_owned());
            }
        }
    }
    items
}

/// The crate modules each module names through `crate::` (a module, or an item the root re-exports from one),
/// outside tests and comments.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let exports = root_exports(&src);
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    // every file (lib.rs too: its re-exports are no imports, but its own code may name modules)
    let mut files: Vec<std::path::PathBuf> = file_modules(&src).into_values().collect();
    files.push(src.join("lib.rs"));
    let module_of = |p: &std::path::Path| -> String {
        let rel = p.strip_prefix(&src).unwrap().to_string_lossy().into_owned();
        rel.split('/')
            .next()
            .unwrap()
            .trim_end_matches(".rs")
            .to_owned()
    };
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        // unit tests may reach anywhere
        let code = text.split("#[cfg(test)]\nmod tests").next().unwrap();
        let mut names = BTreeSet::new();
        for line in code.lines().map(str::trim).filter(|l| !l.starts_with("//")) {
            let mut rest = line;
            while let Some(i) = rest.find("crate::") {
                rest = &rest[i + "crate::".len()..];
                let word: String = rest.chars().take_while(|c| ident(*c)).collect();
                match exports.get(&word) {
                    Some(module) => names.insert(module.clone()),
                    None => names.insert(word),
                };
            }
        }
        // `use crate::{a::X, b, c::{..}}` blocks
        for block in code.split("use crate::{").skip(1) {
            let body = block.split("};").next().unwrap();
            let mut depth = 0;
            let mut word = String::new();
            for c in body.chars() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    _ => {}
                }
                if depth == 0 && ident(c) {
                    word.push(c);
                } else {
                    if !word.is_empty() && depth == 0 {
                        let w = std::mem::take(&mut word);
                        names.insert(exports.get(&w).cloned().unwrap_or(w));
                    }
                    word.clear();
                }
            }
            if !word.is_empty() {
                names.insert(exports.get(&word).cloned().unwrap_or(word));
            }
        }
        let me = module_of(f);
        graph
            .entry(me.clone())
            .or_default()
            .extend(names.into_iter().filter(|n| *n != me));
    }
    let known: BTreeSet<String> = graph.keys().cloned().collect();
    for deps in graph.values_mut() {
        deps.retain(|d| known.contains(d) && d != "lib");
    }
    graph
}

/// The crate's top-level modules from the bottom up: a folder by concept, and the files of the crate root.
/// A module may use only modules of lower layers (the root's files, one layer, use each other without a
/// circle). docs/architecture.md draws the same picture.
const LAYERS: &[&[&str]] = &[
    &["error", "wait", "departure", "endpoint", "macros"],
    &["wire"],
    &["graph"],
    &["node"],
    &["security"],
    &["components"],
    &["codec"],
    &["connections"],
    &["radar"],
];

fn layer(module: &str) -> usize {
    LAYERS
        .iter()
        .position(|l| l.contains(&module))
        .unwrap_or_else(|| panic!("{module} is in no layer of LAYERS: add it where it stands"))
}

#[test]
fn no_module_imports_a_module_that_imports_it_back() {
    let graph = imports();
    assert!(graph.len() > 10, "read the modules: {graph:?}");
    if let Some(cycle) = circle(&graph) {
        panic!("import circle: {}", cycle.join(" -> "));
    }
}

#[test]
fn every_folder_uses_only_the_layers_below_it() {
    let graph = imports();
    let mut up = Vec::new();
    for (m, deps) in graph.iter().filter(|(m, _)| *m != "lib") {
        for d in deps {
            if layer(d) > layer(m) || (layer(d) == layer(m) && LAYERS[layer(m)].len() == 1) {
                up.push(format!("{m} -> {d}"));
            }
        }
    }
    assert!(up.is_empty(), "imports that reach up a layer: {up:?}");
}

/// Issue 37 (docs/zenoh.md): above `node/` and `graph/`, the transport is named only through
/// `node/transport.rs`, so that a second transport changes the layers below and not the binding of the
/// semantics. `radar/mod.rs` is where the transport is chosen and built, and may name it.
#[test]
fn only_the_transport_layers_name_the_transport() {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let named = [
        "rustdds",
        "ros2_client::dds",
        "ros2_client::action",
        "ros2_client::builtin_topics",
        "ros2_client::entities_info",
    ];
    let mut found = Vec::new();
    for path in file_modules(&src).into_values() {
        let rel = path
            .strip_prefix(&src)
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let above = ["components/", "connections/", "radar/", "codec/"]
            .iter()
            .any(|d| rel.starts_with(d));
        if !above || rel == "radar/mod.rs" {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let code = text.split("#[cfg(test)]\nmod tests").next().unwrap();
        for (i, line) in code.lines().enumerate() {
            let line = line.trim();
            if line.starts_with("//") {
                continue;
            }
            if let Some(n) = named.iter().find(|n| line.contains(*n)) {
                found.push(format!("{rel}:{}: {n}", i + 1));
            }
        }
    }
    assert!(
        found.is_empty(),
        "name these through crate::node::transport (or move the code into node/ or graph/):\n{}",
        found.join("\n")
    );
}

#[test]
fn root_re_exports_count_as_imports_of_their_module() {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let exports = root_exports(&src);
    assert_eq!(exports["Radar"], "radar");
    assert_eq!(exports["ConnectionGuard"], "connections");
    assert_eq!(exports["Error"], "error");
    // one folded over lines by rustfmt (none is, in lib.rs today)
    let dir = std::env::temp_dir().join(format!("radar_layering_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("lib.rs"),
        "pub use node::topics::{\n    RawPublisher, RawSubscription, Sample,\n};\npub use radar::Radar;\n",
    )
    .unwrap();
    let folded = root_exports(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(folded["Sample"], "node");
    assert_eq!(folded["Radar"], "radar");
    let graph = imports();
    // a re-export from another crate is no module of this one
    assert!(graph.values().all(|deps| !deps.contains("radar_semantics")));
}

/// Every `impl Radar` block of the crate, and every file below `radar/` that names `Radar` in code.
fn radar_outside_its_folder() -> (Vec<String>, Vec<String>) {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let (mut impls, mut names) = (Vec::new(), Vec::new());
    for (module, path) in file_modules(&src) {
        let text = std::fs::read_to_string(&path).unwrap();
        let code = text.split("#[cfg(test)]\nmod tests").next().unwrap();
        let inside = module == "radar" || module.starts_with("radar::") || module.is_empty();
        for line in code.lines().map(str::trim).filter(|l| !l.starts_with("//")) {
            if line.starts_with("impl Radar ") && !inside {
                impls.push(module.clone());
            }
            let names_it = line.contains("crate::radar")
                || line.contains("crate::Radar")
                || line.contains("crate::RadarBuilder")
                || line.contains("radar::Radar");
            if names_it && !inside {
                names.push(format!("{module}: {line}"));
            }
        }
    }
    (impls, names)
}

#[test]
fn radar_s_methods_are_written_in_its_folder_and_nothing_below_names_it() {
    let (impls, names) = radar_outside_its_folder();
    assert!(impls.is_empty(), "`impl Radar` outside radar/: {impls:?}");
    assert!(
        names.is_empty(),
        "below radar/, code names the Radar: {names:#?}"
    );
    // and the check sees them where they are
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let inside: usize = file_modules(&src)
        .into_iter()
        .filter(|(m, _)| m.starts_with("radar"))
        .map(|(_, p)| {
            std::fs::read_to_string(p)
                .unwrap()
                .matches("\nimpl Radar {")
                .count()
        })
        .sum();
    assert!(inside >= 10, "impl Radar blocks in radar/: {inside}");
}

/// Every source file of the crate under `src` as its module path (`security::keystore`, `graph` for
/// `graph/mod.rs`, `` for `lib.rs`), with its path.
fn file_modules(src: &std::path::Path) -> BTreeMap<String, std::path::PathBuf> {
    let mut out = BTreeMap::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(src).unwrap().with_extension("");
                let mut parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if parts.last().is_some_and(|l| l == "mod") {
                    parts.pop();
                }
                if parts == ["lib"] || parts.first().is_some_and(|f| f == "bin") {
                    continue;
                }
                out.insert(parts.join("::"), p);
            }
        }
    }
    out
}

/// File-level imports of one crate: `crate::a::b::Item` (the deepest module of the path that is a file, or
/// the module a root re-export comes from) and `super::sibling` (a module beside the file). A file's use of
/// its parent's items (`super::Item`) is not counted: that a folder's files build on what its `mod.rs`
/// declares is the folder's own business.
fn file_imports(src: &std::path::Path) -> BTreeMap<String, BTreeSet<String>> {
    let files = file_modules(src);
    let exports = root_exports(src);
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let deepest = |path: &[&str]| -> Option<String> {
        (1..=path.len())
            .rev()
            .map(|k| path[..k].join("::"))
            .find(|m| files.contains_key(m))
    };
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (me, file) in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let code = text.split("#[cfg(test)]\nmod tests").next().unwrap();
        let code: String = code
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        let mut deps = BTreeSet::new();
        // `crate::a::b::C` paths, and the paths inside `use crate::{..}` groups
        let mut paths: Vec<String> = Vec::new();
        let mut rest = code.as_str();
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + "crate::".len()..];
            if let Some(group) = rest.strip_prefix('{') {
                let body = group.split("};").next().unwrap_or_default();
                let (mut depth, mut prefix, mut word) = (0, Vec::<String>::new(), String::new());
                for c in body.chars() {
                    match c {
                        '{' => {
                            prefix.push(std::mem::take(&mut word));
                            depth += 1;
                        }
                        '}' | ',' => {
                            let w = std::mem::take(&mut word);
                            if !w.trim().is_empty() {
                                paths.push(format!("{}{}", prefix.concat(), w.trim()));
                            }
                            if c == '}' {
                                prefix.pop();
                                depth -= 1;
                            }
                        }
                        c if c.is_whitespace() => {}
                        c => word.push(c),
                    }
                }
                let w = word.trim();
                if !w.is_empty() && depth == 0 {
                    paths.push(w.to_owned());
                }
            } else {
                paths.push(
                    rest.chars()
                        .take_while(|c| ident(*c) || *c == ':')
                        .collect(),
                );
            }
        }
        // modules imported by name (`use crate::verbs;`, `verbs::{self, ..}`): `verbs::act::run()` uses `verbs::act`
        let mut aliases: BTreeMap<String, String> = BTreeMap::new();
        for p in paths {
            let segs: Vec<&str> = p
                .split("::")
                .filter(|s| !s.is_empty() && *s != "self")
                .collect();
            let Some(first) = segs.first() else { continue };
            let target = match exports.get(*first) {
                Some(m) if first.starts_with(char::is_uppercase) => Some(m.clone()),
                _ => deepest(&segs),
            };
            if let Some(t) = &target {
                if *t == segs.join("::") {
                    aliases.insert(segs.last().unwrap().to_string(), t.clone());
                }
            }
            deps.extend(target);
        }
        for (alias, module) in &aliases {
            let pat = format!("{alias}::");
            let mut at = 0;
            while let Some(i) = code[at..].find(&pat) {
                let start = at + i;
                at = start + pat.len();
                if code[..start].ends_with(|c: char| ident(c) || c == ':') {
                    continue;
                }
                let tail: String = code[at..]
                    .chars()
                    .take_while(|c| ident(*c) || *c == ':')
                    .collect();
                let mut segs: Vec<&str> = module.split("::").collect();
                segs.extend(tail.split("::").filter(|s| !s.is_empty()));
                deps.extend(deepest(&segs));
            }
        }
        // `super::sibling`
        let parent: Vec<&str> = {
            let mut p: Vec<&str> = me.split("::").collect();
            p.pop();
            if file.ends_with("mod.rs") {
                p.pop();
            }
            p
        };
        let mut rest = code.as_str();
        while let Some(i) = rest.find("super::") {
            rest = &rest[i + "super::".len()..];
            let word: String = rest.chars().take_while(|c| ident(*c)).collect();
            let mut sibling = parent.clone();
            sibling.push(&word);
            let sibling = sibling.join("::");
            if files.contains_key(&sibling) {
                deps.insert(sibling);
            }
        }
        deps.remove(me);
        deps.remove("");
        graph.insert(me.clone(), deps);
    }
    graph
}

/// An import circle in `graph`, if there is one.
fn circle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(m.to_owned(), 1);
        path.push(m.to_owned());
        for d in graph.get(m).into_iter().flatten() {
            match state.get(d.as_str()) {
                Some(1) => {
                    let i = path.iter().position(|p| p == d).unwrap();
                    let mut cycle = path[i..].to_vec();
                    cycle.push(d.clone());
                    return Some(cycle);
                }
                Some(_) => {}
                None => {
                    if let Some(c) = visit(d, graph, state, path) {
                        return Some(c);
                    }
                }
            }
        }
        path.pop();
        state.insert(m.to_owned(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for m in graph.keys() {
        if !state.contains_key(m) {
            if let Some(c) = visit(m, graph, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn no_file_imports_a_file_that_imports_it_back_in_any_crate_under_radar_ros() {
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for krate in ["src", "../semantics/src", "../tools/src", "../python/src"] {
        let graph = file_imports(&here.join(krate));
        assert!(graph.len() > 5, "read the files of {krate}: {graph:?}");
        if let Some(c) = circle(&graph) {
            panic!("import circle in {krate}: {}", c.join(" -> "));
        }
    }
}

#[test]
fn the_file_level_check_sees_siblings_and_groups() {
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let graph = file_imports(&here.join("src"));
    // `use super::keystore::...` in the policy parser, `use crate::{error::..}` groups
    assert!(
        graph["security::policy"].contains("security::keystore"),
        "{graph:?}"
    );
    assert!(graph["security::policy"].contains("error"));
    let tools = file_imports(&here.join("../tools/src"));
    // the command line runs the verbs, which take their argument types from no one above them
    assert!(tools["cli"].contains("verbs::act"), "{:?}", tools["cli"]);
    assert!(!tools["verbs::act"].contains("cli"));
    // a circle is found
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.insert("a".into(), ["b".into()].into());
    g.insert("b".into(), ["a".into()].into());
    assert_eq!(circle(&g), Some(vec!["a".into(), "b".into(), "a".into()]));
}
