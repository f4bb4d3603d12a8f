//! A helper process for the integration tests: a separate program with its own DDS participant.
//!
//! - `radar_test_peer subscribe TOPIC [empty|int32]`: subscribes to TOPIC (std_msgs/msg/Empty or Int32,
//!   signal QoS), prints `matched`
//!   once a publisher is matched, and stays until SIGTERM/SIGINT (then leaves the graph cleanly) or SIGKILL.
//! - `radar_test_peer host`: hosts components as told on stdin, one command per line, answering `ok` (or
//!   `err ...`) on stdout: `response NAME MS` (a response whose run takes MS ms), `echo NAME` (a response
//!   whose start takes a std_msgs/msg/String and returns it), `manager NAME` (serves a connection manager
//!   node), `malformed` (one line per count of dropped messages, `TOPIC PUBLISHER COUNT`, then `ok`),
//!   `publisher TOPIC` (an Empty
//!   signal publisher), `emit TOPIC` (publish once on it, after a subscriber matched), `emit-exit TOPIC`
//!   (publish, then exit at once), `quit` (leave the graph cleanly and exit). Killed from outside for crashes.
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
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "error".into()),
        )
        .with_writer(std::io::stderr)
        .with_ansi(false)
        .try_init();
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
        Some("host") => host(radar).await,
        _ => {
            eprintln!("usage: radar_test_peer check-env | subscribe TOPIC [empty|int32] | whenever EVENT RESPONSE | connect MANAGER SOURCE TARGET | host");
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

/// `host`: components made and signals sent as stdin says (see the module docs).
async fn host(radar: Radar) {
    use std::{collections::HashMap, io::Write};
    use tokio::io::{AsyncBufReadExt, BufReader};
    let mut responses = Vec::new();
    let mut managers = Vec::new();
    let mut publishers: HashMap<String, radar_ros::SignalPublisher<Empty>> = HashMap::new();
    let mut lines = BufReader::new(tokio::io::stdin()).lines();
    let say = |s: &str| {
        let mut out = std::io::stdout();
        let _ = writeln!(out, "{s}");
        let _ = out.flush();
    };
    say("ready");
    while let Ok(Some(line)) = lines.next_line().await {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["response", name, ms] => {
                let ms: u64 = ms.parse().expect("MS");
                let r = radar.spawn_response(
                    name,
                    radar_ros::FnResponse::new(move |_: Empty| async move {
                        tokio::time::sleep(Duration::from_millis(ms)).await;
                        Ok(Empty::default())
                    }),
                );
                match r {
                    Ok(h) => {
                        responses.push(h);
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["echo", name] => {
                let r = radar.spawn_response(
                    name,
                    radar_ros::FnResponse::new(|s: radar_ros::msg::StringMsg| async move { Ok(s) }),
                );
                match r {
                    Ok(h) => {
                        responses.push(h);
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["manager", name] => match radar.serve_manager(name) {
                Ok(m) => {
                    managers.push(m);
                    say("ok")
                }
                Err(e) => say(&format!("err {e}")),
            },
            ["malformed"] => {
                for m in radar.malformed_messages() {
                    say(&format!("{} {} {}", m.topic, m.publisher, m.count));
                }
                say("ok")
            }
            ["publisher", topic] => match radar.signal_publisher::<Empty>(topic) {
                Ok(p) => {
                    publishers.insert(topic.to_string(), p);
                    say("ok")
                }
                Err(e) => say(&format!("err {e}")),
            },
            ["emit" | "emit-exit", topic] => {
                let Some(p) = publishers.get(*topic) else {
                    say(&format!("err no publisher on {topic}"));
                    continue;
                };
                let sent = async {
                    p.wait_for_subscribers(1)
                        .timeout(Duration::from_secs(10))
                        .await?;
                    p.publish(Empty::default())
                };
                match sent.await {
                    Ok(()) if words[0] == "emit-exit" => break,
                    Ok(()) => say("ok"),
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["quit"] => break,
            _ => say(&format!("err unknown command {line:?}")),
        }
    }
    // leaving cleanly: endpoints and participant dropped, so DDS peers hear the goodbye
    drop(publishers);
    drop(managers);
    drop(responses);
    drop(radar);
    tokio::time::sleep(Duration::from_millis(100)).await;
}
