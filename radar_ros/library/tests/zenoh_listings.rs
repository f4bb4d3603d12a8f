//! Issue 37, step 5: the paper's Listings 2 and 3 over Zenoh across network namespaces, as a fleet runs them:
//! the robot's three components (`test_event`, `test_event2`, `test_response`, each its own process) in one
//! namespace, the deliberative program (`main`, in the tests' own namespace) in another, and a router in a third
//! linked to both, forwarding no IP: no multicast and no route between the robot and the program. Every program
//! is the `deliberative` example built with the `zenoh` feature, chosen at run time as ROS 2 chooses it
//! (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`), told where the router is with `ZENOH_CONFIG_OVERRIDE` (a client of
//! it, as rmw_zenoh's documentation has a program that cannot reach the others directly).
//!
//! The oracle is the paper's Figure 3, as `examples/tests/deliberative_processes.rs` checks it over DDS: the
//! connections the program prints go (a) -> (b) -> (c) -> (b); TestEvent2's `once` fires 3 s after it was made;
//! TestEvent starts TestResponse 5 s after the `whenever` was made, and the program hears `started` across the
//! router. Twice: once as it is, once with the router killed (SIGKILL) and started anew right after (c), where
//! the program and the robot lose each other's tokens for about a second: the connections hold (a departure
//! is believed only once it has lasted the lease, as over DDS), and the figure is the same. The components are
//! then stopped with SIGTERM and exit cleanly (status 0). With the lease at 0.1 s (`RADAR_LEASE_SECONDS`), the
//! restart's run fails: the program takes TestResponse for gone, and its connections deliver nothing more.
//!
//! Needs root, iproute2, util-linux (unshare, nsenter), the venv with eclipse-zenoh (the router), and the
//! example built in this target directory (`cargo test --workspace` builds it). Domain 142.
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::{path::PathBuf, process::Stdio, time::Duration};

use tokio::io::{AsyncBufReadExt, BufReader};
use zenoh_util::{link, Netns, Proc, WAIT};

const DOMAIN: u16 = 142;

/// The `deliberative` example of this target directory (built with `--features zenoh`).
fn deliberative() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let bin = exe
        .parent()
        .and_then(|deps| deps.parent())
        .unwrap()
        .join("deliberative");
    assert!(
        bin.exists(),
        "{} is missing: build it with `cargo build -p radar_ros_examples --features zenoh --bin \
         deliberative` in this target directory (`cargo test --workspace` does)",
        bin.display()
    );
    bin
}

/// `deliberative ROLE ARGS` in the namespace of `netns` (this one if `None`), over Zenoh as a client of the
/// router at `router`.
fn program(
    netns: Option<&Netns>,
    router: &str,
    role: &str,
    args: &[&str],
) -> tokio::process::Child {
    let mut cmd = match netns {
        Some(ns) => {
            let mut c = tokio::process::Command::new("nsenter");
            c.arg(format!("--net=/proc/{}/ns/net", ns.pid()))
                .arg(deliberative());
            c
        }
        None => tokio::process::Command::new(deliberative()),
    };
    cmd.arg(role)
        .args(args)
        .env("RMW_IMPLEMENTATION", "rmw_zenoh_cpp")
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env(
            "ZENOH_CONFIG_OVERRIDE",
            format!("mode=\"client\";connect/endpoints=[\"{router}\"]"),
        )
        .stdout(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("start the deliberative example")
}

/// A line of the program's timeline: `[  3.051 s] (b) - ...` as (3.051, "(b) - ...").
fn timed(line: &str) -> Option<(f64, String)> {
    let (t, text) = line.strip_prefix('[')?.split_once(" s] ")?;
    Some((t.trim().parse().ok()?, text.trim().to_owned()))
}

/// Runs the four programs; with `restart`, kills the router once (c) is printed and starts it anew. Returns the
/// program's timeline.
async fn run(robot: &Netns, router_ns: &Netns, restart: bool) -> Vec<(f64, String)> {
    let router_at = "tcp/0.0.0.0:7447";
    let mut router = Proc::start_in(Some(router_ns.pid()), "zenoh_router.py", &[router_at]);
    assert_eq!(router.line().await, "up");
    let robot_router = "tcp/10.88.21.1:7447";
    let mut components: Vec<_> = ["test_event", "test_event2", "test_response"]
        .into_iter()
        .map(|role| program(Some(robot), robot_router, role, &[]))
        .collect();
    let mut main = program(
        None,
        "tcp/10.88.22.1:7447",
        "main",
        &["--loop-secs", "4", "--duration", "6.5"],
    );
    let mut lines = BufReader::new(main.stdout.take().unwrap()).lines();
    let mut timeline = Vec::new();
    let deadline = tokio::time::Instant::now() + WAIT + Duration::from_secs(10);
    while let Some(line) = tokio::time::timeout_at(deadline, lines.next_line())
        .await
        .expect("the program ends within its duration")
        .unwrap()
    {
        println!("[main] {line}");
        if let Some(t) = timed(&line) {
            let made_once = t.1.starts_with("(c) +");
            timeline.push(t);
            if restart && made_once {
                router.kill().await;
                router = Proc::start_in(Some(router_ns.pid()), "zenoh_router.py", &[router_at]);
                assert_eq!(router.line().await, "up");
                println!("[test] router killed and started anew");
            }
        }
    }
    let status = main.wait().await.unwrap();
    assert!(status.success(), "the program ends cleanly: {status}");
    for c in &mut components {
        let pid = c.id().unwrap() as i32;
        // SIGTERM: the components stop as every radar_ros program does (exit slots, then status 0)
        unsafe { libc::kill(pid, libc::SIGTERM) };
        let status = tokio::time::timeout(WAIT, c.wait())
            .await
            .expect("a component stops on SIGTERM")
            .unwrap();
        assert!(
            status.success(),
            "a component exits cleanly on SIGTERM: {status}"
        );
    }
    router.close();
    timeline
}

/// Figure 3, and the times the listings give.
fn check_figure_3(main: &[(f64, String)], why: &str) {
    let figure: Vec<&str> = main
        .iter()
        .filter_map(|(_, t)| t.get(..3).filter(|p| p.starts_with('(')))
        .collect();
    assert_eq!(
        figure,
        ["(a)", "(b)", "(c)", "(b)"],
        "{why}: Figure 3: {main:?}"
    );
    let at = |p: &str| {
        main.iter()
            .find(|(_, t)| t.starts_with(p))
            .map(|(t, _)| *t)
            .unwrap_or_else(|| panic!("{why}: {p:?} in {main:?}"))
    };
    assert!(
        main.iter().any(|(_, t)| t.ends_with("(it fired)")),
        "{why}: test_event2 fires the once: {main:?}"
    );
    let fired = at("(b) -") - at("(c) +");
    assert!(
        (2.9..3.6).contains(&fired),
        "{why}: the once fires 3 s after it was made: {fired:.3}"
    );
    let started = at("test_response started") - at("(b) +");
    assert!(
        (4.9..5.6).contains(&started),
        "{why}: test_event starts the response 5 s after the whenever, heard across the router: {started:.3}"
    );
    println!("{why}: the once fired after {fired:.3} s, the response started after {started:.3} s");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn listings_2_and_3_run_over_zenoh_across_namespaces_through_a_router_and_its_restart() {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test adds links to the network namespace it runs in"
    );
    let router_ns = Netns::new();
    let robot = Netns::new();
    link(
        Some(&robot),
        "zla0",
        "10.88.21.2/24",
        &router_ns,
        "zlc1",
        "10.88.21.1/24",
    );
    link(
        None,
        "zlb0",
        "10.88.22.2/24",
        &router_ns,
        "zlc2",
        "10.88.22.1/24",
    );
    // the robot's namespace has no route to the program's
    zenoh_util::assert_unreachable(&robot, "10.88.22.2");

    let main = run(&robot, &router_ns, false).await;
    check_figure_3(&main, "through the router");
    let main = run(&robot, &router_ns, true).await;
    check_figure_3(&main, "through a router restarted after (c)");
}
