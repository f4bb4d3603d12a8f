//! Issue 25: radar_ros's `security` feature (DDS Security through RustDDS and OpenSSL). The workspace's own
//! build leaves it off (no OpenSSL by default), so this builds radar_ros, the examples, the `radar` CLI, the bench
//! and RustDDS again with it, beside the `zenoh` feature, in `target/features` (`radar_test_util::feature_cargo`:
//! tests/zenoh_feature.rs reuses the build), and checks, in order:
//! - clippy (`-D warnings`) on radar_ros, radar_tools, the examples and the bench with the feature;
//! - radar_ros's security unit tests: the `ROS_SECURITY_*` rules; keystores and enclaves made in
//!   `ros2 security`'s layout whose certificates and signed documents verify against the keystore's CA (a
//!   changed document does not);
//! - RustDDS's unit tests for radar_ros's security patches (25: padded encrypted payloads; 27: several matches
//!   of one endpoint within one participant; 28: the plugins' lock handed over when released; 31: a submessage
//!   from a participant without registered endpoints is no error; 32: the bounded fuzz step, with the
//!   security handshake target; 44: an encoded fragment run is parsed; 54: authentication messages resent soon
//!   after their first sending; 55: session keys kept once derived, and (64) set up for AES-GCM once; 56: a
//!   secured writer sends from its own thread, and a secured reader decodes every sample; 64: a submessage
//!   serialized for protection in one pass has the generic bytes);
//! - `radar_ros/library/tests/secure.rs` over real DDS (two secured programs signal each other, a plain one is kept
//!   out, one secured program hears its own signals on every subscription, only a permitted publisher starts
//!   a secured response (not a secured one without the grant, not a plain rclpy one), docs/security.md's
//!   policy as written, permissions generated from what programs declare and from the live graph (`radar
//!   security generate_policy`'s), a secured Fast DDS 2.9 peer (tests/fastdds/secure_peer.cpp, g++ against Debian's
//!   libfastrtps-dev) starts a secured response and hears it exit, payloads are not readable in frames
//!   captured on the wire, bad enclaves stop a program at start naming what is wrong), one test at a time;
//! - `examples/tests/count_up_secured.rs`: the README's example secured with a keystore from the `radar security`
//!   verbs and the permissions of what it declared in a plain run (`RADAR_GENERATE_POLICY`) follows Listing 1; Listings 2 and 3 as four secured processes follow Figure 3.
//!
//! Everything is built before anything runs over DDS (a build beside a timed run would load the machine).
//! Needs libssl-dev, pkg-config, g++ and libfastrtps-dev (`.ci/run` and tests/python_env.sh install them);
//! without them the build or the interop test fails here, saying so. Runs inside tests/isolated.sh.

use std::process::{Command, Output};

use radar_test_util::{check, feature_cargo, feature_target, ran_and_passed, repo};

/// RustDDS on its own (its manifest, its tests), with its `security` feature, in the feature builds' directory.
fn rustdds_cargo(args: &[&str]) -> Output {
    Command::new(env!("CARGO"))
        .args(args)
        .current_dir(repo())
        .env_remove("RUSTFLAGS")
        .env("CARGO_TARGET_DIR", feature_target())
        .output()
        .expect("run cargo")
}

#[test]
fn the_security_feature_builds_lints_and_its_tests_pass() {
    // build and lint everything first (with Zenoh beside: tests/zenoh_feature.rs reuses this build)
    check(
        &feature_cargo("clippy", &["--all-targets", "--", "-D", "warnings"], &[]),
        "clippy with the security and zenoh features (are libssl-dev and pkg-config installed?)",
    );
    check(
        &feature_cargo("build", &["--bins"], &[]),
        "building radar and the examples with the features",
    );
    let rustdds = repo().join("third_party/rustdds/Cargo.toml");
    let rustdds = rustdds.to_str().unwrap();
    let rustdds_tests = [
        "test",
        "--manifest-path",
        rustdds,
        "--features",
        "security",
        "--lib",
        "--",
        "padded_payload_tests",
        "per_endpoint_handle_tests",
        "lock_tests",
        "unregistered_sender_tests",
        "an_encoded_payload_longer_than_its_fragment_run",
        "decode_failures::",
        "quick_resend_tests",
        "session_key_cache_tests",
        "secured_inline_send",
        "a_submessage_serialized_in_one_pass",
        "decode_key_index_tests",
        "footer_tests",
        "a_footer_read_from_a_buffer",
        "in_place_encoding_tests",
    ];
    let mut no_run = rustdds_tests[..6].to_vec();
    no_run.push("--no-run");
    check(
        &rustdds_cargo(&no_run),
        "building RustDDS's tests with security",
    );
    check(
        &feature_cargo(
            "test",
            &["--lib", "--test", "secure", "--test", "count_up_secured", "--no-run"],
            &[],
        ),
        "building radar_ros's unit tests, radar_ros/library/tests/secure.rs and examples/tests/count_up_secured.rs",
    );

    // then run
    let out = check(
        &feature_cargo("test", &["--lib", "security::"], &[]),
        "radar_ros's security unit tests",
    );
    ran_and_passed(
        &out,
        &[
            "security::tests::the_environment_is_read_as_rcl_reads_it",
            "security::tests::a_missing_enclave_file_is_named_under_enforce_and_tolerated_under_permissive",
            "security::keystore::tests::a_keystore_and_an_enclave_are_made_signed_and_verifiable",
            "security::policy::tests::a_policy_is_translated_as_sros2_translates_it",
            "security::policy::tests::a_generated_policy_keeps_the_files_rules_and_adds_the_graphs",
        ],
    );
    let out = check(
        &rustdds_cargo(&rustdds_tests),
        "RustDDS's security patch tests",
    );
    ran_and_passed(
        &out,
        &[
            "an_encrypted_payload_followed_by_submessage_padding_is_split_at_its_footer",
            "a_signed_payload_followed_by_submessage_padding_validates",
            "two_readers_of_one_participant_matched_with_one_writer_each_get_keys_and_decode",
            "the_plugins_are_handed_over_when_released",
            "a_submessage_from_a_participant_without_registered_endpoints_has_no_keys",
            "an_encoded_payload_longer_than_its_fragment_run_is_parsed",
            "a_source_is_reported_once_per_period_with_how_many_were_not",
            "many_sources_are_bounded",
            "a_stored_authentication_message_is_resent_soon_then_left_to_the_periodic_resend",
            "a_kept_session_key_is_the_derived_one_and_the_cache_is_bounded",
            "a_secured_writer_sends_from_its_own_thread_and_the_secured_reader_decodes_every_sample",
        ],
    );
    // patch 32's bounded fuzz step with the security handshake target, on its own (a CPU burst beside the
    // lock test's timings would be a poor neighbour)
    let mut fuzz = rustdds_tests[..7].to_vec();
    fuzz.push("fuzzing::");
    let out = check(&rustdds_cargo(&fuzz), "RustDDS's fuzz step with security");
    ran_and_passed(
        &out,
        &["every_target_survives_its_corpus_and_mutations_of_it"],
    );
    let out = check(
        &feature_cargo("test", &["--test", "secure", "--", "--test-threads=1"], &[]),
        "radar_ros/library/tests/secure.rs",
    );
    println!("{out}");
    ran_and_passed(
        &out,
        &[
            "secured_programs_signal_each_other_and_a_plain_one_is_kept_out",
            "one_secured_program_hears_its_own_signals_on_every_subscription",
            "only_a_permitted_publisher_starts_a_secured_response",
            "the_documented_policy_lets_only_the_planner_start_the_dock",
            "permissions_generated_from_what_programs_declare_let_only_the_driver_start",
            "a_policy_generated_from_the_live_graph_lets_only_the_driver_start",
            "a_secured_fast_dds_peer_starts_a_secured_response_and_hears_it_exit",
            "secured_payloads_are_not_readable_on_the_wire",
            "a_bad_enclave_stops_the_program_at_start_naming_what_is_wrong",
        ],
    );
    let cli = feature_target().join("debug/radar");
    let out = check(
        &feature_cargo(
            "test",
            &["--test", "count_up_secured"],
            &[("RADAR_CLI", cli.as_os_str())],
        ),
        "examples/tests/count_up_secured.rs",
    );
    ran_and_passed(
        &out,
        &[
            "secured_count_up_follows_listing_1",
            "secured_deliberative_example_follows_figure_3",
        ],
    );
}
