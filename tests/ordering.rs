//! Issue 19, B8: `waitfor` as users run it. A waiter is armed only when the signal's writers have matched it
//! back (RustDDS patch 18), so a component in a fresh process that emits the moment the waiter is armed is
//! heard; and a payload that does not decode is reported and skipped, not the end of the wait. Domains 14-15.

use std::time::Duration;

use radar_ros::{msg::StringMsg, topics::RawMessage, Signal};
use radar_test_util::{publish_unreadable_string, radar, HostPeer, DISCOVERY};

const T: Duration = Duration::from_secs(5);

/// 30 fresh processes, each with a new publisher: the waiter is armed the moment it finds the publisher, the
/// process emits the moment it is told the waiter is armed, and every signal arrives. Before, the waiter was
/// "armed" when its reader had matched the writer, but the writer had not yet matched the reader: what it
/// emitted then was lost and `recv` waited for ever.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn b8_a_waiter_armed_on_a_fresh_process_gets_what_it_emits_right_after() {
    let r = radar(14);
    let peer = env!("CARGO_BIN_EXE_radar_test_peer");
    for batch in 0..6 {
        let rounds = (0..5).map(|i| {
            let r = r.clone();
            async move {
                let topic = format!("/b8_{batch}_{i}");
                let mut p = HostPeer::start(peer, 14).await;
                p.run(&format!("publisher {topic}")).await;
                let mut w = r
                    .waiter::<radar_ros::msg::Empty>(Signal::new(&topic, "std_msgs/msg/Empty"))
                    .timeout(DISCOVERY)
                    .await
                    .unwrap();
                p.run(&format!("emit-now {topic}")).await;
                w.recv().timeout(T).await.unwrap_or_else(|e| {
                    panic!("{topic}: the signal emitted right after arming: {e}")
                });
                p.send("quit").await;
            }
        });
        futures::future::join_all(rounds).await;
    }
}

/// A payload that does not decode as the waiter's type is reported (counted per publisher, logged once) and
/// skipped: the waiter gets the next good one. Before, it used up the waiter's `once` and `recv` failed with
/// "closed".
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn b8_a_bad_payload_is_reported_and_skipped_not_the_end_of_a_wait() {
    let r = radar(15);
    let raw = r.raw_publisher("/b8_bad", "std_msgs/msg/String").unwrap();
    let mut w = r
        .waiter::<StringMsg>(Signal::new("/b8_bad", "std_msgs/msg/String"))
        .timeout(DISCOVERY)
        .await
        .unwrap();
    publish_unreadable_string(&r, &raw).await;
    raw.publish(RawMessage::encode(&StringMsg::from("dock")).unwrap())
        .unwrap();
    let got = w.recv().timeout(T).await.unwrap();
    assert_eq!(got.data, "dock");
}
