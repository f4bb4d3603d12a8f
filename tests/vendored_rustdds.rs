//! The vendored RustDDS (`third_party/rustdds`, patched for radar_ros, see its `RADAR_PATCHES.md`) passes its
//! own unit tests, including one for each patch. RustDDS is not a workspace member (its examples and
//! development dependencies would weigh on every build), so this runs `cargo test --lib` on it in its own
//! target directory. Its unit tests open no sockets to other hosts.

#[test]
fn vendored_rustdds_passes_its_unit_tests() {
    let manifest = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../third_party/rustdds/Cargo.toml"
    );
    let out = std::process::Command::new(env!("CARGO"))
        .args(["test", "--lib", "--manifest-path", manifest])
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_TARGET_DIR")
        .output()
        .expect("run cargo");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let summary: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("test result:"))
        .collect();
    println!("{}", summary.join("\n"));
    assert!(
        out.status.success(),
        "RustDDS unit tests failed:\n{}\n{stderr}",
        stdout
            .lines()
            .filter(|l| l.contains("FAILED") || l.contains("panicked"))
            .collect::<Vec<_>>()
            .join("\n")
    );
    // the patches' own tests ran
    for name in [
        "data_that_arrives_before_its_writer_is_matched_is_delivered_on_the_match",
        "durable_keep_last_writer_keeps_only_its_depth",
        "the_lease_sets_how_often_a_participant_announces_itself_and_checks_its_peers",
        "poll_channels_nobody_registers_hold_no_descriptors",
        "an_unmatched_writer_stops_its_timers_and_a_write_starts_them_again",
        "the_readers_a_writer_reaches_follow_its_matches",
        "garbage_collection_looks_only_at_topics_with_changes",
        "a_participant_closed_while_still_held_sends_what_it_wrote_and_says_goodbye",
        "a_reader_reports_when_a_matched_writer_is_heard_from",
        "announcing_the_participant_never_takes_the_applications_handle",
        "the_generation_changes_only_when_what_routes_are_chosen_from_changes",
        "user_data_is_a_padded_octet_sequence_on_the_wire",
        "participants_announce_their_user_data_and_read_their_peers",
        // patch 32: the bounded fuzz step (corpus and seeded mutations, 3 s per target)
        "every_target_survives_its_corpus_and_mutations_of_it",
    ] {
        assert!(
            stdout.contains(&format!("{name} ... ok")),
            "{name} did not run"
        );
    }
}
