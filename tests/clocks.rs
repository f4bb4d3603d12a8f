//! Clocks that real robots bring (issue 32, rule T1 of `radar_semantics::time`): a peer whose clock is an hour
//! ahead starts a response; the response's own host must still interrupt that run and the next one.
//!
//! The peer is real rclpy (Fast DDS stamps its samples with the process's clock) run under libfaketime
//! (Debian's `faketime` package, which `tests/python_env.sh` installs): its wall clock reads an hour ahead,
//! its monotonic clock is left alone so that its timers keep working.

use std::time::Duration;

use radar_ros::{msg::Empty, FnResponse, ResponseHandle, TimerEvent};
use radar_test_util::{init_logs, radar, require_isolation, Py};

const LIBFAKETIME: &str = "/usr/lib/x86_64-linux-gnu/faketime/libfaketime.so.1";

/// The environment that sets a process's wall clock `offset` away (libfaketime's syntax: `+1h`, `-30s`).
fn skewed(offset: &str) -> Vec<(&'static str, String)> {
    assert!(
        std::path::Path::new(LIBFAKETIME).exists(),
        "{LIBFAKETIME} is missing: apt-get install faketime (tests/python_env.sh installs it)"
    );
    vec![
        ("LD_PRELOAD", LIBFAKETIME.to_owned()),
        ("FAKETIME", offset.to_owned()),
        ("FAKETIME_DONT_FAKE_MONOTONIC", "1".to_owned()),
    ]
}

/// Waits until `drive` has ended `exits` runs, and returns how many of them an interrupt ended.
async fn interrupted_after(drive: &ResponseHandle, exits: u64) -> u64 {
    let mut state = drive.watch_state();
    let s = tokio::time::timeout(
        Duration::from_secs(20),
        state.wait_for(|s| s.exits >= exits),
    )
    .await
    .unwrap_or_else(|_| panic!("drive did not end run {exits} within 20 s"))
    .unwrap()
    .clone();
    s.interrupts
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_start_from_a_host_an_hour_ahead_does_not_blind_the_response_to_its_own_hosts_interrupts()
{
    require_isolation();
    init_logs();
    let domain = 110;
    let r = radar(domain);
    // a run takes 4 s unless interrupted; this host's own timer interrupts whatever runs every 300 ms
    let drive = r
        .spawn_response(
            "drive",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_secs(4)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    let tick = r
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(300)))
        .unwrap();
    let _c = r.whenever(&tick).interrupt(&drive).await.unwrap();

    let env = skewed("+1h");
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let mut ahead = Py::start_with_env(
        domain,
        "tests/python/skewed_pub.py",
        &["/drive/start"],
        &env,
    );
    let said = ahead.line().await;
    let their_clock: f64 = said
        .strip_prefix("published ")
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("the skewed publisher said {said:?}"));
    let ours = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    assert!(
        their_clock - ours > 3000.0,
        "the publisher's clock is not an hour ahead ({their_clock} vs {ours}): is libfaketime working?"
    );
    // the run the skewed host started is interrupted by this host's timer (before: it ran its 4 s)
    assert_eq!(
        interrupted_after(&drive, 1).await,
        1,
        "the run started from a host an hour ahead was not interrupted by this host's own timer"
    );
    ahead.proceed().await;

    // and so is the next run, started from a host in step (before: it ran unbounded too)
    r.inject(drive.reference().start_slot(), Empty::default())
        .await
        .unwrap();
    assert_eq!(
        interrupted_after(&drive, 2).await,
        2,
        "the run after it was not interrupted either"
    );
}
