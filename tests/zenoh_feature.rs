//! Issue 37: radar_ros's `zenoh` feature. The workspace's test build has it on (with `security`,
//! tests/Cargo.toml), so radar_ros's Zenoh tests run in that build like any other test:
//! `radar_ros/library/tests/zenoh*.rs` over real Zenoh against a peer written from rmw_zenoh's design document
//! (tests/python/zenoh_peer.py: the eclipse-zenoh wheel and rclpy's CDR) through a router in rmw_zenoh's
//! default layout (type hashes, transient local, congestion, skewed clocks, matched counts, raw bodies, signal
//! endpoints, a `Radar` on Zenoh, sim time, causes across processes, respawns, actions, network namespaces and
//! sites, the paper's listings), `radar_ros/tools/tests/router.rs` and `zenoh_verbs.rs` (`radar router`, the
//! verbs over Zenoh), and the Python package over Zenoh (tests/python_package.rs). The vendored ros2-client's
//! own Zenoh tests: tests/vendored_ros2_client_zenoh.rs.
//!
//! What is left here: the bench's `zenoh` scenario, quick (it is out of `radar_bench quick`'s default set, which
//! bench/tests/quick.rs runs): one hop over Zenoh peer to peer and through a router, beside DDS, raw and
//! radar_ros, on domain 150.

use std::process::Command;

use radar_test_util::check;

/// The `radar_bench` of this build (`cargo test --workspace` builds it, with its default `zenoh` feature).
fn radar_bench() -> std::path::PathBuf {
    let exe = std::env::current_exe().expect("this test's path");
    let path = exe.parent().unwrap().parent().unwrap().join("radar_bench");
    assert!(
        path.exists(),
        "{} is missing: `cargo test --workspace` builds it",
        path.display()
    );
    path
}

#[test]
fn the_bench_measures_one_hop_over_zenoh() {
    // the workspace's test build has the feature on (a compile error here if tests/Cargo.toml loses it: the
    // Zenoh tests would build to nothing)
    let _ = radar_ros::topics::ZenohSignals::open;
    // the bench's `zenoh` scenario, quick: one hop over Zenoh peer to peer and through a router, beside DDS;
    // radar_ros's own the same
    let bench_out = std::env::temp_dir().join(format!("radar_bench_zenoh_{}", std::process::id()));
    let bench = Command::new(radar_bench())
        .args(["quick", "--only", "zenoh", "--domain", "150", "--out"])
        .arg(&bench_out)
        .output()
        .expect("run radar_bench");
    let table = check(&bench, "radar_bench quick --only zenoh");
    for row in [
        "raw ros2-client over DDS, 1 hop",
        "Zenoh alone (no ros2-client)",
        "raw ros2-client over Zenoh, 1 hop peer to peer",
        "raw ros2-client over Zenoh, 1 hop through the router",
        "radar_ros over DDS, 1 hop",
        "radar_ros over Zenoh, 1 hop (event -> response, manager beside the response), peer to peer",
        "radar_ros over Zenoh, 1 hop (event -> response, manager beside the response), through the router",
        "a joining program lists 100 components (one other process), over DDS",
        "a joining program lists 100 components (one other process), over Zenoh (peer to peer)",
    ] {
        let line = table
            .lines()
            .find(|l| l.starts_with(&format!("| {row}")))
            .unwrap_or_else(|| panic!("a row {row:?} in:\n{table}"));
        let n: u64 = line.split('|').nth(2).unwrap().trim().parse().unwrap();
        assert!(n > 0, "samples measured: {line}");
        println!("radar_bench: {line}");
    }
    let _ = std::fs::remove_dir_all(&bench_out);
}
