//! `radar_checker [--deep] [--first] [SCENARIO...]`: explores the scenarios (all by default) and prints, for
//! each, the states explored, the depth, the time, and a shortest counterexample of every rule broken.
//! `--first` stops at the first scenario that breaks a rule and ends with a line `caught SCENARIO RULE MOVES`
//! (the mutation runner reads it). Exits with 1 if a rule was broken.

fn main() {
    let mut deep = false;
    let mut first = false;
    let mut names = Vec::new();
    for a in std::env::args().skip(1) {
        match a.as_str() {
            "--deep" => deep = true,
            "--first" => first = true,
            "--list" => {
                for s in radar_checker::scenarios::all() {
                    println!("{}", s.name);
                }
                return;
            }
            _ => names.push(a),
        }
    }
    let budget = if deep {
        radar_checker::Budget::deep()
    } else {
        radar_checker::Budget::ci()
    };
    let chosen: Vec<_> = radar_checker::scenarios::all()
        .into_iter()
        .filter(|s| names.is_empty() || names.iter().any(|n| n == s.name))
        .collect();
    let mut failed = false;
    // with --first, a quick pass over every scenario first (a planted bug shows in small states), then the
    // whole budget
    let passes = if first {
        vec![radar_checker::Budget::quick(), budget]
    } else {
        vec![budget]
    };
    for budget in passes {
        for s in &chosen {
            let r = radar_checker::explore(s, budget);
            print!("{r}");
            failed |= !r.broken.is_empty();
            if first {
                if let Some(c) = r.broken.first() {
                    println!("caught {} {} {}", s.name, c.rule, c.moves.len());
                    std::process::exit(1);
                }
            }
        }
    }
    std::process::exit(i32::from(failed));
}
