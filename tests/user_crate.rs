//! Issue 20: radar_ros in the user's own crate, as the README's "Use radar_ros in your crate" says.
//!
//! - A crate generated outside this workspace (in `target/user-crate/`, its own workspace root) from the
//!   README's `Cargo.toml` lines and `main.rs`, depending on radar_ros by path with no `[patch]`, builds, runs,
//!   and acts on a start published by a fresh rclpy process (`ros2 topic pub --once`, as
//!   `python/interop.py pub_once` does it). Built as a user builds it, without radar_ros's optional features,
//!   it refuses `RMW_IMPLEMENTATION=rmw_zenoh_cpp` and `ROS_SECURITY_ENABLE=true` (enforced) at start, saying
//!   which feature it lacks (the workspace's own test build has them on).
//! - The guard: a crate that depends on radar_ros through git and swaps in the crates.io RustDDS 0.15.1 for
//!   radar_ros's (a `[patch]`) does not build: radar_ros's build script stops it, saying what to do.
//!
//! - Issue 34: a crate outside the workspace with generated interface types (`fixtures/generated_crate`: its
//!   `build.rs` generates `geometry_msgs` and `test_msgs` from `AMENT_PREFIX_PATH`, set to the rclpy venv as a
//!   sourced installation sets it, and its own package `radar_demo_msgs` from `msgs/`, copied into the crate)
//!   builds; every fixture of ROS 2's `test_msgs` comes back from it equal, as a response's start payload and
//!   as an event's payload (rclpy -> Rust -> rclpy), and its own `Dock` action, served as a RADAR response,
//!   answers an rclpy `ActionClient`.
//!
//! They build the stack again in a target directory of their own (`target/user-crate/target`, shared: a minute
//! or two the first time). Domains 18 and 118.

use std::{
    path::{Path, PathBuf},
    process::Command,
    time::Duration,
};

use radar_test_util::{python, repo, require_isolation, Py};
use tokio::io::{AsyncBufReadExt, BufReader};

const DOMAIN: u16 = 18;

/// The README block that follows the marker `<!-- user-crate: {what}`.
fn readme_block(what: &str) -> String {
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let marker = format!("<!-- user-crate: {what}");
    let after = &readme[readme
        .find(&marker)
        .unwrap_or_else(|| panic!("README marker {marker}"))..];
    let start = after.find("```").unwrap();
    let body = &after[start..];
    let body = &body[body.find('\n').unwrap() + 1..];
    body[..body.find("```").unwrap()].to_owned()
}

/// The target directory the crates of this file build in: their own (not the workspace's), shared among
/// them (Cargo serializes the builds).
fn user_target() -> PathBuf {
    repo().join("target/user-crate/target")
}

fn cargo() -> Command {
    let mut c = Command::new(env!("CARGO"));
    // built once per run: no incremental state (2 GB of it), line tables only (most of the rest); disk is what a
    // CI machine runs out of first
    c.env_remove("RUSTFLAGS")
        .env_remove("CARGO_TARGET_DIR")
        .env("CARGO_INCREMENTAL", "0")
        .env("CARGO_PROFILE_DEV_DEBUG", "line-tables-only");
    c
}

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

/// Runs `cargo build ARGS` in `dir` with its own target directory, offline (the tests run without network:
/// `tests/isolated.sh` fetched every crate before, and the workspace's `Cargo.lock`, copied in, pins them); the
/// output.
fn build(dir: &Path, args: &[&str]) -> std::process::Output {
    build_with(dir, args, &[])
}

/// [`build`] with more environment variables.
fn build_with(dir: &Path, args: &[&str], env: &[(&str, &std::ffi::OsStr)]) -> std::process::Output {
    std::fs::copy(repo().join("Cargo.lock"), dir.join("Cargo.lock")).unwrap();
    cargo()
        .args(["build", "--offline"])
        .args(args)
        .current_dir(dir)
        .env("CARGO_TARGET_DIR", user_target())
        .envs(env.iter().copied())
        .output()
        .expect("run cargo")
}

/// What cargo said in `stderr`, without its progress lines (`Compiling`, `Blocking`, ...), so that a failure's
/// message shows the error itself rather than a page of crate names that a CI log cuts before the error.
fn cargo_said(stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            let l = l.trim_start();
            ![
                "Compiling ",
                "Blocking ",
                "Checking ",
                "Locking ",
                "Adding ",
                "Updating ",
                "Downgrading ",
            ]
            .iter()
            .any(|p| l.starts_with(p))
        })
        .collect();
    format!(
        "({} progress lines left out)\n{}",
        text.lines().count() - kept.len(),
        kept.join("\n")
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_crate_outside_the_workspace_builds_runs_and_acts_on_a_start_from_rclpy() {
    require_isolation();
    let dir = repo().join("target/user-crate/hello");
    let deps = readme_block("Cargo.toml").replace(
        "path = \"../radar_ros/radar_ros/library\"",
        &format!("path = \"{}\"", repo().join("radar_ros/library").display()),
    );
    assert!(
        deps.contains(&repo().join("radar_ros/library").display().to_string()),
        "the README's dependency line names radar_ros by path: {deps}"
    );
    write(
        &dir.join("Cargo.toml"),
        &format!(
            "[package]\nname = \"hello\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n{deps}\n\
             # a workspace of its own (it lives under radar_ros's target directory)\n[workspace]\n"
        ),
    );
    assert!(!deps.contains("[patch"), "no [patch] in the user's crate");
    write(&dir.join("src/main.rs"), &readme_block("src/main.rs"));
    let out = tokio::task::spawn_blocking({
        let dir = dir.clone();
        move || build(&dir, &[])
    })
    .await
    .unwrap();
    assert!(
        out.status.success(),
        "the user's crate builds: {}",
        cargo_said(&out.stderr)
    );
    // it links radar_ros's own stack, not the crates.io one
    let lock = std::fs::read_to_string(dir.join("Cargo.lock")).unwrap();
    assert!(
        lock.contains("name = \"radar-rustdds\"") && lock.contains("name = \"radar-ros2-client\"")
    );
    assert!(!lock.contains("name = \"rustdds\"") && !lock.contains("name = \"ros2-client\""));

    let mut hello = tokio::process::Command::new(user_target().join("debug/hello"))
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env("RUST_LOG", "warn")
        .stdout(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("run the user's program");
    let mut lines = BufReader::new(hello.stdout.take().unwrap()).lines();
    let mut seen = Vec::new();
    let mut next = async || {
        let l = tokio::time::timeout(Duration::from_secs(30), lines.next_line())
            .await
            .expect("the program prints in time")
            .unwrap()
            .expect("a line");
        seen.push(l.clone());
        l
    };
    assert!(next().await.starts_with("ready"));
    // a fresh rclpy process publishes once, as `ros2 topic pub --once /hello/start std_msgs/msg/Empty` does
    let py = Py::start(
        DOMAIN,
        "tests/python/interop.py",
        &["pub_once", "/hello/start"],
    );
    assert_eq!(next().await, "hello: started");
    assert_eq!(next().await, "hello: exit slot (completed)");
    let status = tokio::time::timeout(Duration::from_secs(10), hello.wait())
        .await
        .expect("the program ends after its run")
        .unwrap();
    assert!(status.success(), "{status}: {seen:?}");
    py.succeeds().await;

    // A user's build has neither optional transport (the workspace's test build has both: tests/Cargo.toml):
    // asked for one at run time, the program does not start, and says how to get it.
    let keystore = dir.join("keystore");
    let enclave = keystore.join("enclaves");
    std::fs::create_dir_all(&enclave).unwrap();
    for f in radar_ros::security::ENCLAVE_FILES {
        std::fs::write(enclave.join(f), "").unwrap();
    }
    for (env, want) in [
        (
            [("RMW_IMPLEMENTATION", "rmw_zenoh_cpp"), ("", "")],
            ["speaks DDS only", "`zenoh` feature"],
        ),
        (
            [
                ("ROS_SECURITY_ENABLE", "true"),
                ("ROS_SECURITY_STRATEGY", "Enforce"),
            ],
            ["built without DDS Security", "`security`"],
        ),
    ] {
        // a program that starts anyway waits for a start that never comes: a bounded wait, then it is killed
        let run = tokio::process::Command::new(user_target().join("debug/hello"))
            .env("ROS_DOMAIN_ID", DOMAIN.to_string())
            .env("ROS_SECURITY_KEYSTORE", &keystore)
            .envs(env.into_iter().filter(|(k, _)| !k.is_empty()))
            .kill_on_drop(true)
            .output();
        let out = tokio::time::timeout(Duration::from_secs(20), run)
            .await
            .unwrap_or_else(|_| {
                panic!("with {env:?}, the user's program started (it still ran after 20 s)")
            })
            .unwrap();
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && want.iter().all(|w| said.contains(w)),
            "with {env:?}, the user's program stops saying {want:?}: {}\n{said}",
            out.status
        );
    }
}

/// Copies the files under `from` into `to` (made as needed).
fn copy_tree(from: &Path, to: &Path) {
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let (src, dst) = (e.path(), to.join(e.file_name()));
        if src.is_dir() {
            copy_tree(&src, &dst);
        } else {
            std::fs::create_dir_all(to).unwrap();
            std::fs::copy(&src, &dst).unwrap();
        }
    }
}

/// Issue 34: generated types in a user's crate, judged by rclpy with ROS 2's own fixtures.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_crate_with_generated_types_echoes_every_test_msgs_fixture_and_serves_its_own_action() {
    require_isolation();
    const DOMAIN: u16 = 118;
    let dir = repo().join("target/user-crate/robot");
    let _ = std::fs::remove_dir_all(&dir);
    copy_tree(&repo().join("tests/fixtures/generated_crate"), &dir);
    copy_tree(
        &repo().join("msgs/radar_demo_msgs"),
        &dir.join("interfaces/radar_demo_msgs"),
    );
    write(
        &dir.join("Cargo.toml"),
        &format!(
            "[package]\nname = \"robot\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n\
             [dependencies]\nradar_ros = {{ path = \"{lib}\" }}\n\
             tokio = {{ version = \"1\", features = [\"rt-multi-thread\", \"macros\"] }}\n\n\
             [build-dependencies]\nradar_idl = {{ path = \"{idl}\" }}\n\n\
             # a workspace of its own (it lives under radar_ros's target directory)\n[workspace]\n",
            lib = repo().join("radar_ros/library").display(),
            idl = repo().join("radar_ros/idl").display(),
        ),
    );
    // AMENT_PREFIX_PATH as sourcing an installation sets it: the venv holds share/test_msgs, share/geometry_msgs
    let venv = python().parent().unwrap().parent().unwrap().to_owned();
    let out = tokio::task::spawn_blocking({
        let dir = dir.clone();
        move || build_with(&dir, &[], &[("AMENT_PREFIX_PATH", venv.as_os_str())])
    })
    .await
    .unwrap();
    assert!(
        out.status.success(),
        "the crate with generated types builds: {}",
        cargo_said(&out.stderr)
    );
    // generated code is code a person would write: it builds without a warning in a user's binary crate
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("interfaces.rs"),
        "warnings in the generated code: {stderr}"
    );

    let mut robot = tokio::process::Command::new(user_target().join("debug/robot"))
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env("RUST_LOG", "warn")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("run the crate's program");
    let mut robot_err = robot.stderr.take().unwrap();
    let stderr = tokio::spawn(async move {
        let mut s = String::new();
        tokio::io::AsyncReadExt::read_to_string(&mut robot_err, &mut s)
            .await
            .unwrap();
        s
    });
    let mut lines = BufReader::new(robot.stdout.take().unwrap()).lines();
    let ready = tokio::time::timeout(Duration::from_secs(30), lines.next_line())
        .await
        .expect("the program prints in time")
        .unwrap()
        .expect("a line");
    assert!(ready.starts_with("ready: 13 test_msgs echoes"), "{ready}");

    // every fixture, both ways (the oracle: rclpy's own fixtures and equality)
    let mut py = Py::start(DOMAIN, "tests/python/generated_types.py", &["roundtrip"]);
    let mut seen = std::collections::BTreeMap::<String, usize>::new();
    let mut wrong = Vec::new();
    while seen.values().sum::<usize>() < 2 * 31 {
        let v = py.json().await;
        assert!(v.get("error").is_none(), "{v}");
        *seen
            .entry(v["via"].as_str().unwrap().to_owned())
            .or_default() += 1;
        if v["equal"] != true {
            wrong.push(v);
        }
    }
    py.succeeds().await;
    assert!(
        wrong.is_empty(),
        "fixtures that did not come back equal: {wrong:#?}"
    );
    assert_eq!(seen["response"], 31);
    assert_eq!(seen["event"], 31);

    // its own action, through an rclpy ActionClient
    let mut py = Py::start(DOMAIN, "tests/python/generated_types.py", &["dock"]);
    let r = py.json().await;
    py.succeeds().await;
    assert_eq!(
        r["status"], 4,
        "the goal succeeded (GoalStatus.STATUS_SUCCEEDED): {r}"
    );
    assert_eq!(r["result_status"], r["docked_constant"], "{r}");
    // 1.0 from the goal's x, plus the goal's speed left at its default 0.5 by rclpy
    assert_eq!(r["travelled"], 1.5, "{r}");
    assert_eq!(
        r["dock_position"],
        serde_json::json!([1.0, 2.0, 0.0]),
        "{r}"
    );
    assert_eq!(r["dock_name"], "north+wall", "{r}");
    let cov = r["dock_covariance"].as_array().unwrap();
    assert_eq!(cov.len(), 9, "{r}");
    assert_eq!(cov[8], 9.0, "{r}");
    let goal_line = tokio::time::timeout(Duration::from_secs(10), lines.next_line())
        .await
        .expect("the program printed the goal")
        .unwrap()
        .unwrap();
    assert_eq!(
        goal_line,
        "dock: to (1, 2) in \"map\" at 0.5 m/s, tags [\"north\", \"wall\"]"
    );

    // told to stop, it stops cleanly
    let pid = robot.id().unwrap().to_string();
    Command::new("kill").args(["-TERM", &pid]).status().unwrap();
    let status = tokio::time::timeout(Duration::from_secs(10), robot.wait())
        .await
        .expect("the program ends on SIGTERM")
        .unwrap();
    assert!(status.success(), "{status}");
    let stderr = stderr.await.unwrap();
    assert!(
        !stderr.lines().any(|l| l.contains("ERROR")),
        "a program told to stop logs no error: {stderr}"
    );
}

/// The crates.io RustDDS 0.15.1, unpacked by cargo into its registry cache (`tests/isolated.sh` fetched it, for
/// `tests/fixtures/crates_io_rustdds`).
fn crates_io_rustdds() -> PathBuf {
    let out = cargo()
        .args([
            "metadata",
            "--offline",
            "--format-version",
            "1",
            "--manifest-path",
        ])
        .arg(repo().join("tests/fixtures/crates_io_rustdds/Cargo.toml"))
        .output()
        .expect("cargo metadata");
    assert!(
        out.status.success(),
        "the crates.io RustDDS is not in cargo's cache (tests/isolated.sh fetches it): {}",
        cargo_said(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let manifest = meta["packages"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "rustdds")
        .expect("rustdds in the metadata")["manifest_path"]
        .as_str()
        .unwrap()
        .to_owned();
    PathBuf::from(manifest).parent().unwrap().to_owned()
}

fn copy(from: &Path, to: &Path) {
    let _ = std::fs::remove_dir_all(to);
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    let status = Command::new("cp")
        .arg("-r")
        .arg(from)
        .arg(to)
        .status()
        .unwrap();
    assert!(
        status.success(),
        "cp -r {} {}",
        from.display(),
        to.display()
    );
}

/// A user who puts the crates.io RustDDS where radar_ros's goes (as a `[patch]` of radar_ros's git source
/// would): a copy of radar_ros, radar_semantics and the vendored ros2-client whose RustDDS is the crates.io
/// 0.15.1 (under radar_ros's package name, as a patch must be). The build stops in radar_ros's build script,
/// saying what to do, before anything of radar_ros is compiled.
#[test]
fn the_guard_stops_a_build_against_the_crates_io_rustdds() {
    let ws = repo().join("target/user-crate/guard");
    copy(&crates_io_rustdds(), &ws.join("rustdds"));
    let manifest = std::fs::read_to_string(ws.join("rustdds/Cargo.toml")).unwrap();
    assert!(
        !manifest.contains("links"),
        "the crates.io RustDDS has no marker"
    );
    let manifest = manifest
        .replacen("name = \"rustdds\"", "name = \"radar-rustdds\"", 1)
        .replacen("version = \"0.15.1\"", "version = \"0.15.1-radar.1\"", 1);
    std::fs::write(ws.join("rustdds/Cargo.toml"), manifest).unwrap();
    for part in [
        "radar_ros/library/src",
        "radar_ros/semantics",
        "radar_ros/idl",
        "third_party/ros2-client",
    ] {
        copy(&repo().join(part), &ws.join(part));
    }
    for file in [
        "radar_ros/library/Cargo.toml",
        "radar_ros/library/build.rs",
        "README.md",
    ] {
        std::fs::copy(repo().join(file), ws.join(file)).unwrap();
    }
    // the workspace as radar_ros's, with the RustDDS swapped
    let root = std::fs::read_to_string(repo().join("Cargo.toml")).unwrap();
    let root = root
        .replace("path = \"third_party/rustdds\"", "path = \"rustdds\"")
        .replace(
            "exclude = [\"third_party\"]",
            "exclude = [\"third_party\", \"rustdds\"]",
        )
        .replacen(
            "members = [",
            "members = [\"radar_ros/library\", \"radar_ros/semantics\"]\n# was: [",
            1,
        );
    std::fs::write(ws.join("Cargo.toml"), root).unwrap();
    let r2c = ws.join("third_party/ros2-client/Cargo.toml");
    let m = std::fs::read_to_string(&r2c)
        .unwrap()
        .replace("path = \"../rustdds\"", "path = \"../../rustdds\"");
    std::fs::write(r2c, m).unwrap();
    let out = build(&ws, &["-p", "radar_ros"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let said = cargo_said(&out.stderr);
    assert!(!out.status.success(), "the build goes through: {said}");
    // how many patches radar_ros asks for, as its build script says
    let build_rs = std::fs::read_to_string(repo().join("radar_ros/library/build.rs")).unwrap();
    let need = build_rs
        .lines()
        .find_map(|l| l.strip_prefix("const RUSTDDS_PATCHES: u32 = "))
        .and_then(|n| n.strip_suffix(';'))
        .expect("RUSTDDS_PATCHES in radar_ros/library/build.rs");
    assert!(
        stderr.contains(&format!(
            "radar_ros is being built against a RustDDS without radar_ros's patches (none of {need} found)"
        ))
            && stderr.contains("remove the `[patch]`")
            && !stderr.contains("error[E"),
        "radar_ros's build script stops it first, saying what to do: {said}"
    );
}

/// Issue 72: code written for radar_ros 0.1 still builds, with deprecation notes that name each name's new
/// place and nothing else: a user crate (outside the workspace, the README's dependency) using the old root
/// names of a type, a generic type, a constant, a function and the renamed `Source`.
#[test]
fn code_written_for_the_old_root_builds_with_notes_naming_the_new_places() {
    let dir = repo().join("target/user-crate/old_names");
    write(
        &dir.join("Cargo.toml"),
        &format!(
            "[package]\nname = \"old_names\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n[dependencies]\n\
             radar_ros = {{ path = \"{}\" }}\n\n[workspace]\n",
            repo().join("radar_ros/library").display()
        ),
    );
    write(
        &dir.join("src/lib.rs"),
        "pub fn old(radar: &radar_ros::Radar) -> Vec<radar_ros::Component> {\n\
         \x20   let _raw: Option<radar_ros::RawMessage> = None;\n\
         \x20   let _sub: Option<radar_ros::SignalSubscription<radar_ros::msg::Empty>> = None;\n\
         \x20   let _lease = radar_ros::DEFAULT_LEASE;\n\
         \x20   let _domain = radar_ros::domain_id_from_env();\n\
         \x20   let _cause: Option<radar_ros::Source> = None;\n\
         \x20   radar.components()\n}\n",
    );
    let out = build(&dir, &[]);
    let said = cargo_said(&out.stderr);
    assert!(out.status.success(), "old code no longer builds: {said}");
    for (old, new) in [
        ("Component", "radar_ros::graph::Component"),
        ("RawMessage", "radar_ros::topics::RawMessage"),
        (
            "SignalSubscription",
            "radar_ros::topics::SignalSubscription",
        ),
        ("DEFAULT_LEASE", "radar_ros::settings::DEFAULT_LEASE"),
        (
            "domain_id_from_env",
            "radar_ros::settings::domain_id_from_env",
        ),
        ("Source", "radar_ros::error::BoxError"),
    ] {
        assert!(
            said.contains(new),
            "no deprecation note for {old} naming {new}: {said}"
        );
    }
    let warnings = said
        .lines()
        .filter(|l| l.starts_with("warning: use of deprecated"))
        .count();
    let all = said
        .lines()
        .filter(|l| l.starts_with("warning:") && !l.contains("generated"))
        .count();
    assert_eq!(all, warnings, "only deprecation notes: {said}");
}
