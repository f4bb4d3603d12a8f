//! `radar_mutants [NAME...]`: plants each bug of `radar_checker::mutants::MUTANTS` (all by default) in a copy
//! of `radar_semantics`, one at a time, builds the checker against it and explores the scenarios until a rule
//! is broken; then runs the old tests of `radar_semantics` (its unit tests, and the proptest models of
//! `tests/`) against the same bug. Prints one line per bug and a Markdown table (docs/checker.md holds the last
//! one). Works in `target/mutants` (the copy and its builds); exits with 1 if the checker missed one.
//!
//! `--checker-only` leaves the old tests out; `--old-tests-only` leaves the checker out.

use std::{path::Path, process::Command};

use radar_checker::mutants::{Mutant, MUTANTS};

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let (src, dst) = (e.path(), to.join(e.file_name()));
        if e.file_type().unwrap().is_dir() {
            copy_dir(&src, &dst);
        } else {
            std::fs::copy(&src, &dst).unwrap();
        }
    }
}

/// The repository (this binary runs from `target/...`, or with `cargo run` from anywhere in it).
fn repo() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// A workspace of the three crates the checker needs, in `target/mutants/work`.
fn work() -> std::path::PathBuf {
    let repo = repo();
    let work = repo.join("target/mutants/work");
    let _ = std::fs::remove_dir_all(&work);
    for c in ["semantics", "spec", "checker"] {
        copy_dir(
            &repo.join("radar_ros").join(c),
            &work.join("radar_ros").join(c),
        );
    }
    std::fs::copy(repo.join("Cargo.lock"), work.join("Cargo.lock")).unwrap();
    let root = std::fs::read_to_string(repo.join("Cargo.toml")).unwrap();
    let package = root
        .split("[workspace.package]")
        .nth(1)
        .and_then(|s| s.split("\n[").next())
        .unwrap();
    std::fs::write(
        work.join("Cargo.toml"),
        format!(
            "[workspace]\nresolver = \"2\"\nmembers = [\"radar_ros/semantics\", \"radar_ros/spec\", \"radar_ros/checker\"]\n\n\
             [workspace.package]{package}\n"
        ),
    )
    .unwrap();
    work
}

fn cargo(work: &Path, args: &[&str]) -> std::process::Output {
    Command::new("cargo")
        .args(args)
        .current_dir(work)
        .env("CARGO_TARGET_DIR", repo().join("target/mutants/target"))
        .env("CARGO_INCREMENTAL", "0")
        .output()
        .expect("cargo runs")
}

/// What one planted bug came to.
struct Outcome {
    caught: Option<(String, String, usize)>,
    unit: Option<bool>,
    models: Option<bool>,
}

fn plant(work: &Path, m: &Mutant) -> String {
    let path = work.join("radar_ros/semantics").join(m.file);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.contains(m.from),
        "{}: its text is not in {} (the machine changed: update the mutant)",
        m.name,
        m.file
    );
    std::fs::write(&path, text.replace(m.from, m.to)).unwrap();
    text
}

fn run(work: &Path, m: &Mutant, checker: bool, old_tests: bool) -> Outcome {
    let original = plant(work, m);
    let caught = if checker { explore(work, m) } else { None };
    let (mut unit, mut models) = (None, None);
    if old_tests {
        let passes = |args: &[&str]| cargo(work, args).status.success();
        unit = Some(!passes(&[
            "test",
            "--release",
            "--offline",
            "-p",
            "radar_semantics",
            "--lib",
        ]));
        // the proptest models alone (`--tests` would run the unit tests again)
        models = Some(!passes(&[
            "test",
            "--release",
            "--offline",
            "-p",
            "radar_semantics",
            "--test",
            "model",
            "--test",
            "goal_model",
            "--test",
            "served_model",
        ]));
    }
    std::fs::write(work.join("radar_ros/semantics").join(m.file), original).unwrap();
    Outcome {
        caught,
        unit,
        models,
    }
}

/// Builds the checker against the planted bug and explores until a rule is broken: (scenario, rule, moves).
fn explore(work: &Path, m: &Mutant) -> Option<(String, String, usize)> {
    let built = cargo(
        work,
        &[
            "build",
            "--release",
            "--offline",
            "-p",
            "radar_checker",
            "--bin",
            "radar_checker",
        ],
    );
    assert!(
        built.status.success(),
        "{}: the planted bug does not build:\n{}",
        m.name,
        String::from_utf8_lossy(&built.stderr)
    );
    let exe = repo().join("target/mutants/target/release/radar_checker");
    let out = Command::new(exe)
        .arg("--first")
        .output()
        .expect("the checker runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    stdout.lines().find_map(|l| {
        let mut w = l.strip_prefix("caught ")?.split(' ');
        Some((
            w.next()?.to_owned(),
            w.next()?.to_owned(),
            w.next()?.parse().ok()?,
        ))
    })
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let old_tests = !args.iter().any(|a| a == "--checker-only");
    let checker = !args.iter().any(|a| a == "--old-tests-only");
    let names: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    let work = work();
    let mut rows = Vec::new();
    let mut missed = 0;
    for m in MUTANTS
        .iter()
        .filter(|m| names.is_empty() || names.iter().any(|n| *n == m.name))
    {
        let started = std::time::Instant::now();
        let o = run(&work, m, checker, old_tests);
        let t = started.elapsed().as_secs_f64();
        let yes_no = |b: Option<bool>| match b {
            Some(true) => "caught",
            Some(false) => "missed",
            None => "-",
        };
        match &o.caught {
            Some((scenario, rule, moves)) => println!(
                "{}: caught by {rule} in {scenario}, {moves} moves ({t:.0} s)",
                m.name
            ),
            None if !checker => println!("{}: ({t:.0} s)", m.name),
            None => {
                missed += 1;
                println!("{}: MISSED by the checker ({t:.0} s)", m.name)
            }
        }
        rows.push(format!(
            "| `{}` | {} | {} | {} | {} | {} |",
            m.name,
            m.what,
            o.caught.as_ref().map_or(
                if checker { "**missed**" } else { "not run" }.to_owned(),
                |(s, r, _)| format!("`{r}` in `{s}`")
            ),
            o.caught
                .as_ref()
                .map_or("-".to_owned(), |(_, _, n)| n.to_string()),
            yes_no(o.unit),
            yes_no(o.models),
        ));
    }
    println!("\n| planted bug | what | found by the checker | shortest trace (moves) | unit tests | proptest models |");
    println!("|---|---|---|---:|---|---|");
    for r in rows {
        println!("{r}");
    }
    std::process::exit(i32::from(missed > 0));
}
