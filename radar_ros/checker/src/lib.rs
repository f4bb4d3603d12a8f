//! # radar_checker: every interleaving of bounded RADAR systems, judged by the specification
//!
//! A [`Scenario`] is a small system: one to three events and responses in some processes, a program whose
//! manager carries out one to three statements, and faults that may strike at any step (a process killed,
//! respawned at once, duplicated, told to stop; time jumping past `HOLD`). [`World`] is its state, with the
//! real machines of `radar_semantics` inside (each response's `ResponseMachine`, each event's `Activation`,
//! the manager's `ConnectionTable`, the instance watcher's `Instances`) and the binding's decisions around them
//! (see [`world`]). Every message is a move of its own, so signals on different topics are read in every order.
//!
//! [stateright](https://docs.rs/stateright) explores every order of moves, breadth first; after each move the
//! specification (`radar_spec`) judges the whole trace so far: every safety rule at every state, the liveness
//! rules at the states with no move left. The first counterexample found of a rule is a shortest one.
//!
//! ```
//! use radar_checker::{explore, scenarios, Budget};
//! let s = scenarios::all().into_iter().find(|s| s.name == "listing-1").unwrap();
//! let r = explore(&s, Budget::ci());
//! assert!(r.broken.is_empty(), "{r}");
//! ```

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod mutants;
pub mod scenario;
pub mod scenarios;
pub mod world;

use std::time::{Duration, Instant};

use radar_spec::{
    rules::ALL,
    trace::{Component as SpecComponent, End, Role},
    Violation,
};
use stateright::{Checker, Model, Property};

pub use scenario::Scenario;
pub use world::{Action, World};

/// How far to explore.
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    /// Stop after this many distinct states (the run then says it is incomplete).
    pub states: usize,
    /// Explore paths up to this many moves.
    pub depth: usize,
}

impl Budget {
    /// What CI explores per scenario: enough for every scenario of [`scenarios::all`] to be explored whole.
    pub fn ci() -> Budget {
        Budget {
            states: 2_500_000,
            depth: 80,
        }
    }

    /// A quick look (the mutation runner's first pass).
    pub fn quick() -> Budget {
        Budget {
            states: 300_000,
            depth: 60,
        }
    }

    /// A deeper run.
    pub fn deep() -> Budget {
        Budget {
            states: 4_000_000,
            depth: 200,
        }
    }
}

/// A scenario as a stateright model.
pub struct System {
    scenario: Scenario,
    components: Vec<SpecComponent>,
    /// Leave out the orders of moves that commute (sleep sets); off: every order.
    reduce: bool,
}

impl System {
    /// The model of `scenario`.
    pub fn new(scenario: Scenario) -> System {
        let components = scenario
            .components
            .iter()
            .map(|c| SpecComponent {
                name: c.name.to_owned(),
                role: match &c.part {
                    scenario::Part::Program => Role::Program,
                    scenario::Part::Event { .. } => Role::Event,
                    scenario::Part::Response { policy, .. } => Role::Response {
                        policy: *policy,
                        causes: true,
                    },
                },
            })
            .collect();
        System {
            scenario,
            components,
            reduce: true,
        }
    }

    /// The model of `scenario` that takes every order of moves, commuting ones too (to check the reduction).
    pub fn every_order(scenario: Scenario) -> System {
        System {
            reduce: false,
            ..System::new(scenario)
        }
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The components, as the specification names them.
    pub fn components(&self) -> &[SpecComponent] {
        &self.components
    }

    /// The rules `w`'s trace breaks, as it ends.
    pub fn judge(&self, w: &World, end: End) -> Vec<Violation> {
        radar_spec::check_records(&self.components, &w.trace, end).violations
    }

    fn mask(v: &[Violation]) -> u64 {
        v.iter()
            .map(|v| {
                let i = ALL
                    .iter()
                    .position(|r| std::ptr::eq(*r, v.rule))
                    .expect("a rule of ALL");
                1u64 << i
            })
            .fold(0, |a, b| a | b)
    }
}

/// Whether rule `I` of [`ALL`] holds in a state.
fn holds<const I: usize>(_: &System, w: &World) -> bool {
    w.broken & (1 << I) == 0
}

macro_rules! properties {
    ($($i:literal)*) => {
        const HOLDS: &[fn(&System, &World) -> bool] = &[$(holds::<$i>),*];
    };
}
properties!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31);

impl Model for System {
    type State = World;
    type Action = Action;

    fn init_states(&self) -> Vec<World> {
        let mut w = World::new(&self.scenario);
        self.settle(&mut w);
        vec![w]
    }

    fn actions(&self, w: &World, out: &mut Vec<Action>) {
        if w.broken == 0 {
            w.actions(&self.scenario, out);
            out.retain(|a| !w.sleep.contains(a));
        }
    }

    fn next_state(&self, w: &World, a: Action) -> Option<World> {
        // sleep sets: the moves taken before this one from here, and those asleep here, that commute with it
        // need not be taken after it (that order is explored from the other side)
        let mut before = Vec::new();
        w.actions(&self.scenario, &mut before);
        before.retain(|b| !w.sleep.contains(b));
        let i = before.iter().position(|b| *b == a).unwrap_or(before.len());
        let asleep: Vec<Action> = w
            .sleep
            .iter()
            .chain(&before[..i])
            .copied()
            .filter(|b| self.reduce && *b != a && self.independent(w, a, *b))
            .collect();
        let mut next = w.clone();
        next.sleep.clear();
        next.step(&self.scenario, a);
        self.settle(&mut next);
        next.sleep = asleep;
        Some(next)
    }

    fn properties(&self) -> Vec<Property<Self>> {
        assert!(ALL.len() <= HOLDS.len(), "more rules than properties");
        ALL.iter()
            .zip(HOLDS)
            .map(|(r, f)| Property::always(r.name, *f))
            .collect()
    }
}

impl System {
    /// Judges the state: safety now, liveness too if no move is left.
    fn settle(&self, w: &mut World) {
        let mut v = self.judge(w, End::Open);
        if v.is_empty() {
            let mut moves = Vec::new();
            w.actions(&self.scenario, &mut moves);
            if moves.is_empty() {
                w.over = true;
                v = self.judge(w, End::Quiescent);
            }
        }
        w.broken = Self::mask(&v);
    }

    /// Whether moves `a` and `b`, both possible in `w`, commute there in a way the rules cannot tell apart:
    /// they are steps of different processes, each leaves the other possible, both orders lead to the same
    /// state, each records the same in either order, and their records name no component in common (so no
    /// rule relates them).
    fn independent(&self, w: &World, a: Action, b: Action) -> bool {
        let s = &self.scenario;
        let pa = w.acts_in(s, a);
        if w.acts_in(s, b).iter().any(|p| pa.contains(p)) {
            return false;
        }
        let after = |first: Action, second: Action| -> Option<World> {
            let mut x = w.clone();
            x.step(s, first);
            let mut moves = Vec::new();
            x.actions(s, &mut moves);
            if !moves.contains(&second) {
                return None;
            }
            x.step(s, second);
            Some(x)
        };
        let (Some(ab), Some(ba)) = (after(a, b), after(b, a)) else {
            return false;
        };
        if !ab.same_now(&ba) {
            return false;
        }
        let n = w.trace.len();
        let unstep = |r: &radar_spec::trace::Record| (r.at, r.obs);
        let steps = |x: &World, first_steps: u32| -> (Vec<_>, Vec<_>) {
            let (one, two): (Vec<_>, Vec<_>) =
                x.trace[n..].iter().partition(|r| r.step == first_steps);
            (
                one.into_iter().map(unstep).collect(),
                two.into_iter().map(unstep).collect(),
            )
        };
        let (ra, rb) = steps(&ab, w.steps);
        let (rb2, ra2) = steps(&ba, w.steps);
        if ra != ra2 || rb != rb2 {
            return false;
        }
        let names = |rs: &[(i64, radar_spec::trace::Obs)]| -> std::collections::BTreeSet<u16> {
            rs.iter().flat_map(|(_, o)| self.mentions(o)).collect()
        };
        names(&ra).is_disjoint(&names(&rb))
    }

    /// The components whose identity a record speaks of, where the rules compare records of different
    /// processes by their order: a loss seen by a statement against the instances that left or came. (Every
    /// other relation the rules draw between records of different processes goes by stamps and emissions, or
    /// through the manager, whose steps never commute with each other.)
    fn mentions(&self, o: &radar_spec::trace::Obs) -> Vec<u16> {
        use radar_spec::trace::Obs;
        match *o {
            Obs::LossSeen { comp, .. } | Obs::Left { comp, .. } | Obs::Spawned { comp, .. } => {
                vec![comp.0]
            }
            _ => Vec::new(),
        }
    }
}

/// A counterexample: a shortest trace that breaks a rule.
#[derive(Clone, Debug)]
pub struct Counterexample {
    /// The rule's name.
    pub rule: &'static str,
    /// The moves, from the start.
    pub moves: Vec<Action>,
    /// The violations the last state shows.
    pub violations: Vec<Violation>,
    /// The trace, printed.
    pub trace: String,
}

/// What one exploration found.
#[derive(Clone, Debug)]
pub struct Explored {
    /// The scenario's name.
    pub scenario: &'static str,
    /// Distinct states explored.
    pub states: usize,
    /// States generated, with repeats.
    pub generated: usize,
    /// The deepest path explored.
    pub depth: usize,
    /// Whether every reachable state within the depth was explored.
    pub complete: bool,
    /// How long it took.
    pub time: Duration,
    /// The rules broken, each with a shortest counterexample.
    pub broken: Vec<Counterexample>,
}

/// Explores every interleaving of `scenario` within `budget`, breadth first (one thread: the first
/// counterexample of each rule is a shortest one).
pub fn explore(scenario: &Scenario, budget: Budget) -> Explored {
    explore_system(System::new(scenario.clone()), budget)
}

/// [`explore`] for a system built as asked (every order, say).
pub fn explore_system(system: System, budget: Budget) -> Explored {
    let start = Instant::now();
    let name = system.scenario.name;
    let checker = system
        .checker()
        .threads(1)
        .target_state_count(budget.states)
        .target_max_depth(budget.depth)
        .spawn_bfs()
        .join();
    let time = start.elapsed();
    let system = checker.model();
    let mut broken = Vec::new();
    for (rule, path) in checker.discoveries() {
        let states = path.clone().into_states();
        let last = states.last().expect("a path has a state");
        let end = if last.over { End::Quiescent } else { End::Open };
        let violations = system.judge(last, end);
        let trace = print_trace(system, last);
        broken.push(Counterexample {
            rule,
            moves: path.into_actions(),
            violations,
            trace,
        });
    }
    broken.sort_by_key(|c| (c.moves.len(), c.rule));
    let states = checker.unique_state_count();
    Explored {
        scenario: name,
        states,
        generated: checker.state_count(),
        depth: checker.max_depth(),
        // the search stops once it has generated the budget's states (repeats included)
        complete: checker.state_count() < budget.states && checker.max_depth() < budget.depth,
        time,
        broken,
    }
}

/// A trace as lines, one record a line, with the components' names.
pub fn print_trace(system: &System, w: &World) -> String {
    use std::fmt::Write;
    let names: Vec<&str> = system
        .components()
        .iter()
        .map(|c| c.name.as_str())
        .collect();
    let name = |c: radar_spec::trace::Comp| names.get(usize::from(c.0)).copied().unwrap_or("?");
    let mut out = String::new();
    for (i, r) in w.trace.iter().enumerate() {
        let t = (r.at - world::EPOCH) / world::STEP;
        let step = r.step;
        let line = format!("{:?}", r.obs);
        // component indices to names, for reading
        let mut named = line.clone();
        for (c, n) in names.iter().enumerate() {
            named = named.replace(&format!("Comp({c})"), n);
        }
        let _ = name;
        let _ = writeln!(out, "{i:>3} step {step:<3} t={t:<4} {named}");
    }
    out
}

impl std::fmt::Display for Explored {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{}: {} states ({} generated), depth {}, {:.2} s{}: {}",
            self.scenario,
            self.states,
            self.generated,
            self.depth,
            self.time.as_secs_f64(),
            if self.complete {
                ", complete"
            } else {
                ", cut at the budget"
            },
            if self.broken.is_empty() {
                "no rule broken".to_owned()
            } else {
                format!("{} rules broken", self.broken.len())
            }
        )?;
        for c in &self.broken {
            writeln!(
                f,
                "  {} broken in {} moves: {:?}",
                c.rule,
                c.moves.len(),
                c.moves
            )?;
            for v in &c.violations {
                writeln!(f, "    {v}")?;
            }
            for line in c.trace.lines() {
                writeln!(f, "    | {line}")?;
            }
        }
        Ok(())
    }
}
