//! CI's bounded model check: every scenario of `radar_checker::scenarios::all` explored whole (every order of
//! its moves, but those that commute), with no rule of `radar_spec` broken. Prints, per scenario, the states
//! explored, the depth and the time.

use radar_checker::{explore, scenarios, Budget};

#[test]
fn every_interleaving_of_every_bounded_scenario_keeps_every_rule() {
    let started = std::time::Instant::now();
    let mut states = 0;
    let mut failures = Vec::new();
    for s in scenarios::all() {
        let r = explore(&s, Budget::ci());
        print!("{r}");
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
    println!(
        "{} scenarios, {states} states in all, {:.1} s",
        scenarios::all().len(),
        started.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{failures:#?}");
}
