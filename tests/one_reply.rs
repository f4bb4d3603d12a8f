//! Each reliable sample between two participants of this host costs two UDP datagrams: the DATA with its
//! HEARTBEAT, and the reader's one ACKNACK (RustDDS patch 63). The reader used to send every ACKNACK once per
//! unicast locator the writer's participant announced (here 127.0.0.1 and the test namespace's 10.77.0.1),
//! and the writer to answer an ACKNACK that crossed its next sample with one more HEARTBEAT: 3.5 datagrams a
//! sample. Its own binary: it counts every datagram of the test namespace (`/proc/self/net/snmp`), and cargo
//! runs test binaries one at a time. Domain 229.

use std::time::Duration;

use radar_ros::msg::StringMsg;
use radar_test_util::{datagrams_sent, radar, DISCOVERY};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_reliable_sample_to_a_participant_of_this_host_costs_two_datagrams() {
    let (a, b) = (radar(229), radar(229));
    let publisher = a.signal_publisher::<StringMsg>("/one_reply/s").unwrap();
    let subscription = b.signal_subscription::<StringMsg>("/one_reply/s").unwrap();
    publisher
        .wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    subscription
        .wait_for_publishers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    // one sample at a time, the next as soon as the last arrived (its ACKNACK may cross the next one)
    let round = |n: usize, from: usize| {
        let (publisher, subscription) = (&publisher, &subscription);
        async move {
            for i in from..from + n {
                publisher
                    .publish(StringMsg::from(format!("s{i}").as_str()))
                    .unwrap();
                let got = tokio::time::timeout(Duration::from_secs(5), subscription.recv())
                    .await
                    .expect("a sample within 5 s")
                    .unwrap();
                assert_eq!(got, StringMsg::from(format!("s{i}").as_str()));
            }
        }
    };
    // discovery's own traffic settles while samples flow
    round(50, 0).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let n = 400;
    let before = datagrams_sent();
    round(n, 50).await;
    // the last ACKNACK
    tokio::time::sleep(Duration::from_millis(100)).await;
    let per_sample = (datagrams_sent() - before) as f64 / n as f64;
    // 2 (DATA+HEARTBEAT, ACKNACK), plus the participants' periodic discovery over the run; 3.5 before
    assert!(
        per_sample < 2.5,
        "{per_sample:.2} UDP datagrams per sample (two is DATA with HEARTBEAT and one ACKNACK)"
    );
    println!("{per_sample:.2} UDP datagrams per sample");
}
