//! A RADAR response served as a ROS 2 action server: `test_msgs/action/Fibonacci` on `/fibonacci`, the
//! action of the ROS 2 tutorials, one number every 0.5 s with feedback, until Ctrl-C.
//!
//! The behaviour is an ordinary response (`/fibonacci_response`, see `fibonacci.rs`); `serve_as_action` lets any
//! action client drive it: a goal starts it, a cancel interrupts it, its `exited` payload is the result.
//!
//! Run: `cargo run --bin fibonacci_action`, then, with a ROS 2 installation (or the rclpy venv of the
//! tests), in another shell:
//!
//! ```text
//! ros2 action send_goal --feedback /fibonacci test_msgs/action/Fibonacci "{order: 5}"
//! ```
//!
//! Options: `--period-ms N` (default 500), `--duration S` (then exit; default: until Ctrl-C or SIGTERM).

use std::time::Duration;

use radar_ros::{action::Fibonacci, Radar};
use radar_ros_examples::{fibonacci::fibonacci_response, number_arg, run_example, Timeline};

#[tokio::main]
async fn main() {
    run_example("fibonacci_action", run()).await;
}

async fn run() -> radar_ros::Result<()> {
    let period = Duration::from_millis(number_arg("--period-ms").unwrap_or(500.0) as u64);
    let radar = Radar::new()?;
    let tl = Timeline::start();
    let response = fibonacci_response(&radar, "fibonacci_response", period)?;
    let server = radar.serve_as_action::<Fibonacci>(&response, "fibonacci")?;
    tl.mark(
        &format!(
            "serving {} (test_msgs/action/Fibonacci) on ROS 2 domain {}: response {}, one number every {period:?}",
            server.action(),
            radar.domain_id(),
            response.name()
        ),
        None,
    );
    let mut states = response.watch_state();
    // Ctrl-C and SIGTERM need nothing here: radar_ros stops the response (an unfinished goal's run ends
    // through its exit slot, the goal is aborted) and ends the program
    let until = async {
        match number_arg("--duration") {
            Some(d) => tokio::time::sleep(Duration::from_secs_f64(d)).await,
            None => std::future::pending().await,
        }
    };
    tokio::pin!(until);
    let mut last = response.state();
    loop {
        tokio::select! {
            _ = &mut until => break,
            changed = states.changed() => {
                if changed.is_err() {
                    break;
                }
                let s = states.borrow_and_update().clone();
                if s.starts > last.starts {
                    tl.mark(&format!("goal {} running", s.starts), None);
                }
                if s.exits > last.exits {
                    tl.mark(&format!("goal {} ended: {}", s.exits, s.last_exit_reason), None);
                }
                last = s;
            }
        }
    }
    tl.mark("stopping", None);
    server.shutdown().await?;
    response.shutdown().await?;
    Ok(())
}
