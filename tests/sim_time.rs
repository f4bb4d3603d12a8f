//! Simulated time: with `-p use_sim_time:=true` a timer event follows `/clock` published by real rclpy (as a
//! simulator publishes it), 10x faster than the wall clock, skips periods the time jumped over, starts its
//! period over when the time jumps backwards, and stands still when `/clock` stops. Domain 106.

use std::{
    sync::{Arc, Mutex},
    time::Duration,
};

use radar_ros::{msg::Empty, ros_args::RosArgs, TimerEvent};
use radar_test_util::{radar_with, Py};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_timer_event_follows_clock_and_its_jumps() {
    let args = RosArgs::parse(["prog", "--ros-args", "-p", "use_sim_time:=true"]).unwrap();
    let r = radar_with(106, |b| b.ros_args(args));
    let clock = r.clock();
    assert!(clock.is_simulated());
    assert_eq!(clock.now().sec, 0, "no /clock heard yet");
    let tick = r
        .spawn_event("tick", TimerEvent::new(Duration::from_secs(10)))
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
    // 10x real time: 100 s -> 129.9 s in 0.1 s steps, 10 ms apart; then reset to 40 s -> 59.9 s
    let mut py = Py::start(
        106,
        "tests/python/clock_pub.py",
        &["100", "100", "10", "500", "300", "40"],
    );
    py.expect_line("ready").await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(at.lock().unwrap().is_empty(), "nothing before time runs");
    py.proceed().await;
    py.expect_line("done").await;
    // 5 s of wall time passed: a wall-clock timer of 10 s would not have triggered at all
    tokio::time::sleep(Duration::from_millis(500)).await;
    // read when the trigger reached the callback: 0.1 s of simulated time per 10 ms of delay
    let got = at.lock().unwrap().clone();
    println!("triggers at simulated {got:?}");
    let want = [100.0, 110.0, 120.0, 50.0];
    assert_eq!(got.len(), want.len(), "triggers at {got:?}, want {want:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            (*g - w).abs() <= 2.0,
            "a trigger at simulated {g} s, want {w} s: {got:?}"
        );
    }
    // /clock stopped at 59.9 s: simulated time stands still, the timer too
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(at.lock().unwrap().len(), want.len());
}
