//! CI's bounded model check: every scenario of `radar_checker::scenarios::all` explored whole (every order of
//! its moves, but those that commute), with no rule of `radar_spec` broken. Prints, per scenario, the states
//! explored, the depth and the time (to stderr itself, which the test harness does not capture: CI's log shows
//! them). The scenarios are dealt out to four tests so that the test harness explores
//! them on every core.

use std::io::Write;

use radar_checker::{explore, scenarios, Budget};

const PARTS: usize = 4;

/// Explores every `PARTS`th scenario from the `part`th.
fn explore_part(part: usize) {
    let started = std::time::Instant::now();
    let mut states = 0;
    let mut failures = Vec::new();
    let all = scenarios::all();
    let mine: Vec<_> = all.iter().skip(part).step_by(PARTS).collect();
    for s in &mine {
        let r = explore(s, Budget::ci());
        // a whole scenario's lines at once (the parts run side by side)
        let _ = write!(std::io::stderr().lock(), "{r}");
        states += r.states;
        if !r.complete {
            failures.push(format!("{}: not explored whole within the budget", s.name));
        }
        for c in &r.broken {
            failures.push(format!(
                "{}: {} broken in {} moves",
                s.name,
                c.rule,
                c.moves.len()
            ));
        }
    }
    let _ = writeln!(
        std::io::stderr().lock(),
        "part {part}: {} of {} scenarios, {states} states in all, {:.1} s",
        mine.len(),
        all.len(),
        started.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn every_interleaving_of_every_bounded_scenario_keeps_every_rule_part_0() {
    explore_part(0);
}

#[test]
fn every_interleaving_of_every_bounded_scenario_keeps_every_rule_part_1() {
    explore_part(1);
}

#[test]
fn every_interleaving_of_every_bounded_scenario_keeps_every_rule_part_2() {
    explore_part(2);
}

#[test]
fn every_interleaving_of_every_bounded_scenario_keeps_every_rule_part_3() {
    explore_part(3);
}
