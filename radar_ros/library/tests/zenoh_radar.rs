//! Issue 37, step 3's second half: a `Radar` on Zenoh. Under `RMW_IMPLEMENTATION=rmw_zenoh_cpp` (in a build
//! with the `zenoh` feature) `Radar::builder().build()` opens a Zenoh session configured as rmw_zenoh's, and its
//! components, its connections in this process and its plain endpoints run over it, as over DDS.
//!
//! The oracle is the peer written from rmw_zenoh's design document (tests/python/zenoh_peer.py: the
//! eclipse-zenoh wheel, rclpy's CDR, rosidl's hashes; nothing from radar_ros or ros2-client), through a router
//! in rmw_zenoh's default layout. Listing 2's shape across it: the peer publishes poses on `/zr/bump`; an event
//! of this program (`/zr/bumper`, a `TopicEvent`) triggers on those with `x > 1`; `whenever bumper start dock`;
//! the response `/zr/dock` runs and its `started` reaches the peer, carrying the pose that triggered it, and its
//! `exited` reaches this program's own subscription. The peer sees the program's nodes and endpoints in the
//! liveliness tokens, as an rmw_zenoh peer's graph shows them.
//!
//! Then across processes: another program on Zenoh (this binary again, `ZR_ROLE=remote`) runs a response
//! `/zr/far` and serves a manager node `/zr/manager`. This program finds `/zr/far` on the graph the tokens make
//! (ros2-client patch 17, `graph/tokens.rs`) and its nodes with the names they use (`Introspect::nodes`), and
//! `whenever bumper start far` made here delivers there; through
//! the other program's manager (its services over Zenoh queryables) `connect` makes the same connection there,
//! `list` shows it, the peer's next bump starts far through it, `disconnect` removes it. The other program
//! SIGKILLed, `/zr/far` leaves this program's graph (the time is printed), and a connection it owned in this
//! program's manager (`/zr/home`) is dropped once the lease has passed; before, a client written from the
//! design document (tests/python/zenoh_service_client.py) calls `/zr/home/list` under the hash rosidl gives
//! `radar_msgs/srv/List` and its reply lists that connection (with the placeholder hash: no server, mutation
//! run). The connection is dropped (a Zenoh caller's GID told back to its
//! process by the graph; without that, never: mutation run). No settling sleeps: each wait is on
//! a match count, a sample or the graph. With the transport refused (RMW_IMPLEMENTATION unset) the test fails
//! at its first check; with the tokens' graph empty, at the lookup of `/zr/far`; with no type hash given to
//! Zenoh, at the first wait for the peer.
//!
//! The program's log lines reach `/rosout` over Zenoh (its tracing subscriber has `radar_ros::rosout::layer()`):
//! the line dock's start slot logs is heard by a second design-document peer on `/rosout`
//! (`rcl_interfaces/msg/Log`, rosidl's hash), with the node's rcl logger name and level.
//!
//! Domain 140. Needs the venv (RADAR_VENV) and the tests' own network namespace (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::sync::{
    atomic::{AtomicUsize, Ordering},
    Arc,
};

use radar_ros::{
    manager::RemoteStatement,
    msg::{Empty, PoseStamped, RosMessage},
    FnResponse, Radar, TopicEvent,
};
use serde_json::Value;
use zenoh_util::{local_router, start_peer_on, WAIT};

const DOMAIN: u16 = 140;

/// This test's name: the other program is this binary run again with `ZR_ROLE=remote`, this test only.
const NAME: &str = "listing_2_runs_over_zenoh_with_a_design_document_peer_as_the_bumper";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn listing_2_runs_over_zenoh_with_a_design_document_peer_as_the_bumper() {
    // the one test of this binary: its environment is its own
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN.to_string());
    std::env::set_var("RMW_IMPLEMENTATION", "rmw_zenoh_cpp");
    if std::env::var("ZR_ROLE").as_deref() == Ok("remote") {
        return remote_program().await;
    }
    // this binary's logs on stderr and on /rosout, as a program that adds radar_ros's layer has them
    {
        use tracing_subscriber::prelude::*;
        tracing_subscriber::registry()
            .with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr))
            .with(radar_ros::rosout::layer())
            .with(tracing_subscriber::filter::LevelFilter::INFO)
            .init();
    }
    let _router = local_router().await;
    // a design-document peer on /rosout (rcl_interfaces/msg/Log with rosidl's hash), as `ros2 topic echo
    // /rosout` over rmw_zenoh would listen
    let mut rosout = zenoh_util::Proc::start(
        "zenoh_peer.py",
        &[
            "tcp/localhost:7447",
            &DOMAIN.to_string(),
            "rcl_interfaces/msg/Log",
            "/rosout",
            "/zr/no_logs_from_the_peer",
        ],
    );
    rosout.until_up().await;
    // in an enclave, as `--ros-args --enclave` puts a ROS 2 program in one: its tokens name it
    let radar = Radar::builder()
        .program("zr_program")
        .handle_signals(false)
        .ros_args(
            radar_ros::ros_args::RosArgs::parse(["zr", "--ros-args", "--enclave", "/zr/main"])
                .unwrap(),
        )
        .build()
        .unwrap();
    assert!(
        radar.over_zenoh() && radar.dds_context().is_none(),
        "RMW_IMPLEMENTATION=rmw_zenoh_cpp chose Zenoh"
    );

    // E1 over Zenoh as over DDS: an event checks while something listens, and stops as soon as its last
    // listener lets go (the listener's session stays: not a lease later, as when a process vanishes)
    let tick = radar
        .spawn_event(
            "/zr/tick",
            radar_ros::TimerEvent::new(std::time::Duration::from_millis(50)),
        )
        .unwrap();
    let listened = radar
        .whenever(&tick)
        .call(|_: Empty| {})
        .timeout(WAIT)
        .await
        .unwrap();
    let t = std::time::Instant::now();
    while !tick.state().active {
        assert!(t.elapsed() < WAIT, "the event checks once listened");
        tokio::time::sleep(std::time::Duration::from_millis(5)).await;
    }
    drop(listened);
    let let_go = std::time::Instant::now();
    while tick.state().active {
        assert!(let_go.elapsed() < WAIT, "the event stops checking");
        tokio::time::sleep(std::time::Duration::from_millis(5)).await;
    }
    println!(
        "zenoh_radar: the event stopped checking {:?} after its last listener let go",
        let_go.elapsed()
    );
    assert!(
        let_go.elapsed() < std::time::Duration::from_secs(1),
        "an event kept checking {:?} after its last listener let go (the lease is 3 s)",
        let_go.elapsed()
    );

    // a type this program has no Rust type or table entry for (radar_demo_msgs, generated for the venv as a
    // user's package is): a statement between a peer's topics relays it, under the hash the peer's tokens
    // announce (the relay registered none: never matched over Zenoh, armed over DDS)
    let demo_type = "radar_demo_msgs/msg/Dock3D";
    let mut demo = zenoh_util::Proc::start(
        "zenoh_peer.py",
        &[
            "tcp/localhost:7447",
            &DOMAIN.to_string(),
            demo_type,
            "/zr/demo_dock/start",
            "/zr/demo_lvl/triggered",
        ],
    );
    demo.until_up().await;
    let relay = radar
        .whenever(radar_ros::Signal::new("/zr/demo_lvl/triggered", demo_type))
        .start(&radar_ros::ResponseRef::new(
            radar_ros::graph::ComponentName::resolve("/zr/demo_dock", "/").unwrap(),
            demo_type,
            demo_type,
        ))
        .timeout(WAIT)
        .await
        .expect("armed over Zenoh with a type only the peers know");
    // sent again until heard: the peer's publisher may learn of the relay's interest after its token was
    // counted (over Zenoh nothing says when it has)
    let t = std::time::Instant::now();
    let relayed = 'heard: loop {
        assert!(t.elapsed() < WAIT, "the peer never heard the relayed start");
        demo.send(r#"{"name": "dock7", "position": {"x": 1.5}}"#)
            .await;
        while let Some(line) = demo
            .line_within(std::time::Duration::from_millis(200))
            .await
        {
            let v: Value = serde_json::from_str(&line).unwrap();
            if v.get("received").is_some() {
                break 'heard v["received"].clone();
            }
        }
    };
    assert_eq!(
        (relayed["name"].as_str(), relayed["position"]["x"].as_f64()),
        (Some("dock7"), Some(1.5)),
        "{relayed}"
    );
    drop(relay);
    demo.close();

    let bumper = radar
        .spawn_event(
            "/zr/bumper",
            TopicEvent::new("/zr/bump", |p: &PoseStamped| {
                (p.pose.position.x > 1.0).then(|| p.clone())
            }),
        )
        .unwrap();
    let runs = Arc::new(AtomicUsize::new(0));
    let counted = runs.clone();
    let dock = radar
        .spawn_response(
            "/zr/dock",
            FnResponse::new(move |_: PoseStamped| {
                let counted = counted.clone();
                async move {
                    tracing::info!("dock runs marker-zr");
                    counted.fetch_add(1, Ordering::SeqCst);
                    Ok(Empty::default())
                }
            }),
        )
        .unwrap();
    let exited = radar
        .signal_subscription::<Empty>("/zr/dock/exited")
        .unwrap();
    let bumps = radar
        .signal_subscription::<PoseStamped>("/zr/bump")
        .unwrap();
    let _c = radar.whenever(&bumper).start(&dock).await.unwrap();

    // the peer hears `started` and publishes the bumps
    let (mut peer, _, _, mut lines) = start_peer_on(
        None,
        "tcp/localhost:7447",
        DOMAIN,
        ("peer", "volatile"),
        ("/zr/dock/started", "/zr/bump"),
        &[],
    )
    .await;
    bumps.wait_for_publishers(1).timeout(WAIT).await.unwrap();
    exited.wait_for_publishers(1).timeout(WAIT).await.unwrap();
    peer.send(r#"{"header": {"frame_id": "soft"}, "pose": {"position": {"x": 0.5}}}"#)
        .await;
    peer.send(r#"{"header": {"frame_id": "hard"}, "pose": {"position": {"x": 2.5}}}"#)
        .await;
    let started = loop {
        let v: Value = serde_json::from_str(&peer.line().await).unwrap();
        if v.get("received").is_some() {
            break v;
        }
        lines.push(v);
    };
    assert_eq!(
        (
            started["received"]["header"]["frame_id"].as_str(),
            started["received"]["pose"]["position"]["x"].as_f64()
        ),
        (Some("hard"), Some(2.5)),
        "the first `started` the peer hears carries the pose that triggered the event (the soft one did not): \
         {started}"
    );
    exited.recv().timeout(WAIT).await.unwrap();
    assert_eq!(runs.load(Ordering::SeqCst), 1, "dock ran once");
    // the line dock's start slot logged reaches the peer on /rosout, named after dock's node as rcl names it
    let logged = loop {
        let v: Value = serde_json::from_str(&rosout.line().await).unwrap();
        if v["received"]["msg"]
            .as_str()
            .is_some_and(|m| m.contains("marker-zr"))
        {
            break v;
        }
    };
    assert_eq!(
        (
            logged["received"]["name"].as_str(),
            logged["received"]["level"].as_u64()
        ),
        (Some("zr.dock"), Some(20)),
        "{logged}"
    );
    rosout.close();

    // the program's graph, as an rmw_zenoh peer reads it from the liveliness tokens
    let hash = PoseStamped::TYPE_HASH.unwrap();
    let tokens: Vec<String> = lines
        .iter()
        .filter(|v| v["put"].as_bool() == Some(true))
        .filter_map(|v| v["token"].as_str().map(str::to_owned))
        .collect();
    let has = |kind: &str, tail: &str| {
        tokens
            .iter()
            .any(|t| t.contains(&format!("/{kind}/")) && t.contains(tail))
    };
    assert!(
        has("NN", "/NN/%zr%main/%zr/dock")
            && has("NN", "/NN/%zr%main/%zr/bumper")
            && has("NN", "/NN/%zr%main/%/zr_program"),
        "nodes dock, bumper and the program node are on the graph: {tokens:#?}"
    );
    assert!(
        has("MP", &format!("/%zr%dock%started/geometry_msgs::msg::dds_::PoseStamped_/{hash}/"))
            && has("MS", &format!("/%zr%dock%start/geometry_msgs::msg::dds_::PoseStamped_/{hash}/"))
            && has("MS", &format!("/%zr%bump/geometry_msgs::msg::dds_::PoseStamped_/{hash}/")),
        "dock's `started` publisher and `start` subscription, and the bumper's subscription, with rosidl's \
         hash: {tokens:#?}"
    );

    // another program over Zenoh: a response `/zr/far` and a manager node `/zr/manager`
    let (mut remote, mut out) = zenoh_util::start_role(NAME, "ZR_ROLE", "ZR_UP").await;
    // found through the graph the tokens make
    let far = radar.response("/zr/far").timeout(WAIT).await.unwrap();
    let nodes = radar.introspect().nodes().timeout(WAIT).await.unwrap();
    let node = |fq: &str| {
        nodes
            .iter()
            .find(|n| n.fully_qualified() == fq)
            .unwrap_or_else(|| panic!("node {fq} on the graph: {nodes:#?}"))
    };
    assert!(
        node("/zr/far").publishes.contains("/zr/far/started")
            && node("/zr/far").subscribes.contains("/zr/far/start")
            && node("/zr/manager").serves.contains("/zr/manager/connect"),
        "the other program's nodes with what they use, as `ros2 node info` shows them: {nodes:#?}"
    );
    assert_eq!(
        (
            node("/zr/far").enclave.as_str(),
            node("/zr/manager").enclave.as_str()
        ),
        ("/zr/side", "/zr/side"),
        "the enclave the other program's tokens name"
    );
    let far_started = radar
        .signal_subscription::<PoseStamped>("/zr/far/started")
        .unwrap();
    far_started
        .wait_for_publishers(1)
        .timeout(WAIT)
        .await
        .unwrap();
    let bump = |frame: &str, x: f64| {
        format!(r#"{{"header": {{"frame_id": "{frame}"}}, "pose": {{"position": {{"x": {x}}}}}}}"#)
    };
    {
        // this program's manager relays to a slot of the other program
        let _far = radar.whenever(&bumper).start(&far).await.unwrap();
        peer.send(&bump("to far", 3.5)).await;
        let p = far_started.recv().timeout(WAIT).await.unwrap();
        assert_eq!(p.header.frame_id, "to far", "far started with the bump");
    }
    // the other program's manager, through its services over Zenoh (queryables)
    let m = radar
        .remote_manager("/zr/manager")
        .timeout(WAIT)
        .await
        .unwrap();
    let id = m
        .connect(RemoteStatement::whenever("/zr/bumper/triggered").to("/zr/far/start"))
        .timeout(WAIT)
        .await
        .unwrap();
    let listed = m.list().timeout(WAIT).await.unwrap();
    assert!(
        listed
            .iter()
            .any(|c| c.id == id && c.target == "/zr/far/start"),
        "the remote manager lists the connection it made: {listed:?}"
    );
    peer.send(&bump("through the remote manager", 4.5)).await;
    let p = far_started.recv().timeout(WAIT).await.unwrap();
    assert_eq!(p.header.frame_id, "through the remote manager");
    m.disconnect(id).timeout(WAIT).await.unwrap();
    assert!(
        m.list()
            .timeout(WAIT)
            .await
            .unwrap()
            .iter()
            .all(|c| c.id != id),
        "gone once disconnected"
    );

    // the other program killed: its components leave this program's graph
    // the other program owns a connection in this program's manager: when it dies, the connection goes
    let _home = radar.serve_manager("/zr/home").unwrap();
    let stdin = remote.stdin.as_mut().unwrap();
    tokio::io::AsyncWriteExt::write_all(stdin, b"connect\n")
        .await
        .unwrap();
    let owned: u64 = loop {
        let line = tokio::time::timeout(WAIT, out.next_line())
            .await
            .expect("the remote program connects")
            .unwrap()
            .expect("the remote program ended before it connected");
        if let Some(id) = line.split("ZR_CONNECTED ").nth(1) {
            break id.trim().parse().unwrap();
        }
    };
    let home = radar
        .remote_manager("/zr/home")
        .timeout(WAIT)
        .await
        .unwrap();
    let has_owned = |list: Vec<radar_ros::msg::Connection>| list.iter().any(|c| c.id == owned);
    assert!(
        has_owned(home.list().timeout(WAIT).await.unwrap()),
        "the other program's connection is in this program's manager"
    );
    // a client written from rmw_zenoh's design document calls the manager, naming the service's hash rosidl
    // wrote (radar_msgs/srv/List as a whole; a placeholder hash in the server's key is never reached)
    let mut client = zenoh_util::Proc::start(
        "zenoh_service_client.py",
        &[
            "tcp/127.0.0.1:7447",
            &DOMAIN.to_string(),
            "/zr/home/list",
            "radar_msgs/srv/List",
            "{}",
        ],
    );
    let server: Value = serde_json::from_str(&client.line().await).unwrap();
    assert!(server.get("server").is_some(), "{server}");
    let reply: Value = serde_json::from_str(&client.line().await).unwrap();
    let ids: Vec<u64> = reply["reply"]["connections"]
        .as_array()
        .unwrap_or_else(|| panic!("a List reply: {reply}"))
        .iter()
        .map(|c| c["id"].as_u64().unwrap())
        .collect();
    assert!(
        ids.contains(&owned),
        "the design-document client's reply lists the connection: {reply}"
    );
    assert_eq!(
        reply["seq"], 1,
        "the reply names the request's sequence number: {reply}"
    );
    let done: Value = serde_json::from_str(&client.line().await).unwrap();
    assert_eq!(done["replies"], 1, "one server answered: {done}");
    let listed = |radar: &Radar| {
        radar
            .components()
            .iter()
            .any(|c| c.name().fully_qualified() == "/zr/far")
    };
    assert!(listed(&radar), "far is on the graph while its process runs");
    remote.kill().await.unwrap();
    let killed = std::time::Instant::now();
    while listed(&radar) {
        assert!(
            killed.elapsed() < WAIT,
            "far left the graph with its process"
        );
        tokio::time::sleep(std::time::Duration::from_millis(5)).await;
    }
    println!(
        "zenoh_radar: far gone from the graph {:?} after SIGKILL",
        killed.elapsed()
    );
    while has_owned(home.list().timeout(WAIT).await.unwrap()) {
        assert!(
            killed.elapsed() < WAIT,
            "the killed owner's connection is dropped by the manager"
        );
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
    println!(
        "zenoh_radar: the killed owner's connection dropped {:?} after SIGKILL",
        killed.elapsed()
    );
    peer.close();
}

/// The other program: a response `/zr/far` (whose start type is the peer's pose) and a manager node
/// `/zr/manager`, over Zenoh, until its stdin closes or it is killed.
async fn remote_program() {
    let radar = Radar::builder()
        .program("zr_remote")
        .handle_signals(false)
        .ros_args(
            radar_ros::ros_args::RosArgs::parse(["zr", "--ros-args", "--enclave", "/zr/side"])
                .unwrap(),
        )
        .build()
        .unwrap();
    assert!(radar.over_zenoh());
    let _far = radar
        .spawn_response(
            "/zr/far",
            FnResponse::new(|_: PoseStamped| async move { Ok(Empty::default()) }),
        )
        .unwrap();
    let _manager = radar.serve_manager("/zr/manager").unwrap();
    println!("ZR_UP");
    let mut lines =
        tokio::io::AsyncBufReadExt::lines(tokio::io::BufReader::new(tokio::io::stdin()));
    let mut owned = Vec::new();
    while let Ok(Some(line)) = lines.next_line().await {
        if line == "connect" {
            // a connection this program owns in the other's manager (not detached)
            let home = radar
                .remote_manager("/zr/home")
                .timeout(WAIT)
                .await
                .unwrap();
            let id = home
                .connect(RemoteStatement::whenever("/zr/bumper/triggered").to("/zr/dock/start"))
                .timeout(WAIT)
                .await
                .unwrap();
            println!("ZR_CONNECTED {id}");
            owned.push(home);
        }
    }
}
