//! ROS 2 actions and RADAR responses, both ways, over real DDS: an action server as a response
//! (`Radar::action_response`) and a response as an action server (`Radar::serve_as_action`), against each other
//! and against real rclpy (`rclpy.action`, `test_msgs/action/Fibonacci` from the ros-jazzy-test-msgs wheel;
//! `tests/python/actions.py`). Rules A1-A7 and S1-S7 are in `radar_ros::action`. Domains 63-67, 16-17, 149.

use std::time::Duration;

use radar_ros::{
    action::{ActionResponseOptions, Fibonacci, FibonacciFeedback, FibonacciGoal, FibonacciResult},
    msg::ResponseState,
};
use radar_ros_examples::{
    fibonacci::fibonacci_response,
    test_support::{assert_no_error_lines, examples_dir},
};
use radar_test_util::{radar, Py, ResponseProbe, Seen, DISCOVERY};
use serde_json::Value;

const T: Duration = Duration::from_secs(20);

type Probe = ResponseProbe<FibonacciGoal, FibonacciResult>;

fn goal(order: i32) -> FibonacciGoal {
    FibonacciGoal { order }
}

fn sequence(order: usize) -> Vec<i32> {
    let mut s = vec![0, 1];
    for i in 1..order {
        s.push(s[i] + s[i - 1]);
    }
    s
}

fn result(order: usize) -> FibonacciResult {
    FibonacciResult {
        sequence: sequence(order),
    }
}

/// The next state of `probe` whose `exits` reaches `n`.
async fn after_exits(probe: &Probe, n: u64) -> ResponseState {
    probe.states_until(T, |s| s.exits >= n).await.1
}

/// Reads the Python side's JSON lines until one has `event` == `what`.
async fn event(py: &mut Py, what: &str) -> Value {
    loop {
        let v = py.json_with("event").await;
        if v["event"] == what {
            return v;
        }
    }
}

/// Rules A1-A4 and S1-S5 against each other: a native response served as an action, driven through an
/// action response in another participant; goal -> started -> feedback -> exited(result), interrupt ->
/// cancel -> exited, and a second client's goal rejected while the first runs.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_response_served_as_an_action_is_driven_through_an_action_response() {
    let (server_side, client_side) = (radar(63), radar(63));
    let fib = fibonacci_response(&server_side, "/fib_impl", Duration::from_millis(40)).unwrap();
    let _served = server_side
        .serve_as_action::<Fibonacci>(&fib, "/fibonacci")
        .unwrap();
    // a cancel must not wait for this limit to end (the server answers the result request sent at the start)
    let client = client_side
        .action_response_with::<Fibonacci>(
            "/fibonacci",
            ActionResponseOptions::default().cancel_timeout(Duration::from_secs(120)),
        )
        .unwrap();
    let _other = client_side
        .action_response_with::<Fibonacci>(
            "/fibonacci",
            ActionResponseOptions::default().named("/fibonacci_other"),
        )
        .unwrap();
    let probe = Probe::connect(&client_side, "/fibonacci").await;
    let other_probe = Probe::connect(&client_side, "/fibonacci_other").await;
    let feedback = client_side
        .signal_subscription::<FibonacciFeedback>(client.feedback().topic())
        .unwrap();
    feedback
        .wait_for_publishers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();

    // A1, A2, S1, S5: the goal runs, feedback flows, the result comes back
    probe.start.publish(goal(6)).unwrap();
    let seen = probe.signals(2, T).await;
    assert_eq!(
        seen,
        vec![Seen::Started(goal(6)), Seen::Exited(result(6))],
        "started on acceptance, exited with the result"
    );
    // feedback arrives on the feedback signal (its own writer: it may come after exited)
    let first = feedback.recv().timeout(T).await.unwrap();
    let mut sequences = vec![first.sequence];
    while let Some(f) = feedback.try_recv() {
        sequences.push(f.sequence);
    }
    assert!(
        sequences.iter().all(|s| sequence(6).starts_with(s)),
        "{sequences:?}"
    );
    let s = after_exits(&probe, 1).await;
    assert_eq!((s.completed, s.failures), (1, 0), "{s:?}");

    // S2: a goal while another runs is rejected (A3: exited without started, the run failed)
    probe.start.publish(goal(200)).unwrap();
    assert_eq!(probe.signals(1, T).await, vec![Seen::Started(goal(200))]);
    other_probe.start.publish(goal(3)).unwrap();
    assert_eq!(
        other_probe.signals(1, T).await,
        vec![Seen::Exited(FibonacciResult::default())]
    );
    let s = after_exits(&other_probe, 1).await;
    assert!(
        s.failures == 1 && s.last_exit_reason.contains("goal rejected"),
        "{s:?}"
    );

    // A4, S3: interrupt cancels the goal; the server side's response is interrupted
    tokio::time::sleep(Duration::from_millis(200)).await;
    probe.interrupt.publish(Default::default()).unwrap();
    let seen = probe.signals(2, T).await;
    assert_eq!(seen[0], Seen::Interrupted);
    assert!(matches!(seen[1], Seen::Exited(_)), "{seen:?}");
    let s = after_exits(&probe, 2).await;
    assert_eq!(
        (s.interrupts, s.last_exit_reason.as_str()),
        (1, "interrupted")
    );
    assert_eq!(
        fib.state().interrupts,
        1,
        "the served response was interrupted"
    );

    // and it is free again: the next goal runs to the end
    probe.start.publish(goal(3)).unwrap();
    assert_eq!(
        probe.signals(2, T).await,
        vec![Seen::Started(goal(3)), Seen::Exited(result(3))]
    );
}

/// A fresh Fast DDS participant's profile with a short lease, so that a killed rclpy process is noticed in
/// about 2 s instead of Fast DDS's 20 s.
fn short_lease_profile(dir: &std::path::Path) -> std::path::PathBuf {
    let p = dir.join("fastdds_short_lease.xml");
    std::fs::write(
        &p,
        r#"<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <participant profile_name="short_lease" is_default_profile="true">
    <rtps>
      <builtin>
        <discovery_config>
          <leaseDuration><sec>2</sec></leaseDuration>
          <leaseAnnouncement><sec>0</sec><nanosec>500000000</nanosec></leaseAnnouncement>
        </discovery_config>
      </builtin>
    </rtps>
  </participant>
</profiles>
"#,
    )
    .unwrap();
    p
}

async fn rclpy_server(domain: u16, args: &[&str]) -> Py {
    let mut py = Py::start(domain, "tests/python/actions.py", args);
    event(&mut py, "ready").await;
    py
}

/// Rules A1-A5 against a real rclpy ActionServer: goal -> result, feedback as a connection source, cancel
/// mid-goal through `interrupt` (the server's partial result is carried by `exited`), a rejected goal.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_rclpy_action_server_is_a_radar_response() {
    let r = radar(64);
    let mut py = rclpy_server(
        64,
        &[
            "server",
            "/fibonacci",
            "--period",
            "0.05",
            "--reject-above",
            "500",
        ],
    )
    .await;
    let fib = r.action_response::<Fibonacci>("/fibonacci").unwrap();
    let probe = Probe::connect(&r, "/fibonacci").await;

    // feedback as a connection source: a whenever counts it
    let counted = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let c = counted.clone();
    let _count = r
        .whenever(fib.feedback())
        .call(move |f: FibonacciFeedback| {
            assert!(f.sequence.len() >= 3);
            c.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        })
        .await
        .unwrap();

    probe.start.publish(goal(5)).unwrap();
    assert_eq!(event(&mut py, "execute").await["order"], 5);
    assert_eq!(
        probe.signals(2, T).await,
        vec![Seen::Started(goal(5)), Seen::Exited(result(5))]
    );
    radar_test_util::eventually(T, "feedback through the whenever", || {
        counted.load(std::sync::atomic::Ordering::SeqCst) == 4
    })
    .await;

    // A4: cancel mid-goal; the server's partial sequence comes back on exited
    probe.start.publish(goal(400)).unwrap();
    assert_eq!(probe.signals(1, T).await, vec![Seen::Started(goal(400))]);
    tokio::time::sleep(Duration::from_millis(300)).await;
    probe.interrupt.publish(Default::default()).unwrap();
    let seen = probe.signals(2, T).await;
    assert_eq!(seen[0], Seen::Interrupted);
    let Seen::Exited(partial) = &seen[1] else {
        panic!("{seen:?}")
    };
    assert!(
        partial.sequence.len() > 3 && partial.sequence.len() < 400,
        "the canceled goal's partial result: {partial:?}"
    );
    event(&mut py, "cancel_requested").await;
    let done = event(&mut py, "done").await;
    assert_eq!(done["status"], "CANCELED");
    assert_eq!(
        done["sequence"].as_array().unwrap().len(),
        partial.sequence.len(),
        "exited carries what the server reported"
    );

    // A3: a rejected goal: no started, exited, the run failed
    probe.start.publish(goal(501)).unwrap();
    assert_eq!(
        probe.signals(1, T).await,
        vec![Seen::Exited(FibonacciResult::default())]
    );
    event(&mut py, "rejected").await;
    let s = after_exits(&probe, 3).await;
    assert!(s.last_exit_reason.contains("goal rejected"), "{s:?}");
    assert_eq!((s.completed, s.interrupts, s.failures), (1, 1, 1), "{s:?}");

    // the graph tells the action's type; a response of another action type on that name fails its runs,
    // saying what is served there (DDS would match the endpoints whatever their types)
    assert_eq!(
        r.action_type("/fibonacci").await.unwrap(),
        "test_msgs/action/Fibonacci"
    );
    let other = radar(64); // one participant cannot hold one topic with two types
    let wrong = other
        .action_response_with::<Dock>(
            "/fibonacci",
            ActionResponseOptions::default().named("/wrong_type"),
        )
        .unwrap();
    let wrong_probe = ResponseProbe::<DockGoal, DockResult>::connect(&other, "/wrong_type").await;
    wrong_probe.start.publish(DockGoal::default()).unwrap();
    assert!(matches!(
        wrong_probe.signals(1, T).await[..],
        [Seen::Exited(_)]
    ));
    let s = wrong_probe.states_until(T, |s| s.exits >= 1).await.1;
    assert!(
        s.last_exit_reason
            .contains("serves test_msgs/action/Fibonacci"),
        "{s:?}"
    );
    drop(wrong);
}

/// An action type this test's servers do not serve.
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
    type Feedback = DockResult;
}

/// Rule A7: an rclpy server killed (SIGKILL) mid-goal ends the run with a failure once its lease ends, never
/// hangs; the next start waits for a server and fails when none comes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_rclpy_server_killed_mid_goal_ends_the_run_with_a_failure() {
    let r = radar(65);
    let dir = std::env::temp_dir().join(format!("radar_actions_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = short_lease_profile(&dir);
    let mut py = Py::start_with_env(
        65,
        "tests/python/actions.py",
        &["server", "/fibonacci", "--period", "0.1"],
        &[("FASTRTPS_DEFAULT_PROFILES_FILE", profile.to_str().unwrap())],
    );
    event(&mut py, "ready").await;
    let _fib = r
        .action_response_with::<Fibonacci>(
            "/fibonacci",
            ActionResponseOptions::default().server_timeout(Duration::from_secs(2)),
        )
        .unwrap();
    let probe = Probe::connect(&r, "/fibonacci").await;
    probe.start.publish(goal(1000)).unwrap();
    assert_eq!(probe.signals(1, T).await, vec![Seen::Started(goal(1000))]);
    event(&mut py, "execute").await;
    py.kill();
    let t0 = std::time::Instant::now();
    assert!(matches!(probe.signals(1, T).await[..], [Seen::Exited(_)]));
    let lost_after = t0.elapsed();
    let s = after_exits(&probe, 1).await;
    assert!(
        s.failures == 1 && s.last_exit_reason.contains("left the ROS graph"),
        "{s:?}"
    );
    println!("server killed mid-goal: exited after {lost_after:?}");
    assert!(lost_after < Duration::from_secs(8), "{lost_after:?}");

    // no server: the next run waits 2 s for one, then fails
    probe.start.publish(goal(3)).unwrap();
    assert!(matches!(probe.signals(1, T).await[..], [Seen::Exited(_)]));
    let s = after_exits(&probe, 2).await;
    assert!(
        s.last_exit_reason.contains("no action server answered"),
        "{s:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Rules S1-S5 against a real rclpy ActionClient (a fresh process per goal, as `ros2 action send_goal` is):
/// goal -> feedback -> result; a cancel mid-goal interrupts the response and ends the goal CANCELED; a second
/// client's goal while one runs is rejected.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_rclpy_action_client_drives_a_response_served_as_an_action() {
    let r = radar(66);
    let fib = fibonacci_response(&r, "/fib_impl", Duration::from_millis(50)).unwrap();
    let _served = r.serve_as_action::<Fibonacci>(&fib, "/fibonacci").unwrap();

    let mut py = Py::start(
        66,
        "tests/python/actions.py",
        &["client", "/fibonacci", "6"],
    );
    assert_eq!(event(&mut py, "answer").await["accepted"], true);
    let fb = event(&mut py, "feedback").await;
    assert!(fb["sequence"].as_array().unwrap().len() >= 3, "{fb}");
    let res = event(&mut py, "result").await;
    assert_eq!(res["status"], "SUCCEEDED");
    assert_eq!(
        res["sequence"],
        serde_json::to_value(sequence(6)).unwrap(),
        "the result is exited's payload"
    );
    py.succeeds().await;
    assert_eq!(fib.state().completed, 1);

    // cancel mid-goal, and a second client rejected meanwhile
    let mut long = Py::start(
        66,
        "tests/python/actions.py",
        &["client", "/fibonacci", "300", "--cancel-after", "1.5"],
    );
    assert_eq!(event(&mut long, "answer").await["accepted"], true);
    let mut second = Py::start(
        66,
        "tests/python/actions.py",
        &["client", "/fibonacci", "3"],
    );
    assert_eq!(
        event(&mut second, "answer").await["accepted"],
        false,
        "rule S2"
    );
    second.succeeds().await;
    assert_eq!(event(&mut long, "cancel_answer").await["canceling"], 1);
    let res = event(&mut long, "result").await;
    assert_eq!(res["status"], "CANCELED");
    long.succeeds().await;
    let s = fib.state();
    assert_eq!((s.interrupts, s.completed), (1, 1), "{s:?}");
}

/// The stdout of an example that ended; fails unless it ended with success and logged no error line.
fn ended_cleanly(out: std::process::Output, what: &str) -> String {
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr),
    );
    println!("{stdout}");
    assert!(out.status.success(), "{what}: {stderr}");
    assert_no_error_lines(&stderr, what);
    stdout
}

/// The `fibonacci_action` example, run with no arguments, serves `/fibonacci` to an rclpy ActionClient (a fresh
/// process, as `ros2 action send_goal --feedback` is) until SIGINT, then ends cleanly.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_fibonacci_action_example_serves_an_rclpy_client() {
    radar_test_util::require_isolation();
    let exe = examples_dir("fibonacci_action").join("fibonacci_action");
    let server = tokio::process::Command::new(&exe)
        .env("ROS_DOMAIN_ID", "67")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("run the example");
    let mut py = Py::start(
        67,
        "tests/python/actions.py",
        &["client", "/fibonacci", "4"],
    );
    assert_eq!(event(&mut py, "answer").await["accepted"], true);
    // feedback is a volatile topic: a fresh client may miss the first one while its reader is being matched
    let fb = event(&mut py, "feedback").await;
    let fb: Vec<i32> = serde_json::from_value(fb["sequence"].clone()).unwrap();
    assert!(
        fb.len() >= 3 && sequence(4).starts_with(&fb),
        "feedback is the sequence so far: {fb:?}"
    );
    let res = event(&mut py, "result").await;
    assert_eq!(res["status"], "SUCCEEDED");
    assert_eq!(res["sequence"], serde_json::json!([0, 1, 1, 2, 3]));
    py.succeeds().await;
    // Ctrl-C
    unsafe { libc::kill(server.id().unwrap() as i32, libc::SIGINT) };
    let out = tokio::time::timeout(T, server.wait_with_output())
        .await
        .expect("the example ends on SIGINT")
        .unwrap();
    let stdout = ended_cleanly(out, "fibonacci_action");
    assert!(stdout.contains("goal 1 ended: completed"), "{stdout}");
}

/// The `goal_until` example drives a real rclpy action server through `once go start fibonacci until bumper`:
/// the bumper cancels the goal mid-way and `exited` carries the sequence the server had computed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_goal_until_example_cancels_an_rclpy_goal_when_the_bumper_triggers() {
    radar_test_util::require_isolation();
    let mut py = rclpy_server(68, &["server", "/fibonacci", "--period", "0.5"]).await;
    let exe = examples_dir("goal_until").join("goal_until");
    let out = tokio::time::timeout(
        T,
        tokio::process::Command::new(&exe)
            .env("ROS_DOMAIN_ID", "68")
            .kill_on_drop(true)
            .output(),
    )
    .await
    .expect("goal_until ends")
    .unwrap();
    let stdout = ended_cleanly(out, "goal_until");
    assert!(stdout.contains("started: goal order 10"), "{stdout}");
    assert!(
        stdout.contains("interrupted: the bumper cancels the goal"),
        "{stdout}"
    );
    let exited = stdout
        .lines()
        .find(|l| l.contains("exited: "))
        .unwrap_or_else(|| panic!("no exited line: {stdout}"));
    assert!(exited.ends_with("(interrupted)"), "{exited}");
    let done = event(&mut py, "done").await;
    assert_eq!(done["status"], "CANCELED");
    let partial = serde_json::to_string(&done["sequence"])
        .unwrap()
        .replace(',', ", ");
    assert!(
        exited.contains(&partial) && done["sequence"].as_array().unwrap().len() < 11,
        "exited carries the server's partial sequence {partial}: {exited}"
    );
}

/// Issue 19, B4 (rule A5 with `until`): `once go start fib until bumper`, the bumper right after the start,
/// while the action response still waits for its server. The run is the statement's from its start, not from
/// the server's acceptance: it is interrupted, and no goal runs when the server comes. Before, the window
/// opened only at `started` (acceptance), the bumper was dropped, and the goal ran to its end.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn b4_until_interrupts_a_goal_still_waiting_for_its_server() {
    use radar_ros::{msg::Empty, Signal};
    let (client_side, server_side) = (radar(16), radar(16));
    let fib = client_side
        .action_response_with::<Fibonacci>(
            "/b4_fibonacci",
            ActionResponseOptions::default().server_timeout(Duration::from_secs(30)),
        )
        .unwrap();
    let probe = Probe::connect(&client_side, "/b4_fibonacci").await;
    let (go, bumper) = (
        client_side.signal_publisher::<Empty>("/b4_go").unwrap(),
        client_side.signal_publisher::<Empty>("/b4_bumper").unwrap(),
    );
    let _c = client_side
        .once(Signal::new("/b4_go", "std_msgs/msg/Empty"))
        .start(&*fib)
        .map(|_: Empty| goal(5))
        .until(Signal::new("/b4_bumper", "std_msgs/msg/Empty"))
        .timeout(DISCOVERY)
        .await
        .unwrap();
    go.publish(Empty::default()).unwrap();
    bumper.publish(Empty::default()).unwrap();
    // interrupted before any server answered: `interrupted` and `exited`, no `started`
    let st = after_exits(&probe, 1).await;
    assert_eq!((st.starts, st.interrupts), (1, 1), "{st:?}");
    // the server comes now: no goal reaches it
    let impl_ = fibonacci_response(&server_side, "/b4_impl", Duration::from_millis(20)).unwrap();
    let _served = server_side
        .serve_as_action::<Fibonacci>(&impl_, "/b4_fibonacci")
        .unwrap();
    tokio::time::sleep(Duration::from_millis(1500)).await;
    assert_eq!(
        impl_.state().starts,
        0,
        "no goal was sent after the interrupt"
    );
}

/// Issue 19, B11 (rule S7): a response served as an action runs another statement's start when a goal comes,
/// and its state still says idle (a start behaviour that blocks before its first await): the goal is accepted,
/// the response queues its start (policy queue-one), and the other run's `exited` does not answer the goal:
/// the goal's own run does, after it. Before, any `exited` of the response answered the running goal, which
/// then SUCCEEDED with the other run's result.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn b11_another_run_of_a_served_response_does_not_answer_the_goal() {
    let (server_side, client_side) = (radar(17), radar(17));
    let slow = server_side
        .spawn_response(
            "/b11_impl",
            radar_ros::FnResponse::new(|g: FibonacciGoal| async move {
                // blocks before its first await: the response's state says idle meanwhile
                std::thread::sleep(Duration::from_millis(400));
                tokio::time::sleep(Duration::from_millis(100)).await;
                Ok(FibonacciResult {
                    sequence: vec![g.order],
                })
            })
            .start_policy(radar_ros::StartPolicy::QueueOne),
        )
        .unwrap();
    let _served = server_side
        .serve_as_action::<Fibonacci>(&slow, "/b11_fibonacci")
        .unwrap();
    let fib = client_side
        .action_response::<Fibonacci>("/b11_fibonacci")
        .unwrap();
    let probe = Probe::connect(&client_side, "/b11_fibonacci").await;
    let other = client_side
        .signal_publisher::<FibonacciGoal>("/b11_impl/start")
        .unwrap();
    let started = client_side
        .signal_subscription::<FibonacciGoal>("/b11_impl/started")
        .unwrap();
    other
        .wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    started
        .wait_for_publishers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    // another statement's run (its result would be [99]) ...
    other.publish(goal(99)).unwrap();
    started.recv().timeout(T).await.unwrap();
    // ... and a goal while it runs
    probe.start.publish(goal(3)).unwrap();
    let seen = probe.signals(2, T).await;
    assert_eq!(
        seen,
        [
            Seen::Started(goal(3)),
            Seen::Exited(FibonacciResult { sequence: vec![3] })
        ],
        "the goal is answered by its own run, not the other one"
    );
    let st = after_exits(&probe, 1).await;
    assert_eq!(st.last_exit_reason, "completed", "{st:?}");
    drop(fib);
}

/// The `go_to_pose` example as its documentation says: a fresh process publishes one
/// `geometry_msgs/msg/PoseStamped` `"{pose: {position: {x: 1.0}}}"` on `/go_to/start` (what `ros2 topic pub
/// --once` does: rclpy, default QoS, wait for the subscriber), then `radar inject` the same payload; each
/// drives the response once, with the pose given. Domain 117.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_go_to_pose_example_is_started_by_a_one_shot_pose_stamped() {
    radar_test_util::require_isolation();
    let exe = examples_dir("go_to_pose").join("go_to_pose");
    let robot = tokio::process::Command::new(&exe)
        .args(["--drive-ms", "200"])
        .env("ROS_DOMAIN_ID", "117")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("run the example");
    let mut py = Py::interop(
        117,
        &[
            "pub_once",
            "/go_to/start",
            "geometry_msgs/msg/PoseStamped",
            "{pose: {position: {x: 1.0}}}",
        ],
    );
    // the response's state says when each drive has ended
    let watcher = radar(117);
    let states = watcher
        .state_subscription::<ResponseState>("/go_to/state")
        .unwrap();
    let exits = |n: u64| {
        let states = &states;
        async move {
            tokio::time::timeout(T, async { while states.recv().await.unwrap().exits < n {} })
                .await
                .unwrap_or_else(|_| panic!("drive {n} did not end"))
        }
    };
    assert_eq!(py.json().await["published"], "/go_to/start");
    py.succeeds().await;
    exits(1).await;
    // the same payload through radar's command line
    let radar = examples_dir("go_to_pose").join("radar");
    let out = tokio::time::timeout(
        T,
        tokio::process::Command::new(&radar)
            .args([
                "inject",
                "/go_to/start",
                "{pose: {position: {x: 2.5}}, header: {frame_id: map}}",
            ])
            .env("ROS_DOMAIN_ID", "117")
            .output(),
    )
    .await
    .expect("radar inject ends")
    .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    exits(2).await;
    unsafe { libc::kill(robot.id().unwrap() as i32, libc::SIGINT) };
    let out = tokio::time::timeout(T, robot.wait_with_output())
        .await
        .expect("the example ends on SIGINT")
        .unwrap();
    let stdout = ended_cleanly(out, "go_to_pose");
    assert!(
        stdout.contains("going to (1, 0, 0) in frame \"\""),
        "{stdout}"
    );
    assert!(
        stdout.contains("going to (2.5, 0, 0) in frame \"map\""),
        "{stdout}"
    );
    assert_eq!(stdout.matches("arrived (completed)").count(), 2, "{stdout}");
}

/// A goal whose answer is lost on the way (as rmw_fastrtps drops a reply when the server's reply writer has not
/// matched the client's reply reader within ~100 ms: discovery runs on each side at its own pace, and under load
/// the server may hear the goal before it knows our reader) still starts: the server's status list, a transient
/// local topic that reaches us whenever its writer matches, names the goal accepted. The server here is a raw
/// ros2-client action server that never sends the goal's answer, only the status list and the result. Before,
/// the response waited for the answer forever (`goal_until` under load: the bumper's cancel then waited its 10 s,
/// a failure seen once in CI).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_goal_whose_answer_is_lost_starts_when_the_status_list_shows_it_accepted() {
    use ros2_client::{
        action::{GetResultResponse, GoalStatusEnum},
        action_msgs::{GoalInfo, GoalStatus, GoalStatusArray},
        dds::ServiceMapping,
        ActionTypeName, Name, NodeName, NodeOptions,
    };
    use serde::{Deserialize, Serialize};
    #[derive(Clone, Serialize, Deserialize)]
    struct G {
        order: i32,
    }
    #[derive(Clone, Serialize, Deserialize)]
    struct R {
        sequence: Vec<i32>,
    }
    impl ros2_client::Message for G {}
    impl ros2_client::Message for R {}

    let (server_side, client_side) = (radar(149), radar(149));
    let mut node = server_side
        .dds_context()
        .expect("a DDS Radar")
        .new_node(
            NodeName::new("/", "answer_lost_server").unwrap(),
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .unwrap();
    let (signal, state) = (radar_ros::qos::signal_qos(), radar_ros::qos::state_qos());
    let mut server = node
        .create_action_server::<G, R, R>(
            ServiceMapping::Enhanced,
            &Name::parse("/answer_lost").unwrap(),
            &ActionTypeName::new("test_msgs", "Fibonacci"),
            ros2_client::action::ActionServerQosPolicies {
                goal_service: signal.clone(),
                result_service: signal.clone(),
                cancel_service: signal.clone(),
                feedback_publisher: signal,
                status_publisher: state,
            },
        )
        .unwrap();
    let fib = client_side
        .action_response::<Fibonacci>("/answer_lost")
        .unwrap();
    let probe = Probe::connect(&client_side, "/answer_lost").await;
    probe.start.publish(goal(4)).unwrap();

    let (_, request) = tokio::time::timeout(T, server.goal_server().async_receive_request())
        .await
        .expect("the goal reaches the server")
        .unwrap();
    assert_eq!(request.goal.order, 4);
    // no answer to the goal; the goal in the status list, as a server lists a goal it accepted
    let listed = |status| GoalStatusArray {
        status_list: vec![GoalStatus {
            goal_info: GoalInfo {
                goal_id: request.goal_id,
                stamp: ros2_client::builtin_interfaces::Time::ZERO,
            },
            status,
        }],
    };
    server
        .send_goal_statuses(listed(GoalStatusEnum::Executing))
        .unwrap();
    let (result_req, asked) =
        tokio::time::timeout(T, server.result_server().async_receive_request())
            .await
            .expect("the client asks for the result once the goal runs")
            .unwrap();
    assert_eq!(asked.goal_id, request.goal_id);
    server
        .send_goal_statuses(listed(GoalStatusEnum::Succeeded))
        .unwrap();
    server
        .send_result(
            result_req,
            GetResultResponse {
                status: GoalStatusEnum::Succeeded,
                result: R {
                    sequence: sequence(4),
                },
            },
        )
        .unwrap();
    assert_eq!(
        probe.signals(2, T).await,
        vec![Seen::Started(goal(4)), Seen::Exited(result(4))]
    );
    drop(fib);
}
