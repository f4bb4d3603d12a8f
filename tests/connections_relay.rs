//! The connection tests of `connection_cases.rs` with every delivery written on the slot's topic (two DDS
//! hops: source -> manager -> response), as a manager in another process delivers. Same domains as
//! `connections.rs` (cargo runs test binaries one after the other).

#[path = "connection_cases.rs"]
mod cases;
#[path = "ordering_cases.rs"]
mod ordering;

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Int32},
    FnResponse, Signal,
};

/// A participant in `domain` whose manager writes every delivery on the slot's topic.
fn radar(domain: u16) -> radar_ros::Radar {
    radar_test_util::radar_with(domain, |b| b.local_delivery(false))
}

/// The relay way is taken: every delivery is a DDS sample on the slot's topic, which any subscriber sees.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_delivery_is_written_on_the_slot_topic() {
    let r = radar(1);
    let src = r.signal_publisher::<Int32>("/n").unwrap();
    let seen = r.signal_subscription::<Int32>("/echo/start").unwrap();
    let resp = r
        .spawn_response(
            "echo",
            FnResponse::new(|_: Int32| async { Ok(Empty::default()) }),
        )
        .unwrap();
    let _c = r
        .whenever(Signal::new("/n", "std_msgs/msg/Int32"))
        .start(&resp)
        .await
        .unwrap();
    assert_eq!(resp.slot_publishers()[0], 1, "the manager's writer");
    for i in 1..=5 {
        src.publish(Int32 { data: i }).unwrap();
        let m = seen.recv().timeout(Duration::from_secs(10)).await.unwrap();
        assert_eq!(m.data, i);
    }
    assert_eq!(r.connections()[0].hops, 2);
}
