//! Connections over real DDS through the embedded manager, delivering to this process's responses directly
//! (one DDS hop: the source's). Domains 77-86, 89, 35-36, 0. The same cases run through DDS writers in
//! `connections_relay.rs`.

#[path = "connection_cases.rs"]
mod cases;

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Int32},
    FnResponse, Signal,
};

/// A participant in `domain` whose manager hands signals to this process's responses directly (the default).
fn radar(domain: u16) -> radar_ros::Radar {
    radar_test_util::radar(domain)
}

/// The direct way is taken: the response gets every signal while no DDS writer of this process is matched
/// with its `start` (so nothing crosses a second hop), and a subscriber of the slot's topic sees nothing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_response_of_this_process_gets_its_signals_without_a_second_dds_hop() {
    use std::sync::atomic::Ordering;
    let r = radar(1);
    let src = r.signal_publisher::<Int32>("/n").unwrap();
    let seen = r
        .signal_subscription::<Int32>("/echo/start")
        .expect("a subscription to the slot's topic");
    let got = std::sync::Arc::new(std::sync::atomic::AtomicI32::new(0));
    let g = got.clone();
    let resp = r
        .spawn_response(
            "echo",
            FnResponse::new(move |m: Int32| {
                g.store(m.data, Ordering::SeqCst);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
    let c = r
        .whenever(Signal::new("/n", "std_msgs/msg/Int32"))
        .start(&resp)
        .await
        .unwrap();
    for i in 1..=5 {
        src.publish(Int32 { data: i }).unwrap();
        radar_test_util::eventually(Duration::from_secs(10), "the start", || {
            got.load(Ordering::SeqCst) == i
        })
        .await;
    }
    assert_eq!(c.delivered(), 5);
    assert_eq!(
        resp.slot_publishers()[0],
        0,
        "no DDS writer delivers to the start slot"
    );
    assert_eq!(seen.publishers(), 0);
    assert!(seen.try_recv().is_none(), "nothing written on /echo/start");
}
