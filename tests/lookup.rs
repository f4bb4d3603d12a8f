//! Finding components by name through ROS graph discovery, in this process and in another participant, and
//! the errors when the name is wrong. Domains 87-88.

use std::time::Duration;

use radar_ros::{
    msg::{Empty, StringMsg},
    Error, FnResponse, TimerEvent,
};
use radar_test_util::{eventually, radar};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn components_in_other_participants_are_found_by_name_and_connected() {
    let host = radar(87);
    let _tick = host
        .spawn_event("robot1/tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let echo = host
        .spawn_response(
            "robot1/echo",
            FnResponse::new(|s: StringMsg| async move { Ok(s) }),
        )
        .unwrap();
    let runs = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let r2 = runs.clone();
    let _count = host
        .spawn_response(
            "robot1/count",
            FnResponse::new(move |_: Empty| {
                r2.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();

    // the deliberative program: another participant, namespace /robot1, relative names
    let me = radar_ros::Radar::builder()
        .domain_id(87)
        .namespace("/robot1")
        .discovery_range(radar_ros::settings::DiscoveryRange::Subnet)
        .build()
        .unwrap();
    let tick = me.event("tick").await.unwrap();
    assert_eq!(tick.triggered().topic(), "/robot1/tick/triggered");
    assert_eq!(tick.triggered().ros_type(), "std_msgs/msg/Empty");
    let echo_ref = me.response("/robot1/echo").await.unwrap();
    assert_eq!(
        &echo_ref,
        echo.reference(),
        "a looked-up reference equals the local one"
    );
    let count = me.response("count").await.unwrap();
    let _c = me.whenever(tick.triggered()).start(&count).await.unwrap();
    eventually(
        Duration::from_secs(10),
        "runs through the looked-up names",
        || runs.load(std::sync::atomic::Ordering::SeqCst) >= 2,
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn lookups_wait_for_late_components_and_explain_wrong_names() {
    let r = radar(88);
    let _a = r
        .spawn_response(
            "count_up",
            FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
        )
        .unwrap();
    let _b = r
        .spawn_response(
            "count_down",
            FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
        )
        .unwrap();
    let _e = r
        .spawn_event("start_event", TimerEvent::new(Duration::from_secs(1)))
        .unwrap();

    let e = r
        .response("count_upp")
        .timeout(Duration::from_millis(300))
        .await
        .unwrap_err();
    assert!(matches!(e, Error::NotFound { .. }), "{e:?}");
    let text = e.to_string();
    assert!(text.contains("\"/count_upp\""), "{text}");
    let seen = text.split("Components seen: ").nth(1).unwrap();
    assert!(
        seen.starts_with("/count_up (response), /count_down (response)"),
        "closest first: {seen}"
    );
    assert!(seen.contains("/start_event (event)"), "{seen}");

    let e = r.response("start_event").await.unwrap_err().to_string();
    assert!(
        e.contains("is a RADAR event, but a response was asked for"),
        "{e}"
    );
    let e = r.event("count_up").await.unwrap_err().to_string();
    assert!(
        e.contains("is a RADAR response, but a event was asked for")
            || e.contains("radar.response(..)"),
        "{e}"
    );
    let e = r.event("bad-name").await.unwrap_err();
    assert!(matches!(e, Error::InvalidName { .. }), "{e:?}");

    // a component that appears while we wait is found
    let r2 = r.clone();
    let late = tokio::spawn(async move {
        tokio::time::sleep(Duration::from_millis(400)).await;
        r2.spawn_event("late", TimerEvent::new(Duration::from_secs(1)))
            .unwrap()
    });
    let t0 = std::time::Instant::now();
    let found = r.event("late").await.unwrap();
    assert!(t0.elapsed() >= Duration::from_millis(350));
    assert_eq!(found.triggered().topic(), "/late/triggered");
    drop(late.await.unwrap());
}
