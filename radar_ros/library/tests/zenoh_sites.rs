//! Issue 37, the fleet layout's second case: a router per site, the routers joined to each other, and every
//! program a peer of its own site's router in rmw_zenoh's default layout (connect `tcp/localhost:7447`). Two
//! network namespaces: site A (the tests' own) holds radar_ros's side and router A; site B holds the peer
//! written from rmw_zenoh's design document (tests/python/zenoh_peer.py) and router B. Only a link between
//! the two namespaces joins them, and only router A is told where router B is; no multicast. Nothing is told
//! to radar_ros's side: its session is the backend's default (rmw_zenoh's).
//!
//! Checked: `PoseStamped` crosses both ways between the sites, the graph crosses too (radar_ros's side counts
//! the peer's subscription, from its liveliness token), and when router B dies (SIGKILL) the peer is seen
//! gone from site A's graph; once router B is back, the peer reconnects to it and the sites exchange again.
//! The times are printed.
//!
//! Needs root, iproute2, util-linux and the venv with eclipse-zenoh; runs inside tests/isolated.sh (port 7447
//! is the tests' namespace's own; run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml)). Domain 134.
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant};

use zenoh_util::{both_ways, link, start_peer, Netns, Proc, Side, WAIT};

const DOMAIN: u16 = 134;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_sites_each_with_its_router_exchange_signals_and_see_each_others_graph() {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test adds a link to the network namespace it runs in and \
         starts a router on port 7447"
    );
    assert!(
        std::env::var_os("ZENOH_CONFIG_OVERRIDE").is_none()
            && std::env::var_os("ZENOH_SESSION_CONFIG_URI").is_none(),
        "radar_ros's side uses the default session here: unset ZENOH_CONFIG_OVERRIDE and \
         ZENOH_SESSION_CONFIG_URI"
    );
    let site_b = Netns::new();
    link(
        None,
        "zsa0",
        "10.88.5.1/24",
        &site_b,
        "zsb0",
        "10.88.5.2/24",
    );
    let start_router_b =
        || Proc::start_in(Some(site_b.pid()), "zenoh_router.py", &["tcp/0.0.0.0:7447"]);
    let mut router_b = start_router_b();
    assert_eq!(router_b.line().await, "up");
    // router A: this site's, on loopback for its programs and the site link, joined to router B
    let mut router_a = Proc::start(
        "zenoh_router.py",
        &["tcp/0.0.0.0:7447", "tcp/10.88.5.2:7447"],
    );
    assert_eq!(router_a.line().await, "up");
    let (mut peer, _, _, _) =
        start_peer(Some(site_b.pid()), "tcp/localhost:7447", DOMAIN, "peer").await;

    let started = Instant::now();
    let mut side = Side::open(DOMAIN);
    both_ways(
        &mut side,
        &mut peer,
        1.5,
        "site A to site B through their routers",
    )
    .await;
    println!(
        "across two sites' routers: both ways in {:?}",
        started.elapsed()
    );
    assert!(
        side.publisher.get_subscription_count(&side.node) >= 1,
        "site A's graph has site B's subscription"
    );

    // router B dies: site B's peer is cut off from site A, and seen gone from its graph
    router_b.kill().await;
    let since = Instant::now();
    while side.publisher.get_subscription_count(&side.node) > 0 {
        assert!(
            since.elapsed() < WAIT,
            "site B's peer is seen gone from site A's graph once site B's router is gone"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    println!(
        "site B's router killed: its peer gone from site A's graph in {:?}",
        since.elapsed()
    );

    // router B back: the peer and router A reconnect to it by themselves
    let mut router_b = start_router_b();
    assert_eq!(router_b.line().await, "up");
    let back = Instant::now();
    both_ways(&mut side, &mut peer, 2.5, "after site B's router came back").await;
    println!(
        "site B's router restarted: both ways again in {:?}",
        back.elapsed()
    );
    peer.close();
    router_b.close();
    router_a.close();
}
