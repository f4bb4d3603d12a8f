//! A response whose start is a robot's own kind of goal, `geometry_msgs/msg/PoseStamped`: `/go_to` drives to
//! the pose it is started with (here it says where it goes and takes a second), and its `exited` carries the
//! pose it reached. Any ROS 2 tool starts it, as it would any subscriber of that type.
//!
//! Run: `cargo run --bin go_to_pose`, then, with a ROS 2 installation, in another shell:
//!
//! ```text
//! ros2 topic pub --once /go_to/start geometry_msgs/msg/PoseStamped "{pose: {position: {x: 1.0}}}"
//! ```
//!
//! or, with no ROS installation, the same payload through radar's own command line:
//!
//! ```text
//! cargo run -p radar_tools --bin radar -- inject /go_to/start "{pose: {position: {x: 1.0}}}"
//! ```
//!
//! Options: `--drive-ms N` (how long a drive takes, default 1000), `--duration S` (then exit; default: until
//! Ctrl-C or SIGTERM).

use std::time::Duration;

use radar_ros::{msg::PoseStamped, FnResponse, Radar};
use radar_ros_examples::{number_arg, run_example, Timeline};

#[tokio::main]
async fn main() {
    run_example("go_to_pose", run()).await;
}

async fn run() -> radar_ros::Result<()> {
    let drive = Duration::from_millis(number_arg("--drive-ms").unwrap_or(1000.0) as u64);
    let radar = Radar::new()?;
    let tl = Timeline::start();
    let go_to = radar.spawn_response(
        "go_to",
        FnResponse::new(move |goal: PoseStamped| async move {
            let p = &goal.pose.position;
            println!(
                "going to ({}, {}, {}) in frame {:?}",
                p.x, p.y, p.z, goal.header.frame_id
            );
            tokio::time::sleep(drive).await;
            Ok(goal)
        })
        .on_interrupt(|| async { println!("stopped on the way") }),
    )?;
    tl.mark(
        &format!(
            "{} waits for a geometry_msgs/msg/PoseStamped on {} (ROS 2 domain {})",
            go_to.name(),
            go_to.reference().start_slot().topic(),
            radar.domain_id()
        ),
        None,
    );
    let mut states = go_to.watch_state();
    let until = async {
        match number_arg("--duration") {
            Some(d) => tokio::time::sleep(Duration::from_secs_f64(d)).await,
            None => std::future::pending().await,
        }
    };
    tokio::pin!(until);
    let mut exits = go_to.state().exits;
    loop {
        tokio::select! {
            _ = &mut until => break,
            changed = states.changed() => {
                if changed.is_err() {
                    break;
                }
                let s = states.borrow_and_update().clone();
                if s.exits > exits {
                    exits = s.exits;
                    tl.mark(&format!("arrived ({})", s.last_exit_reason), None);
                }
            }
        }
    }
    go_to.shutdown().await?;
    Ok(())
}
