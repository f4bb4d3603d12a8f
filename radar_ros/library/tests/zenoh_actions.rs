//! Issue 37: an action server over Zenoh as a RADAR response (`Radar::action_response`, rules A1-A7), against
//! an action server written from rmw_zenoh's design document (tests/python/zenoh_action_server.py: queryables
//! and publishers under `<action>/_action/`, named with the hashes rosidl wrote, replies carrying the request's
//! attachment back), through a router.
//!
//! A `Radar` on Zenoh drives `test_msgs/action/Fibonacci` at `/za/fibonacci`. Checked, in order:
//!
//! - a goal of order 5: `started` (the server accepted it, A2), feedback as the response's `feedback` signal
//!   (read on its topic), `exited` with the server's sequence, the run completed; the server saw one goal and
//!   one result request;
//! - a goal of order 60 (6 s of feedback), interrupted after its first feedback: the server is asked to cancel
//!   the goal it runs (A4), `interrupted`, then `exited` with the partial sequence the server reported with
//!   status CANCELED (5: the code `action_msgs/msg/GoalStatus` gives it, read from rclpy's message class by the
//!   peer); the run counted interrupted;
//! - a goal the server rejects (order -1): no `started`, `exited`, the run failed saying "goal rejected" (A3);
//! - an action without type hashes (no rmw_zenoh peer would match its keys) is refused, saying what to do;
//! - a response served as an action (`Radar::serve_as_action`, rules S1-S7) over Zenoh, driven by an action
//!   client written from the design document (tests/python/zenoh_action_client.py), a fresh process per goal:
//!   a goal runs to SUCCEEDED with feedback and the status EXECUTING, a goal canceled mid-run ends CANCELED
//!   and interrupts the response, a goal while another runs is rejected;
//! - two radar_ros programs, as a user runs the action examples: `fibonacci_action` serves a response as an
//!   action, `goal_until`'s `once go start fibonacci until bumper` cancels its goal mid-way, after the
//!   goal's feedback reached it; the server ends cleanly on SIGINT, its goal ended interrupted.
//!
//! No settling sleeps: each wait is on a signal, a state or the peer's line. Domain 148. Needs the venv
//! (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use radar_ros::{
    action::{Fibonacci, FibonacciFeedback, FibonacciGoal, FibonacciResult},
    msg::{Empty, ResponseState},
    topics::SignalSubscription,
    Radar,
};
use serde_json::Value;
use zenoh_util::{local_router, Proc, WAIT};

const DOMAIN: u16 = 148;

/// The peer's next line that has `key` (`""`: any line), failing after [`WAIT`].
async fn peer_said(peer: &mut Proc, key: &str) -> Value {
    let r = tokio::time::timeout(WAIT, async {
        loop {
            let v: Value = serde_json::from_str(&peer.line().await).expect("a JSON line");
            println!("{v}");
            assert!(v.get("bad_attachment").is_none(), "{v}");
            if key.is_empty() || v.get(key).is_some() {
                return v;
            }
        }
    })
    .await;
    r.unwrap_or_else(|_| panic!("the action server did not say {key:?} within {WAIT:?}"))
}

/// The next sample of `sub`, failing after [`WAIT`].
async fn next<M: radar_ros::msg::RosMessage>(sub: &SignalSubscription<M>, what: &str) -> M {
    tokio::time::timeout(WAIT, sub.recv())
        .await
        .unwrap_or_else(|_| panic!("no {what} within {WAIT:?}"))
        .expect(what)
}

/// Reads `state` until the response has ended `exits` runs and is idle.
async fn after_exits(state: &SignalSubscription<ResponseState>, exits: u64) -> ResponseState {
    loop {
        let s = next(state, "state").await;
        if s.exits >= exits && s.state_label == "idle" {
            return s;
        }
    }
}

/// An action type whose Rust type carries no type hashes.
struct Dock;
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
struct DockGoal {
    station: String,
}
radar_ros::ros_message!(DockGoal, "my_robot", action "Dock_Goal");
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
struct DockResult {
    docked: bool,
}
radar_ros::ros_message!(DockResult, "my_robot", action "Dock_Result");
impl radar_ros::action::Action for Dock {
    const PACKAGE: &'static str = "my_robot";
    const NAME: &'static str = "Dock";
    type Goal = DockGoal;
    type Result = DockResult;
    type Feedback = Empty;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_action_server_over_zenoh_is_a_radar_response() {
    // the one test of this binary: its environment is its own
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN.to_string());
    std::env::set_var("RMW_IMPLEMENTATION", "rmw_zenoh_cpp");
    let _router = local_router().await;
    let mut server = Proc::start(
        "zenoh_action_server.py",
        &["tcp/localhost:7447", &DOMAIN.to_string(), "/za/fibonacci"],
    );
    peer_said(&mut server, "up").await;

    let radar = Radar::builder()
        .program("za_program")
        .handle_signals(false)
        .build()
        .unwrap();
    assert!(radar.over_zenoh());
    let fib = radar.action_response::<Fibonacci>("/za/fibonacci").unwrap();
    let r = fib.reference().clone();
    let started = radar
        .signal_subscription::<FibonacciGoal>(r.started().topic())
        .unwrap();
    let exited = radar
        .signal_subscription::<FibonacciResult>(r.exited().topic())
        .unwrap();
    let interrupted = radar
        .signal_subscription::<Empty>("/za/fibonacci/interrupted")
        .unwrap();
    let state = radar.state_subscription("/za/fibonacci/state").unwrap();
    let feedback = radar
        .signal_subscription::<FibonacciFeedback>(fib.feedback().topic())
        .unwrap();

    // A1, A2, A7: a goal runs to its end; its feedback is the response's feedback signal
    radar
        .inject(r.start_slot(), FibonacciGoal { order: 5 })
        .timeout(WAIT)
        .await
        .unwrap();
    let goal = peer_said(&mut server, "goal").await;
    assert_eq!(
        (goal["goal"].as_i64(), goal["accepted"].as_bool()),
        (Some(5), Some(true)),
        "{goal}"
    );
    assert_eq!(next(&started, "started").await.order, 5);
    let first = next(&feedback, "feedback").await;
    assert_eq!(first.sequence, vec![0, 1, 1], "the server's first feedback");
    assert_eq!(
        next(&exited, "exited").await.sequence,
        vec![0, 1, 1, 2, 3],
        "exited carries the server's result"
    );
    peer_said(&mut server, "result_asked").await;
    let answered = peer_said(&mut server, "answered_result").await;
    assert_eq!(answered["answered_result"], 4, "SUCCEEDED: {answered}");
    let s = after_exits(&state, 1).await;
    assert_eq!(
        (s.completed, s.last_exit_reason.as_str()),
        (1, "completed"),
        "{s:?}"
    );

    // A4: interrupt cancels the running goal; the partial result the server reports comes back on exited
    while feedback.try_recv().is_some() {}
    radar
        .inject(r.start_slot(), FibonacciGoal { order: 60 })
        .timeout(WAIT)
        .await
        .unwrap();
    assert_eq!(next(&started, "started").await.order, 60);
    next(&feedback, "the long goal's feedback").await;
    radar
        .inject(r.interrupt_slot(), Empty::default())
        .timeout(WAIT)
        .await
        .unwrap();
    let cancel = peer_said(&mut server, "cancel").await;
    assert_eq!(
        cancel["known"], true,
        "the cancel names the running goal: {cancel}"
    );
    let ended = peer_said(&mut server, "ended").await;
    assert_eq!(ended["ended"], 5, "CANCELED: {ended}");
    next(&interrupted, "interrupted").await;
    let partial = next(&exited, "exited after the cancel").await;
    assert!(
        partial.sequence.len() >= 3 && partial.sequence.len() < 60,
        "the canceled goal's partial result: {partial:?}"
    );
    let s = after_exits(&state, 2).await;
    assert_eq!(s.interrupts, 1, "{s:?}");

    // A3: a rejected goal: no started, exited, the run failed
    radar
        .inject(r.start_slot(), FibonacciGoal { order: -1 })
        .timeout(WAIT)
        .await
        .unwrap();
    let goal = peer_said(&mut server, "goal").await;
    assert_eq!(goal["accepted"], false, "{goal}");
    assert_eq!(next(&exited, "exited").await, FibonacciResult::default());
    let s = after_exits(&state, 3).await;
    assert!(s.last_exit_reason.contains("goal rejected"), "{s:?}");
    assert_eq!((s.completed, s.interrupts, s.failures), (1, 1, 1), "{s:?}");
    assert!(
        started.try_recv().is_none(),
        "a rejected goal is never started"
    );

    // an action without type hashes is refused over Zenoh, saying what to do
    let refused = radar
        .action_response::<Dock>("/za/dock")
        .unwrap_err()
        .to_string();
    assert!(refused.contains("TYPE_HASHES"), "{refused}");
    drop(fib);
    server.close();

    served_to_a_design_document_client(&radar).await;
    the_action_examples_drive_each_other().await;
}

/// A response that computes the sequence of a goal's order, one number every 50 ms, publishing the sequence
/// so far on its `feedback` topic (what `serve_as_action` forwards).
fn fibonacci_response(radar: &Radar, name: &str) -> radar_ros::ResponseHandle {
    let feedback = std::sync::Arc::new(
        radar
            .signal_publisher::<FibonacciFeedback>(&format!("{name}/feedback"))
            .unwrap(),
    );
    radar
        .spawn_response(
            name,
            radar_ros::FnResponse::new(move |goal: FibonacciGoal| {
                let feedback = feedback.clone();
                async move {
                    let mut sequence = vec![0, 1];
                    while sequence.len() < goal.order.max(2) as usize {
                        let n = sequence[sequence.len() - 1] + sequence[sequence.len() - 2];
                        sequence.push(n);
                        let _ = feedback.publish(FibonacciFeedback {
                            sequence: sequence.clone(),
                        });
                        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
                    }
                    Ok(FibonacciResult { sequence })
                }
            }),
        )
        .unwrap()
}

/// Rules S1-S5 over Zenoh: a response served as an action (`Radar::serve_as_action`), driven by an action
/// client written from the design document (tests/python/zenoh_action_client.py), each goal from a fresh
/// process as `ros2 action send_goal` sends one: a goal runs to its result (SUCCEEDED, 4) with feedback and
/// the status array saying EXECUTING; a second goal is canceled mid-run (the cancel
/// answered with the goal canceling; the result CANCELED, 5; the response interrupted); a goal while another
/// runs is rejected (S2). Then a late observer (a fresh process subscribing to `status` only, transient local
/// as rcl_action makes it) reads the last status array: both goals, SUCCEEDED and CANCELED.
async fn served_to_a_design_document_client(radar: &Radar) {
    let fib = fibonacci_response(radar, "/za/fib_impl");
    let _served = radar
        .serve_as_action::<Fibonacci>(&fib, "/za/served")
        .unwrap();
    let client = |order: &str, cancel: Option<&str>| {
        let mut args = vec!["tcp/localhost:7447", "148", "/za/served", order];
        args.extend(cancel);
        Proc::start("zenoh_action_client.py", &args)
    };

    // the goal's answer, the status and feedback samples and the result come by different paths: their
    // lines are read until the result, then checked in any order
    let mut one = client("6", None);
    let mut said = Vec::new();
    while said.last().and_then(|v: &Value| v.get("result")).is_none() {
        said.push(peer_said(&mut one, "").await);
    }
    let has = |key: &str, value: Value| said.iter().any(|v| v.get(key) == Some(&value));
    assert!(has("accepted", Value::from(true)), "{said:?}");
    let first_goal = said.iter().find_map(|v| v.get("goal_id")).unwrap().clone();
    // EXECUTING (2) once the response said started (ACCEPTED before it, if the client's subscription was
    // routed by then: a volatile topic)
    assert!(has("status", Value::from(2)), "EXECUTING: {said:?}");
    assert!(
        has("feedback", Value::from(6)),
        "the last feedback: {said:?}"
    );
    let done = said.last().unwrap();
    assert_eq!(done["status"], 4, "SUCCEEDED: {done}");
    assert_eq!(
        done["result"],
        serde_json::json!([0, 1, 1, 2, 3, 5]),
        "exited's payload: {done}"
    );
    assert_eq!(fib.state().completed, 1);

    // a long goal (10 s), canceled mid-run; a second client's goal meanwhile is rejected
    let mut long = client("200", Some("cancel"));
    let long_goal = peer_said(&mut long, "goal_id").await["goal_id"].clone();
    assert_eq!(peer_said(&mut long, "accepted").await["accepted"], true);
    peer_said(&mut long, "feedback").await;
    let mut second = client("3", None);
    assert_eq!(
        peer_said(&mut second, "accepted").await["accepted"],
        false,
        "rule S2"
    );
    long.send("cancel").await;
    // the cancel's answer and the result are answers to two queries: either may come first
    let (mut answer, mut done) = (None, None);
    while answer.is_none() || done.is_none() {
        let v = peer_said(&mut long, "").await;
        if v.get("cancel_answer").is_some() {
            answer = Some(v);
        } else if v.get("result").is_some() {
            done = Some(v);
        } else if let Some(status) = v.get("status") {
            assert!(
                matches!(status.as_i64(), Some(1 | 2 | 3 | 5)),
                "no SUCCEEDED nor ABORTED: {v}"
            );
        }
    }
    let (answer, done) = (answer.unwrap(), done.unwrap());
    assert_eq!(
        (
            answer["cancel_answer"].as_i64(),
            answer["canceling"].as_i64()
        ),
        (Some(0), Some(1)),
        "{answer}"
    );
    assert_eq!(done["status"], 5, "CANCELED: {done}");
    let s = fib.state();
    assert_eq!((s.interrupts, s.completed), (1, 1), "{s:?}");

    // the rejected goal never entered the table (S2); the canceled one's end was the last change
    let mut late = Proc::start(
        "zenoh_action_client.py",
        &["tcp/localhost:7447", "148", "/za/served", "watch"],
    );
    let seen = peer_said(&mut late, "statuses").await;
    // in the table's order (by goal id)
    let mut statuses: Vec<Value> = seen["statuses"].as_array().unwrap().clone();
    statuses.sort_by_key(|s| s[0].as_str().map(str::to_owned));
    let mut expected = vec![
        serde_json::json!([first_goal, 4]),
        serde_json::json!([long_goal, 5]),
    ];
    expected.sort_by_key(|s| s[0].as_str().map(str::to_owned));
    assert_eq!(
        statuses, expected,
        "the last status array, read by a late subscriber"
    );
}

/// An example of this target directory (built with `--features zenoh`: `cargo test --workspace` builds it so).
fn example(name: &str) -> std::path::PathBuf {
    let exe = std::env::current_exe().unwrap();
    let bin = exe
        .parent()
        .and_then(|deps| deps.parent())
        .unwrap()
        .join(name);
    assert!(
        bin.exists(),
        "{} is missing: build it with `cargo build -p radar_ros_examples --features zenoh --bin {name}` \
         in this target directory (`cargo test --workspace` does)",
        bin.display()
    );
    bin
}

/// The example `name` over Zenoh (a peer of the router at rmw_zenoh's default endpoint), on this domain.
fn run_example(name: &str) -> tokio::process::Command {
    let mut cmd = tokio::process::Command::new(example(name));
    cmd.env("RMW_IMPLEMENTATION", "rmw_zenoh_cpp")
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .kill_on_drop(true);
    cmd
}

/// The stdout of an example that ended; fails unless it ended with success and wrote no error line.
fn ended_cleanly(out: std::process::Output, what: &str) -> String {
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr),
    );
    println!("{what}:\n{stdout}{stderr}");
    assert!(out.status.success(), "{what}: {stderr}");
    assert!(
        !stderr.lines().any(|l| l.contains("ERROR")),
        "{what} logged an error: {stderr}"
    );
    stdout
}

/// Two radar_ros programs over Zenoh, as a user runs the action examples (README, "ROS 2 actions"):
/// `fibonacci_action` serves a response as `/fibonacci`; `goal_until` runs `once go start fibonacci until
/// bumper` against it, and the bumper cancels the goal mid-way: feedback, `interrupted`, then `exited`; the
/// server, told to stop (SIGINT), ends cleanly having seen its goal end interrupted.
async fn the_action_examples_drive_each_other() {
    let server = run_example("fibonacci_action").spawn().unwrap();
    let client = tokio::time::timeout(WAIT, run_example("goal_until").output())
        .await
        .expect("goal_until ends")
        .unwrap();
    let stdout = ended_cleanly(client, "goal_until");
    assert!(stdout.contains("started: goal order 10"), "{stdout}");
    assert!(
        stdout.contains("interrupted: the bumper cancels the goal"),
        "{stdout}"
    );
    let exited = stdout
        .lines()
        .find(|l| l.contains("exited: "))
        .unwrap_or_else(|| panic!("no exited line: {stdout}"));
    // the canceled goal's result is what the served response's `exited` carried (S3): an interrupted
    // `FnResponse` exits with the default result
    assert!(exited.ends_with("exited: [] (interrupted)"), "{exited}");
    assert!(
        stdout.contains("feedback [0, 1, 1, 2]"),
        "the server's feedback reached the client's `feedback` signal: {stdout}"
    );
    unsafe { libc::kill(server.id().unwrap() as i32, libc::SIGINT) };
    let out = tokio::time::timeout(WAIT, server.wait_with_output())
        .await
        .expect("fibonacci_action ends on SIGINT")
        .unwrap();
    let stdout = ended_cleanly(out, "fibonacci_action");
    assert!(stdout.contains("goal 1 ended: interrupted"), "{stdout}");
}
