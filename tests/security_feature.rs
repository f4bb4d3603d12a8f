//! Issue 25: RustDDS's patches for DDS Security (`third_party/rustdds/RADAR_PATCHES.md`) pass their unit tests
//! with RustDDS's `security` feature: 25, padded encrypted payloads; 27, several matches of one endpoint within
//! one participant; 28, the plugins' lock handed over when released; 31, a submessage from a participant
//! without registered endpoints is no error; 32, the bounded fuzz step, with the security handshake target; 44,
//! an encoded fragment run is parsed; 54, authentication messages resent soon after their first sending; 55,
//! session keys kept once derived, and (64) set up for AES-GCM once; 56, a secured writer sends from its own
//! thread, and a secured reader decodes every sample; 64, a submessage serialized for protection in one pass
//! has the generic bytes. RustDDS is not a workspace member: this runs `cargo test --features security` on its
//! own manifest, in its own target directory (the one tests/vendored_rustdds.rs builds its plain tests in).
//!
//! radar_ros's side of the feature needs no build of its own: the workspace's test build has `security` (and
//! `zenoh`) on (tests/Cargo.toml), so radar_ros's security unit tests, `radar_ros/library/tests/secure.rs` (two
//! secured programs, a plain one kept out, permissions generated from declarations and from the live graph, a
//! secured Fast DDS 2.9 peer from tests/fastdds/secure_peer.cpp, payloads unreadable on the wire, bad enclaves
//! refused) and `examples/tests/count_up_secured.rs` (Listings 1-3 secured) run in it like any other test.
//! Needs libssl-dev, pkg-config, g++ and libfastrtps-dev (`.ci/run` and tests/python_env.sh install them).

use std::process::{Command, Output};

use radar_test_util::{check, ran_and_passed, repo};

/// RustDDS on its own (its manifest, its tests, its target directory), with its `security` feature.
fn rustdds_cargo(args: &[&str]) -> Output {
    Command::new(env!("CARGO"))
        .args(args)
        .current_dir(repo())
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .expect("run cargo")
}

#[test]
fn rustdds_security_patches_pass_their_tests() {
    // the workspace's test build has the feature on (a compile error here if tests/Cargo.toml loses it: secure.rs
    // and count_up_secured.rs would build to nothing)
    let _: fn(&std::path::Path) -> _ = radar_ros::security::keystore::create_keystore;
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
}
