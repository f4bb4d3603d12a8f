//! `radar view` (issue 35): the page in a real browser during Listing 1 (Debian's chromium driven by Playwright
//! for Python, `tests/python/view_browser.py`), and the WebSocket as a client that is not a browser sees it: a
//! snapshot, then every change in order, at most `--rate` messages a second however fast the system moves.
//! The same data for Foxglove and Lichtblick (`--foxglove`, the Foxglove SDK's server), read by a client that
//! speaks the SDK's WebSocket protocol (`foxglove.sdk.v1`) as the protocol's documents lay it out. Domains
//! 122-125.

use std::{collections::BTreeMap, process::Stdio, time::Duration};

use futures::{SinkExt, StreamExt};
use radar_ros::{
    msg::{Empty, ResponseState, StringMsg},
    settings::DiscoveryRange,
    FnResponse, Radar, TimerEvent,
};
use radar_ros_examples::test_support::{examples_dir, require_isolation};
use serde_json::{json, Value};
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio_tungstenite::tungstenite::{self, client::IntoClientRequest};

/// A `radar view` process in a domain, with the URL it said, stopped with SIGTERM by [`View::stop`].
struct View {
    child: tokio::process::Child,
    url: String,
    /// Its first line, as JSON (`url`, `domain`, `foxglove`).
    said: Value,
}

impl View {
    async fn start(domain: u16, args: &[&str]) -> View {
        let mut child = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"))
            .args(["view", "--port", "0", "--json"])
            .args(args)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env_remove("RUST_LOG")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .unwrap();
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let first = tokio::time::timeout(Duration::from_secs(20), lines.next_line())
            .await
            .expect("radar view says where it listens")
            .unwrap()
            .expect("a first line");
        let said: Value = serde_json::from_str(&first).unwrap();
        assert_eq!(said["domain"], domain, "{said}");
        let url = said["url"].as_str().unwrap().to_owned();
        assert!(
            url.starts_with("http://127.0.0.1:"),
            "loopback by default: {url}"
        );
        View { child, url, said }
    }

    fn ws(&self) -> String {
        format!("{}ws", self.url.replacen("http://", "ws://", 1))
    }

    /// SIGTERM; it must end at once, cleanly, with no error-level line.
    async fn stop(self) {
        let pid = self.child.id().unwrap() as i32;
        unsafe { libc::kill(pid, libc::SIGTERM) };
        let out = tokio::time::timeout(Duration::from_secs(10), self.child.wait_with_output())
            .await
            .expect("radar view ends on SIGTERM")
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "radar view: {:?} {stderr}",
            out.status
        );
        assert!(!stderr.contains("ERROR"), "{stderr}");
    }
}

type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(url: &str) -> Socket {
    tokio_tungstenite::connect_async(url).await.unwrap().0
}

/// The next JSON message, or `None` if none came within `within`.
async fn next(ws: &mut Socket, within: Duration) -> Option<Value> {
    loop {
        match tokio::time::timeout(within, ws.next()).await.ok()?? {
            Ok(tungstenite::Message::Text(t)) => return Some(serde_json::from_str(&t).unwrap()),
            Ok(tungstenite::Message::Close(c)) => panic!("the view closed the socket: {c:?}"),
            Ok(_) => continue,
            Err(e) => panic!("{e}"),
        }
    }
}

/// What a page makes of the messages: the components' states, the timeline, and checks of the protocol
/// (the snapshot first, then changes numbered one after another; timeline lines numbered without a gap).
#[derive(Default)]
struct Page {
    seq: Option<u64>,
    components: BTreeMap<String, Value>,
    lines: Vec<Value>,
    last_line: u64,
    dropped: u64,
    changes: usize,
    /// The rules the page was told the system broke.
    violations: Vec<Value>,
}

impl Page {
    fn take(&mut self, m: &Value) {
        match m["type"].as_str() {
            Some("snapshot") => {
                assert!(self.seq.is_none(), "a second snapshot: {m}");
                self.seq = m["seq"].as_u64();
                for c in m["components"].as_array().unwrap() {
                    self.components
                        .insert(c["name"].as_str().unwrap().into(), c["state"].clone());
                }
                self.dropped = m["dropped"].as_u64().unwrap();
                self.lines_in(&m["timeline"]);
                self.violations = m["violations"].as_array().unwrap().clone();
            }
            Some("changes") => {
                let seq = self.seq.expect("changes before the snapshot");
                assert_eq!(
                    m["seq"].as_u64(),
                    Some(seq + 1),
                    "changes out of order: {m}"
                );
                self.seq = Some(seq + 1);
                self.changes += 1;
                for c in m["components"].as_array().unwrap() {
                    self.components
                        .insert(c["name"].as_str().unwrap().into(), c["state"].clone());
                }
                for g in m["gone"].as_array().unwrap() {
                    self.components.remove(g.as_str().unwrap());
                }
                self.dropped += m["dropped"].as_u64().unwrap();
                self.lines_in(&m["timeline"]);
                self.violations
                    .extend(m["violations"].as_array().unwrap().iter().cloned());
            }
            _ => panic!("not a snapshot or changes: {m}"),
        }
    }

    /// Takes the lines not seen yet; those of one message come numbered one after another.
    fn lines_in(&mut self, lines: &Value) {
        for l in lines.as_array().unwrap() {
            let n = l["n"].as_u64().unwrap();
            if n > self.last_line {
                self.last_line = n;
                self.lines.push(l.clone());
            }
        }
    }

    fn of(&self, component: &str, signal: &str) -> usize {
        self.lines
            .iter()
            .filter(|l| l["component"] == component && l["signal"] == signal)
            .count()
    }
}

fn radar(domain: u16, program: &str) -> Radar {
    Radar::builder()
        .domain_id(domain)
        .discovery_range(DiscoveryRange::Subnet)
        .program(program)
        .build()
        .unwrap()
}

/// Reads messages into `page` until `done` holds of it; fails after `within`.
async fn until(ws: &mut Socket, page: &mut Page, within: Duration, done: impl Fn(&Page) -> bool) {
    let end = tokio::time::Instant::now() + within;
    while !done(page) {
        let left = end.saturating_duration_since(tokio::time::Instant::now());
        match next(ws, left).await {
            Some(m) => page.take(&m),
            None => panic!(
                "not within {within:?}: components {:?}, {} lines",
                page.components, page.last_line
            ),
        }
    }
}

/// The page in Debian's chromium during Listing 1: the components appear, the `once ... until` connection is
/// drawn, start_event's trigger is on the timeline, count_up's box changes without a reload, `radar act
/// interrupt` shows within 2 s, the page's own interrupt button reaches an rclpy subscriber of `interrupted`,
/// the namespace filter hides what is outside it, and nothing is asked of any host but 127.0.0.1. Screenshots in
/// target/view-screenshots (`RADAR_VIEW_SCREENSHOT=FILE` copies the Listing 1 one there: the README's picture).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_shows_listing_1_live_in_a_browser_and_acts_from_it() {
    require_isolation();
    let domain = 122;
    let view = View::start(domain, &["--allow-act"]).await;
    let out = radar_test_util::repo().join("target/view-screenshots");
    let py = tokio::process::Command::new(radar_test_util::python())
        .arg(radar_test_util::repo().join("tests/python/view_browser.py"))
        .args(["--url", &view.url, "--out", out.to_str().unwrap()])
        .arg("--count-up")
        .arg(examples_dir("count_up").join("count_up"))
        .args(["--radar", env!("CARGO_BIN_EXE_radar")])
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .env("PYTHONUNBUFFERED", "1")
        .kill_on_drop(true)
        .output();
    let py = tokio::time::timeout(Duration::from_secs(150), py)
        .await
        .expect("view_browser.py ends")
        .unwrap();
    let stdout = String::from_utf8_lossy(&py.stdout);
    println!("{stdout}");
    assert!(
        py.status.success() && stdout.contains("{\"ok\": true}"),
        "view_browser.py failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&py.stderr)
    );
    if let Some(to) = std::env::var_os("RADAR_VIEW_SCREENSHOT") {
        std::fs::copy(out.join("listing1.png"), to).unwrap();
    }
    view.stop().await;
}

/// Two pages, one joining midway, against a response started five times: each gets a snapshot first, then
/// changes numbered one after another; both end with the state the response itself published (read here from
/// its state topic, not from the view) and with every `started` and `exited` once. A page from another site is
/// refused, and acting is refused without --allow-act.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pages_get_a_snapshot_then_every_change_in_order() {
    require_isolation();
    let domain = 123;
    let r = radar(domain, "view_ws");
    let job = r
        .spawn_response(
            "/ws/job",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_millis(150)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    let view = View::start(domain, &["--rate", "20"]).await;
    let mut a = connect(&view.ws()).await;
    let first = next(&mut a, Duration::from_secs(5)).await.unwrap();
    assert_eq!(first["type"], "snapshot", "{first}");
    assert_eq!(first["allow_act"], false);
    let mut page_a = Page::default();
    page_a.take(&first);
    until(&mut a, &mut page_a, Duration::from_secs(15), |p| {
        p.components
            .get("/ws/job")
            .is_some_and(|s| s["state_label"] == "idle")
    })
    .await;

    let start = r.signal_publisher::<Empty>(&job.topic("start")).unwrap();
    start
        .wait_for_subscribers(1)
        .timeout(Duration::from_secs(5))
        .await
        .unwrap();
    let state = r
        .state_subscription::<ResponseState>(&job.name().topic("state"))
        .unwrap();
    let (mut b, mut page_b) = (None, Page::default());
    let mut truth = None;
    for k in 1..=5u64 {
        start.publish(Empty::default()).unwrap();
        // wait for the run's end on the response's own state topic
        loop {
            let s = state.recv().timeout(Duration::from_secs(5)).await.unwrap();
            let ended = s.exits == k && s.state_label == "idle";
            truth = Some(s);
            if ended {
                break;
            }
        }
        if k == 2 {
            let mut ws = connect(&view.ws()).await;
            let m = next(&mut ws, Duration::from_secs(5)).await.unwrap();
            assert_eq!(
                m["type"], "snapshot",
                "the second page's first message: {m}"
            );
            page_b.take(&m);
            b = Some(ws);
        }
    }
    // nothing more comes after the last run's idle
    assert!(state
        .recv()
        .timeout(Duration::from_millis(300))
        .await
        .is_err());
    let truth = serde_json::to_value(truth.unwrap()).unwrap();
    let mut b = b.unwrap();
    for (ws, page) in [(&mut a, &mut page_a), (&mut b, &mut page_b)] {
        until(ws, page, Duration::from_secs(5), |p| {
            p.components["/ws/job"]["exits"] == 5
        })
        .await;
        assert_eq!(page.components["/ws/job"], truth);
        assert_eq!(page.dropped, 0);
        // five runs that keep RADAR's rules: the view judges them and tells no violation
        assert_eq!(page.violations, Vec::<Value>::new());
    }
    assert_eq!(page_a.of("/ws/job", "started"), 5, "{:?}", page_a.lines);
    assert_eq!(page_a.of("/ws/job", "exited"), 5, "{:?}", page_a.lines);
    assert!(page_a.changes >= 5, "{} changes", page_a.changes);
    // the page that joined late has the runs since it joined (and those before, from its snapshot)
    assert_eq!(page_b.of("/ws/job", "exited"), 5, "{:?}", page_b.lines);

    // acting is off without --allow-act
    a.send(tungstenite::Message::Text(
        json!({ "op": "act", "slot": "start", "component": "/ws/job" })
            .to_string()
            .into(),
    ))
    .await
    .unwrap();
    loop {
        let m = next(&mut a, Duration::from_secs(5))
            .await
            .expect("an answer");
        if m["type"] == "error" {
            assert!(
                m["message"].as_str().unwrap().contains("--allow-act"),
                "{m}"
            );
            break;
        }
        assert_ne!(m["type"], "acted");
    }
    // a page of another site may not open the socket
    let mut req = view.ws().into_client_request().unwrap();
    req.headers_mut()
        .insert("Origin", "http://example.com".parse().unwrap());
    match tokio_tungstenite::connect_async(req).await {
        Err(tungstenite::Error::Http(resp)) => assert_eq!(resp.status(), 403),
        other => panic!("a foreign origin was let in: {:?}", other.map(|_| ())),
    }
    view.stop().await;
}

/// A flood of 1,500 signals in about a second, with `--rate 1`: a page gets at most one changes message a
/// second, each with at most 200 timeline lines, and every signal is either sent or counted as dropped. At one
/// message a second the page can take 200 lines a second, so the flood overflows it unless publishing it takes
/// over 7.5 s (CI once took over 1.9 s, which `--rate 4` did not survive).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flood_is_held_to_the_rate_and_nothing_is_lost_uncounted() {
    require_isolation();
    let domain = 124;
    let r = radar(domain, "view_flood");
    let flood = r
        .spawn_response(
            "/flood",
            FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
        )
        .unwrap();
    let view = View::start(domain, &["--rate", "1"]).await;
    let mut ws = connect(&view.ws()).await;
    let mut page = Page::default();
    page.take(&next(&mut ws, Duration::from_secs(5)).await.unwrap());
    until(&mut ws, &mut page, Duration::from_secs(15), |p| {
        p.components.contains_key("/flood")
    })
    .await;
    // the view's reader of /flood/started, and this test's own (the oracle of what went over the wire)
    let topic = flood.topic("started");
    let publisher = r.signal_publisher::<Empty>(&topic).unwrap();
    publisher
        .wait_for_subscribers(1)
        .timeout(Duration::from_secs(5))
        .await
        .unwrap();
    let n = 1500;
    let (lines_before, dropped_before) = (page.of("/flood", "started"), page.dropped);
    let reading = tokio::spawn(async move {
        let mut arrivals = Vec::new();
        let mut page = page;
        // until every signal is accounted for (sent or dropped), then 2.5 s more to see nothing comes twice
        let mut end = tokio::time::Instant::now() + Duration::from_secs(40);
        let mut all_accounted = false;
        while let Some(m) = next(
            &mut ws,
            end.saturating_duration_since(tokio::time::Instant::now()),
        )
        .await
        {
            arrivals.push(tokio::time::Instant::now());
            page.take(&m);
            let accounted = page.of("/flood", "started") - lines_before
                + (page.dropped - dropped_before) as usize;
            if accounted >= n && !all_accounted {
                all_accounted = true;
                end = tokio::time::Instant::now() + Duration::from_millis(2500);
            }
        }
        (page, arrivals, ws)
    });
    // paced so the readers keep up (keep-last 10 on both sides) and the flood spans a few ticks
    let flood_start = std::time::Instant::now();
    for k in 0..n {
        publisher.publish(Empty::default()).unwrap();
        if k % 2 == 1 {
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
    }
    let flood_took = flood_start.elapsed();
    let (page, arrivals, _ws) = reading.await.unwrap();
    let sent = page.of("/flood", "started") - lines_before;
    let dropped = page.dropped - dropped_before;
    assert_eq!(
        sent as u64 + dropped,
        n as u64,
        "{sent} signals sent to the page and {dropped} counted as dropped, of {n}"
    );
    assert!(
        dropped > 0,
        "the flood was over the bound: {sent} sent, flood took {flood_took:?}"
    );
    // at most 1 a second: in any second, no more than 1 message (2 with one on each edge)
    let span = arrivals.last().unwrap().duration_since(arrivals[0]);
    assert!(
        arrivals.len() >= 2 && sent <= 200 * arrivals.len(),
        "{sent} lines in {} messages, flood took {flood_took:?}",
        arrivals.len()
    );
    eprintln!(
        "{sent} sent, {dropped} dropped, {} messages in {span:?}, flood took {flood_took:?}",
        arrivals.len()
    );
    for (i, t) in arrivals.iter().enumerate() {
        let within = arrivals[i..]
            .iter()
            .take_while(|u| u.duration_since(*t) < Duration::from_secs(1))
            .count();
        assert!(
            within <= 2,
            "{within} messages within a second ({} in {span:?})",
            arrivals.len()
        );
    }
    view.stop().await;
}

/// `--foxglove 0`: a client of the Foxglove SDK's protocol sees a JSON channel per state and per signal (schemas
/// named after their ROS types), receives a response's `started` payload and state as message data, and the
/// connection graph shows the program's manager subscribing the event's `triggered` and publishing into the
/// response's `start` (the `whenever` made here).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn foxglove_clients_get_states_signals_and_the_connection_graph() {
    require_isolation();
    let domain = 125;
    let r = radar(domain, "view_foxglove");
    let tick = r
        .spawn_event("/fx/tick", TimerEvent::new(Duration::from_millis(300)))
        .unwrap();
    let job = r
        .spawn_response(
            "/fx/job",
            FnResponse::new(|s: StringMsg| async move { Ok(s) }),
        )
        .unwrap();
    let _whenever = r
        .whenever(&tick)
        .start(&job)
        .map(|_: Empty| StringMsg::from("go"))
        .await
        .unwrap();
    let view = View::start(domain, &["--foxglove", "0"]).await;
    let said = &view.said;
    let url = said["foxglove"]
        .as_str()
        .unwrap_or_else(|| panic!("no foxglove URL: {said}"));
    assert!(url.starts_with("ws://127.0.0.1:"), "{url}");
    let mut req = url.into_client_request().unwrap();
    req.headers_mut()
        .insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
    let (mut ws, resp) = tokio_tungstenite::connect_async(req).await.unwrap();
    assert_eq!(resp.headers()["sec-websocket-protocol"], "foxglove.sdk.v1");
    ws.send(tungstenite::Message::Text(
        json!({ "op": "subscribeConnectionGraph" })
            .to_string()
            .into(),
    ))
    .await
    .unwrap();

    let mut channels: BTreeMap<String, Value> = BTreeMap::new();
    let mut subscribed = false;
    let (mut started, mut state, mut graph) = (None, None, None::<Value>);
    let end = tokio::time::Instant::now() + Duration::from_secs(30);
    while started.is_none() || state.is_none() || graph.is_none() {
        let m = tokio::time::timeout_at(end, ws.next())
            .await
            .unwrap_or_else(|_| {
                panic!("not all seen: channels {channels:?}, started {started:?}, state {state:?}, graph {graph:?}")
            })
            .unwrap()
            .unwrap();
        match m {
            tungstenite::Message::Text(t) => {
                let v: Value = serde_json::from_str(&t).unwrap();
                match v["op"].as_str() {
                    Some("serverInfo") => {
                        let caps = v["capabilities"].as_array().unwrap();
                        assert!(caps.contains(&json!("connectionGraph")), "{v}");
                    }
                    Some("advertise") => {
                        for c in v["channels"].as_array().unwrap() {
                            channels.insert(c["topic"].as_str().unwrap().into(), c.clone());
                        }
                    }
                    Some("connectionGraphUpdate") => {
                        let published = &v["publishedTopics"];
                        let ok = published.as_array().is_some_and(|ts| {
                            ts.iter().any(|t| {
                                t["name"] == "/fx/job/start"
                                    && t["publisherIds"].as_array().is_some_and(|ids| {
                                        ids.iter()
                                            .any(|i| i.as_str().unwrap().contains("view_foxglove"))
                                    })
                            })
                        });
                        if ok {
                            graph = Some(v);
                        }
                    }
                    _ => {}
                }
            }
            tungstenite::Message::Binary(b) => {
                // opcode 1 (message data), subscription id, log time, the JSON payload
                assert_eq!(b[0], 1);
                let id = u32::from_le_bytes(b[1..5].try_into().unwrap());
                let body: Value = serde_json::from_slice(&b[13..]).unwrap();
                match id {
                    1 => started = Some(body),
                    2 => state = Some(body),
                    _ => panic!("subscription {id}"),
                }
            }
            _ => {}
        }
        if !subscribed
            && channels.contains_key("/fx/job/started")
            && channels.contains_key("/fx/job/state")
        {
            let subs = json!({ "op": "subscribe", "subscriptions": [
                { "id": 1, "channelId": channels["/fx/job/started"]["id"] },
                { "id": 2, "channelId": channels["/fx/job/state"]["id"] },
            ]});
            ws.send(tungstenite::Message::Text(subs.to_string().into()))
                .await
                .unwrap();
            subscribed = true;
        }
    }
    let st = &channels["/fx/job/state"];
    assert_eq!(st["encoding"], "json");
    assert_eq!(st["schemaName"], "radar_msgs/msg/ResponseState");
    assert_eq!(st["schemaEncoding"], "jsonschema");
    let schema: Value = serde_json::from_str(st["schema"].as_str().unwrap()).unwrap();
    assert_eq!(
        schema["properties"]["starts"]["type"], "integer",
        "{schema}"
    );
    assert_eq!(
        channels["/fx/job/started"]["schemaName"],
        "std_msgs/msg/String"
    );
    assert_eq!(
        channels["/fx/tick/state"]["schemaName"],
        "radar_msgs/msg/EventState"
    );
    assert_eq!(started.unwrap(), json!({ "data": "go" }));
    assert_eq!(state.unwrap()["name"], "/fx/job");
    let graph = graph.unwrap();
    let subscribers = graph["subscribedTopics"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["name"] == "/fx/tick/triggered")
        .unwrap_or_else(|| panic!("{graph}"));
    assert!(
        subscribers["subscriberIds"]
            .to_string()
            .contains("view_foxglove"),
        "{graph}"
    );
    view.stop().await;
}
