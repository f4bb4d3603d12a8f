//! The vendored ros2-client (`third_party/ros2-client`, see its `RADAR_PATCHES.md`): each radar_ros patch,
//! over real DDS between two participants.

use std::time::Duration;

use radar_test_util::{init_logs, require_isolation, DISCOVERY};
use ros2_client::{
    dds::rustdds::{self, SampleIdentity, SequenceNumber, Timestamp, GUID},
    Context, ContextOptions, MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};

const DOMAIN: u16 = 3;

#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
struct Int32 {
    data: i32,
}

fn node(ctx: &Context, name: &str) -> ros2_client::Node {
    let mut node = ctx
        .new_node(
            NodeName::new("/", name).unwrap(),
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .unwrap();
    tokio::spawn(node.spinner().unwrap().spin());
    node
}

fn qos() -> QosProfile {
    radar_ros::qos::signal_qos()
}

/// A publisher in one participant and a subscription in another, matched both ways.
async fn pair(
    topic: &str,
) -> (
    (Context, ros2_client::Node, ros2_client::Publisher<Int32>),
    (Context, ros2_client::Node, ros2_client::Subscription<Int32>),
) {
    init_logs();
    require_isolation();
    let ctx = |_| Context::with_options(ContextOptions::new().domain_id(DOMAIN)).unwrap();
    let (a, b) = (ctx(0), ctx(1));
    let (mut na, mut nb) = (node(&a, "writer_side"), node(&b, "reader_side"));
    let ty = MessageTypeName::new("std_msgs", "Int32");
    let name = Name::new("/", topic).unwrap();
    let ta = na.create_topic(&name, ty.clone(), &qos()).unwrap();
    let tb = nb.create_topic(&name, ty, &qos()).unwrap();
    let p = na.create_publisher::<Int32>(&ta, Some(qos())).unwrap();
    let s = nb.create_subscription::<Int32>(&tb, Some(qos())).unwrap();
    tokio::time::timeout(DISCOVERY, p.wait_for_subscription(&na))
        .await
        .expect("the subscription matched");
    tokio::time::timeout(DISCOVERY, s.wait_for_publisher(&nb))
        .await
        .expect("the publisher matched");
    // the reader side matched: the writer's first heartbeat may still be on its way; a fresh sample is
    // delivered either way (RustDDS patch 2)
    ((a, na, p), (b, nb, s))
}

#[tokio::test(flavor = "multi_thread")]
async fn publish_with_options_carries_the_source_time_and_the_related_identity() {
    let ((_a, _na, p), (_b, _nb, s)) = pair("patch1").await;
    let related = SampleIdentity {
        writer_guid: GUID::from_bytes([7; 16]),
        sequence_number: SequenceNumber::from(42_i64),
    };
    let at: Timestamp = ros2_client::ROSTime::from_nanos(1_700_000_000_123_456_789).into();
    let written = p
        .publish_with_options(
            Int32 { data: 7 },
            rustdds::WriteOptionsBuilder::new()
                .source_timestamp(at)
                .related_sample_identity(related)
                .build(),
        )
        .map_err(|e| e.forget_data())
        .expect("written");
    assert_eq!(
        written.writer_guid,
        p.guid(),
        "the identity of the sample written"
    );
    let (m, info) = tokio::time::timeout(DISCOVERY, s.async_take())
        .await
        .expect("delivered")
        .expect("decoded");
    assert_eq!(m.data, 7);
    let got = info.source_timestamp().expect("a source time");
    assert!(
        (got.to_nanos() - 1_700_000_000_123_456_789).abs() <= 1,
        "the source time given, not the time of writing: {got:?}"
    );
    let rel = info.related_request_id().expect("a related identity");
    assert_eq!(SampleIdentity::from(rel), related);
    // a plain publish carries none
    p.publish(Int32 { data: 8 })
        .map_err(|e| e.forget_data())
        .unwrap();
    let (_, info) = tokio::time::timeout(DISCOVERY, s.async_take())
        .await
        .unwrap()
        .unwrap();
    assert!(info.related_request_id().is_none());
}

#[tokio::test(flavor = "multi_thread")]
async fn wait_for_acknowledgments_returns_once_the_reader_has_everything() {
    let ((_a, _na, p), (_b, _nb, s)) = pair("patch2").await;
    for i in 0..20 {
        p.publish(Int32 { data: i })
            .map_err(|e| e.forget_data())
            .unwrap();
    }
    let acked = tokio::task::spawn_blocking(move || {
        let r = p.wait_for_acknowledgments(Duration::from_secs(10));
        (r, p)
    })
    .await
    .unwrap();
    assert_eq!(acked.0.ok(), Some(true), "acknowledged within the limit");
    // everything acknowledged is in the reader's cache now
    for i in 0..20 {
        let (m, _) = s.take().unwrap().expect("already there");
        assert_eq!(m.data, i);
    }
}
