//! Issue 37: Zenoh across network namespaces with no path between them but a router, as a fleet runs it (a
//! robot and a cloud planner that cannot see each other, a router both reach). Three namespaces: the
//! design-document peer (tests/python/zenoh_peer.py) in one, a router (tests/python/zenoh_router.py, rmw_zenoh's
//! layout) in another, radar_ros's side in the tests' own; each peer's namespace is linked to the router's
//! only, which forwards no IP: no multicast, no route from one peer to the other. radar_ros's side is told
//! where the router is with `ZENOH_CONFIG_OVERRIDE`, as an rmw_zenoh node is.
//!
//! Both sides are clients of the router: rmw_zenoh's router does no failover brokering (it forwards nothing
//! between two peers that cannot reach each other), so a program that cannot reach the others directly
//! connects as a client (or through a router of its own), as rmw_zenoh's documentation says.
//!
//! Checked: `PoseStamped` crosses both ways through the router; again after the router is killed (SIGKILL)
//! and started anew mid-run (both sessions reconnect by themselves); a peer killed with SIGKILL is seen gone
//! from radar_ros's graph (its liveliness token dropped) at once (its connection closes), and a peer cut off
//! (its link down: nothing closes) within the router's lease (10 s, Zenoh's and rmw_zenoh's default). The
//! times are printed.
//!
//! Needs root, iproute2, util-linux (unshare, nsenter) and the venv with eclipse-zenoh; runs inside
//! tests/isolated.sh (run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml)). Domain 132.
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant};

use zenoh_util::{both_ways, link, start_peer, Netns, Proc, Side};

const DOMAIN: u16 = 132;

/// How long until radar_ros's graph shows no subscriber of its publisher: at most `bound`.
async fn seen_gone(side: &Side, bound: Duration, who: &str) -> Duration {
    let since = Instant::now();
    while side.publisher.get_subscription_count(&side.node) > 0 {
        assert!(
            since.elapsed() < bound,
            "{who} is seen gone within {bound:?}"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    since.elapsed()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn signals_cross_namespaces_through_a_router_survive_its_restart_and_a_killed_peer_is_seen_gone(
) {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "run inside tests/isolated.sh: this test adds links to the network namespace it runs in"
    );
    let router_ns = Netns::new();
    let peer_ns = Netns::new();
    link(
        None,
        "zrb0",
        "10.88.2.2/24",
        &router_ns,
        "zrc2",
        "10.88.2.1/24",
    );
    link(
        Some(&peer_ns),
        "zra0",
        "10.88.1.2/24",
        &router_ns,
        "zrc1",
        "10.88.1.1/24",
    );
    // the peer's namespace has no route to this one
    zenoh_util::assert_unreachable(&peer_ns, "10.88.2.2");

    let router_at = "tcp/0.0.0.0:7447";
    let mut router = Proc::start_in(Some(router_ns.pid()), "zenoh_router.py", &[router_at]);
    assert_eq!(router.line().await, "up");
    let (mut peer, _, _, _) =
        start_peer(Some(peer_ns.pid()), "tcp/10.88.1.1:7447", DOMAIN, "client").await;
    // one test in this binary: nothing else reads the environment meanwhile
    std::env::set_var(
        "ZENOH_CONFIG_OVERRIDE",
        "mode=\"client\";connect/endpoints=[\"tcp/10.88.2.1:7447\"]",
    );
    let started = Instant::now();
    let mut side = Side::open(DOMAIN);
    both_ways(
        &mut side,
        &mut peer,
        1.5,
        "through the router in its own namespace",
    )
    .await;
    println!("through the router: both ways in {:?}", started.elapsed());

    // the router killed and started anew: both sessions reconnect
    router.kill().await;
    let mut router = Proc::start_in(Some(router_ns.pid()), "zenoh_router.py", &[router_at]);
    assert_eq!(router.line().await, "up");
    let restarted = Instant::now();
    both_ways(&mut side, &mut peer, 2.5, "after the router's restart").await;
    println!(
        "after a router restart: both ways again in {:?}",
        restarted.elapsed()
    );

    // a peer killed with SIGKILL: its subscription's token leaves radar_ros's graph
    assert!(side.publisher.get_subscription_count(&side.node) >= 1);
    peer.kill().await;
    let gone = seen_gone(&side, Duration::from_secs(12), "a peer killed with SIGKILL").await;
    println!("a SIGKILLed peer seen gone in {gone:?}");

    // a peer cut off (its link down: no connection closes, nothing is said) is seen gone when the router's
    // lease on it ends
    let (mut peer, _, _, _) =
        start_peer(Some(peer_ns.pid()), "tcp/10.88.1.1:7447", DOMAIN, "client").await;
    both_ways(&mut side, &mut peer, 3.5, "a second peer").await;
    router_ns.ip(&["link", "set", "zrc1", "down"]);
    // the router's lease on it ends: 10 s, and a keep-alive period
    let gone = seen_gone(&side, Duration::from_secs(15), "a peer cut off").await;
    println!("a peer cut off seen gone in {gone:?}");
    peer.kill().await;
    router.close();
}
