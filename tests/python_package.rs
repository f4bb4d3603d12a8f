//! Issue 24: the Python package (`radar_ros/python`) is built and installed into the interop venv as a user
//! installs it (maturin), then its pytest suite runs over real DDS (domains 215-219; see
//! `radar_ros/python/tests/`), and `mypy --strict` checks the package's types and the Python example against
//! its stubs. Then the same wheel (manylinux, checked by auditwheel) is installed into a fresh venv of the
//! system's Python and runs Listing 1 with no Rust toolchain on PATH (issue 70), and a Python program runs over
//! Zenoh (the package is built with its `zenoh` feature). A missing tool or helper fails the
//! test; a skipped Python test fails it too.

use std::{
    path::{Path, PathBuf},
    process::Command,
};

use radar_ros_examples::test_support::{assert_listing_1_times, assert_no_error_lines};
use radar_test_util::require_isolation;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_owned()
}

/// The built `count_up` example (the Python example's timeline is checked against it).
fn count_up_example() -> PathBuf {
    example("count_up")
}

/// An example program of this build (with the `zenoh` feature: tests/Cargo.toml).
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let path = exe.parent().unwrap().parent().unwrap().join(name);
    assert!(
        path.exists(),
        "{} is missing: `cargo test --workspace` builds it, or `cargo build --bin {name}`",
        path.display()
    );
    path
}

/// Installs the package, built with its `zenoh` feature (one build serves the suite over DDS and the program
/// over Zenoh below); the venv it is in.
fn install() -> PathBuf {
    let out = Command::new("bash")
        .arg(repo().join("tests/python_package.sh"))
        .env("RADAR_PY_FEATURES", "zenoh")
        .output()
        .expect("run tests/python_package.sh");
    assert!(
        out.status.success(),
        "building or installing the Python package failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    PathBuf::from(String::from_utf8_lossy(&out.stdout).trim())
}

#[test]
fn the_python_package_passes_its_tests_over_real_dds_and_its_types_check() {
    require_isolation();
    let venv = install();
    let py = venv.join("bin/python");
    let out = Command::new(&py)
        .args(["-m", "pytest", "-v", "-rfEs", "-p", "no:cacheprovider"])
        .arg(repo().join("radar_ros/python/tests"))
        .env("RADAR_TEST_PEER", env!("CARGO_BIN_EXE_radar_test_peer"))
        .env("RADAR_COUNT_UP_EXE", count_up_example())
        .env("PYTHONUNBUFFERED", "1")
        .env_remove("ROS_DOMAIN_ID")
        .output()
        .expect("run pytest");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "the Python tests failed (above)");
    let summary = stdout.lines().last().unwrap_or_default();
    assert!(
        summary.contains(" passed") && !summary.contains("skipped") && !summary.contains("xfail"),
        "every Python test runs and passes: {summary}"
    );

    // the installed package carries its types (py.typed, the native module's stub), and they hold
    mypy(&py, &["-p", "radar_ros"]);
    // the example type-checks against them
    let example = repo().join("examples/python/count_up.py");
    mypy(&py, &[example.to_str().unwrap()]);

    // the same wheel as a user without a Rust toolchain installs it (after the suite: Listing 1's timing is
    // checked, on a machine the suite no longer loads)
    the_wheel_installs_without_rust_and_runs_listing_1(&py);

    the_package_runs_over_zenoh(&py);
}

/// Issue 37: the package's `zenoh` feature: a Python program on Zenoh (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`)
/// signals a Rust program's response and runs one of its own for it (tests/python/zenoh_python_package.py,
/// domain 144, beside the `deliberative` example of this build); then `mypy --strict` on the Zenoh helpers
/// of the Rust tests (radar_ros/library/tests/zenoh*.rs run them).
fn the_package_runs_over_zenoh(py: &Path) {
    let scripts = repo().join("tests/python");
    let out = Command::new(py)
        .arg(scripts.join("zenoh_python_package.py"))
        .arg("144")
        .arg(example("deliberative"))
        .output()
        .expect("run tests/python/zenoh_python_package.py");
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "tests/python/zenoh_python_package.py: the Python package over Zenoh failed:\n{said}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for want in [
        r#"{"echo": "DOCK"}"#,
        r#"{"rust_response": ["started", "interrupted", "exited"]}"#,
    ] {
        assert!(
            said.lines().any(|l| l == want),
            "{want} in the Python program's output:\n{said}"
        );
    }
    // as the helpers are run: from their directory, for the interpreter of the venv
    let out = Command::new(py)
        .args([
            "-m",
            "mypy",
            "--strict",
            "zenoh_peer.py",
            "zenoh_router.py",
            "zenoh_service_client.py",
            "zenoh_action_server.py",
            "zenoh_action_client.py",
            "zenoh_python_package.py",
        ])
        .current_dir(&scripts)
        .output()
        .expect("run mypy");
    assert!(
        out.status.success(),
        "mypy --strict on the Zenoh helpers:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Issue 70: the wheel that `tests/python_package.sh` built is manylinux-tagged and auditwheel agrees; it
/// installs, alone and from the file, into a fresh venv of the machine's own Python (`python3 -m venv`, as beside
/// an apt-installed ROS), and the Python Listing 1 runs from there with a PATH holding that venv's `bin/` only
/// (no cargo, rustc or ROS on it; no variable of the build's environment), following the listing. Domain 140.
fn the_wheel_installs_without_rust_and_runs_listing_1(tools_py: &Path) {
    let wheels = std::env::var_os("RADAR_PY_TARGET")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("target/python-pkg"))
        .join("wheels");
    let wheel = std::fs::read_dir(&wheels)
        .expect("the wheels directory")
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "whl"))
        .unwrap_or_else(|| panic!("no wheel in {}", wheels.display()));
    let name = wheel.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        name.starts_with("radar_ros-")
            && name.contains("-abi3-manylinux_")
            && name.ends_with("_x86_64.whl"),
        "one abi3 manylinux wheel: {name}"
    );

    // auditwheel (from the tools venv): the wheel needs no library beyond what manylinux allows, at its tag
    let show = Command::new(tools_py)
        .args(["-m", "auditwheel", "show"])
        .arg(&wheel)
        .output()
        .expect("run auditwheel");
    let said = String::from_utf8_lossy(&show.stdout).replace('\n', " ");
    assert!(
        show.status.success(),
        "auditwheel show {name}: {said}{}",
        String::from_utf8_lossy(&show.stderr)
    );
    let tag = name.split('-').nth(4).unwrap().trim_end_matches(".whl");
    assert!(
        said.contains(&format!(
            "consistent with the following platform tag: \"{tag}\""
        )),
        "auditwheel agrees with the wheel's tag {tag}: {said}"
    );

    // a fresh venv of the system's Python, the wheel alone installed into it from the file
    let fresh = repo().join("target/python-wheel-venv");
    let _ = std::fs::remove_dir_all(&fresh);
    let system_python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    run_ok(
        Command::new(&system_python)
            .args(["-m", "venv"])
            .arg(&fresh),
        "python3 -m venv",
    );
    run_ok(
        Command::new(fresh.join("bin/pip"))
            .args(["install", "--disable-pip-version-check", "-q", "--no-index"])
            .arg(&wheel),
        "pip install of the wheel (no index: it needs nothing else)",
    );

    // nothing of the build's environment: PATH is the venv's bin/ alone
    let in_fresh = |c: &mut Command| {
        c.env_clear()
            .env("PATH", fresh.join("bin"))
            .env("HOME", std::env::var_os("HOME").unwrap_or_default())
            .env("ROS_DOMAIN_ID", "151")
            .env("PYTHONUNBUFFERED", "1")
            .current_dir(repo());
    };
    let mut probe = Command::new(fresh.join("bin/python"));
    probe.args([
        "-c",
        "import shutil, radar_ros; print(radar_ros.__file__); \
         print([t for t in ('cargo', 'rustc', 'ros2') if shutil.which(t)])",
    ]);
    in_fresh(&mut probe);
    let probed = run_ok(&mut probe, "import radar_ros from the fresh venv");
    assert!(
        probed.starts_with(&fresh.to_string_lossy().into_owned())
            && probed.trim_end().ends_with("[]"),
        "radar_ros is the installed wheel's, and no Rust toolchain or ROS is on PATH: {probed}"
    );

    let mut listing = Command::new(fresh.join("bin/python"));
    listing.args(["examples/python/count_up.py", "--duration", "9.7"]);
    in_fresh(&mut listing);
    let out = listing.output().expect("run the Python Listing 1");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "Listing 1 from the wheel failed: {stderr}"
    );
    assert_no_error_lines(&stderr, "Listing 1 from the wheel");
    // the Python example prints signals as it reads them (the Rust one by their source times): the listing's
    // steps and times are checked, not the order of lines a few ms apart
    assert_listing_1_times(&stdout);
}

/// Runs `c`, asserts it succeeded; its stdout.
fn run_ok(c: &mut Command, what: &str) -> String {
    let out = c.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn mypy(py: &std::path::Path, what: &[&str]) {
    let out = Command::new(py)
        .args([
            "-m",
            "mypy",
            "--strict",
            "--no-incremental",
            "--python-version",
            "3.10",
        ])
        .args(what)
        .output()
        .expect("run mypy");
    assert!(
        out.status.success(),
        "mypy --strict {what:?}:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
