//! Runs the `count_up` example (Listing 1) as a separate process and checks its printed timeline against the
//! listing, step by step, within 100 ms (counted from the `once` statement, the listing's 0 s), and that it ends
//! without an error line; then again with its wall clock stepped 2 s forward mid-run (libfaketime), as NTP or
//! chrony step a robot's clock at boot. Domains 60 and 61, one run at a time. Runs inside `tests/isolated.sh`
//! like every DDS test.

use std::{
    io::{BufRead, BufReader},
    path::PathBuf,
    process::{Command, Stdio},
    sync::Mutex,
    time::Duration,
};

use radar_ros::{msg::Empty, Radar};
use radar_ros_examples::test_support::{
    assert_follows_listing_1, assert_no_error_lines, examples_dir, require_isolation,
};

/// One run at a time: each is timed to 100 ms, and two at once on a 2-core machine add their own delays.
static ONE_RUN: Mutex<()> = Mutex::new(());

/// Debian's `faketime` package (`.ci/run` installs it).
const LIBFAKETIME: &str = "/usr/lib/x86_64-linux-gnu/faketime/libfaketime.so.1";

fn example_binary() -> PathBuf {
    examples_dir("count_up").join("count_up")
}

#[test]
fn count_up_follows_listing_1_within_100_ms_per_step() {
    require_isolation();
    let _one = ONE_RUN.lock().unwrap_or_else(|p| p.into_inner());
    let out = Command::new(example_binary())
        .args(["--duration", "9.7"])
        .env("ROS_DOMAIN_ID", "60")
        .output()
        .expect("run count_up");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "count_up failed: {stderr}");
    assert_no_error_lines(&stderr, "count_up");
    assert_follows_listing_1(&stdout);
}

/// The wall clock of the example steps 2 s forward during its first run (between 2.15 and 3.15 s).
/// Its signals' source timestamps jump with it (a subscriber here, on a clock that did not step, sees the
/// restart's `started` stamped 2 s ahead: the step took place), and its timeline still follows the listing: the
/// lines are placed on the monotonic clock by their age, so a step moves none of those after it. (Before, a
/// timeline of wall-clock times moved every line after the step by 2 s; seen in CI, where a VM's clock stepped
/// 2.17 s during the Python example's comparison with this one.)
#[test]
fn a_wall_clock_step_mid_run_moves_no_line_of_the_timeline() {
    require_isolation();
    let _one = ONE_RUN.lock().unwrap_or_else(|p| p.into_inner());
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
        .block_on(clock_step_run());
}

/// The run of [`a_wall_clock_step_mid_run_moves_no_line_of_the_timeline`].
async fn clock_step_run() {
    assert!(
        std::path::Path::new(LIBFAKETIME).exists(),
        "{LIBFAKETIME} is missing: apt-get install faketime (.ci/run installs it)"
    );
    let dir = std::env::temp_dir().join(format!("count_up_clock_step_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let offset = dir.join("offset");
    std::fs::write(&offset, "+0s\n").unwrap();

    // a witness on a clock that does not step: the example's `started` samples, with their source stamps
    let radar = Radar::builder()
        .domain_id(61)
        .handle_signals(false)
        .build()
        .expect("a Radar on domain 61");
    let started = radar
        .signal_subscription::<Empty>("/count_up/started")
        .unwrap();

    let mut child = Command::new(example_binary())
        .args(["--duration", "9.7"])
        .env("ROS_DOMAIN_ID", "61")
        .env("LD_PRELOAD", LIBFAKETIME)
        .env("FAKETIME_TIMESTAMP_FILE", &offset)
        // the offset file is read again at most a second after it changes (read on every clock call, as
        // FAKETIME_NO_CACHE does, it slows every timer of the example)
        .env("FAKETIME_CACHE_DURATION", "1")
        .env("FAKETIME_DONT_FAKE_MONOTONIC", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run count_up under libfaketime");
    let stdout = child.stdout.take().unwrap();
    let stepping = offset.clone();
    // reads the timeline as it is printed; steps the clock once the first run has started (printed at about
    // 2.15 s, in effect within a second: the clock steps between the first run's counts, no signal in flight)
    let reader = std::thread::spawn(move || {
        let mut out = String::new();
        let mut stepped = false;
        for line in BufReader::new(stdout).lines() {
            let line = line.expect("the example's stdout");
            if !stepped && line.contains("count_up started") {
                std::fs::write(&stepping, "+2s\n").unwrap();
                stepped = true;
            }
            out.push_str(&line);
            out.push('\n');
        }
        out
    });

    // how far ahead of this process's clock each of the first two `started` was stamped (s)
    let mut ahead = Vec::new();
    for _ in 0..2 {
        let (_, stamp) = started
            .recv_stamped()
            .timeout(Duration::from_secs(20))
            .await
            .expect("count_up starts");
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos() as i64;
        ahead.push((stamp - now) as f64 / 1e9);
    }
    let (out, stdout) = tokio::task::spawn_blocking(move || {
        let out = child.wait_with_output().expect("count_up ends");
        (out, reader.join().expect("the stdout reader"))
    })
    .await
    .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    println!("{stdout}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "count_up failed: {stderr}");
    assert_no_error_lines(&stderr, "count_up");
    assert!(
        ahead[0].abs() < 0.5 && (1.5..2.5).contains(&ahead[1]),
        "the example's clock steps 2 s forward between its first and second start (its stamps ahead of ours: \
         {ahead:?} s): is libfaketime working?"
    );
    assert_follows_listing_1(&stdout);
}
