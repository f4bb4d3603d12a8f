//! Runs Listings 2 and 3 (`launch_scripts/deliberative.sh`) and checks that the connections appear and
//! disappear as in the paper's Figure 3: (a) -> (b) -> (c) -> (b). Domain 62.

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
