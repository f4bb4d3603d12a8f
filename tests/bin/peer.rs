//! A helper process for the integration tests: a separate program with its own DDS participant.
//!
//! - `radar_test_peer subscribe TOPIC`: subscribes to TOPIC (std_msgs/msg/Empty, signal QoS), prints `matched`
//!   once a publisher is matched, and stays until SIGTERM/SIGINT (then leaves the graph cleanly) or SIGKILL.
//! - `radar_test_peer check-env`: creates a participant from the environment (ROS_DOMAIN_ID, ...) and prints
//!   `ok`, or prints the error and exits with status 2.

use std::time::Duration;

use radar_ros::{msg::Empty, Radar};
use tokio::signal::unix::{signal, SignalKind};

#[tokio::main]
async fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let radar = match Radar::new() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    match args.first().map(String::as_str) {
        Some("check-env") => println!("ok domain={}", radar.domain_id()),
        Some("subscribe") => {
            let topic = args.get(1).expect("subscribe TOPIC");
            let sub = radar
                .signal_subscription::<Empty>(topic)
                .expect("subscription");
            sub.wait_for_publishers(1, Duration::from_secs(30))
                .await
                .expect("a publisher");
            println!("matched");
            let mut term = signal(SignalKind::terminate()).expect("SIGTERM handler");
            tokio::select! {
                _ = term.recv() => {}
                _ = tokio::signal::ctrl_c() => {}
            }
            drop(sub);
            drop(radar);
            // let RustDDS send its dispose messages
            tokio::time::sleep(Duration::from_millis(200)).await;
            use std::io::Write;
            let _ = writeln!(std::io::stdout(), "bye");
        }
        _ => {
            eprintln!("usage: radar_test_peer check-env | subscribe TOPIC");
            std::process::exit(64);
        }
    }
}
