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
fn no_function_is_over_80_lines_in_the_library_semantics_tools_or_python_crates() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .unwrap();
    for dir in [
        "radar_ros/library/src",
        "radar_ros/semantics/src",
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
