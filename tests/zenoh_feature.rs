//! Issue 37 (under way): radar_ros's `zenoh` feature, which builds ros2-client's Zenoh backend beside DDS. The
//! workspace's own build leaves it off (a DDS-only build stays small), so this builds radar_ros with it, beside
//! the `security` feature, in `target/features` (`radar_test_util::feature_cargo`: tests/security_feature.rs
//! built most of it already with the same packages and features) and checks, in order:
//! - clippy (`-D warnings`) on radar_ros, radar_tools, the bench and the examples with the features, all targets
//!   (done already when tests/security_feature.rs ran first);
//! - `radar_ros/library/tests/zenoh.rs` over real Zenoh: radar_ros's types cross to and from a peer written from
//!   rmw_zenoh's design document (tests/python/zenoh_peer.py: the eclipse-zenoh wheel and rclpy's CDR) through a
//!   router in rmw_zenoh's default layout (tests/python/zenoh_router.py), named with rosidl's type hash
//!   (ros2-client patch 10), and a hash that is malformed or in conflict is refused;
//! - `radar_ros/library/tests/zenoh_latched.rs`: transient local over Zenoh (ros2-client patch 12), both ways with
//!   the design-document peer's advanced publisher and subscriber: a late subscriber gets the last state;
//! - `radar_ros/library/tests/zenoh_congestion.rs`: a reliable KEEP_ALL burst larger than Zenoh's queues arrives
//!   whole and in order (ros2-client patch 13: it blocks on congestion, as rmw_zenoh's);
//! - `radar_ros/library/tests/zenoh_clock.rs`: a peer whose clock is an hour ahead (libfaketime) is heard and
//!   hears, plain and latched;
//! - `radar_ros/library/tests/zenoh_matched.rs`: matched counts from liveliness tokens as rmw_zenoh counts them
//!   (ros2-client patch 14), against the design-document peer as it comes and is SIGKILLed;
//! - `radar_ros/library/tests/zenoh_raw.rs`: raw bodies and a given source time (ros2-client patch 15) both ways
//!   with the design-document peer, what the manager's relays need;
//! - `radar_ros/library/tests/zenoh_signals.rs`: `radar_ros::topics::ZenohSignals`, radar_ros's signal publishers and
//!   subscriptions over Zenoh, waiting, sending and hearing against the design-document peer;
//! - `radar_ros/library/tests/zenoh_radar.rs`: a `Radar` on Zenoh (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`): Listing 2's
//!   shape with the design-document peer as the bumper, its graph read from the liveliness tokens; another
//!   program's response and manager (services over queryables) used across processes, and the manager called
//!   by a client written from the design document;
//! - `radar_ros/library/tests/zenoh_sim_time.rs`: a timer event of a `Radar` on Zenoh with `use_sim_time`
//!   follows `/clock` from the design-document peer, its jumps, and stands still when it stops;
//! - `radar_ros/library/tests/zenoh_causes.rs`: a signal's cause crosses processes over Zenoh (ros2-client
//!   patch 19): an `until`'s interrupt ends only its statement's run in another process; the design-document
//!   peer, reading as rmw_zenoh reads, still reads a caused sample;
//! - `radar_ros/library/tests/zenoh_respawn.rs`: a target killed and started again at once over Zenoh: seen
//!   replaced, a plain connection lost, a re-arming one delivering to the new process;
//! - `radar_ros/library/tests/zenoh_actions.rs`: actions over Zenoh: an action server written from the design
//!   document driven as a RADAR response (goal, feedback, result, cancel, rejection), and a response served as
//!   an action to an action client written from the design document (a fresh process per goal);
//! - `radar_ros/library/tests/zenoh_netns.rs`: the same across network namespaces with no path between them
//!   but a router in a third, through a router restart, and a killed or cut-off peer seen gone (as root; its
//!   times are printed);
//! - `radar_ros/library/tests/zenoh_sites.rs`: a router per site, joined to each other, programs peers of their
//!   own site's router: both ways, the graph across, a site's router killed and back;
//! - `radar_ros/library/tests/zenoh_listings.rs`: the paper's Listings 2 and 3 (the `deliberative` example built
//!   with the feature, four processes, `RMW_IMPLEMENTATION=rmw_zenoh_cpp`) across namespaces through a router,
//!   and again with the router killed and started anew mid-run: Figure 3 both times;
//! - the `radar` verbs over Zenoh (radar_ros/tools/tests/zenoh_verbs.rs): ls, cat (parameters), watch, act,
//!   inject, con and dis through `radar router` and `radar_manager`; watching activates no event;
//! - `radar router` (radar_ros/tools/tests/router.rs): a router as rmw_zenoh's, through which two
//!   design-document peers in rmw_zenoh's default layout meet, stopped cleanly by SIGINT and SIGTERM; a peer an
//!   hour ahead said once as a warning, not an error per sample;
//! - `radar_bench quick --only zenoh`: one hop over ros2-client's Zenoh backend, peer to peer and through a
//!   router, beside DDS, radar_ros's own one hop over Zenoh beside radar_ros's over DDS, and how long a joining
//!   program takes to list 100 components over each (the rows are printed);
//! - the Python package built with its `zenoh` feature, and a Python program on Zenoh
//!   (tests/python/zenoh_python_package.py): a Python response started by the design-document peer, a Rust
//!   response in another process found by name and driven with `once ... until` from Python;
//! - `mypy --strict` on the Python scripts.
//!
//! Everything is built before anything runs. Needs the rclpy venv with the eclipse-zenoh wheel
//! (tests/python_env.sh); runs inside tests/isolated.sh.

use std::process::{Command, Output};

use radar_test_util::{check, feature_cargo, feature_target, python, ran_and_passed, repo};

/// `cargo test|build` of the feature builds (tests/security_feature.rs built most of it already), with the
/// rclpy venv for the design-document peers.
fn cargo(verb: &str, rest: &[&str]) -> Output {
    let venv = python().parent().unwrap().parent().unwrap().to_owned();
    feature_cargo(verb, rest, &[("RADAR_VENV", venv.as_os_str())])
}

#[test]
fn the_zenoh_feature_builds_lints_and_its_tests_pass() {
    check(
        &cargo("clippy", &["--all-targets", "--", "-D", "warnings"]),
        "clippy with the zenoh and security features",
    );
    // one `--test` per name
    let tests = |names: &[&'static str]| -> Vec<&'static str> {
        names.iter().flat_map(|n| ["--test", *n]).collect()
    };
    let netns_tests = ["zenoh_netns", "zenoh_sites", "zenoh_listings"];
    let netns = [tests(&netns_tests), vec!["--", "--nocapture"]].concat();
    let test = tests(&[
        "zenoh",
        "zenoh_latched",
        "zenoh_congestion",
        "zenoh_clock",
        "zenoh_matched",
        "zenoh_raw",
        "zenoh_signals",
        "zenoh_radar",
        "zenoh_sim_time",
        "zenoh_causes",
        "zenoh_respawn",
        "zenoh_actions",
    ]);
    let router = tests(&["router", "zenoh_verbs"]);
    let no_run = [&test[..], &tests(&netns_tests), &router, &["--no-run"]].concat();
    check(
        &cargo("test", &no_run),
        "building radar_ros's Zenoh tests and radar_tools's router.rs and zenoh_verbs.rs",
    );
    // zenoh_listings.rs runs the paper's listings as the example programs, over Zenoh; zenoh_actions.rs the
    // action examples
    check(
        &cargo("build", &["--bins"]),
        "building the deliberative and action examples, radar and radar_bench with the zenoh feature",
    );
    let out = check(
        &cargo("test", &netns),
        "radar_ros/library/tests/zenoh_netns.rs, zenoh_sites.rs and zenoh_listings.rs",
    );
    ran_and_passed(
        &out,
        &[
            "signals_cross_namespaces_through_a_router_survive_its_restart_and_a_killed_peer_is_seen_gone",
            "two_sites_each_with_its_router_exchange_signals_and_see_each_others_graph",
            "listings_2_and_3_run_over_zenoh_across_namespaces_through_a_router_and_its_restart",
        ],
    );
    for l in out
        .lines()
        .filter(|l| l.contains(" in ") && !l.starts_with("test result"))
    {
        println!("zenoh_netns: {l}");
    }
    let out = check(
        &cargo("test", &test),
        "radar_ros/library/tests/zenoh.rs, zenoh_latched.rs, zenoh_congestion.rs, zenoh_clock.rs, zenoh_matched.rs, zenoh_raw.rs, zenoh_signals.rs, zenoh_radar.rs, zenoh_sim_time.rs, zenoh_causes.rs, zenoh_respawn.rs and zenoh_actions.rs",
    );
    ran_and_passed(
        &out,
        &[
            "radar_ros_types_cross_zenoh_to_and_from_a_peer_written_from_rmw_zenohs_design",
            "a_type_hash_given_to_zenoh_is_refused_when_malformed_or_in_conflict",
            "latched_state_reaches_a_late_rmw_zenoh_peer_and_a_late_subscription_gets_the_peers",
            "a_reliable_keep_all_burst_larger_than_zenohs_queues_arrives_whole_and_in_order",
            "a_peer_an_hour_ahead_is_heard_and_hears_plain_and_latched",
            "matched_counts_over_zenoh_follow_a_design_document_peer_as_it_comes_and_is_killed",
            "raw_bodies_and_their_source_times_cross_zenoh_to_and_from_a_design_document_peer",
            "radar_ros_signal_endpoints_over_zenoh_wait_send_and_hear_as_over_dds",
            "listing_2_runs_over_zenoh_with_a_design_document_peer_as_the_bumper",
            "a_timer_event_over_zenoh_follows_a_design_document_peers_clock",
            "an_until_across_processes_over_zenoh_interrupts_only_its_statements_run",
            "a_target_respawned_over_zenoh_is_seen_gone_and_a_rearming_connection_follows_it",
            "an_action_server_over_zenoh_is_a_radar_response",
        ],
    );
    let out = check(
        &cargo("test", &router),
        "radar_ros/tools/tests/router.rs and zenoh_verbs.rs",
    );
    ran_and_passed(
        &out,
        &[
            "radar_router_joins_design_document_peers_and_stops_cleanly",
            "a_peer_an_hour_ahead_is_said_once_as_a_warning_not_an_error_per_sample",
            "the_radar_verbs_drive_components_over_zenoh_and_watching_activates_nothing",
        ],
    );
    // the bench's `zenoh` scenario, quick: one hop over Zenoh peer to peer and through a router, beside DDS;
    // radar_ros's own the same
    let bench_out = std::env::temp_dir().join(format!("radar_bench_zenoh_{}", std::process::id()));
    let bench = Command::new(feature_target().join("debug/radar_bench"))
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
    // the Python package built with its zenoh feature (in this target directory: Zenoh is built here already)
    // and installed into the venv, then a Python program on Zenoh (the next run of tests/python_package.rs
    // installs its own build again)
    let zenoh_target = feature_target();
    check(
        &Command::new("bash")
            .arg(repo().join("tests/python_package.sh"))
            .env("RADAR_PY_FEATURES", "zenoh")
            .env("RADAR_PY_TARGET", &zenoh_target)
            .output()
            .expect("run tests/python_package.sh"),
        "building the Python package with its zenoh feature",
    );
    let scripts = repo().join("tests/python");
    let said = check(
        &Command::new(python())
            .arg(scripts.join("zenoh_python_package.py"))
            .arg("144")
            .arg(zenoh_target.join("debug/deliberative"))
            .output()
            .expect("run tests/python/zenoh_python_package.py"),
        "tests/python/zenoh_python_package.py: the Python package over Zenoh",
    );
    for want in [
        r#"{"echo": "DOCK"}"#,
        r#"{"rust_response": ["started", "interrupted", "exited"]}"#,
    ] {
        assert!(
            said.lines().any(|l| l == want),
            "{want} in the Python program's output:\n{said}"
        );
    }
    let mypy = Command::new(python())
        .args([
            "-m",
            "mypy",
            "--strict",
            "zenoh_peer.py",
            "zenoh_router.py",
            "zenoh_service_client.py",
            "zenoh_action_server.py",
            "zenoh_action_client.py",
            "zenoh_python_package.py",
        ])
        .current_dir(&scripts)
        .output()
        .expect("run mypy");
    check(&mypy, "mypy --strict on the Zenoh helpers");
}
