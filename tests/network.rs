//! radar_ros between two machines, and over a bad network. Two network namespaces stand in for two hosts:
//! joined by a veth pair (a clean cable), or by `radar_test_netem`, a user-space relay that loses, delays
//! and reorders packets (the kernel here has no `sch_netem`). Every component runs in a
//! `radar_test_peer host` process on one of the hosts. Domains 55-57.
//!
//! `RADAR_NETWORK_SIGNALS` sets how many signals cross the lossy link (default 300); the numbers are
//! printed for docs/reliability.md.

use std::time::Instant;

use radar_test_util::{init_logs, require_isolation, HostPeer, TwoHosts};

const PEER: &str = env!("CARGO_BIN_EXE_radar_test_peer");
const NETEM: &str = env!("CARGO_BIN_EXE_radar_test_netem");
const LOG: &str = "warn,rustdds=error,ros2_client=error";

/// The peers' `RUST_LOG`: [`LOG`], or `RADAR_PEER_LOG` to trace a run.
fn log() -> String {
    std::env::var("RADAR_PEER_LOG").unwrap_or_else(|_| LOG.to_owned())
}

fn signals() -> usize {
    std::env::var("RADAR_NETWORK_SIGNALS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300)
}

/// `n=.. in_order=.. p50_us=..` as pairs.
fn stats(line: &str) -> std::collections::HashMap<String, String> {
    line.split_whitespace()
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn components_on_two_hosts_find_each_other_by_name_and_connect_across() {
    init_logs();
    require_isolation();
    let hosts = TwoHosts::cable();
    let mut a = HostPeer::start_on(Some(&hosts.a), PEER, 55, &log()).await;
    let mut b = HostPeer::start_on(Some(&hosts.b), PEER, 55, &log()).await;
    // a response and a signal on each host
    a.run("response lamp 0").await;
    a.run("publisher /door/triggered").await;
    b.run("response arm 0").await;
    b.run("publisher /bell/triggered").await;
    // each host's program finds the other host's response by name and connects its signal across
    let t0 = Instant::now();
    let found_a = a.query("whenever /bell/triggered arm").await;
    let found_b = b.query("whenever /door/triggered lamp").await;
    println!(
        "two hosts: arm found from 10.88.0.1 ({found_a:?}), lamp from 10.88.0.2 ({found_b:?}); both armed \
         after {:?}",
        t0.elapsed()
    );
    for n in 1..=3 {
        // host B's signal, through host A's connection, to B's arm; and the other way round. One run at a
        // time: a response ignores a start while it runs
        b.run("emit /bell/triggered").await;
        a.run("emit /door/triggered").await;
        b.run(&format!("wait-state arm {n} 10000")).await;
        a.run(&format!("wait-state lamp {n} 10000")).await;
    }
    for mut p in [a, b] {
        p.send("quit").await;
        assert!(p.wait().await.success());
    }
}

/// Sends `n` stamped signals from host A to a connection on host B and returns B's summary line.
async fn signals_across(hosts: &TwoHosts, domain: u16, n: usize) -> String {
    let mut a = HostPeer::start_on(Some(&hosts.a), PEER, domain, &log()).await;
    let mut b = HostPeer::start_on(Some(&hosts.b), PEER, domain, &log()).await;
    a.run("publisher-i64 /seq/triggered").await;
    b.run("collect-arm /seq/triggered").await;
    // 200 per second: a robot's event rate, and packets far enough apart for the jitter to reorder them
    a.run(&format!("emit-seq /seq/triggered {n} 5000")).await;
    let summary = b.query(&format!("collect-wait {n} 60000")).await;
    for mut p in [a, b] {
        p.send("quit").await;
        p.wait().await;
    }
    summary.into_iter().next().expect("a summary line")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reliable_signals_cross_a_lossy_link_complete_and_in_order() {
    init_logs();
    require_isolation();
    let n = signals();
    let seed: u64 = std::env::var("RADAR_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(11);
    println!("seed {seed} (RADAR_SEED to repeat)");
    // the same link without impairment, for the baseline in this run
    let clean = {
        let hosts = TwoHosts::lossy(NETEM, 0.0, 0.0, 0.0, seed);
        signals_across(&hosts, 56, n).await
    };
    let lossy = {
        // 10% of packets lost each way, 2 ms delay plus up to 6 ms jitter (so packets overtake each other)
        let hosts = TwoHosts::lossy(NETEM, 0.10, 2.0, 6.0, seed);
        signals_across(&hosts, 57, n).await
    };
    println!("{n} signals, relay without loss: {clean}");
    println!("{n} signals, 10% loss, 2-8 ms delay: {lossy}");
    for (what, line) in [("clean", &clean), ("lossy", &lossy)] {
        let s = stats(line);
        assert_eq!(
            s["n"],
            n.to_string(),
            "{what}: every signal arrives: {line}"
        );
        assert_eq!(s["in_order"], "true", "{what}: in the order sent: {line}");
    }
}
