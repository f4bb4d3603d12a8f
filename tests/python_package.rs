//! Issue 24: the Python package (`radar_ros/python`) is built and installed into the interop venv as a user
//! installs it (maturin), then its pytest suite runs over real DDS (domains 215-219; see
//! `radar_ros/python/tests/`), and `mypy --strict` checks the package's types and the Python example against
//! its stubs. A missing tool or helper fails the test; a skipped Python test fails it too.

use std::{path::PathBuf, process::Command};

use radar_test_util::require_isolation;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_owned()
}

/// The built `count_up` example (the Python example's timeline is checked against it).
fn count_up_example() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let path = exe.parent().unwrap().parent().unwrap().join("count_up");
    assert!(
        path.exists(),
        "{} is missing: `cargo test --workspace` builds it, or `cargo build --bin count_up`",
        path.display()
    );
    path
}

/// Installs the package; the venv it is in.
fn install() -> PathBuf {
    let out = Command::new("bash")
        .arg(repo().join("tests/python_package.sh"))
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
