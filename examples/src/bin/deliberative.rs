//! The paper's Listings 2 and 3 (its §VI example), with every component in its own process:
//!
//! ```text
//! def do_loop():                              def main():
//!     once TestEvent2 interrupt TestResponse      whenever TestEvent start TestResponse
//!     for ii in range(15): sleep(1)               do_loop()
//!                                                 while True: pass
//! ```
//! - `TestEvent` counts to 5, one count a second, then triggers (and starts over).
//! - `TestEvent2` does the same but triggers after 3 s.
//! - `TestResponse` counts for 10 s after it starts, then exits; it may be interrupted between counts.
//!
//! `deliberative test_event|test_event2|test_response` runs one component; `deliberative main` runs the
//! deliberative program, which finds the components by name on the ROS graph and prints the connections as
//! they appear and disappear: Figure 3's (a) none, (b) the `whenever`, (c) plus the `once` inside `do_loop`,
//! then (b) again when TestEvent2 fires the `once` or `do_loop` returns. `launch_scripts/deliberative.sh`
//! starts all four.
//!
//! Options for `main`: `--loop-secs N` (do_loop's length, default 15), `--duration S` (then exit; default: run
//! until Ctrl-C). For the events: `--count N` (seconds counted before triggering; default 5 and 3), which is
//! also their parameter `count` (`--ros-args -p count:=2`, a params file, `ros2 param set /test_event count 2`:
//! read when a count begins). `launch_scripts/two_robots.sh` runs the whole example twice under two namespaces
//! with settings from `launch_scripts/robots.yaml`.

use std::time::Duration;

use radar_ros::{
    msg::Empty,
    nodes::EventNode,
    params::{ParamDecl, Params},
    Event, ExitReason, Radar, Response, ResponseRef, SlotError,
};
use radar_ros_examples::{init_logs, Timeline};

/// Counts to `count` (a parameter, default `n`), one count a second, then triggers.
struct CountThenTrigger {
    n: u32,
    params: Option<Params>,
}

impl Event for CountThenTrigger {
    type Payload = Empty;
    fn attach(&mut self, node: &mut EventNode<'_>) -> radar_ros::Result<()> {
        self.params = Some(
            node.declare([ParamDecl::new("count", self.n)
                .description("seconds counted before triggering")
                .integer_range(0, 3600, 1)])?,
        );
        Ok(())
    }
    async fn check(&mut self) -> Result<Empty, SlotError> {
        let n = self
            .params
            .as_ref()
            .and_then(|p| p.i64("count"))
            .unwrap_or(i64::from(self.n));
        for _ in 0..n {
            tokio::time::sleep(Duration::from_secs(1)).await;
        }
        Ok(Empty::default())
    }
}

/// Counts for 10 s, then exits normally; interruptible between counts.
struct TestResponse(Timeline);

impl Response for TestResponse {
    type Start = Empty;
    type Output = Empty;
    async fn start(&mut self, _: Empty) -> Result<Empty, SlotError> {
        for i in 1..=10 {
            tokio::time::sleep(Duration::from_secs(1)).await;
            self.0.mark(&format!("test_response counts {i}"), None);
        }
        Ok(Empty::default())
    }
    async fn exit(&mut self, why: ExitReason) -> radar_ros::ExitAction {
        self.0
            .mark(&format!("test_response exits ({})", why.describe()), None);
        radar_ros::ExitAction::Done
    }
}

fn arg(args: &[String], flag: &str) -> Option<f64> {
    args.iter()
        .skip_while(|a| *a != flag)
        .nth(1)
        .map(|s| s.parse().expect("a number"))
}

/// Runs until the program is told to stop: on SIGINT or SIGTERM radar_ros stops every component (a running
/// response's exit slot runs, `exited` is sent), leaves the ROS graph and ends the process.
async fn until_stopped() {
    std::future::pending().await
}

#[tokio::main]
async fn main() {
    init_logs();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let role = args.first().cloned().unwrap_or_default();
    if let Err(e) = run(&role, &args).await {
        eprintln!("deliberative {role}: {e}");
        std::process::exit(1);
    }
}

async fn run(role: &str, args: &[String]) -> radar_ros::Result<()> {
    let radar = Radar::new()?;
    let tl = Timeline::start();
    match role {
        "test_event" | "test_event2" => {
            let n = match arg(args, "--count") {
                Some(n) => n as u32,
                None if role == "test_event" => 5,
                None => 3,
            };
            let _h = radar.spawn_event(role, CountThenTrigger { n, params: None })?;
            until_stopped().await;
        }
        "test_response" => {
            let _h = radar.spawn_response("test_response", TestResponse(tl))?;
            until_stopped().await;
        }
        "main" => {
            let loop_secs = arg(args, "--loop-secs").unwrap_or(15.0);
            let duration = arg(args, "--duration");
            let main = deliberative(&radar, tl, loop_secs);
            match duration {
                Some(d) => {
                    let _ = tokio::time::timeout(Duration::from_secs_f64(d), main).await;
                }
                None => {
                    tokio::select! {
                        r = main => r?,
                        _ = until_stopped() => {}
                    }
                }
            }
            tl.mark("main ends: its connections go", None);
        }
        _ => {
            eprintln!("usage: deliberative test_event | test_event2 [--count N] | test_response | main [--loop-secs N] [--duration S]");
            std::process::exit(64);
        }
    }
    Ok(())
}

/// Listing 2's `main`.
async fn deliberative(radar: &Radar, tl: Timeline, loop_secs: f64) -> radar_ros::Result<()> {
    let wait = Duration::from_secs(30);
    let test_event = radar.event("test_event").timeout(wait).await?;
    let test_event2 = radar.event("test_event2").timeout(wait).await?;
    let test_response = radar.response("test_response").timeout(wait).await?;
    tl.mark(
        "(a) found test_event, test_event2, test_response; no connections",
        None,
    );
    let _printer = tokio::spawn(print_response(radar.clone(), tl, test_response.clone()));

    let _c1 = radar
        .whenever(test_event.triggered())
        .start(&test_response)
        .await?;
    tl.mark("(b) + whenever test_event start test_response", None);
    do_loop(radar, tl, &test_event2, &test_response, loop_secs).await?;
    tl.mark("do_loop returned", None);
    // Listing 2's `while True: pass`: main keeps its connection until the program is stopped
    std::future::pending().await
}

/// Listing 3's `do_loop`.
async fn do_loop(
    radar: &Radar,
    tl: Timeline,
    test_event2: &radar_ros::EventRef,
    test_response: &ResponseRef,
    loop_secs: f64,
) -> radar_ros::Result<()> {
    let end = tokio::time::Instant::now() + Duration::from_secs_f64(loop_secs);
    let c2 = radar
        .once(test_event2.triggered())
        .interrupt(test_response)
        .await?;
    tl.mark("(c) + once test_event2 interrupt test_response", None);
    tokio::select! {
        _ = c2.closed() => tl.mark("(b) - once test_event2 interrupt test_response (it fired)", None),
        _ = tokio::time::sleep_until(end) => {
            drop(c2);
            tl.mark("(b) - once test_event2 interrupt test_response (do_loop returns)", None);
            return Ok(());
        }
    }
    tokio::time::sleep_until(end).await;
    Ok(())
}

/// Prints the response's signals.
async fn print_response(radar: Radar, tl: Timeline, r: ResponseRef) -> radar_ros::Result<()> {
    let started = radar.signal_subscription::<Empty>(r.started().topic())?;
    let interrupted = radar.signal_subscription::<Empty>(r.interrupted().topic())?;
    let exited = radar.signal_subscription::<Empty>(r.exited().topic())?;
    loop {
        tokio::select! {
            x = started.recv() => { x?; tl.mark("test_response started", None) }
            x = interrupted.recv() => { x?; tl.mark("test_response interrupted", None) }
            x = exited.recv() => { x?; tl.mark("test_response exited", None) }
        }
    }
}
