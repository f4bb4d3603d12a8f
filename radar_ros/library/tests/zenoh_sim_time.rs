//! Simulated time over Zenoh (issue 37): a `Radar` on Zenoh (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`) with
//! `-p use_sim_time:=true` follows `/clock` published by a peer written from rmw_zenoh's design document
//! (tests/python/zenoh_peer.py, `rosgraph_msgs/msg/Clock` with rosidl's hash), as a simulator bridged to
//! rmw_zenoh publishes it: a timer event of 10 s triggers at simulated 100, 110 and 120 s while `/clock` runs
//! 10x faster than the wall clock, starts its period over when the time jumps back to 40 s (a trigger at 50),
//! and stands still when `/clock` stops. As `tests/sim_time.rs` checks it over DDS with rclpy. Domain 145;
//! needs the venv (RADAR_VENV) and tests/isolated.sh (a router on port 7447); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::{
    sync::{Arc, Mutex},
    time::Duration,
};

use radar_ros::{msg::Empty, ros_args::RosArgs, Radar, TimerEvent};
use serde_json::Value;
use zenoh_util::{local_router, Proc};

const DOMAIN: u16 = 145;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_timer_event_over_zenoh_follows_a_design_document_peers_clock() {
    // the one test of this binary: its environment is its own
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN.to_string());
    std::env::set_var("RMW_IMPLEMENTATION", "rmw_zenoh_cpp");
    let _router = local_router().await;
    let args = RosArgs::parse(["prog", "--ros-args", "-p", "use_sim_time:=true"]).unwrap();
    let r = Radar::builder()
        .ros_args(args)
        .handle_signals(false)
        .build()
        .unwrap();
    assert!(r.over_zenoh());
    let clock = r.clock();
    assert!(clock.is_simulated());
    let tick = r
        .spawn_event("zst_tick", TimerEvent::new(Duration::from_secs(10)))
        .unwrap();
    let at: Arc<Mutex<Vec<f64>>> = Default::default();
    let (seen, c) = (at.clone(), clock.clone());
    let _w = r
        .whenever(tick.triggered())
        .call(move |_: Empty| {
            let t = c.now();
            seen.lock()
                .unwrap()
                .push(t.sec as f64 + t.nanosec as f64 * 1e-9);
        })
        .await
        .unwrap();

    let mut peer = Proc::start(
        "zenoh_peer.py",
        &[
            "tcp/localhost:7447",
            &DOMAIN.to_string(),
            "rosgraph_msgs/msg/Clock",
            "/zst_unused",
            "/clock",
        ],
    );
    peer.until_up().await;
    assert!(at.lock().unwrap().is_empty(), "nothing before time runs");
    // 10x real time: 100 s -> 124.9 s in 0.1 s steps, 10 ms apart; then back to 40 s -> 54.9 s
    let steps = (1000..1250).chain(400..550);
    for tenths in steps {
        let (sec, nanosec) = (tenths / 10, (tenths % 10) * 100_000_000);
        peer.send(&format!(
            r#"{{"clock": {{"sec": {sec}, "nanosec": {nanosec}}}}}"#
        ))
        .await;
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // the peer says each one sent; the last one said, the callbacks have had the time of a hop
    let mut sent = 0;
    while sent < 400 {
        let v: Value = serde_json::from_str(&peer.line().await).unwrap();
        if v.get("sent").is_some() {
            sent += 1;
        }
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let got = at.lock().unwrap().clone();
    println!("zenoh_sim_time: triggers at simulated {got:?}");
    let want = [100.0, 110.0, 120.0, 50.0];
    assert_eq!(got.len(), want.len(), "triggers at {got:?}, want {want:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            (*g - w).abs() <= 2.0,
            "a trigger at simulated {g} s, want {w} s: {got:?}"
        );
    }
    // /clock stopped at 54.9 s: simulated time stands still, the timer too
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(at.lock().unwrap().len(), want.len());
    peer.close();
}
