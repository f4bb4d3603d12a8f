//! A helper process for the integration tests: a separate program with its own DDS participant.
//!
//! - `radar_test_peer subscribe TOPIC [empty|int32]`: subscribes to TOPIC (std_msgs/msg/Empty or Int32,
//!   signal QoS), prints `matched`
//!   once a publisher is matched, and stays until SIGTERM/SIGINT (radar_ros then leaves the graph cleanly and
//!   ends the process) or SIGKILL.
//! - `radar_test_peer host`: hosts components as told on stdin, one command per line, answering `ok` (or
//!   `err ...`) on stdout: `response NAME MS` (a response whose run takes MS ms), `response-alt NAME ODD EVEN` (its
//!   1st, 3rd, ... runs take ODD ms, the others EVEN ms), `echo NAME` (a response
//!   whose start takes a std_msgs/msg/String and returns it), `manager NAME` (serves a connection manager
//!   node), `malformed` (one line per count of dropped messages, `TOPIC PUBLISHER COUNT`, then `ok`),
//!   `whenever SOURCE RESPONSE` (finds RESPONSE by name, arms `whenever SOURCE start RESPONSE` for an Empty
//!   SOURCE topic; answers `found_ms N`), `wait-state NAME EXITS MS` (until response NAME's state shows EXITS
//!   runs ended), `publisher-i64 TOPIC` and `emit-seq TOPIC N PERIOD_US` (N std_msgs/msg/Int64 stamped with
//!   the send time in ns), `collect-arm TOPIC` (a whenever with an anonymous slot recording those) and
//!   `collect-wait N MS` (answers `n=.. in_order=.. p50_us=.. p95_us=.. max_us=..`),
//!   `event NAME PERIOD_MS` (an event triggering every PERIOD_MS with a std_msgs/msg/Int64 payload: the
//!   emission time in ns), `echo-i64 NAME` (a response whose start takes an Int64 and returns it),
//!   `connect-via MANAGER SOURCE TARGET` (a whenever made through a manager node's service, owned by this
//!   process; answers `id N`), `connect-remote MANAGER SOURCE TARGET` (the same through `RemoteManager`, which
//!   says this program is alive to the manager), `connect-send MANAGER SOURCE TARGET TIMEOUT_S` (sends that request and
//!   answers at once, without waiting for the reply), `once SOURCE RESPONSE` (an embedded `once SOURCE start RESPONSE` for an Int64
//!   SOURCE; answers `before_ns T`, the time just before arming),
//!   `wait-peers NAME SLOT_PUBLISHERS SIGNAL_SUBSCRIBERS` (until response NAME's slots and signals are
//!   matched both ways with that many peers each, see `ResponseHandle::wait_for_peers`),
//!   `publisher TOPIC` (an Empty
//!   signal publisher), `emit TOPIC` (publish once on it, after a subscriber matched), `emit-now TOPIC`
//!   (publish once at once, without waiting), `matched TOPIC` (until that publisher has matched a subscriber: DDS
//!   does not deliver a volatile sample written before its writer knew the reader, whatever the reader knew),
//!   `emit-exit TOPIC`
//!   (publish, then exit at once), `quit` (leave the graph cleanly and exit). Killed from outside for crashes.
//! - `radar_test_peer check-env`: creates a participant from the environment (ROS_DOMAIN_ID, ...) and prints
//!   `ok`, or prints the error and exits with status 2.

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Int32},
    Radar,
};

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
            // until SIGTERM/SIGINT: radar_ros then leaves the graph (the goodbye) and ends the process
            let _sub = sub;
            std::future::pending::<()>().await;
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
            std::future::pending::<()>().await;
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
            let _client = client;
            std::future::pending::<()>().await;
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
) -> radar_ros::topics::SignalSubscription<M> {
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
    let mut responses: HashMap<String, radar_ros::ResponseHandle> = HashMap::new();
    let mut managers = Vec::new();
    let mut guards = Vec::new();
    let mut events = Vec::new();
    let mut clients = Vec::new();
    let mut remotes = Vec::new();
    let mut i64_publishers: HashMap<
        String,
        radar_ros::topics::SignalPublisher<radar_ros::msg::Int64>,
    > = HashMap::new();
    let collected: std::sync::Arc<std::sync::Mutex<Vec<(i64, i64)>>> = Default::default();
    let mut publishers: HashMap<String, radar_ros::topics::SignalPublisher<Empty>> = HashMap::new();
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
            ["response", name, ms] | ["response-alt", name, ms, _] => {
                // `response NAME MS`: every run takes MS ms; `response-alt NAME ODD EVEN`: the 1st, 3rd, ...
                // runs take ODD ms, the 2nd, 4th, ... EVEN ms
                let odd: u64 = ms.parse().expect("MS");
                let even: u64 = match words.as_slice() {
                    [_, _, _, even] => even.parse().expect("MS"),
                    _ => odd,
                };
                let runs = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
                let r = radar.spawn_response(
                    name,
                    radar_ros::FnResponse::new(move |_: Empty| {
                        let k = runs.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
                        let ms = if k % 2 == 1 { odd } else { even };
                        async move {
                            tokio::time::sleep(Duration::from_millis(ms)).await;
                            Ok(Empty::default())
                        }
                    }),
                );
                match r {
                    Ok(h) => {
                        responses.insert(name.to_string(), h);
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
                        responses.insert(name.to_string(), h);
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
            ["whenever", source, response] => {
                let t0 = std::time::Instant::now();
                let armed = async {
                    let r = radar
                        .response(response)
                        .timeout(Duration::from_secs(30))
                        .await?;
                    let found = t0.elapsed();
                    let g = radar
                        .whenever(radar_ros::Signal::new(*source, "std_msgs/msg/Empty"))
                        .start(&r)
                        .timeout(Duration::from_secs(30))
                        .await?;
                    Ok::<_, radar_ros::Error>((found, g))
                };
                match armed.await {
                    Ok((found, g)) => {
                        guards.push(g);
                        say(&format!("found_ms {}", found.as_millis()));
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["wait-state", name, exits, ms] => {
                let (exits, ms): (u64, u64) = (exits.parse().unwrap(), ms.parse().unwrap());
                let waited = async {
                    let s = radar.state_subscription::<radar_ros::msg::ResponseState>(&format!(
                        "/{name}/state"
                    ))?;
                    loop {
                        if s.recv().await?.exits >= exits {
                            return Ok::<_, radar_ros::Error>(());
                        }
                    }
                };
                match tokio::time::timeout(Duration::from_millis(ms), waited).await {
                    Ok(Ok(())) => say("ok"),
                    Ok(Err(e)) => say(&format!("err {e}")),
                    Err(_) => say(&format!(
                        "err {name} did not reach {exits} exits in {ms} ms"
                    )),
                }
            }
            ["publisher-i64", topic] => {
                match radar.signal_publisher::<radar_ros::msg::Int64>(topic) {
                    Ok(p) => {
                        i64_publishers.insert(topic.to_string(), p);
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["emit-seq", topic, n, period_us] => {
                let (n, period): (u64, u64) = (n.parse().unwrap(), period_us.parse().unwrap());
                let Some(p) = i64_publishers.get(*topic) else {
                    say(&format!("err no publisher on {topic}"));
                    continue;
                };
                let sent = async {
                    p.wait_for_subscribers(1)
                        .timeout(Duration::from_secs(30))
                        .await?;
                    for _ in 0..n {
                        p.publish(radar_ros::msg::Int64 { data: now_ns() })?;
                        tokio::time::sleep(Duration::from_micros(period)).await;
                    }
                    Ok::<_, radar_ros::Error>(())
                };
                match sent.await {
                    Ok(()) => say("ok"),
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["collect-arm", topic] => {
                let rec = collected.clone();
                let armed = radar
                    .whenever(radar_ros::Signal::new(*topic, "std_msgs/msg/Int64"))
                    .call(move |m: radar_ros::msg::Int64| {
                        rec.lock().unwrap().push((m.data, now_ns()));
                    })
                    .timeout(Duration::from_secs(30))
                    .await;
                match armed {
                    Ok(g) => {
                        guards.push(g);
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["collect-wait", n, ms] => {
                let (n, ms): (usize, u64) = (n.parse().unwrap(), ms.parse().unwrap());
                let deadline = tokio::time::Instant::now() + Duration::from_millis(ms);
                while collected.lock().unwrap().len() < n && tokio::time::Instant::now() < deadline
                {
                    tokio::time::sleep(Duration::from_millis(5)).await;
                }
                let got = collected.lock().unwrap().clone();
                let in_order = got.windows(2).all(|w| w[0].0 < w[1].0);
                let mut lat: Vec<i64> = got.iter().map(|(s, r)| (r - s) / 1000).collect();
                lat.sort();
                let q = |f: f64| {
                    lat.get(((lat.len() as f64 - 1.0) * f).round() as usize)
                        .copied()
                        .unwrap_or(-1)
                };
                say(&format!(
                    "n={} in_order={} p50_us={} p95_us={} max_us={}",
                    got.len(),
                    in_order,
                    q(0.5),
                    q(0.95),
                    lat.last().copied().unwrap_or(-1)
                ));
                say("ok")
            }
            ["event", name, period_ms] => {
                let period = Duration::from_millis(period_ms.parse().unwrap());
                match radar.spawn_event(name, Stamped { period }) {
                    Ok(e) => {
                        events.push(e);
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["connect-via", manager, source, target] => {
                let client = radar_test_util::ManagerClient::new(
                    &radar,
                    manager,
                    &format!("peer_{}_{}", std::process::id(), clients.len()),
                )
                .await;
                let req = radar_ros::msg::ConnectRequest {
                    kind: radar_ros::msg::Connection::WHENEVER,
                    source: source.to_string(),
                    target: target.to_string(),
                    ..Default::default()
                };
                let resp =
                    radar_test_util::call_once(&client.connect, req, Duration::from_secs(20)).await;
                clients.push(client);
                if resp.ok {
                    say(&format!("id {}", resp.id));
                    say("ok")
                } else {
                    say(&format!("err {}", resp.error))
                }
            }
            ["connect-remote", manager, source, target] => {
                // the same through RemoteManager, which also says this program is alive to the manager
                let r = async {
                    let m = radar
                        .remote_manager(manager)
                        .timeout(Duration::from_secs(20))
                        .await?;
                    let id = m
                        .connect(radar_ros::manager::RemoteStatement::whenever(source).to(target))
                        .timeout(Duration::from_secs(20))
                        .await?;
                    remotes.push(m);
                    Ok::<u64, radar_ros::Error>(id)
                };
                match r.await {
                    Ok(id) => {
                        say(&format!("id {id}"));
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["connect-send", manager, source, target, timeout] => {
                // sends a connect request and answers at once, without waiting for the reply
                let client = radar_test_util::ManagerClient::new(
                    &radar,
                    manager,
                    &format!("peer_{}_{}", std::process::id(), clients.len()),
                )
                .await;
                let req = radar_ros::msg::ConnectRequest {
                    kind: radar_ros::msg::Connection::WHENEVER,
                    source: source.to_string(),
                    target: target.to_string(),
                    timeout: timeout.parse().expect("seconds"),
                    ..Default::default()
                };
                match client.connect.async_send_request(req).await {
                    Ok(_) => say("ok"),
                    Err(e) => say(&format!("err {e:?}")),
                }
                clients.push(client);
            }
            ["once", source, response] => {
                let r = radar
                    .response(response)
                    .timeout(Duration::from_secs(30))
                    .await;
                // a signal emitted before this moment is stale for the statement, whenever it is armed
                let before = now_ns();
                let armed = async {
                    radar
                        .once(radar_ros::Signal::new(*source, "std_msgs/msg/Int64"))
                        .start(&r?)
                        .timeout(Duration::from_secs(30))
                        .await
                };
                match armed.await {
                    Ok(g) => {
                        say(&format!("before_ns {before}"));
                        guards.push(g);
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["echo-i64", name] => {
                let r = radar.spawn_response(
                    name,
                    radar_ros::FnResponse::new(|m: radar_ros::msg::Int64| async move { Ok(m) }),
                );
                match r {
                    Ok(h) => {
                        responses.insert(name.to_string(), h);
                        say("ok")
                    }
                    Err(e) => say(&format!("err {e}")),
                }
            }
            ["wait-peers", name, slot_publishers, signal_subscribers] => {
                let Some(h) = responses.get(*name) else {
                    say(&format!("err no response {name} here"));
                    continue;
                };
                let (p, sub): (usize, usize) = (
                    slot_publishers.parse().unwrap(),
                    signal_subscribers.parse().unwrap(),
                );
                match h
                    .wait_for_peers(p, sub)
                    .timeout(Duration::from_secs(30))
                    .await
                {
                    Ok(()) => say("ok"),
                    Err(e) => say(&format!("err {e}")),
                }
            }
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
            ["matched", topic] => match publishers.get(*topic) {
                Some(p) => match p
                    .wait_for_subscribers(1)
                    .timeout(Duration::from_secs(10))
                    .await
                {
                    Ok(()) => say("ok"),
                    Err(e) => say(&format!("err {e}")),
                },
                None => say(&format!("err no publisher on {topic}")),
            },
            ["emit-now", topic] => match publishers.get(*topic) {
                // publish at once, without waiting for a subscriber (the caller knows it has matched)
                Some(p) => match p.publish(Empty::default()) {
                    Ok(()) => say("ok"),
                    Err(e) => say(&format!("err {e}")),
                },
                None => say(&format!("err no publisher on {topic}")),
            },
            ["quit"] => break,
            _ => say(&format!("err unknown command {line:?}")),
        }
    }
    // leaving cleanly: endpoints and participant dropped, so DDS peers hear the goodbye
    drop(guards);
    drop(clients);
    drop(events);
    drop(i64_publishers);
    drop(publishers);
    drop(managers);
    drop(responses);
    drop(radar);
    tokio::time::sleep(Duration::from_millis(100)).await;
}

fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// An event that triggers every `period` while active, carrying its emission time (ns since the epoch).
struct Stamped {
    period: Duration,
}

impl radar_ros::Event for Stamped {
    type Payload = radar_ros::msg::Int64;
    async fn check(&mut self) -> Result<radar_ros::msg::Int64, radar_ros::SlotError> {
        tokio::time::sleep(self.period).await;
        Ok(radar_ros::msg::Int64 { data: now_ns() })
    }
}
