//! Listing 1 with one process per component: the same `CountUp` and `SleepThenTrigger` types as the
//! `count_up` example, each hosted by its own `Radar` (DDS participant), found through DDS discovery.
//!
//! ```text
//! count_up_nodes count_up      # the response
//! count_up_nodes start_event   # StartEvent (2 s)
//! count_up_nodes end_event     # EndEvent (4 s)
//! count_up_nodes statement [--duration S]   # once start_event start count_up until end_event
//! ```
//! `launch_scripts/count_up_processes.sh` starts all four. Components run until SIGINT/SIGTERM; the statement
//! prints its timeline from the moment it is armed and exits after `--duration` seconds (default 12).

use std::time::Duration;

use radar_ros::Radar;
use radar_ros_examples::{
    init_logs,
    listing1::{watch_count_up, watch_event, CountUp, SleepThenTrigger},
    Timeline,
};

#[tokio::main]
async fn main() {
    init_logs();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let duration = args
        .iter()
        .skip_while(|a| *a != "--duration")
        .nth(1)
        .map(|s| s.parse::<f64>().expect("--duration SECONDS"))
        .unwrap_or(12.0);
    let role = args.first().map(String::as_str).unwrap_or("");
    if let Err(e) = run(role, duration).await {
        eprintln!("count_up_nodes {role}: {e}");
        std::process::exit(1);
    }
}

/// Runs until the program is told to stop: on SIGINT or SIGTERM radar_ros stops every component (a running
/// response's exit slot runs, `exited` is sent), leaves the ROS graph and ends the process.
async fn until_stopped() {
    std::future::pending().await
}

async fn run(role: &str, duration: f64) -> radar_ros::Result<()> {
    let radar = Radar::new()?;
    let tl = Timeline::start();
    match role {
        "count_up" => {
            let _h = radar.spawn_response("count_up", CountUp::new(tl))?;
            until_stopped().await;
        }
        "start_event" | "end_event" => {
            let secs = if role == "start_event" { 2 } else { 4 };
            let _h = radar.spawn_event(role, SleepThenTrigger::new(Duration::from_secs(secs)))?;
            until_stopped().await;
        }
        "statement" => {
            // the components are in other processes: find them by name on the ROS graph
            let wait = Duration::from_secs(30);
            let start = radar.event("start_event").timeout(wait).await?;
            let end = radar.event("end_event").timeout(wait).await?;
            let count_up = radar.response("count_up").timeout(wait).await?;
            let statement = radar
                .once(&start)
                .start(&count_up)
                .until(&end)
                .timeout(wait)
                .await?;
            // the listing's times count from the statement being armed
            let tl = Timeline::start();
            tl.mark("once start_event start count_up until end_event", Some(0.0));
            let printers = [
                tokio::spawn(watch_count_up(&radar, tl)?),
                tokio::spawn(watch_event(&radar, tl, "start_event")?),
                tokio::spawn(watch_event(&radar, tl, "end_event")?),
            ];
            tokio::select! {
                _ = tokio::time::sleep(Duration::from_secs_f64(duration)) => {}
                _ = until_stopped() => {}
            }
            for p in printers {
                p.abort();
            }
            drop(statement);
            tl.mark("done", None);
        }
        _ => {
            eprintln!("usage: count_up_nodes count_up | start_event | end_event | statement [--duration S]");
            std::process::exit(64);
        }
    }
    Ok(())
}
