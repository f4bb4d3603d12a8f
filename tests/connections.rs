//! Connections over real DDS through the embedded manager, delivering to this process's responses directly
//! (one DDS hop: the source's). Domains 77-86, 89, 35-36, 0. The same cases run through DDS writers in
//! `connections_relay.rs`.

#[path = "connection_cases.rs"]
mod cases;
#[path = "ordering_cases.rs"]
mod ordering;

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
    assert_eq!(
        r.connections()[0].hops,
        1,
        "a plain publisher's source: its hop only"
    );
    // no writer now, but one is made if the response leaves while the connection lives (to reach one of that
    // name elsewhere): the policy generated from this run grants the program node that write
    let policy = r.policy();
    let writes_start = policy.split("<profile ").any(|p| {
        !p.starts_with(r#"ns="/" node="echo""#)
            && p.split("<topics ").any(|t| {
                t.starts_with(r#"publish="ALLOW">"#) && t.contains("<topic>/echo/start</topic>")
            })
    });
    assert!(
        writes_start,
        "the program node may write /echo/start:\n{policy}"
    );
}

/// An event of this process reaches the connection in the emitting task (no DDS hop into the manager), and
/// nothing twice although its DDS samples reach the manager's reader too: to a slot of this process no hop,
/// to a response in another participant one.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_event_of_this_process_reaches_its_connections_without_a_dds_hop_and_only_once() {
    use std::sync::{Arc, Mutex};
    /// Emits 1, 2, 3, ... every 10 ms while listened to.
    struct Count(i32);
    impl radar_ros::Event for Count {
        type Payload = Int32;
        async fn check(&mut self) -> Result<Int32, radar_ros::SlotError> {
            tokio::time::sleep(Duration::from_millis(10)).await;
            self.0 += 1;
            Ok(Int32 { data: self.0 })
        }
    }
    let r = radar(2);
    let other = radar(2);
    let ev = r.spawn_event("count", Count(0)).unwrap();
    let seen_here: Arc<Mutex<Vec<i32>>> = Default::default();
    let seen_there: Arc<Mutex<Vec<i32>>> = Default::default();
    let s = seen_there.clone();
    let _there = other
        .spawn_response(
            "there",
            FnResponse::new(move |m: Int32| {
                s.lock().unwrap().push(m.data);
                async { Ok(Empty::default()) }
            })
            .start_policy(radar_ros::StartPolicy::QueueOne),
        )
        .unwrap();
    let there = r
        .response("/there")
        .timeout(Duration::from_secs(10))
        .await
        .unwrap();
    let h = seen_here.clone();
    let to_here = r
        .whenever(ev.triggered())
        .call(move |m: Int32| h.lock().unwrap().push(m.data))
        .await
        .unwrap();
    let to_there = r.whenever(ev.triggered()).start(&there).await.unwrap();
    let hops: std::collections::BTreeMap<String, u8> = r
        .connections()
        .into_iter()
        .map(|c| (c.target, c.hops))
        .collect();
    assert_eq!(hops["(anonymous)"], 0, "{hops:?}");
    assert_eq!(hops["/there/start"], 1, "{hops:?}");
    radar_test_util::eventually(Duration::from_secs(10), "30 deliveries each", || {
        seen_here.lock().unwrap().len() >= 30 && seen_there.lock().unwrap().len() >= 30
    })
    .await;
    drop((to_here, to_there));
    tokio::time::sleep(Duration::from_millis(300)).await;
    for (what, seen) in [("here", &seen_here), ("there", &seen_there)] {
        let seen = seen.lock().unwrap();
        assert!(
            seen.windows(2).all(|w| w[0] < w[1]),
            "{what}: every signal once, in order: {seen:?}"
        );
    }
}
