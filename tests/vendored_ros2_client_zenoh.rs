//! The vendored ros2-client's Zenoh backend (`third_party/ros2-client/src/zenoh_backend`, `zenoh` feature)
//! passes its own unit tests, including the unit tests of radar_ros's patches to it (`RADAR_PATCHES.md`: 10, 12,
//! 14, 17-20; the others are tested through radar_ros, by its Zenoh tests (radar_ros/library/tests/zenoh*.rs)), and those of patch 26 (DDS
//! services from rmw_cyclonedds_cpp clients), which build here as well. ros2-client is not a workspace member, so this runs `cargo test --lib --features zenoh
//! zenoh_backend::` on it, offline, in a target directory of its own (`target/ros2-client-zenoh`); its
//! `Cargo.lock` starts from the workspace's (so the Zenoh crates are those the workspace pins) and its crates
//! are fetched by tests/isolated.sh before the tests. Its tests
//! open Zenoh sessions on loopback ports 17513-17548 only (multicast scouting off); run inside
//! tests/isolated.sh, as every test here.

use radar_test_util::repo;

#[test]
fn vendored_ros2_client_passes_its_zenoh_unit_tests() {
    radar_test_util::require_isolation();
    let dir = repo().join("third_party/ros2-client");
    assert!(
        dir.join("Cargo.lock").exists(),
        "third_party/ros2-client/Cargo.lock is missing: tests/isolated.sh makes it (from the workspace's) and \
         fetches its crates before the tests, which run offline"
    );
    let out = std::process::Command::new(env!("CARGO"))
        .args([
            "test",
            "--offline",
            "--lib",
            "--features",
            "zenoh",
            "--",
            "zenoh_backend::",
            "radar_patch_26_tests::",
        ])
        .current_dir(&dir)
        .env_remove("RUSTFLAGS")
        .env("CARGO_TARGET_DIR", repo().join("target/ros2-client-zenoh"))
        .output()
        .expect("run cargo");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    let summary: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("test result:"))
        .collect();
    println!("{}", summary.join("\n"));
    assert!(
        out.status.success(),
        "ros2-client's Zenoh unit tests failed:\n{}\n{stderr}",
        stdout
            .lines()
            .filter(|l| l.contains("FAILED") || l.contains("panicked"))
            .collect::<Vec<_>>()
            .join("\n")
    );
    // the patches' own tests ran (not filtered away, not renamed); patch 26: rmw_cyclonedds_cpp's request header
    // (DDS services; built here too)
    for name in [
        "a_cyclone_request_header_is_split_off_and_echoed_in_front_of_the_reply",
        "cyclone_is_told_by_the_guid_prefix_vendor",
    ] {
        assert!(
            stdout.contains(&format!(
                "test service::wrappers::radar_patch_26_tests::{name} ... ok"
            )),
            "patch 26's test {name} did not run"
        );
    }
    for name in [
        // patch 12: transient local through zenoh-ext's advanced publisher and subscriber
        "pubsub::tests::a_late_transient_local_subscription_gets_the_cached_samples",
        // patch 14: matched counts from the liveliness tokens
        "graph_cache::tests::counts_matched_endpoints_as_rmw_zenoh_does",
        "graph_cache::tests::a_watch_gets_the_count_at_once_then_each_change_of_it",
        "pubsub::tests::a_publisher_counts_the_subscriptions_that_match_it",
        // patch 17: each token's session
        "context::tests::graph_entities_name_the_session_node_and_endpoint_of_each_token",
        // patch 18: a subscription the graph does not list
        "pubsub::tests::an_unlisted_subscription_receives_without_being_counted",
        // patch 19: a sample's cause after the attachment's fields
        "attachment::tests::a_related_identity_follows_the_three_fields_and_reads_back",
        // patch 10: a type named with the hash its caller knows
        "type_hash::tests::a_registered_hash_is_what_senders_name_and_conflicts_are_refused",
        // patch 20: async action calls, action_msgs' status codes
        "action::tests::async_goal_feedback_cancel_and_result",
        "action::tests::goal_status_codes_are_action_msgs",
        // patch 21: the action status topic transient local
        "action::tests::a_late_action_client_reads_the_last_status_array",
        // patch 22: no error line when a reader has gone
        "service::tests::a_call_given_up_logs_no_error_when_its_query_times_out",
        "service::tests::a_second_answer_after_the_first_logs_no_error",
        "service::tests::a_server_dropped_while_queries_arrive_logs_no_error",
        "pubsub::tests::a_subscription_dropped_while_samples_arrive_logs_no_error",
        // patch 23: a node's enclave in its tokens
        "keyexpr::tests::a_token_names_its_enclave",
    ] {
        assert!(
            stdout.contains(&format!("test zenoh_backend::{name} ... ok")),
            "{name} did not run and pass:\n{stdout}"
        );
    }
}
