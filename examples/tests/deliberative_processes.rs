//! Runs Listings 2 and 3 (`launch_scripts/deliberative.sh`) and checks that the connections appear and
//! disappear as in the paper's Figure 3: (a) -> (b) -> (c) -> (b) (domain 62); and the two-robot launch
//! (`launch_scripts/two_robots.sh`, domain 63).

use radar_ros_examples::test_support::{
    examples_dir, require_isolation, run_launch_script, timeline,
};

#[test]
fn connections_follow_figure_3() {
    require_isolation();
    let examples = examples_dir("deliberative");
    let stdout = run_launch_script(
        "deliberative.sh",
        62,
        &["--loop-secs", "4", "--duration", "6.5"],
        &examples,
    );
    let main = timeline(&stdout, Some("main"));
    let figure: Vec<&str> = main
        .iter()
        .filter_map(|(_, t)| t.get(..3).filter(|p| p.starts_with('(')))
        .collect();
    assert_eq!(figure, ["(a)", "(b)", "(c)", "(b)"], "Figure 3: {main:?}");
    let at = |p: &str| {
        main.iter()
            .find(|(_, t)| t.starts_with(p))
            .map(|(t, _)| *t)
            .unwrap()
    };
    let fired = main.iter().any(|(_, t)| t.ends_with("(it fired)"));
    assert!(fired, "test_event2 fires the once after 3 s: {main:?}");
    let dt = at("(b) -") - at("(c) +");
    assert!(
        (2.9..3.4).contains(&dt),
        "the once fires 3 s after it was made: {dt:.3}"
    );
    let started = at("test_response started") - at("(b) +");
    assert!(
        (4.9..5.4).contains(&started),
        "test_event starts the response after 5 s: {started:.3}"
    );
    assert!(main.iter().any(|(_, t)| t == "do_loop returned"));
    // the interrupt at 3 s found the response idle: nothing was interrupted
    assert!(!stdout.contains("test_response interrupted"));
}

/// `launch_scripts/two_robots.sh`: the example twice under /robot1 and /robot2 in one domain, with
/// `--params-file launch_scripts/robots.yaml` (robot1's test_event counts to 2, robot2's to 4, every
/// test_event2 to 3). Each robot's program finds its own components, and each response starts after its own
/// robot's count.
#[test]
fn two_robots_run_side_by_side_with_their_own_settings() {
    require_isolation();
    let examples = examples_dir("deliberative");
    let stdout = run_launch_script(
        "two_robots.sh",
        63,
        &["--loop-secs", "4", "--duration", "6.5"],
        &examples,
    );
    for (robot, count) in [("robot1", 2.0), ("robot2", 4.0)] {
        let main = timeline(&stdout, Some(&format!("{robot} main")));
        let at = |p: &str| {
            main.iter()
                .find(|(_, t)| t.starts_with(p))
                .map(|(t, _)| *t)
                .unwrap_or_else(|| panic!("{robot}: {p:?} in {main:?}"))
        };
        let started = at("test_response started") - at("(b) +");
        assert!(
            (count - 0.1..count + 0.4).contains(&started),
            "{robot}: its test_event starts the response after its own count {count} s: {started:.3}"
        );
        let fired = at("(b) -") - at("(c) +");
        assert!(
            (2.9..3.4).contains(&fired),
            "{robot}: test_event2 counts to 3 (robots.yaml): {fired:.3}"
        );
    }
}
