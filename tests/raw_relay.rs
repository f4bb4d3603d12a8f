//! A relay that does not know the Rust type moves messages through unchanged: typed in, raw through, typed
//! out, equal. Domain 70.

use std::time::Duration;

use radar_ros::msg::{
    Empty, Header, Point, Pose, PoseStamped, Quaternion, RosMessage, StringMsg, Time,
};
use radar_test_util::{radar, DISCOVERY};

async fn through_raw_relay<M: RosMessage + PartialEq>(
    domain_radar: &radar_ros::Radar,
    name: &str,
    samples: Vec<M>,
) {
    let src = format!("/raw_{name}/in");
    let dst = format!("/raw_{name}/out");
    let ros_type = M::ros_type_name();
    let input = domain_radar.signal_publisher::<M>(&src).unwrap();
    let relay_in = domain_radar.raw_subscription(&src, &ros_type).unwrap();
    let relay_out = domain_radar.raw_publisher(&dst, &ros_type).unwrap();
    let output = domain_radar.signal_subscription::<M>(&dst).unwrap();
    input
        .wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    relay_in
        .wait_for_publishers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    relay_out
        .wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    output
        .wait_for_publishers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    for m in samples {
        input.publish(m.clone()).unwrap();
        let (raw, _) = tokio::time::timeout(Duration::from_secs(5), relay_in.recv_stamped())
            .await
            .unwrap()
            .unwrap();
        relay_out.publish(raw).unwrap();
        let got = output.recv().timeout(Duration::from_secs(5)).await.unwrap();
        assert_eq!(
            got, m,
            "{ros_type} changed on the way through the raw relay"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn raw_relays_forward_any_message_unchanged() {
    let r = radar(70);
    through_raw_relay(&r, "empty", vec![Empty::default()]).await;
    through_raw_relay(
        &r,
        "string",
        [
            "",
            "a",
            "ab",
            "abc",
            "abcd",
            "naïve ünïcødé",
            &"x".repeat(5000),
        ]
        .into_iter()
        .map(StringMsg::from)
        .collect(),
    )
    .await;
    // a string before 8-byte floats: alignment padding must survive
    let pose = |frame: &str, x: f64| PoseStamped {
        header: Header {
            stamp: Time {
                sec: 1_700_000_000,
                nanosec: 123_456_789,
            },
            frame_id: frame.into(),
        },
        pose: Pose {
            position: Point {
                x,
                y: -2.5,
                z: 1e-9,
            },
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: std::f64::consts::FRAC_1_SQRT_2,
                w: std::f64::consts::FRAC_1_SQRT_2,
            },
        },
    };
    through_raw_relay(
        &r,
        "pose",
        vec![pose("map", 1.0), pose("odom1", 2.0), pose("", 3.0)],
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn raw_endpoints_reject_bad_type_names_and_only_match_their_type() {
    let r = radar(71);
    let e = r
        .raw_subscription("/t", "String")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("package/msg/Name"), "{e}");
    let raw = r.raw_subscription("/t", "std_msgs/msg/String").unwrap();
    let wrong = r.signal_publisher::<Empty>("/t").unwrap();
    let right = r.signal_publisher::<StringMsg>("/t").unwrap();
    raw.wait_for_publishers(1).timeout(DISCOVERY).await.unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(raw.publishers(), 1, "the Empty publisher is another type");
    assert_eq!(wrong.subscribers(), 0);
    assert_eq!(right.subscribers(), 1);
}
