//! `docs/architecture.md` cannot drift from the tree: every source file of the crates under `radar_ros/` is
//! listed there, and every file listed there exists.

use std::collections::BTreeSet;

/// The `.rs` files under `dir`, as paths from the repository's root.
fn sources(root: &std::path::Path, dir: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut dirs = vec![root.join(dir)];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.insert(p.strip_prefix(root).unwrap().to_string_lossy().into_owned());
            }
        }
    }
    out
}

/// The `radar_ros/...rs` paths the page names (in backticks).
fn listed(page: &str) -> BTreeSet<String> {
    page.split('`')
        .skip(1)
        .step_by(2)
        .filter(|s| s.starts_with("radar_ros/") && s.ends_with(".rs"))
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_architecture_page_lists_every_source_file_and_only_those() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .unwrap();
    let page = std::fs::read_to_string(root.join("docs/architecture.md")).unwrap();
    let on_page = listed(&page);
    let mut in_tree = BTreeSet::new();
    for dir in [
        "radar_ros/library/src",
        "radar_ros/semantics/src",
        "radar_ros/spec/src",
        "radar_ros/checker/src",
        "radar_ros/idl/src",
        "radar_ros/tools/src",
        "radar_ros/python/src",
    ] {
        in_tree.extend(sources(root, dir));
    }
    assert!(in_tree.len() > 60, "read the tree: {in_tree:?}");
    let missing: Vec<_> = in_tree.difference(&on_page).collect();
    assert!(
        missing.is_empty(),
        "not in docs/architecture.md (add a row saying what each holds): {missing:?}"
    );
    let gone: Vec<_> = on_page
        .iter()
        .filter(|p| !p.contains("/tests/") && !in_tree.contains(*p))
        .collect();
    assert!(
        gone.is_empty(),
        "docs/architecture.md lists files that do not exist: {gone:?}"
    );
}

#[test]
fn a_page_path_is_read_from_backticks_only() {
    let page =
        "| `radar_ros/library/src/a.rs` | x |\nradar_ros/library/src/b.rs and `radar_ros/library/src/c` and `other/d.rs`";
    assert_eq!(
        listed(page),
        BTreeSet::from(["radar_ros/library/src/a.rs".to_owned()])
    );
}

/// The functions of the files under `dir` longer than `max` lines (signature to closing brace), outside test
/// modules: (file, function, lines).
fn long_functions(root: &std::path::Path, dir: &str, max: usize) -> Vec<(String, String, usize)> {
    let mut out = Vec::new();
    for file in sources(root, dir) {
        let text = std::fs::read_to_string(root.join(&file)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let end = lines
            .windows(2)
            .position(|w| w[0].starts_with("#[cfg(test)]") && w[1].starts_with("mod tests"))
            .unwrap_or(lines.len());
        for (i, line) in lines[..end].iter().enumerate() {
            let trimmed = line.trim_start();
            let indent = &line[..line.len() - trimmed.len()];
            let sig = trimmed
                .trim_start_matches("pub ")
                .trim_start_matches("pub(crate) ")
                .trim_start_matches("pub(super) ")
                .trim_start_matches("async ")
                .trim_start_matches("const ")
                .trim_start_matches("unsafe ");
            let Some(rest) = sig.strip_prefix("fn ") else {
                continue;
            };
            if line.trim_end().ends_with(';') {
                continue;
            }
            let closing = format!("{indent}}}");
            let Some(len) = lines[i + 1..end]
                .iter()
                .position(|l| l.trim_end() == closing)
            else {
                continue;
            };
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if len + 2 > max {
                out.push((file.clone(), name, len + 2));
            }
        }
    }
    out
}

#[test]
fn no_function_is_over_80_lines_in_any_crate_but_the_checker() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .unwrap();
    for dir in [
        "radar_ros/library/src",
        "radar_ros/semantics/src",
        "radar_ros/idl/src",
        "radar_ros/spec/src",
        // not yet radar_ros/checker/src: world.rs's `step`, `actions` and `effects` (140, 111, 108 lines) want
        // splitting by action kind
        "radar_ros/tools/src",
        "radar_ros/python/src",
    ] {
        let long = long_functions(root, dir, 80);
        assert!(
            long.is_empty(),
            "functions over 80 lines in {dir} (split them by what they do): {long:?}"
        );
    }
}

#[test]
fn the_length_check_counts_from_signature_to_closing_brace() {
    let dir = std::env::temp_dir().join(format!("radar_fnlen_{}", std::process::id()));
    std::fs::create_dir_all(dir.join("src")).unwrap();
    let body: String = (0..79).map(|i| format!("    let _x{i} = {i};\n")).collect();
    std::fs::write(
        dir.join("src/a.rs"),
        format!("fn short() {{\n}}\n\npub(crate) async fn long() {{\n{body}}}\n"),
    )
    .unwrap();
    let long = long_functions(&dir, "src", 80);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(long, vec![("src/a.rs".to_owned(), "long".to_owned(), 81)]);
}

/// The lines of `text` before its unit tests (the first `#[cfg(test)]` at the start of a line).
fn lines_before_tests(text: &str) -> usize {
    text.lines()
        .take_while(|l| !l.starts_with("#[cfg(test)]"))
        .count()
}

#[test]
fn no_source_file_is_over_600_lines_before_its_tests_in_any_crate() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .unwrap();
    let mut long = Vec::new();
    for dir in [
        "radar_ros/library/src",
        "radar_ros/semantics/src",
        "radar_ros/tools/src",
        "radar_ros/python/src",
    ] {
        for path in sources(root, dir) {
            let n = lines_before_tests(&std::fs::read_to_string(root.join(&path)).unwrap());
            if n > 600 {
                long.push((path, n));
            }
        }
    }
    assert!(
        long.is_empty(),
        "files over 600 lines before their tests (split them by concept): {long:?}"
    );
}

#[test]
fn the_file_length_counts_up_to_the_tests_module() {
    let text =
        "//! doc\nfn a() {}\n    #[cfg(test)] // not at the start\n#[cfg(test)]\nmod tests {}\n";
    assert_eq!(lines_before_tests(text), 3);
    assert_eq!(lines_before_tests("fn a() {}\nfn b() {}\n"), 2);
}

/// `radar_ros::interfaces` is kept in the repository (`generated/interfaces.rs`, so that a user's build compiles
/// no generator): it must be what radar_idl generates from the definitions radar_ros ships, as a user's build
/// script would. `RADAR_BLESS=1` writes it again.
#[test]
fn the_shipped_interfaces_are_what_radar_idl_generates() {
    let mut g = radar_idl::rust::Generator::with_interfaces(radar_idl::Interfaces::empty())
        .standalone("::radar_ros");
    for pkg in radar_idl::shipped_packages() {
        g = g.package(pkg);
    }
    let fresh = g
        .generate()
        .expect("radar_idl generates the shipped interfaces");
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("generated/interfaces.rs");
    if std::env::var_os("RADAR_BLESS").is_some() {
        std::fs::write(&path, &fresh).unwrap();
    }
    let kept = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        kept == fresh,
        "{} is not what radar_idl generates now: run `RADAR_BLESS=1 cargo test -p radar_ros --test architecture` \
         and commit it",
        path.display()
    );
}

/// The crates a build of radar_ros with `features` compiles (normal and build dependencies), by name.
fn crates_built(features: &[&str]) -> Vec<String> {
    let out = std::process::Command::new(env!("CARGO"))
        .args([
            "tree",
            "--offline",
            "-p",
            "radar_ros",
            "-e",
            "normal,build",
            "--prefix",
            "none",
        ])
        .args(features.iter().flat_map(|f| ["--features", f]))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "cargo tree: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut names: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let mut words = l.split_whitespace();
            Some(format!("{} {}", words.next()?, words.next()?))
        })
        .collect();
    names.sort();
    names.dedup();
    names
}

/// Issue 70: a DDS-only user (default features) builds no code generator (ros2-client's msggen, radar_idl and
/// its parser), no crate that is deprecated or unmaintained (serde_yaml; mio 0.6 and net2, RUSTSEC-2020-0016),
/// and at most 130 crates.
#[test]
fn a_default_build_compiles_no_code_generator_and_no_deprecated_crate() {
    let built = crates_built(&[]);
    let unwanted: Vec<&String> = built
        .iter()
        .filter(|c| {
            let (name, version) = c.split_once(' ').unwrap();
            [
                "clap",
                "nom",
                "itertools",
                "radar_idl",
                "ros2msg",
                "pest",
                "serde_yaml",
                "net2",
            ]
            .contains(&name)
                || (name == "mio" && version.starts_with("v0."))
        })
        .collect();
    assert!(
        unwanted.is_empty(),
        "a default build of radar_ros compiles {unwanted:?}"
    );
    assert!(
        built.len() <= 130,
        "a default build of radar_ros compiles {} crates (at most 130): {built:?}",
        built.len()
    );
}

/// The names `radar_ros`'s root exports, from lib.rs and the exported macros: `(name, hidden)`. Reads the
/// crate root's own items only (not what is inside its inline modules), `pub use` groups and renames included.
fn root_exports(lib_rs: &str, macros_rs: &str) -> BTreeSet<(String, bool)> {
    let code: String = lib_rs
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let mut out = BTreeSet::new();
    let (mut depth, mut hidden, mut i) = (0usize, false, 0usize);
    let b = code.as_bytes();
    while i < b.len() {
        let rest = &code[i..];
        match b[i] {
            b'{' => depth += 1,
            b'}' => depth = depth.saturating_sub(1),
            _ if depth == 0 && rest.starts_with("#[doc(hidden)]") => hidden = true,
            _ if depth == 0 && rest.starts_with("pub use ") => {
                let end = rest.find(';').expect("a pub use ends with ;");
                let body: String = rest["pub use ".len()..end]
                    .split_whitespace()
                    .collect::<Vec<_>>()
                    .join(" ");
                for name in use_names(&body) {
                    match body.strip_suffix("::*") {
                        // a glob of a module of lib.rs: the public items written in it
                        Some(module) if name == "*" => {
                            for name in items_of_module(&code, module) {
                                out.insert((name, hidden));
                            }
                        }
                        _ => {
                            out.insert((name, hidden));
                        }
                    }
                }
                hidden = false;
                i += end;
                continue;
            }
            _ if depth == 0 && rest.starts_with("pub mod ") => {
                let name: String = rest["pub mod ".len()..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                out.insert((name, hidden));
                hidden = false;
            }
            _ => {}
        }
        i += 1;
    }
    let mut lines = macros_rs.lines().peekable();
    while let Some(l) = lines.next() {
        if l.trim() == "#[macro_export]" {
            let hidden = false;
            let next = lines.next().unwrap_or_default();
            let name = next
                .trim()
                .trim_start_matches("macro_rules! ")
                .trim_end_matches(" {");
            out.insert((format!("{name}!"), hidden || name.starts_with("__")));
        }
    }
    out
}

/// The `pub type`, `pub const` and `pub fn` names written in `mod NAME { ... }` of `code`.
fn items_of_module(code: &str, module: &str) -> Vec<String> {
    let start = code
        .find(&format!("mod {module} {{"))
        .unwrap_or_else(|| panic!("a glob of `{module}`, which lib.rs does not hold inline"));
    let body = &code[start..];
    let end = body.find("\n}").expect("the module's closing brace");
    body[..end]
        .lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let rest = ["pub type ", "pub const ", "pub fn "]
                .iter()
                .find_map(|p| l.strip_prefix(p))?;
            Some(
                rest.chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect(),
            )
        })
        .collect()
}

/// The names a `pub use` body brings in: `a::b::C` -> C, `a::{B, C as D}` -> B, D, `x as y` -> y.
fn use_names(body: &str) -> Vec<String> {
    if let (Some(open), Some(close)) = (body.find('{'), body.rfind('}')) {
        let inner = &body[open + 1..close];
        let mut parts = Vec::new();
        let (mut depth, mut start) = (0, 0);
        for (i, c) in inner.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    parts.push(&inner[start..i]);
                    start = i + 1;
                }
                _ => {}
            }
        }
        parts.push(&inner[start..]);
        return parts
            .into_iter()
            .map(str::trim)
            .filter(|p| !p.is_empty())
            .flat_map(use_names)
            .collect();
    }
    let last = body
        .rsplit(" as ")
        .next()
        .unwrap()
        .rsplit("::")
        .next()
        .unwrap()
        .trim();
    vec![last.to_owned()]
}

/// The root's exports as docs/public_api.md lists them: `name` in backticks at the start of a table row, with
/// "hidden" in the row for those kept for old code only.
fn announced(page: &str) -> BTreeSet<(String, bool)> {
    page.lines()
        .filter_map(|l| {
            let l = l.strip_prefix("| `")?;
            let name = &l[..l.find('`')?];
            Some((name.to_owned(), l.contains("hidden")))
        })
        .collect()
}

#[test]
fn the_root_exports_exactly_what_docs_public_api_announces() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let read = |p: &str| std::fs::read_to_string(root.join(p)).unwrap();
    let exported = root_exports(&read("src/lib.rs"), &read("src/macros.rs"));
    let page = announced(&read("../../docs/public_api.md"));
    let unannounced: Vec<_> = exported.difference(&page).collect();
    let gone: Vec<_> = page.difference(&exported).collect();
    assert!(
        unannounced.is_empty() && gone.is_empty(),
        "radar_ros's root changed without docs/public_api.md saying so (a name, and whether it is hidden):\n\
         exported, not in the page: {unannounced:?}\nin the page, not exported: {gone:?}\n\
         A change of the public face is a decision: write it in the page (and CHANGES.md), with the old name \
         kept hidden for a release where code may use it"
    );
}

#[test]
fn the_export_reader_reads_groups_renames_modules_hidden_items_and_macros() {
    let lib = "//! docs\nmod private;\npub mod shown;\npub use a::b::{C, d::{E, F as G}};\n\
               #[doc(hidden)]\npub use h;\npub mod inline {\n    pub use inner::Skipped;\n}\n\
               pub use x::Y as Z;\n// pub use commented::Out;\nmod old {\n    #[deprecated]\n    \
               pub type Old<'a> = crate::x::Old<'a>;\n    pub const LATE: u8 = 1;\n    pub fn gone() {}\n}\n\
               #[doc(hidden)]\npub use old::*;\n";
    let macros = "#[macro_export]\nmacro_rules! once {\n#[doc(hidden)]\n#[macro_export]\nmacro_rules! __helper {\n";
    let got: Vec<(String, bool)> = root_exports(lib, macros).into_iter().collect();
    let want: Vec<(String, bool)> = [
        ("C", false),
        ("E", false),
        ("G", false),
        ("LATE", true),
        ("Old", true),
        ("Z", false),
        ("__helper!", true),
        ("gone", true),
        ("h", true),
        ("inline", false),
        ("once!", false),
        ("shown", false),
    ]
    .iter()
    .map(|(n, h)| (n.to_string(), *h))
    .collect();
    assert_eq!(got, want);
}
