//! Issue 35 (first part): readers that only observe. A reader that says so in its USER_DATA
//! (`Radar::observe_raw`, what `radar record` and `radar watch` use) receives every trigger of an event but is
//! not one of its listeners: it never makes the event check. A plain rclpy subscriber (as `ros2 topic echo`)
//! is a listener, as before. Domain 120.

use std::time::Duration;

use radar_ros::TimerEvent;
use radar_test_util::{radar, require_isolation, Py};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_observer_sees_the_triggers_an_rclpy_listener_causes_and_never_activates_the_event() {
    require_isolation();
    const DOMAIN: u16 = 120;
    let program = radar(DOMAIN);
    let tick = program
        .spawn_event("/obs/tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let mut state = tick.watch_state();
    // another participant only observes `triggered`
    let watcher = radar(DOMAIN);
    let seen = watcher
        .observe_raw("/obs/tick/triggered", "std_msgs/msg/Empty")
        .unwrap();
    // matched (discovery takes well under a second here), the event still does not check
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let s = tick.state();
    assert!(!s.active, "an observer does not activate the event: {s:?}");
    assert_eq!(s.listeners, 0, "{s:?}");
    assert_eq!(s.activations, 0, "{s:?}");

    // a plain rclpy subscriber is a listener: the event checks, and the observer sees every trigger too
    let mut sub = Py::start(
        DOMAIN,
        "tests/python/subscribe.py",
        &["/obs/tick/triggered"],
    );
    assert_eq!(sub.json().await["subscribed"], true);
    tokio::time::timeout(Duration::from_secs(10), state.wait_for(|s| s.active))
        .await
        .expect("the rclpy subscriber activates the event")
        .unwrap();
    assert_eq!(tick.state().listeners, 1, "the rclpy subscriber alone");
    for _ in 0..3 {
        tokio::time::timeout(Duration::from_secs(5), seen.recv_stamped())
            .await
            .expect("the observer receives the triggers")
            .unwrap();
    }
    while sub.json().await["received"].as_u64().unwrap_or(0) < 3 {}

    // the rclpy subscriber leaves: the event stops checking, though the observer is still there
    sub.proceed().await;
    sub.succeeds().await;
    tokio::time::timeout(Duration::from_secs(10), state.wait_for(|s| !s.active))
        .await
        .expect("the event deactivates when its only listener leaves")
        .unwrap();
    let s = tick.state();
    assert_eq!(s.listeners, 0, "{s:?}");
    assert_eq!(s.activations, 1, "{s:?}");
    drop(seen);
}
