//! `radar_checker [--deep] [SCENARIO...]`: explores the scenarios (all by default) and prints, for each, the
//! states explored, the depth, the time, and a shortest counterexample of every rule broken.

fn main() {
    let mut deep = false;
    let mut names = Vec::new();
    for a in std::env::args().skip(1) {
        match a.as_str() {
            "--deep" => deep = true,
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
    let mut failed = false;
    for s in radar_checker::scenarios::all() {
        if !names.is_empty() && !names.iter().any(|n| n == s.name) {
            continue;
        }
        let r = radar_checker::explore(&s, budget);
        print!("{r}");
        failed |= !r.broken.is_empty();
    }
    std::process::exit(i32::from(failed));
}
