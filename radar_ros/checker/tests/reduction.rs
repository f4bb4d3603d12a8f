//! The reduction (sleep sets over moves that commute) leaves out only orders that say nothing new: on every
//! scenario small enough to explore whole both ways, the rules broken, and the length of the shortest
//! counterexample of each, are the same with and without it.

use radar_checker::{explore_system, scenarios, Budget, System};

#[test]
fn the_reduced_search_finds_what_every_order_finds() {
    let budget = Budget {
        states: 2_000_000,
        depth: 40,
    };
    let mut compared = 0;
    for s in scenarios::all() {
        let full = explore_system(System::every_order(s.clone()), budget);
        if !full.complete {
            continue; // too large to explore in every order here
        }
        let reduced = explore_system(System::new(s.clone()), budget);
        assert!(
            reduced.complete,
            "{}: the reduced search is incomplete",
            s.name
        );
        let found = |e: &radar_checker::Explored| -> Vec<(&'static str, usize)> {
            e.broken.iter().map(|c| (c.rule, c.moves.len())).collect()
        };
        assert_eq!(found(&reduced), found(&full), "{}", s.name);
        println!(
            "{}: {} states in every order, {} reduced; broken: {:?}",
            s.name,
            full.states,
            reduced.states,
            found(&full)
        );
        compared += 1;
    }
    assert!(compared >= 5, "only {compared} scenarios compared");
}
