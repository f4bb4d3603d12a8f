//! Two robots from one executable, as `ros2 launch` starts them: the `count_up` example twice at once in one
//! domain, each with `--ros-args -r __ns:=/robotN -r __node:=counterN` (what a launch file's
//! `Node(namespace=..., name=...)` passes). Each must run Listing 1 on its own: its components under its
//! namespace, its program node renamed, its timeline undisturbed by the other robot's signals (without the
//! namespaces both would be `/count_up`, and each end_event would interrupt both runs), and a `-p` on one
//! robot's command line setting its CountUp's `limit` parameter only. Real rclpy checks the node names, topics
//! and parameter values where rcl would put them. Domain 107.

use std::{process::Command, time::Duration};

use radar_ros::Radar;
use radar_ros_examples::test_support::{
    assert_no_error_lines, examples_dir, require_isolation, timeline, times,
};

const DOMAIN: u16 = 107;

fn robot(n: u32, more: &[&str]) -> std::process::Child {
    Command::new(examples_dir("count_up").join("count_up"))
        .args(["--duration", "14", "--ros-args", "-r"])
        .arg(format!("__ns:=/robot{n}"))
        .arg("-r")
        .arg(format!("__node:=counter{n}"))
        .args(more)
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run count_up")
}

/// Runs tests/python/graph_probe.py with the rclpy venv (what `tests/isolated.sh` builds).
async fn graph_probe(args: &[&str]) -> serde_json::Value {
    let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_owned();
    let venv = std::env::var_os("RADAR_VENV")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| repo.join("target/ros2-venv"));
    let python = venv.join("bin/python");
    assert!(
        python.exists(),
        "the rclpy venv is missing at {}: run tests/python_env.sh",
        venv.display()
    );
    let out = tokio::process::Command::new(python)
        .arg(repo.join("tests/python/graph_probe.py"))
        .args(args)
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .kill_on_drop(true)
        .output();
    let out = tokio::time::timeout(Duration::from_secs(60), out)
        .await
        .expect("the probe ends")
        .unwrap();
    assert!(
        out.status.success(),
        "graph_probe.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_namespaced_count_ups_run_side_by_side() {
    require_isolation();
    // robot2 counts to 6 only: `-p` sets its CountUp's `limit` parameter. (Not 4: a first run of 4 counts ends
    // 4 s after start_event activated, exactly when end_event's `until` comes, and either may win.)
    let robots = [robot(1, &[]), robot(2, &["-p", "limit:=6"])];
    // seen from outside, while they run: each robot's components and program node under its namespace
    let radar = Radar::builder()
        .domain_id(DOMAIN)
        .program("observer")
        .build()
        .unwrap();
    for n in [1, 2] {
        for component in ["count_up", "start_event", "end_event"] {
            let name = format!("/robot{n}/{component}");
            let found = if component == "count_up" {
                radar
                    .response(&name)
                    .timeout(Duration::from_secs(10))
                    .await
                    .map(|_| ())
            } else {
                radar
                    .event(&name)
                    .timeout(Duration::from_secs(10))
                    .await
                    .map(|_| ())
            };
            found.unwrap_or_else(|e| panic!("{name} on the graph: {e}"));
        }
    }
    radar
        .introspect()
        .settle(Duration::from_millis(300))
        .await
        .unwrap();
    // what rclpy sees: node names, topics and parameter values where rcl would put them
    let seen = graph_probe(&[
        "/robot1/count_up:limit,period",
        "/robot2/count_up:limit,period",
        "/robot1/start_event:delay",
    ])
    .await;
    let strings = |v: &serde_json::Value| -> Vec<String> {
        v.as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|s| s.as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default()
    };
    let nodes = strings(&seen["nodes"]);
    for want in [
        "/robot1/counter1",
        "/robot2/counter2",
        "/robot1/count_up",
        "/robot2/count_up",
        "/robot1/start_event",
        "/robot2/end_event",
    ] {
        assert!(nodes.iter().any(|n| n == want), "node {want} in {nodes:?}");
    }
    let topics = strings(&seen["topics"]);
    for want in [
        "/robot1/count_up/start",
        "/robot2/end_event/triggered",
        "/robot2/count_up/state",
    ] {
        assert!(
            topics.iter().any(|t| t == want),
            "topic {want} in {topics:?}"
        );
    }
    assert!(
        !topics.iter().any(|t| t.starts_with("/count_up")),
        "nothing at the root: {topics:?}"
    );
    assert_eq!(
        seen["params"]["/robot1/count_up"],
        serde_json::json!({"limit": 10, "period": 0.5})
    );
    assert_eq!(
        seen["params"]["/robot2/count_up"],
        serde_json::json!({"limit": 6, "period": 0.5})
    );
    assert_eq!(
        seen["params"]["/robot1/start_event"],
        serde_json::json!({"delay": 2.0})
    );
    let programs = radar.introspect().connection_topics();
    for n in [1, 2] {
        let want = format!("/robot{n}/counter{n}/connections");
        assert!(programs.contains(&want), "{want} in {programs:?}");
    }
    assert!(
        !programs.iter().any(|t| t.starts_with("/count_up")),
        "nothing at the root namespace: {programs:?}"
    );
    for (n, child) in robots.into_iter().enumerate() {
        let out = child.wait_with_output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        println!("robot{}:\n{stdout}", n + 1);
        assert!(out.status.success(), "robot{} failed: {stderr}", n + 1);
        assert_no_error_lines(&stderr, "count_up");
        let tl = timeline(&stdout, None);
        // the events count from when the statement activates them (a moment after start on a busy machine)
        let active = |event: &str| times(&tl, &format!("{event} active (checking)"))[0];
        let started = times(&tl, "count_up started");
        assert!(
            started.len() >= 2 && (started[0] - active("start_event") - 2.0).abs() <= 0.15,
            "robot{}: started 2 s after start_event activated, then again: {started:?}",
            n + 1
        );
        let interrupted = times(&tl, "count_up interrupted");
        assert_eq!(
            interrupted.len(),
            1,
            "robot{}: only its own end_event interrupts its own run: {interrupted:?}",
            n + 1
        );
        assert!(
            (interrupted[0] - active("end_event") - 4.0).abs() <= 0.15,
            "robot{}: interrupted 4 s after end_event activated: {interrupted:?}",
            n + 1
        );
        let sevens = times(&tl, "count_up counts 7");
        match n {
            0 => assert!(!sevens.is_empty(), "robot1 counts to 10"),
            _ => assert!(
                sevens.is_empty(),
                "robot2 counts to its limit 6: {sevens:?}"
            ),
        }
        assert_eq!(
            times(&tl, "start_event triggered").len(),
            1,
            "robot{}: its start_event triggers once (once), the other robot's is not heard",
            n + 1
        );
    }
}
