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
    // the bounded fuzz step on its own, after the rest: its CPU burst must not overlap the timed network tests
    let cargo_test = |filter: &[&str]| {
        let out = std::process::Command::new(env!("CARGO"))
            .args(["test", "--lib", "--manifest-path", manifest, "--"])
            .args(filter)
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_TARGET_DIR")
            .output()
            .expect("run cargo");
        (
            out.status,
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (status, mut stdout, mut stderr) = cargo_test(&["--skip", "fuzzing::"]);
    let (fuzz_status, fuzz_out, fuzz_err) = cargo_test(&["fuzzing::"]);
    stdout.push_str(&fuzz_out);
    stderr.push_str(&fuzz_err);
    let ok = status.success() && fuzz_status.success();
    let summary: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("test result:"))
        .collect();
    println!("{}", summary.join("\n"));
    assert!(
        ok,
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
        // patch 70: endpoints that announce different ROS 2 type hashes are not matched
        "only_two_different_announced_hashes_refuse_a_match_and_each_remote_is_warned_about_once",
        "the_hash_is_read_from_rosidl_user_data",
        // patch 69: a preemptive ACKNACK takes the form the writer's vendor answers
        "a_preemptive_acknack_takes_the_form_the_writers_vendor_answers",
        // patch 68: a reader fed by the application does not ask its feeding writer for a HEARTBEAT
        "a_reader_fed_by_the_application_does_not_ask_its_writer_for_a_heartbeat",
        // patch 59: a late reader is sent a writer's history window after window, without waiting
        "a_repair_window_short_of_the_history_ends_with_a_heartbeat",
        // patch 60: repair to a reader on this host goes in larger rounds
        "a_repair_round_to_a_reader_on_this_host_carries_more",
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
        // patch 43: an endpoint's USER_DATA (ROS 2's type hash) in discovery
        "an_endpoints_user_data_is_announced_as_a_padded_octet_sequence_and_read_back",
        // patch 42: a received sample does not keep its receive buffer alive
        "a_received_payload_is_copied_out_of_the_receive_buffer",
        // patch 41: a reader forgets the instances that are gone
        "a_disposed_instance_is_reclaimed_once_its_samples_are_taken",
        "an_alive_or_untaken_instance_is_kept",
        "forgetting_keeps_instances_with_samples_waiting",
        "the_sedp_readers_forget_the_endpoints_of_a_participant_that_is_gone",
        // patch 40: a reader that asks again for what it acknowledged gets it
        "a_reader_that_asks_again_for_what_it_acknowledged_gets_it",
        "a_reader_that_asks_again_for_acknowledged_samples_gets_them",
        // patch 38: a best-effort reader awaits nothing from a writer matched again
        "a_best_effort_reader_keeps_a_writer_matched_again_within_the_topics_limits",
        // patch 37: endpoints heard of before their participant get its addresses
        "endpoints_heard_of_before_their_participant_get_its_locators_when_it_comes",
        // patch 36: a best-effort peer costs no memory per sample
        "a_writer_whose_readers_are_all_best_effort_keeps_its_depth",
        "a_best_effort_reader_tracks_nothing_below_what_it_received",
        // patch 35: what peers that left announced does not stay in memory
        "sedp_samples_expire_and_user_samples_stay",
        "a_participant_that_leaves_takes_its_topic_data_and_the_attic_is_bounded",
        // patch 34: a writer not heard from is asked again; an empty writer answers the question
        "a_reader_asks_every_writer_it_has_not_heard_from_for_a_heartbeat",
        "a_writer_with_nothing_written_answers_a_preemptive_acknack",
        // patch 33: an outage of a destination is one warning, a count every 10 s, one line when it ends
        "failing_sends_are_reported_once_then_counted",
        "a_sender_counts_its_failing_sends_per_destination",
        // patch 32: the bounded fuzz step (corpus and seeded mutations, 3 s per target)
        "every_target_survives_its_corpus_and_mutations_of_it",
    ] {
        assert!(
            stdout.contains(&format!("{name} ... ok")),
            "{name} did not run"
        );
    }
}
