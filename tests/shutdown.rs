//! Issue 19, R7: the exit slot always runs, also when the program ends. A program as users write it
//! (`bin/stopper.rs`: a response driving for a minute, an exit slot that "stops the motors") is started, its
//! response is started from this process, and then the program is told to stop (SIGINT, SIGTERM), or returns
//! from `main`, or calls `Radar::shutdown`. Every time, its exit slot's side effect is seen, `exited` reaches
//! this process, the program leaves the graph at once (peers hear its goodbye), exits with status 0, and logs no
//! error. Ctrl-C under `ros2 launch` (two SIGINTs) lets the exit slots finish; a SIGTERM while stopping ends it
//! at once; an exit slot that takes longer than the shutdown timeout is named.
//! Domain 4.

use std::{process::Stdio, time::Duration};

use radar_ros::{msg::Empty, topics::SignalPublisher, topics::SignalSubscription, Radar};
use radar_test_util::{radar, DISCOVERY};
use tokio::io::{AsyncBufReadExt, BufReader, Lines};

const DOMAIN: u16 = 4;
const T: Duration = Duration::from_secs(10);

/// How a program is made to end.
#[derive(Clone, Copy, Debug)]
enum End {
    Signal(i32),
    /// Ctrl-C on a terminal running `ros2 launch`: the terminal's SIGINT, then launch's own a few ms later,
    /// while the exit slot (300 ms) works.
    CtrlCUnderLaunch,
    /// It ends by itself (its mode says how).
    ByItself,
}

/// A `radar_test_stopper` process.
struct Program {
    child: tokio::process::Child,
    out: Lines<BufReader<tokio::process::ChildStdout>>,
    err: tokio::task::JoinHandle<Vec<String>>,
    seen: Vec<String>,
}

impl Program {
    async fn start(name: &str, mode: &str, extra: &[&str]) -> Program {
        let mut child = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar_test_stopper"))
            .arg(name)
            .arg(mode)
            .args(extra)
            .env("ROS_DOMAIN_ID", DOMAIN.to_string())
            .env("RUST_LOG", "info,rustdds=error")
            .env("NO_COLOR", "1")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("start radar_test_stopper");
        let out = BufReader::new(child.stdout.take().unwrap()).lines();
        let mut err_lines = BufReader::new(child.stderr.take().unwrap()).lines();
        let err = tokio::spawn(async move {
            let mut v = Vec::new();
            while let Ok(Some(l)) = err_lines.next_line().await {
                v.push(l);
            }
            v
        });
        let mut p = Program {
            child,
            out,
            err,
            seen: Vec::new(),
        };
        p.expect_line("ready").await;
        p
    }

    /// Reads stdout until a line equal to `line`; panics after [`T`].
    async fn expect_line(&mut self, line: &str) {
        let found = tokio::time::timeout(T, async {
            while let Ok(Some(l)) = self.out.next_line().await {
                self.seen.push(l.clone());
                if l == line {
                    return true;
                }
            }
            false
        })
        .await;
        assert!(
            matches!(found, Ok(true)),
            "the program did not print {line:?}; it printed {:?}",
            self.seen
        );
    }

    fn signal(&self, sig: i32) {
        let pid = self.child.id().expect("running") as i32;
        assert_eq!(unsafe { libc::kill(pid, sig) }, 0, "kill -{sig} {pid}");
    }

    /// Waits for the exit (at most `limit`): its status, all it printed, and its stderr.
    async fn finish(
        mut self,
        limit: Duration,
    ) -> (std::process::ExitStatus, Vec<String>, Vec<String>) {
        let status = tokio::time::timeout(limit, self.child.wait())
            .await
            .unwrap_or_else(|_| {
                panic!(
                    "the program did not end within {limit:?}; it printed {:?}",
                    self.seen
                )
            })
            .expect("wait");
        while let Ok(Some(l)) = self.out.next_line().await {
            self.seen.push(l);
        }
        let err = self.err.await.unwrap();
        (status, self.seen, err)
    }
}

/// This process's view of a program's response.
struct Observer {
    start: SignalPublisher<Empty>,
    started: SignalSubscription<Empty>,
    exited: SignalSubscription<Empty>,
}

impl Observer {
    async fn connect(r: &Radar, name: &str) -> Observer {
        let o = Observer {
            start: r.signal_publisher(&format!("/{name}/start")).unwrap(),
            started: r.signal_subscription(&format!("/{name}/started")).unwrap(),
            exited: r.signal_subscription(&format!("/{name}/exited")).unwrap(),
        };
        o.start
            .wait_for_subscribers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        o.started
            .wait_for_publishers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        o.exited
            .wait_for_publishers(1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
        o
    }
}

/// One program: started, its response started, then ended as `end` says; everything R7 promises is checked.
async fn round(r: &Radar, name: String, mode: &str, end: End) {
    let extra: &[&str] = match end {
        End::CtrlCUnderLaunch => &["--exit-ms", "300"],
        _ => &[],
    };
    let p = Program::start(&name, mode, extra).await;
    let o = Observer::connect(r, &name).await;
    o.start.publish(Empty::default()).unwrap();
    o.started
        .recv()
        .timeout(T)
        .await
        .expect("the response started");
    let t0 = std::time::Instant::now();
    match end {
        End::Signal(sig) => p.signal(sig),
        End::CtrlCUnderLaunch => {
            p.signal(libc::SIGINT);
            tokio::time::sleep(Duration::from_millis(3)).await;
            p.signal(libc::SIGINT);
        }
        End::ByItself => {}
    }
    // `exited` reaches another process
    o.exited
        .recv()
        .timeout(T)
        .await
        .unwrap_or_else(|e| panic!("{name} ({mode}, {end:?}): no exited: {e}"));
    let exited_after = t0.elapsed();
    let (status, out, err) = p.finish(T).await;
    let ended_after = t0.elapsed();
    assert!(
        out.iter().any(|l| l == "exit slot: exit_signal"),
        "{name} ({mode}, {end:?}): the exit slot ran: {out:?}"
    );
    assert!(
        status.success(),
        "{name} ({mode}, {end:?}): {status}; stderr {err:#?}"
    );
    let errors: Vec<&String> = err.iter().filter(|l| l.contains(" ERROR ")).collect();
    assert!(
        errors.is_empty(),
        "{name} ({mode}, {end:?}): error lines {errors:#?}"
    );
    // it said goodbye: its writers are gone at once, not when its lease runs out (3 s)
    let left = tokio::time::timeout(Duration::from_millis(1500), async {
        while o.exited.publishers() > 0 {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    })
    .await;
    assert!(
        left.is_ok(),
        "{name} ({mode}, {end:?}): its goodbye was heard"
    );
    println!(
        "{name} ({mode}, {end:?}): exited seen after {:.1} ms, process ended after {:.1} ms, gone from the graph \
         {:.1} ms after that",
        exited_after.as_secs_f64() * 1e3,
        ended_after.as_secs_f64() * 1e3,
        (t0.elapsed() - ended_after).as_secs_f64() * 1e3
    );
}

/// `n` rounds of `mode` ended as `end`, five programs at a time.
async fn rounds(r: &Radar, tag: &str, n: usize, mode: &str, end: End) {
    for batch in (0..n).collect::<Vec<_>>().chunks(5) {
        let all = batch
            .iter()
            .map(|i| round(r, format!("{tag}_{i}"), mode, end));
        futures::future::join_all(all).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigint_runs_the_exit_slot_and_sends_exited_before_the_program_leaves() {
    let r = radar(DOMAIN);
    rounds(&r, "int", 20, "wait", End::Signal(libc::SIGINT)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_runs_the_exit_slot_and_sends_exited_before_the_program_leaves() {
    let r = radar(DOMAIN);
    rounds(&r, "term", 20, "wait", End::Signal(libc::SIGTERM)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn returning_from_main_runs_the_exit_slot_and_sends_exited() {
    let r = radar(DOMAIN);
    rounds(&r, "ret", 20, "return", End::ByItself).await;
    rounds(&r, "ret_ct", 10, "return-current-thread", End::ByItself).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_shutdown_runs_the_exit_slot_also_for_programs_that_handle_signals_themselves() {
    let r = radar(DOMAIN);
    rounds(&r, "shut", 5, "shutdown", End::ByItself).await;
    rounds(&r, "manual", 5, "manual", End::Signal(libc::SIGINT)).await;
}

/// Issue 32: Ctrl-C on a `ros2 launch` reaches every process twice (the terminal's SIGINT to the group, then
/// launch's own to each child, milliseconds apart). The second must not cut the exit slot: every program ends as
/// after one SIGINT (exit slot finished, `exited` sent, status 0, no error line). Before: "second signal:
/// exiting at once, exit slots not finished", status 130, and launch logged the process as died.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ctrl_c_under_ros2_launch_two_sigints_let_the_exit_slots_finish() {
    let r = radar(DOMAIN);
    rounds(&r, "launch_int", 10, "wait", End::CtrlCUnderLaunch).await;
}

/// Launch's escalation: SIGINT (twice, as above), then SIGTERM after its `sigterm_timeout` while the exit slot
/// still works: the SIGTERM ends the program at once (status 143), saying the exit slots did not finish.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_while_stopping_exits_at_once() {
    let r = radar(DOMAIN);
    let mut p = Program::start("escalated", "wait", &["--exit-ms", "60000"]).await;
    let o = Observer::connect(&r, "escalated").await;
    o.start.publish(Empty::default()).unwrap();
    o.started.recv().timeout(T).await.unwrap();
    p.signal(libc::SIGINT);
    tokio::time::sleep(Duration::from_millis(3)).await;
    p.signal(libc::SIGINT);
    p.expect_line("exit slot begins").await;
    // the repeated SIGINT did not end it
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(
        p.child.try_wait().unwrap().is_none(),
        "the second SIGINT ended the program"
    );
    let t0 = std::time::Instant::now();
    p.signal(libc::SIGTERM);
    let (status, _, err) = p.finish(T).await;
    assert_eq!(status.code(), Some(143), "{status}");
    assert!(
        t0.elapsed() < Duration::from_secs(2),
        "at once: {:?}",
        t0.elapsed()
    );
    assert!(
        err.iter().any(|l| l.contains("SIGTERM while stopping")),
        "it says why: {err:#?}"
    );
}

/// Issue 32: a program told to stop starts nothing more. Its statement `whenever tick start remote` (an event
/// triggering every 50 ms and a response, both in this process) relays a start every 50 ms; its own response's
/// exit slot takes 1.5 s. From the signal on, no start reaches the remote response (one already on its way
/// may), though the ticks go on. Before: it kept starting the remote response for the whole 1.5 s.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_program_told_to_stop_starts_nothing_more_while_its_exit_slots_run() {
    let r = radar(DOMAIN);
    let starts = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let s = starts.clone();
    let _remote = r
        .spawn_response(
            "stopping_remote",
            radar_ros::FnResponse::new(move |_: Empty| {
                s.lock().unwrap().push(std::time::Instant::now());
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
    let _tick = r
        .spawn_event(
            "stopping_tick",
            radar_ros::TimerEvent::new(Duration::from_millis(50)),
        )
        .unwrap();
    let mut p = Program::start("stopping", "relay", &["--exit-ms", "1500"]).await;
    p.expect_line("relaying").await;
    let o = Observer::connect(&r, "stopping").await;
    o.start.publish(Empty::default()).unwrap();
    o.started.recv().timeout(T).await.unwrap();
    radar_test_util::eventually(T, "starts relayed", || starts.lock().unwrap().len() >= 3).await;
    let told = std::time::Instant::now();
    p.signal(libc::SIGINT);
    let (status, out, err) = p.finish(T).await;
    assert!(status.success(), "{status}; stderr {err:#?}");
    assert!(
        out.iter().any(|l| l == "exit slot: exit_signal"),
        "its exit slot ran: {out:?}"
    );
    let late: Vec<_> = starts
        .lock()
        .unwrap()
        .iter()
        .filter(|t| **t > told + Duration::from_millis(100))
        .map(|t| t.duration_since(told))
        .collect();
    assert!(
        late.is_empty(),
        "starts relayed after the program was told to stop: {late:?}"
    );
}

/// Issue 32: an exit slot that runs after `main` has returned (the program's runtime is gone) can still use the
/// ROS graph: it finds a response it never looked up before and starts it. Before: discovery ran on the
/// program's runtime, so the lookup waited until its timeout and the start never came.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_exit_slot_after_main_returned_can_look_up_and_start_a_component() {
    let r = radar(DOMAIN);
    let (_other, starts) = radar_test_util::counter(&r, "returned_other");
    for mode in ["return", "return-current-thread"] {
        let before = starts.load(std::sync::atomic::Ordering::SeqCst);
        let name = format!("returned_{}", mode.replace('-', "_"));
        let p = Program::start(&name, mode, &["--exit-starts", "/returned_other"]).await;
        let o = Observer::connect(&r, &name).await;
        o.start.publish(Empty::default()).unwrap();
        o.started.recv().timeout(T).await.unwrap();
        let (status, out, err) = p.finish(T).await;
        assert!(status.success(), "{mode}: {status}; stderr {err:#?}");
        assert!(
            out.iter().any(|l| l == "exit slot started /returned_other"),
            "{mode}: the exit slot found and started the other response: {out:?}"
        );
        radar_test_util::eventually(T, "the other response started", || {
            starts.load(std::sync::atomic::Ordering::SeqCst) > before
        })
        .await;
    }
}

/// An exit slot that takes longer than the shutdown timeout: the program ends after the timeout, with status 1
/// and an error line that names the response.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stop_that_takes_longer_than_the_shutdown_timeout_names_what_did_not_finish() {
    let r = radar(DOMAIN);
    let p = Program::start(
        "slow_exit",
        "wait",
        &["--exit-ms", "60000", "--shutdown-timeout-ms", "700"],
    )
    .await;
    let o = Observer::connect(&r, "slow_exit").await;
    o.start.publish(Empty::default()).unwrap();
    o.started.recv().timeout(T).await.unwrap();
    let t0 = std::time::Instant::now();
    p.signal(libc::SIGTERM);
    let (status, out, err) = p.finish(T).await;
    let took = t0.elapsed();
    assert_eq!(status.code(), Some(1), "{status}");
    assert!(
        took >= Duration::from_millis(700) && took < Duration::from_secs(4),
        "within the timeout and a moment: {took:?}"
    );
    assert!(out.iter().any(|l| l == "exit slot begins"), "{out:?}");
    assert!(
        err.iter()
            .any(|l| l.contains(" ERROR ") && l.contains("/slow_exit")),
        "an error line names it: {err:#?}"
    );
}
