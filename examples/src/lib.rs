//! Helpers shared by the examples: a timeline printer, log setup, and the behaviours the examples share.

use std::{
    sync::{Mutex, OnceLock},
    time::{Duration, Instant},
};

pub mod fibonacci;
pub mod listing1;

/// Prints timestamped lines, `[  2.003 s] what`, relative to when it was created, in the order the things they
/// tell happened, not the order this process heard of them.
///
/// Signals travel on different topics and are read in another order than they were sent (a restart's
/// `started` can be read before the `exited` of the run before; an event's `triggered` state after the
/// interrupt it caused). A line given the time its signal was emitted ([`Timeline::mark_at`], the signal's
/// source timestamp) is held for [`SETTLE`] and printed in order of those times, so the timeline reads in
/// cause order. Lines still held when the process exits (`main` returns, or Ctrl-C) are printed then.
///
/// Times are kept on the monotonic clock. A source timestamp is a wall-clock time, so it is read as an age (how
/// long before the wall clock's now it was stamped) and placed that long before the monotonic now: a step of the
/// wall clock (NTP or chrony setting it at boot, a virtual machine resumed) moves only the lines of signals
/// that were in flight when it stepped, not the rest of the timeline.
#[derive(Clone, Copy, Debug)]
pub struct Timeline {
    /// Its start, in ns on the monotonic clock ([`mono_ns`]).
    t0: i64,
}

/// How long a line is held for lines of things that happened before it to arrive: well above a DDS hop.
pub const SETTLE: Duration = Duration::from_millis(150);

/// Lines not printed yet: (when it happened, in ns on the monotonic clock; order given; the line).
static HELD: Mutex<Vec<(i64, u64, String)>> = Mutex::new(Vec::new());

/// Now, in ns on the monotonic clock (from this process's first call).
fn mono_ns() -> i64 {
    static ORIGIN: OnceLock<Instant> = OnceLock::new();
    ORIGIN.get_or_init(Instant::now).elapsed().as_nanos() as i64
}

/// Now on the wall clock (the clock of source timestamps), in ns since the epoch.
fn wall_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as i64)
}

/// The monotonic time of something stamped `at_ns` on the wall clock: its age by the wall clock, back from the
/// monotonic now.
fn mono_of_wall(at_ns: i64) -> i64 {
    let (mono, wall) = (mono_ns(), wall_ns());
    mono - (wall - at_ns)
}

/// Prints the held lines of things that happened up to `until` (ns, monotonic), in order.
fn print_held(until: i64) {
    let mut held = HELD.lock().unwrap_or_else(|p| p.into_inner());
    held.sort();
    let n = held.partition_point(|(at, _, _)| *at <= until);
    for (_, _, line) in held.drain(..n) {
        println!("{line}");
    }
}

extern "C" fn print_all_held() {
    print_held(i64::MAX);
}

impl Timeline {
    /// A timeline starting now.
    pub fn start() -> Timeline {
        static PRINTER: OnceLock<()> = OnceLock::new();
        PRINTER.get_or_init(|| {
            std::thread::spawn(|| loop {
                std::thread::sleep(Duration::from_millis(20));
                print_held(mono_ns() - SETTLE.as_nanos() as i64);
            });
            // `exit` (a signal's handler, or the end of `main`) prints what is still held
            // SAFETY: registers a plain function without arguments, as atexit requires
            unsafe { libc::atexit(print_all_held) };
        });
        Timeline { t0: mono_ns() }
    }

    /// Seconds since the start.
    pub fn now(&self) -> f64 {
        (mono_ns() - self.t0) as f64 / 1e9
    }

    /// A line for something that happens now; `listing` is when the paper's listing says it should happen.
    pub fn mark(&self, what: &str, listing: Option<f64>) {
        self.hold(what, listing, mono_ns());
    }

    /// A line for something that happened at `at_ns` (ns since the epoch: a signal's source timestamp).
    pub fn mark_at(&self, what: &str, listing: Option<f64>, at_ns: i64) {
        self.hold(what, listing, mono_of_wall(at_ns));
    }

    /// Holds the line for something that happened at `at` (ns, monotonic).
    fn hold(&self, what: &str, listing: Option<f64>, at: i64) {
        static ORDER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let secs = (at - self.t0) as f64 / 1e9;
        let line = match listing {
            Some(l) => format!("[{secs:7.3} s] {what:<34} (listing: {l:.1} s)"),
            None => format!("[{secs:7.3} s] {what}"),
        };
        let order = ORDER.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        HELD.lock()
            .unwrap_or_else(|p| p.into_inner())
            .push((at, order, line));
    }

    /// Prints every line held so far (before the program prints something of its own).
    pub fn flush(&self) {
        print_all_held();
    }
}

/// The number after `flag` on the command line (`--order 5`), if given; exits with a message if it is not a
/// number.
pub fn number_arg(flag: &str) -> Option<f64> {
    let value = std::env::args().skip_while(|a| a != flag).nth(1)?;
    match value.parse() {
        Ok(n) => Some(n),
        Err(_) => {
            eprintln!("{flag} takes a number, not {value:?}");
            std::process::exit(64)
        }
    }
}

/// Runs an example's `main` body: logs set up, and an error printed as `NAME: error` with exit status 1.
pub async fn run_example<F: std::future::Future<Output = radar_ros::Result<()>>>(
    name: &str,
    body: F,
) {
    init_logs();
    if let Err(e) = body.await {
        eprintln!("{name}: {e}");
        std::process::exit(1);
    }
}

/// Logs warnings and errors to stderr, and info and above to `/rosout` (as rclpy nodes do, so `ros2 topic echo
/// /rosout` and rqt_console show them); `--ros-args --log-level LEVEL` (as `ros2 launch` passes it) sets both,
/// `RUST_LOG` the stderr one.
pub fn init_logs() {
    use tracing_subscriber::prelude::*;
    let quiet =
        "rustdds=error,ros2_client::distributions=error,ros2_client::service::wrappers=error";
    // a malformed --ros-args is reported by Radar::new, with what to do
    let level = radar_ros::ros_args::RosArgs::from_env()
        .ok()
        .and_then(|a| a.tracing_filter())
        .unwrap_or_else(|| "warn".into());
    let stderr = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| format!("{level},{quiet}").into());
    let _ = tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_filter(stderr),
        )
        .with(radar_ros::rosout::layer())
        .try_init();
}

/// Support for the examples' tests, which run the example programs as processes.
pub mod test_support {
    use std::path::PathBuf;

    /// Panics unless running inside `tests/isolated.sh` (or with `RADAR_ALLOW_NETWORK` set).
    pub fn require_isolation() {
        assert!(
            std::env::var("RADAR_ISOLATED").as_deref() == Ok("1")
                || std::env::var("RADAR_ALLOW_NETWORK").is_ok(),
            "run inside tests/isolated.sh (see README.md)"
        );
    }

    /// Panics if `stderr` of a program that ended normally has an error-level log line (a program that ends
    /// normally prints none).
    pub fn assert_no_error_lines(stderr: &str, what: &str) {
        let errors: Vec<&str> = stderr.lines().filter(|l| l.contains("ERROR")).collect();
        assert!(
            errors.is_empty(),
            "{what} ended normally but logged {} error line(s):\n{}",
            errors.len(),
            errors.join("\n")
        );
    }

    /// Runs `launch_scripts/<script>` with `args` in `domain` and returns what it printed; panics if it failed
    /// or if any of its processes logged an error.
    pub fn run_launch_script(
        script: &str,
        domain: u16,
        args: &[&str],
        examples: &std::path::Path,
    ) -> String {
        run_launch_script_with(script, domain, args, examples, &[])
    }

    /// [`run_launch_script`] with more environment variables for every process (`ROS_SECURITY_*`, ...).
    pub fn run_launch_script_with(
        script: &str,
        domain: u16,
        args: &[&str],
        examples: &std::path::Path,
        env: &[(&str, &std::ffi::OsStr)],
    ) -> String {
        let path = format!("{}/../launch_scripts/{script}", env!("CARGO_MANIFEST_DIR"));
        let out = std::process::Command::new("bash")
            .arg(&path)
            .args(args)
            .envs(env.iter().copied())
            .env("RADAR_EXAMPLES", examples)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .output()
            .expect("run the launch script");
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        println!("{stdout}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{script} failed: {stderr}");
        assert_no_error_lines(&stderr, script);
        stdout
    }

    /// The `[  t s] text` lines of a timeline (only those printed by `role` when its lines are prefixed
    /// `[role] `), as (seconds, text without the `(listing: ...)` hint).
    pub fn timeline(out: &str, role: Option<&str>) -> Vec<(f64, String)> {
        out.lines()
            .filter_map(|l| match role {
                Some(r) => l.strip_prefix(&format!("[{r}] ")),
                None => Some(l),
            })
            .filter_map(|l| l.strip_prefix('['))
            .filter_map(|l| l.split_once(" s] "))
            .filter_map(|(t, text)| {
                let text = text.split("(listing").next()?.trim().to_owned();
                Some((t.trim().parse().ok()?, text))
            })
            .collect()
    }

    /// The timeline with its clock moved so that the first line starting with `first` is at 0 s: the listing's
    /// 0 s is its statement, not the process start (a debug build on a loaded machine spends 50-150 ms
    /// making its nodes first).
    pub fn from_line(tl: Vec<(f64, String)>, first: &str) -> Vec<(f64, String)> {
        let zero = tl
            .iter()
            .find(|(_, s)| s.starts_with(first))
            .unwrap_or_else(|| panic!("no line starts with {first:?}: {tl:?}"))
            .0;
        tl.into_iter().map(|(t, s)| (t - zero, s)).collect()
    }

    /// When `what` was printed, every time.
    pub fn times(tl: &[(f64, String)], what: &str) -> Vec<f64> {
        tl.iter()
            .filter(|(_, s)| s == what)
            .map(|(t, _)| *t)
            .collect()
    }

    /// The directory of the built example programs (the binaries of this package, beside every other binary of
    /// the target directory), checking that `name` is there.
    pub fn examples_dir(name: &str) -> PathBuf {
        // target/<profile>/deps/<test>-<hash> -> target/<profile>
        let exe = std::env::current_exe().expect("the test binary's path");
        let dir = exe.parent().unwrap().parent().unwrap().to_owned();
        assert!(
            dir.join(name).exists(),
            "{} is missing: `cargo test` builds the programs of radar_ros_examples; or `cargo build --bin {name}`",
            dir.join(name).display()
        );
        dir
    }

    /// Asserts that a line came at `listing`'s time (seconds), within 100 ms.
    pub fn near(actual: f64, listing: f64, what: &str) {
        assert!(
            (actual - listing).abs() <= 0.1,
            "{what}: at {actual:.3} s, listing says {listing:.1} s"
        );
    }

    /// The timeline `stdout` printed follows Listing 1, each step within 100 ms of the listing's time, and reads
    /// in the order things happened (the Rust examples print signals by their source times).
    pub fn assert_follows_listing_1(stdout: &str) {
        let tl = assert_listing_1_times(stdout);
        // the timeline reads in the order things happened (signals by their source times), not in the order
        // they were read: the restart's `started` after the `exited` before it, end_event's trigger before the
        // interrupt it caused
        let position = |what: &str, from: f64| {
            tl.iter()
                .position(|(t, s)| s == what && *t >= from)
                .unwrap_or_else(|| panic!("{what} after {from}: {tl:#?}"))
        };
        assert!(position("end_event triggered", 3.9) < position("count_up interrupted", 3.9));
        assert!(position("count_up exited", 8.9) < position("count_up started", 8.9));
    }

    /// Each step of Listing 1 in the timeline `stdout` printed, within 100 ms of the listing's time, whatever
    /// the order of lines a few ms apart (the Python example prints signals as it reads them); the timeline.
    pub fn assert_listing_1_times(stdout: &str) -> Vec<(f64, String)> {
        let tl = from_line(timeline(stdout, None), "once start_event start count_up");

        near(
            times(&tl, "start_event triggered")[0],
            2.0,
            "start_event triggers",
        );
        let started = times(&tl, "count_up started");
        assert!(started.len() >= 3, "three runs begin by 9.7 s: {started:?}");
        near(
            started[0],
            2.0,
            "count_up starts (once start_event start count_up)",
        );
        // start_event deactivates once the `once` connection is gone
        let inactive = times(&tl, "start_event inactive");
        assert!(
            inactive.iter().any(|t| (*t - 2.0).abs() <= 0.1),
            "start_event deactivates at 2 s: {inactive:?}"
        );

        // first run: counts at 2.5, 3.0, 3.5, then end_event at 4.0 interrupts it (until end_event)
        for (k, t) in times(&tl, "count_up counts 1").iter().zip([2.5, 4.5]) {
            near(*k, t, "count 1");
        }
        near(times(&tl, "count_up counts 2")[0], 3.0, "count 2");
        near(times(&tl, "count_up counts 3")[0], 3.5, "count 3");
        let interrupted = times(&tl, "count_up interrupted");
        assert_eq!(
            interrupted.len(),
            1,
            "only the statement's own run is interrupted: {interrupted:?}"
        );
        near(interrupted[0], 4.0, "end_event interrupts count_up");
        near(
            times(&tl, "end_event triggered")[0],
            4.0,
            "end_event triggers",
        );

        // on exit: restart, counting to 10 undisturbed (end_event at 8 s is outside the until window)
        near(started[1], 4.0, "count_up restarts from its exit slot");
        let restart_counts: Vec<f64> = (1..=10)
            .map(|k| {
                *times(&tl, &format!("count_up counts {k}"))
                    .last()
                    .filter(|t| **t > 4.0)
                    .unwrap_or(&0.0)
            })
            .collect();
        for (k, t) in restart_counts.iter().enumerate() {
            let k = k + 1;
            if k == 1 || k == 2 {
                // counts 1 and 2 happen again in the third run; take those of the second
                continue;
            }
            near(*t, 4.0 + 0.5 * k as f64, &format!("second run, count {k}"));
        }
        near(
            times(&tl, "count_up exit slot (completed)")[0],
            9.0,
            "second run completes",
        );
        near(started[2], 9.0, "count_up restarts again");

        // issue 32: the spent `once ... until` lets go of end_event once the run it bounded has ended: end_event
        // goes inactive right after the interrupt, and never triggers again (before: at 8 s, 12 s, ...)
        let end_inactive = times(&tl, "end_event inactive");
        assert!(
            end_inactive.iter().any(|t| *t >= 4.0 && *t <= 4.2),
            "end_event deactivates once the statement's run has ended: {end_inactive:?}"
        );
        assert_eq!(
            times(&tl, "end_event triggered").len(),
            1,
            "end_event triggers once, for the statement's run only"
        );
        let printed: Vec<f64> = tl.iter().map(|(t, _)| *t).collect();
        assert!(
            printed.windows(2).all(|w| w[0] <= w[1]),
            "lines in time order: {tl:#?}"
        );
        tl
    }
}
