//! The reduction (sleep sets over moves that commute) leaves out only orders that say nothing new: on every
//! scenario small enough to explore whole both ways, the rules broken, and the length of the shortest
//! counterexample of each, are the same with and without it, and so is every state a run can end in.

use radar_checker::{explore_system, scenarios, Budget, System};

#[test]
fn the_reduced_search_finds_what_every_order_finds() {
    let budget = Budget {
        states: 400_000,
        depth: 40,
    };
    // the scenarios small enough in every order (the others are cut there, and left out)
    let small = [
        "listing-1",
        "listing-1-manager-beside-the-response",
        "once-until-response-killed",
        "once-until-program-stops",
        "once-until-program-killed",
        "once-call-scope-ends",
        "once-unreadable-payload",
        "interrupt-overtakes-its-start",
    ];
    let mut compared = 0;
    for s in scenarios::all()
        .into_iter()
        .filter(|s| small.contains(&s.name))
    {
        let full = explore_system(System::every_order(s.clone()), budget);
        assert!(
            full.complete,
            "{}: too large to explore in every order",
            s.name
        );
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

/// The states the runs of `system` end in (what is left of them but their history), by hash.
fn endings(system: &System) -> std::collections::BTreeSet<u64> {
    use stateright::Model;
    use std::hash::{Hash, Hasher};
    let mut out = std::collections::BTreeSet::new();
    let mut todo = system.init_states();
    let mut moves = Vec::new();
    while let Some(w) = todo.pop() {
        moves.clear();
        system.actions(&w, &mut moves);
        let mut all = Vec::new();
        w.actions(system.scenario(), &mut all);
        if all.is_empty() {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            (&w.insts, &w.mgr, &w.procs, &w.chans, &w.struck).hash(&mut h);
            out.insert(h.finish());
        }
        for a in moves.drain(..) {
            if let Some(n) = system.next_state(&w, a) {
                todo.push(n);
            }
        }
    }
    out
}

#[test]
fn the_reduced_search_ends_in_every_state_every_order_ends_in() {
    for name in [
        "listing-1-manager-beside-the-response",
        "interrupt-overtakes-its-start",
        "once-call-scope-ends",
        "once-until-program-stops",
    ] {
        let s = scenarios::all()
            .into_iter()
            .find(|s| s.name == name)
            .unwrap();
        let full = endings(&System::every_order(s.clone()));
        let reduced = endings(&System::new(s));
        println!("{name}: {} endings", full.len());
        assert!(!full.is_empty());
        assert_eq!(reduced, full, "{name}");
    }
}
