//! A helper process for the integration tests: a separate program with its own DDS participant.
//!
//! - `radar_test_peer subscribe TOPIC [empty|int32]`: subscribes to TOPIC (std_msgs/msg/Empty or Int32,
//!   signal QoS), prints `matched`
//!   once a publisher is matched, and stays until SIGTERM/SIGINT (then leaves the graph cleanly) or SIGKILL.
//! - `radar_test_peer check-env`: creates a participant from the environment (ROS_DOMAIN_ID, ...) and prints
//!   `ok`, or prints the error and exits with status 2.

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Int32},
    Radar,
};
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
            let sub: Box<dyn std::any::Any> = match args.get(2).map(String::as_str) {
                None | Some("empty") => Box::new(subscribe::<Empty>(&radar, topic).await),
                Some("int32") => Box::new(subscribe::<Int32>(&radar, topic).await),
                Some(other) => panic!("unknown type {other}: use empty or int32"),
            };
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
        Some("whenever") => {
            // whenever EVENT start RESPONSE, with this process's embedded manager; stays until killed
            let (event, response) = (&args[1], &args[2]);
            let e = radar
                .event(event)
                .timeout(Duration::from_secs(20))
                .await
                .expect("the event");
            let r = radar
                .response(response)
                .timeout(Duration::from_secs(20))
                .await
                .expect("the response");
            let _c = radar
                .whenever(e.triggered())
                .start(&r)
                .await
                .expect("the connection");
            println!("connected");
            let mut term = signal(SignalKind::terminate()).expect("SIGTERM handler");
            term.recv().await;
        }
        Some("connect") => {
            // connect MANAGER SOURCE TARGET: make a whenever connection through the manager's service
            let (manager, source, target) = (&args[1], &args[2], &args[3]);
            let client = radar_test_util::ManagerClient::new(
                &radar,
                manager,
                &format!("peer_{}", std::process::id()),
            )
            .await;
            let req = radar_ros::msg::ConnectRequest {
                kind: radar_ros::msg::Connection::WHENEVER,
                source: source.clone(),
                target: target.clone(),
                ..Default::default()
            };
            let resp =
                radar_test_util::call_once(&client.connect, req, Duration::from_secs(20)).await;
            println!("connected {} {}", resp.ok, resp.id);
            let mut term = signal(SignalKind::terminate()).expect("SIGTERM handler");
            term.recv().await;
            drop(client);
            drop(radar);
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
        _ => {
            eprintln!("usage: radar_test_peer check-env | subscribe TOPIC [empty|int32] | whenever EVENT RESPONSE | connect MANAGER SOURCE TARGET");
            std::process::exit(64);
        }
    }
}

async fn subscribe<M: radar_ros::msg::RosMessage>(
    radar: &Radar,
    topic: &str,
) -> radar_ros::SignalSubscription<M> {
    let s = radar.signal_subscription::<M>(topic).expect("subscription");
    s.wait_for_publishers(1)
        .timeout(Duration::from_secs(30))
        .await
        .expect("a publisher");
    s
}
