//! The crate's modules form layers: no module uses (`crate::...`, or an item the crate root re-exports from a
//! module) a module that uses it back, directly or through others. Reads the sources, so a new import circle
//! fails here, naming it.

use std::collections::{BTreeMap, BTreeSet};

/// The items `lib.rs` re-exports at the root (`pub use module::{A, B}`), by the module they come from: a
/// `crate::Radar` is an import of `radar` as much as `crate::radar::Radar` is.
fn root_exports(src: &std::path::Path) -> BTreeMap<String, String> {
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let mut items = BTreeMap::new();
    for line in lib.lines().filter(|l| l.starts_with("pub use ")) {
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
    let mut files = Vec::new();
    let mut dirs = vec![src.clone()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                files.push(p);
            }
        }
    }
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

#[test]
fn no_module_imports_a_module_that_imports_it_back() {
    let graph = imports();
    assert!(graph.len() > 15, "read the modules: {graph:?}");
    // depth-first search for a back edge
    fn visit(
        m: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(m.to_owned(), 1);
        path.push(m.to_owned());
        for d in &graph[m] {
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
            if let Some(cycle) = visit(m, &graph, &mut state, &mut Vec::new()) {
                panic!("import circle: {}", cycle.join(" -> "));
            }
        }
    }
    // the core stands below what stands on it
    for (high, low) in [
        ("radar", "participant"),
        ("manager", "pool"),
        ("participant", "refs"),
    ] {
        let reaches = |from: &str, to: &str| {
            let mut seen = BTreeSet::new();
            let mut todo = vec![from.to_owned()];
            while let Some(m) = todo.pop() {
                if m == to {
                    return true;
                }
                if seen.insert(m.clone()) {
                    todo.extend(graph[&m].iter().cloned());
                }
            }
            false
        };
        assert!(!reaches(low, high), "{low} must not depend on {high}");
    }
}

#[test]
fn root_re_exports_count_as_imports_of_their_module() {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let exports = root_exports(&src);
    assert_eq!(exports["Radar"], "radar");
    assert_eq!(exports["SignalPublisher"], "topics");
    assert_eq!(exports["Error"], "error");
    let graph = imports();
    // the action server names `crate::SignalPublisher` and nothing else of `topics`
    assert!(graph["action"].contains("topics"), "{:?}", graph["action"]);
    // a re-export from another crate is no module of this one
    assert!(graph.values().all(|deps| !deps.contains("radar_semantics")));
}
