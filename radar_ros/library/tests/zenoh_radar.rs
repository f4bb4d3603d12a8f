//! Issue 37, step 3's second half: a `Radar` on Zenoh. Under `RMW_IMPLEMENTATION=rmw_zenoh_cpp` (in a build
//! with the `zenoh` feature) `Radar::builder().build()` opens a Zenoh session configured as rmw_zenoh's, and its
//! components, its connections in this process and its plain endpoints run over it, as over DDS.
//!
//! The oracle is the peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py: the
//! eclipse-zenoh wheel, rclpy's CDR, rosidl's hashes; nothing from radar_ros or ros2-client), through a router
//! in rmw_zenoh's default layout. Listing 2's shape across it: the peer publishes poses on `/zr/bump`; an event
//! of this program (`/zr/bumper`, a `TopicEvent`) triggers on those with `x > 1`; `whenever bumper start dock`;
//! the response `/zr/dock` runs and its `started` reaches the peer, carrying the pose that triggered it, and its
//! `exited` reaches this program's own subscription. The peer sees the program's nodes and endpoints in the
//! liveliness tokens, as an rmw_zenoh peer's graph shows them. No settling sleeps: each wait is on a match
//! count or a sample. With the transport refused (RMW_IMPLEMENTATION unset), the test fails at its first check.
//!
//! Domain 140. Needs the venv (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by
//! tests/zenoh_feature.rs.
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::sync::{
    atomic::{AtomicUsize, Ordering},
    Arc,
};

use radar_ros::{
    msg::{Empty, PoseStamped, RosMessage},
    FnResponse, Radar, TopicEvent,
};
use serde_json::Value;
use zenoh_util::{local_router, start_peer_on, WAIT};

const DOMAIN: u16 = 140;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn listing_2_runs_over_zenoh_with_a_design_document_peer_as_the_bumper() {
    // the one test of this binary: its environment is its own
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN.to_string());
    std::env::set_var("RMW_IMPLEMENTATION", "rmw_zenoh_cpp");
    let _router = local_router().await;
    let radar = Radar::builder()
        .program("zr_program")
        .handle_signals(false)
        .build()
        .unwrap();
    assert!(
        radar.over_zenoh() && radar.dds_context().is_none(),
        "RMW_IMPLEMENTATION=rmw_zenoh_cpp chose Zenoh"
    );

    let bumper = radar
        .spawn_event(
            "/zr/bumper",
            TopicEvent::new("/zr/bump", |p: &PoseStamped| {
                (p.pose.position.x > 1.0).then(|| p.clone())
            }),
        )
        .unwrap();
    let runs = Arc::new(AtomicUsize::new(0));
    let counted = runs.clone();
    let dock = radar
        .spawn_response(
            "/zr/dock",
            FnResponse::new(move |_: PoseStamped| {
                let counted = counted.clone();
                async move {
                    counted.fetch_add(1, Ordering::SeqCst);
                    Ok(Empty::default())
                }
            }),
        )
        .unwrap();
    let exited = radar
        .signal_subscription::<Empty>("/zr/dock/exited")
        .unwrap();
    let bumps = radar
        .signal_subscription::<PoseStamped>("/zr/bump")
        .unwrap();
    let _c = radar.whenever(&bumper).start(&dock).await.unwrap();

    // the peer hears `started` and publishes the bumps
    let (mut peer, _, _, mut lines) = start_peer_on(
        None,
        "tcp/localhost:7447",
        DOMAIN,
        ("peer", "volatile"),
        ("/zr/dock/started", "/zr/bump"),
        &[],
    )
    .await;
    bumps.wait_for_publishers(1).timeout(WAIT).await.unwrap();
    exited.wait_for_publishers(1).timeout(WAIT).await.unwrap();
    peer.send(r#"{"header": {"frame_id": "soft"}, "pose": {"position": {"x": 0.5}}}"#)
        .await;
    peer.send(r#"{"header": {"frame_id": "hard"}, "pose": {"position": {"x": 2.5}}}"#)
        .await;
    let started = loop {
        let v: Value = serde_json::from_str(&peer.line().await).unwrap();
        if v.get("received").is_some() {
            break v;
        }
        lines.push(v);
    };
    assert_eq!(
        (
            started["received"]["header"]["frame_id"].as_str(),
            started["received"]["pose"]["position"]["x"].as_f64()
        ),
        (Some("hard"), Some(2.5)),
        "the first `started` the peer hears carries the pose that triggered the event (the soft one did not): \
         {started}"
    );
    exited.recv().timeout(WAIT).await.unwrap();
    assert_eq!(runs.load(Ordering::SeqCst), 1, "dock ran once");

    // the program's graph, as an rmw_zenoh peer reads it from the liveliness tokens
    let hash = PoseStamped::TYPE_HASH.unwrap();
    let tokens: Vec<String> = lines
        .iter()
        .filter(|v| v["put"].as_bool() == Some(true))
        .filter_map(|v| v["token"].as_str().map(str::to_owned))
        .collect();
    let has = |kind: &str, tail: &str| {
        tokens
            .iter()
            .any(|t| t.contains(&format!("/{kind}/")) && t.contains(tail))
    };
    assert!(
        has("NN", "/%zr/dock") && has("NN", "/%zr/bumper") && has("NN", "/zr_program"),
        "nodes dock, bumper and the program node are on the graph: {tokens:#?}"
    );
    assert!(
        has("MP", &format!("/%zr%dock%started/geometry_msgs::msg::dds_::PoseStamped_/{hash}/"))
            && has("MS", &format!("/%zr%dock%start/geometry_msgs::msg::dds_::PoseStamped_/{hash}/"))
            && has("MS", &format!("/%zr%bump/geometry_msgs::msg::dds_::PoseStamped_/{hash}/")),
        "dock's `started` publisher and `start` subscription, and the bumper's subscription, with rosidl's \
         hash: {tokens:#?}"
    );
    peer.close();
}
