//! Runs Listing 1 with one process per component (`launch_scripts/count_up_processes.sh`) and checks the
//! statement's timeline: the same component types work unchanged as separate processes. Domain 61.

use radar_ros_examples::test_support::{
    examples_dir, require_isolation, run_launch_script, timeline, times,
};

#[test]
fn listing_1_runs_with_one_process_per_component() {
    require_isolation();
    let examples = examples_dir("count_up_nodes");
    let stdout = run_launch_script("count_up_processes.sh", 61, &["--duration", "5"], &examples);
    let tl = timeline(&stdout, Some("statement"));
    let at = |what: &str| times(&tl, what);
    let near = |t: f64, listing: f64, what: &str| {
        assert!(
            (t - listing).abs() <= 0.1,
            "{what}: {t:.3} s, listing {listing:.1} s"
        );
    };
    near(at("start_event triggered")[0], 2.0, "start_event triggers");
    let started = at("count_up started");
    near(started[0], 2.0, "count_up starts");
    near(
        at("count_up interrupted")[0],
        4.0,
        "end_event interrupts count_up",
    );
    near(started[1], 4.0, "count_up restarts from its exit slot");
    // the response process counted: its lines are there too
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("[count_up] ") && l.ends_with("count_up counts 3")),
        "{stdout}"
    );
}
