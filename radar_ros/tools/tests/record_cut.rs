//! `radar record` stopped the way programs are stopped: SIGTERM (`timeout`, systemd, docker, a launch file's
//! shutdown) finishes the file; SIGKILL (the OOM killer, `kill -9`) leaves a file the Python `mcap` reader
//! (`make_reader`, as users open files) and `radar replay` read up to its last commit. In both, every signal
//! sent up to a second before the stop is in the file. Domain 19.

use std::{
    os::unix::process::ExitStatusExt,
    process::Stdio,
    sync::{Arc, Mutex},
    time::Duration,
};

use radar_ros::{settings::DiscoveryRange, Radar, TimerEvent};
use serde_json::Value;

const DOMAIN: &str = "19";
const TOPIC: &str = "/cut/tick/triggered";

fn epoch_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64
}

/// Runs the Python reader on `file` (`--summary` first if `summary`): its JSON lines.
fn python_read(file: &std::path::Path, summary: bool) -> Vec<Value> {
    let mut cmd = std::process::Command::new(radar_test_util::python());
    cmd.arg(radar_test_util::repo().join("tests/python/mcap_read.py"));
    if summary {
        cmd.arg("--summary");
    }
    let out = cmd.arg(file).output().unwrap();
    assert!(
        out.status.success(),
        "mcap_read.py {}: {}",
        file.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// What one recording cut off gave: how the recorder ended, what it printed, the triggers in the file (their
/// source times), and when the signal was sent.
struct Cut {
    status: std::process::ExitStatus,
    stdout: String,
    stderr: String,
    in_file: Vec<i64>,
    stopped_at: i64,
}

/// Records the tick event to `file`, sends `signal` to the recorder after `after`, and reads the file back.
async fn record_then(file: &std::path::Path, after: Duration, signal: i32) -> Cut {
    let child = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"))
        .args([
            "record",
            "-o",
            file.to_str().unwrap(),
            "--activate",
            "--json",
            "/cut/tick",
        ])
        .env("ROS_DOMAIN_ID", DOMAIN)
        .env_remove("RUST_LOG")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .unwrap();
    tokio::time::sleep(after).await;
    let stopped_at = epoch_ns();
    let pid = child.id().unwrap() as i32;
    assert_eq!(
        unsafe { libc::kill(pid, signal) },
        0,
        "kill -{signal} {pid}"
    );
    let out = tokio::time::timeout(Duration::from_secs(10), child.wait_with_output())
        .await
        .expect("the recorder ended after the signal")
        .unwrap();
    let in_file = python_read(file, false)
        .iter()
        .filter(|m| m["topic"] == TOPIC)
        .map(|m| m["publish_time"].as_i64().unwrap())
        .collect();
    Cut {
        status: out.status,
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        in_file,
        stopped_at,
    }
}

/// Every trigger this process saw sent from the file's first one up to a second before the stop is in the file.
fn nothing_lost_before_the_last_second(cut: &Cut, seen: &[i64], how: &str) {
    let first = *cut
        .in_file
        .iter()
        .min()
        .unwrap_or_else(|| panic!("{how}: no trigger in the file; stderr: {}", cut.stderr));
    let due: Vec<i64> = seen
        .iter()
        .copied()
        .filter(|t| *t >= first && *t <= cut.stopped_at - 1_000_000_000)
        .collect();
    let missing: Vec<i64> = due
        .iter()
        .filter(|t| !cut.in_file.contains(t))
        .copied()
        .collect();
    assert!(
        due.len() >= 20,
        "{how}: only {} triggers sent while recording",
        due.len()
    );
    assert!(
        missing.is_empty(),
        "{how}: {} of {} triggers sent before the last second are not in the file (sent {:?} ms before the stop)",
        missing.len(),
        due.len(),
        missing
            .iter()
            .map(|t| (cut.stopped_at - t) / 1_000_000)
            .collect::<Vec<_>>()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_recording_stopped_with_sigterm_or_killed_keeps_what_came_before() {
    radar_ros_examples::test_support::require_isolation();
    let r = Radar::builder()
        .domain_id(DOMAIN.parse().unwrap())
        .discovery_range(DiscoveryRange::Subnet)
        .build()
        .unwrap();
    let _tick = r
        .spawn_event("/cut/tick", TimerEvent::new(Duration::from_millis(50)))
        .unwrap();
    // what was sent, as this process hears it (the same source times the recording keeps)
    let sub = r.raw_subscription(TOPIC, "std_msgs/msg/Empty").unwrap();
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    tokio::spawn(async move {
        while let Ok((_, stamp)) = sub.recv_stamped().await {
            log.lock().unwrap().push(stamp);
        }
    });
    let dir = std::env::temp_dir().join(format!("radar_record_cut_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();

    // SIGTERM: the recorder finishes the file (a summary readers seek with) and says what it wrote
    let file = dir.join("term.mcap");
    let cut = record_then(&file, Duration::from_secs(3), libc::SIGTERM).await;
    assert!(
        cut.status.success(),
        "SIGTERM: {:?} {}",
        cut.status,
        cut.stderr
    );
    let printed: Value = serde_json::from_str(cut.stdout.lines().last().unwrap_or_default())
        .unwrap_or_else(|e| panic!("SIGTERM: no summary printed ({e}): {}", cut.stdout));
    let info = &python_read(&file, true)[0];
    assert_eq!(info["summary"], true, "SIGTERM: the file was finished");
    assert_eq!(info["messages"], printed["messages"]);
    nothing_lost_before_the_last_second(&cut, &seen.lock().unwrap(), "SIGTERM");

    // SIGKILL after 5 s: no summary, but the file is whole up to its last commit
    let file = dir.join("kill.mcap");
    let cut = record_then(&file, Duration::from_secs(5), libc::SIGKILL).await;
    assert_eq!(cut.status.signal(), Some(libc::SIGKILL));
    let info = &python_read(&file, true)[0];
    assert_eq!(info["summary"], false, "a killed recorder wrote no summary");
    nothing_lost_before_the_last_second(&cut, &seen.lock().unwrap(), "SIGKILL");

    // and `radar replay` plays the killed file
    let replayed = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"))
        .args([
            "replay",
            file.to_str().unwrap(),
            "--rate",
            "20",
            "--wait",
            "0.1",
            "--json",
        ])
        .env("ROS_DOMAIN_ID", DOMAIN)
        .output()
        .await
        .unwrap();
    assert!(
        replayed.status.success(),
        "replay: {}",
        String::from_utf8_lossy(&replayed.stderr)
    );
    let rep: Value = serde_json::from_slice(&replayed.stdout).unwrap();
    assert_eq!(
        rep["published"].as_u64().unwrap() as usize,
        cut.in_file.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
