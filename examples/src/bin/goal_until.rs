//! A deliberative program that drives a ROS 2 action server through RADAR statements: the action server is a
//! response (`radar.action_response`), so `once go start fibonacci until bumper` sends a goal when `go`
//! triggers and cancels it if `bumper` triggers while it runs.
//!
//! ```text
//! event go:      sleep 1 s, trigger          def main:
//! event bumper:  sleep 3 s, trigger              once go start fibonacci(order) until bumper
//! ```
//!
//! With a goal that takes longer than 2 s (the default: order 10 at the server's 0.5 s per number), the
//! bumper cancels it: `interrupted`, then `exited` with the part of the sequence the server computed. With a
//! short one (`--order 3`) the goal finishes first and the bumper changes nothing.
//!
//! Run an action server first: `cargo run --bin fibonacci_action` (or the rclpy server of the tests,
//! `tests/python/actions.py server /fibonacci --period 0.5`), then `cargo run --bin goal_until`.
//! Options: `--order N` (default 10), `--bumper-after S` (default 3).

use std::time::Duration;

use radar_ros::{
    action::{Fibonacci, FibonacciFeedback, FibonacciGoal, FibonacciResult},
    msg::Empty,
    Radar,
};
use radar_ros_examples::{listing1::SleepThenTrigger, number_arg, run_example, Timeline};

#[tokio::main]
async fn main() {
    run_example("goal_until", run()).await;
}

async fn run() -> radar_ros::Result<()> {
    let order = number_arg("--order").unwrap_or(10.0) as i32;
    let bumper_after = Duration::from_secs_f64(number_arg("--bumper-after").unwrap_or(3.0));
    let radar = Radar::new()?;
    let fibonacci = radar.action_response::<Fibonacci>("/fibonacci")?;
    let go = radar.spawn_event("go", SleepThenTrigger::new(Duration::from_secs(1)))?;
    let bumper = radar.spawn_event("bumper", SleepThenTrigger::new(bumper_after))?;

    // print what the response says, from its signals
    let tl = Timeline::start();
    let r = fibonacci.reference();
    let _started = radar
        .whenever(r.started())
        .call(move |g: FibonacciGoal| tl.mark(&format!("started: goal order {}", g.order), None))
        .await?;
    let _feedback = radar
        .whenever(fibonacci.feedback())
        .call(move |f: FibonacciFeedback| tl.mark(&format!("feedback {:?}", f.sequence), None))
        .await?;
    let _interrupted = radar
        .whenever(r.interrupted())
        .call(move |_: Empty| tl.mark("interrupted: the bumper cancels the goal", None))
        .await?;
    let mut exited = radar.waiter::<FibonacciResult>(r.exited()).await?;

    // once go start fibonacci until bumper
    let _statement = radar
        .once(&go)
        .start(&fibonacci)
        .map(move |_: Empty| FibonacciGoal { order })
        .until(&bumper)
        .await?;
    tl.mark(
        &format!("armed: once go start fibonacci (order {order}) until bumper"),
        None,
    );
    let result = exited.recv().timeout(Duration::from_secs(60)).await?;
    let s = fibonacci.state();
    tl.mark(
        &format!("exited: {:?} ({})", result.sequence, s.last_exit_reason),
        None,
    );
    Ok(())
}
