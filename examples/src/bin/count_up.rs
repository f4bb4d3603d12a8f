//! The paper's Listing 1, in one process:
//!
//! ```text
//! response CountUp:            event StartEvent:      event EndEvent:
//!   i = 0                        sleep (2 s)            sleep (4 s)
//!   while i < 10:                trigger                trigger
//!     sleep(0.5 s); i += 1
//!   interrupt                  def main:
//!   on exit: restart             once start_event start countUp until end_event
//! ```
//!
//! Every component is a real ROS 2 node on one DDS participant; signals travel over DDS topics
//! (`/start_event/triggered`, `/count_up/start`, ...) through the embedded connection manager. The statement
//! `once start_event start count_up until end_event` delivers the first `triggered` of `start_event` to
//! `count_up/start` and then lets go of `start_event` (which deactivates); `end_event` reaches
//! `count_up/interrupt` only while the run that the statement started is in progress. The restart asked for by
//! CountUp's exit slot is CountUp's own doing, not the statement's, so it runs outside that window: after the
//! interrupt at 4 s, CountUp restarts and counts to 10 undisturbed. The statement is then spent (its start has
//! fired and the run it began has ended), so it lets go of `end_event` too, which deactivates at 4 s. The
//! timeline prints each signal at the time it was emitted, in that order.
//!
//! Run: `cargo run --bin count_up` (`-- --duration 12` to change how long it runs). Ctrl-C (or SIGTERM)
//! stops it at any time as it stops every radar_ros program: CountUp's exit slot runs (it prints
//! `count_up exit slot (exit_signal)`), `exited` is sent, and the program leaves the ROS graph.

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
    let duration = std::env::args()
        .skip_while(|a| a != "--duration")
        .nth(1)
        .map(|s| s.parse::<f64>().expect("--duration SECONDS"))
        .unwrap_or(12.0);
    if let Err(e) = run(duration).await {
        eprintln!("count_up: {e}");
        std::process::exit(1);
    }
}

async fn run(duration: f64) -> radar_ros::Result<()> {
    let radar = Radar::new()?;
    println!(
        "Listing 1 (count_up) on ROS 2 domain {}; every component is a node on one DDS participant",
        radar.domain_id()
    );
    // main begins: the listing's times count from here
    let tl = Timeline::start();
    let count_up = radar.spawn_response("count_up", CountUp::new(tl))?;
    let start_event =
        radar.spawn_event("start_event", SleepThenTrigger::new(Duration::from_secs(2)))?;
    let end_event =
        radar.spawn_event("end_event", SleepThenTrigger::new(Duration::from_secs(4)))?;
    let printers = [
        tokio::spawn(watch_count_up(&radar, tl)?),
        tokio::spawn(watch_event(&radar, tl, "start_event")?),
        tokio::spawn(watch_event(&radar, tl, "end_event")?),
    ];
    tl.mark("once start_event start count_up until end_event", Some(0.0));
    let _statement = radar
        .once(start_event.triggered())
        .start(&count_up)
        .until(end_event.triggered())
        .await?;
    // Ctrl-C needs nothing here: radar_ros stops the components (exit slots run) and ends the program
    tokio::time::sleep(Duration::from_secs_f64(duration)).await;
    for p in printers {
        p.abort();
    }
    tl.mark(
        "done: shutting down (count_up's exit slot runs once more)",
        None,
    );
    count_up.shutdown().await?;
    Ok(())
}
