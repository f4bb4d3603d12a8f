//! Runs Listing 1 with one process per component (`launch_scripts/count_up_processes.sh`) and checks the
//! statement's timeline: the same component types work unchanged as separate processes. Domain 61.

use std::process::Command;

use radar_ros_examples::test_support::{examples_dir, require_isolation};

#[test]
fn listing_1_runs_with_one_process_per_component() {
    require_isolation();
    let examples = examples_dir("count_up_nodes");
    let script = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../launch_scripts/count_up_processes.sh"
    );
    let out = Command::new("bash")
        .args([script, "--duration", "5"])
        .env("RADAR_EXAMPLES", &examples)
        .env("ROS_DOMAIN_ID", "61")
        .output()
        .expect("run the launch script");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let at = |what: &str| -> Vec<f64> {
        stdout
            .lines()
            .filter_map(|l| l.strip_prefix("[statement] ["))
            .filter_map(|l| l.split_once(" s] "))
            .filter(|(_, text)| text.split("(listing").next().unwrap().trim() == what)
            .filter_map(|(t, _)| t.trim().parse::<f64>().ok())
            .collect()
    };
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
