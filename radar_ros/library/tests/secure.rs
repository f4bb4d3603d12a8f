//! Issue 25: radar_ros programs secured with enclaves of one keystore (made by `radar_ros::security::keystore`,
//! sros2's layout) talk over DDS Security: two programs signal each other, and one hears its own signals on
//! every subscription; a plain participant neither sees nor starts their components; only a permitted
//! publisher starts a secured response (not a secured one without the grant, not a plain rclpy one); a secured
//! Fast DDS 2.9 peer interoperates (and one of another CA is kept out); payloads are not readable on the wire; a tampered permissions document, a certificate from another CA and a missing
//! file stop a program at start, naming what is wrong. Runs only with the `security` feature
//! (`cargo test --workspace` runs it: its build has the feature, tests/Cargo.toml), over real DDS inside tests/isolated.sh (root in its namespace, the
//! rclpy venv as RADAR_VENV, g++ and libfastrtps-dev). Domain 109.
#![cfg(feature = "security")]

use std::{path::PathBuf, time::Duration};

use radar_ros::{
    msg::Empty,
    security::{keystore, policy, SecurityOptions},
    settings::DiscoveryRange,
    FnResponse, Radar,
};

const DOMAIN: u16 = 109;
const WAIT: Duration = Duration::from_secs(15);

/// The tests share one domain and the captured log: each holds this while it runs, so one runs at a time.
static ONE_AT_A_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// What the process logged at warn level or above (RustDDS's `log` records too), since [`logged`] was last
/// called. The tests run one at a time ([`ONE_AT_A_TIME`]).
static LOG: std::sync::Mutex<Vec<u8>> = std::sync::Mutex::new(Vec::new());

struct Sink;
impl std::io::Write for Sink {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        LOG.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn logged() -> String {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::new("warn"))
        .with_ansi(false)
        .with_writer(|| Sink)
        .try_init();
    String::from_utf8(std::mem::take(&mut *LOG.lock().unwrap())).unwrap()
}

fn keystore(name: &str) -> PathBuf {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1"),
        "DDS tests run inside tests/isolated.sh"
    );
    let ks = std::env::temp_dir().join(format!("radar_secure_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&ks);
    keystore::create_keystore(&ks).unwrap();
    for e in ["/robot", "/planner"] {
        keystore::create_enclave(&ks, e, &keystore::Grant::all()).unwrap();
    }
    ks
}

fn radar(security: Option<SecurityOptions>) -> radar_ros::Result<Radar> {
    Radar::builder()
        .domain_id(DOMAIN)
        .discovery_range(DiscoveryRange::Subnet)
        .security(security)
        .build()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn secured_programs_signal_each_other_and_a_plain_one_is_kept_out() {
    let _one = ONE_AT_A_TIME.lock().await;
    let ks = keystore("pair");
    logged();
    let named = |program: &str| {
        Radar::builder()
            .domain_id(DOMAIN)
            .discovery_range(DiscoveryRange::Subnet)
            .program(program)
            .security(Some(SecurityOptions::enforce(&ks, &format!("/{program}"))))
            .build()
            .unwrap()
    };
    let robot = named("robot");
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let _dock = counting_response(&robot, "secure_dock", &starts);
    let planner = radar(Some(SecurityOptions::enforce(&ks, "/planner"))).unwrap();
    let dock = planner
        .response("/secure_dock")
        .timeout(WAIT)
        .await
        .unwrap();
    let mut exited = planner
        .waiter::<Empty>(dock.exited())
        .timeout(WAIT)
        .await
        .unwrap();
    let t0 = std::time::Instant::now();
    planner
        .inject(dock.start_slot(), Empty::default())
        .timeout(WAIT)
        .await
        .unwrap();
    exited.recv().timeout(WAIT).await.unwrap();
    println!("secured: first start -> exited in {:?}", t0.elapsed());
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), 1);
    // what a program that runs normally logs: nothing at error level (matching before the keys are exchanged
    // is the usual order, RustDDS patch 26)
    let log = logged();
    let errors: Vec<&str> = log.lines().filter(|l| l.contains("ERROR")).collect();
    assert!(
        errors.is_empty(),
        "error lines while secured programs talk:\n{}",
        errors.join("\n")
    );
    // warm: the next start, on endpoints whose keys are exchanged
    let mut exited = planner
        .waiter::<Empty>(dock.exited())
        .timeout(WAIT)
        .await
        .unwrap();
    let t1 = std::time::Instant::now();
    planner
        .inject(dock.start_slot(), Empty::default())
        .timeout(WAIT)
        .await
        .unwrap();
    exited.recv().timeout(WAIT).await.unwrap();
    println!("secured: second start -> exited in {:?}", t1.elapsed());
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), 2);

    // a plain participant: it does not see the secured components, and what it publishes is not acted on
    let plain = radar(None).unwrap();
    let lookup = plain
        .response("/secure_dock")
        .timeout(Duration::from_secs(3))
        .await;
    assert!(
        matches!(lookup, Err(radar_ros::Error::NotFound { .. })),
        "{lookup:?}"
    );
    let p = plain
        .signal_publisher::<Empty>("/secure_dock/start")
        .unwrap();
    for _ in 0..10 {
        p.publish(Empty::default()).unwrap();
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    assert_eq!(
        starts.load(std::sync::atomic::Ordering::SeqCst),
        2,
        "a plain publisher's start is not acted on"
    );
    std::fs::remove_dir_all(&ks).unwrap();
}

/// One secured program whose endpoints match each other (Listing 1 in one process: the response and what
/// listens to it on one participant), with two subscriptions of one topic: every subscription gets the
/// signals, and nothing is logged at error level. Before RustDDS patch 27 a participant's own matches got
/// their keys the wrong way round (nothing arrived) and a second subscription of a topic got none
/// ("already associated with ... key materials").
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_secured_program_hears_its_own_signals_on_every_subscription() {
    let _one = ONE_AT_A_TIME.lock().await;
    let ks = keystore("own");
    logged();
    let robot = radar(Some(SecurityOptions::enforce(&ks, "/robot"))).unwrap();
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let _counter = counting_response(&robot, "secure_counter", &starts);
    let counter = robot
        .response("/secure_counter")
        .timeout(WAIT)
        .await
        .unwrap();
    let mut started_a = robot
        .waiter::<Empty>(counter.started())
        .timeout(WAIT)
        .await
        .unwrap();
    let mut started_b = robot
        .waiter::<Empty>(counter.started())
        .timeout(WAIT)
        .await
        .unwrap();
    let mut exited = robot
        .waiter::<Empty>(counter.exited())
        .timeout(WAIT)
        .await
        .unwrap();
    let t0 = std::time::Instant::now();
    robot
        .inject(counter.start_slot(), Empty::default())
        .timeout(WAIT)
        .await
        .unwrap();
    started_a
        .recv()
        .timeout(WAIT)
        .await
        .expect("first subscription of started");
    started_b
        .recv()
        .timeout(WAIT)
        .await
        .expect("second subscription of started");
    exited.recv().timeout(WAIT).await.expect("exited");
    println!(
        "secured, one program: start -> exited in {:?}",
        t0.elapsed()
    );
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), 1);
    let log = logged();
    let errors: Vec<&str> = log.lines().filter(|l| l.contains("ERROR")).collect();
    assert!(
        errors.is_empty(),
        "error lines in one secured program:\n{}",
        errors.join("\n")
    );
    std::fs::remove_dir_all(&ks).unwrap();
}

/// Who may start a secured response: a secured program whose permissions grant the `start` topic (the
/// planner, `Grant::all`) is acted on; a secured program of the same keystore whose permissions (from a policy
/// file that denies it `start` and allows it everything else) do not grant it cannot publish there (a clear
/// error naming the topic), while it may publish the `interrupt`; a plain rclpy publisher (real ROS 2, Fast DDS) is
/// not acted on, while the same publisher starts a plain response beside it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn only_a_permitted_publisher_starts_a_secured_response() {
    let _one = ONE_AT_A_TIME.lock().await;
    let ks = keystore("perm");
    // an enclave whose policy (sros2's format, as `radar security create_permission` reads it) lets it do
    // everything but start the gate: it may interrupt it
    keystore::create_enclave(&ks, "/intruder", &keystore::Grant::all()).unwrap();
    let policy = ks.join("intruder_policy.xml");
    std::fs::write(
        &policy,
        r#"<policy version="0.2.0">
  <enclaves>
    <enclave path="/intruder">
      <profiles>
        <profile ns="/" node="intruder">
          <topics publish="DENY"><topic>/secure_gate/start</topic></topics>
          <topics publish="ALLOW" subscribe="ALLOW"><topic>*</topic></topics>
          <services request="ALLOW" reply="ALLOW"><service>*</service></services>
        </profile>
      </profiles>
    </enclave>
  </enclaves>
</policy>"#,
    )
    .unwrap();
    policy::create_permission(&ks, "/intruder", &policy).unwrap();
    let robot = radar(Some(SecurityOptions::enforce(&ks, "/robot"))).unwrap();
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let _gate = counting_response(&robot, "secure_gate", &starts);
    let count = || starts.load(std::sync::atomic::Ordering::SeqCst);

    // the secured program without the grant: it can find the response (it may subscribe to everything),
    // but not publish to its start
    let intruder = radar(Some(SecurityOptions::enforce(&ks, "/intruder"))).unwrap();
    let gate = intruder
        .response("/secure_gate")
        .timeout(WAIT)
        .await
        .unwrap();
    logged();
    let refused = intruder.signal_publisher::<Empty>("/secure_gate/start");
    let e = refused
        .err()
        .expect("no publisher for a topic the permissions do not grant")
        .to_string();
    println!("unpermitted: {e}");
    assert!(
        e.contains("/secure_gate/start") && e.contains("does not grant it"),
        "{e}"
    );
    let refused = intruder.inject(gate.start_slot(), Empty::default()).await;
    assert!(refused.is_err(), "inject without the grant: {refused:?}");
    // the refusal is the caller's error to report (RustDDS patch 30), not an error line of its own
    let log = logged();
    assert!(
        !log.contains("ERROR"),
        "a refused endpoint logs no error by itself: {log}"
    );
    // what the policy allows it does: the interrupt topic is granted
    intruder
        .signal_publisher::<Empty>("/secure_gate/interrupt")
        .expect("the policy grants publishing the interrupt");

    // a plain rclpy publisher, and the same publisher to a plain response beside it (it works there)
    let plain = radar(None).unwrap();
    let plain_starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let _plain_gate = counting_response(&plain, "plain_gate", &plain_starts);
    let venv = std::env::var_os("RADAR_VENV").expect(
        "RADAR_VENV names the rclpy venv (tests/isolated.sh builds it with tests/python_env.sh)",
    );
    let py = PathBuf::from(venv).join("bin/python");
    assert!(
        py.exists(),
        "{} is missing: run tests/python_env.sh",
        py.display()
    );
    let rclpy = tokio::process::Command::new(py)
        .args(["-c", RCLPY_PUBLISHER])
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .env_remove("ROS_SECURITY_ENABLE")
        .kill_on_drop(true)
        .output();
    let out = tokio::time::timeout(Duration::from_secs(60), rclpy)
        .await
        .expect("the rclpy publisher ends within 60 s")
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "rclpy publisher: {stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    println!("rclpy: {stdout}");
    assert!(
        stdout.contains("secure_gate subscribers seen: 0"),
        "a plain rclpy node does not even see the secured subscriber: {stdout}"
    );
    let t = std::time::Instant::now();
    while plain_starts.load(std::sync::atomic::Ordering::SeqCst) == 0 && t.elapsed() < WAIT {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(
        plain_starts.load(std::sync::atomic::Ordering::SeqCst) > 0,
        "the rclpy publisher starts a plain response"
    );
    assert_eq!(
        count(),
        0,
        "neither the unpermitted nor the plain publisher started the secured response"
    );

    // the permitted one is acted on
    let planner = radar(Some(SecurityOptions::enforce(&ks, "/planner"))).unwrap();
    let gate = planner
        .response("/secure_gate")
        .timeout(WAIT)
        .await
        .unwrap();
    let mut exited = planner
        .waiter::<Empty>(gate.exited())
        .timeout(WAIT)
        .await
        .unwrap();
    planner
        .inject(gate.start_slot(), Empty::default())
        .timeout(WAIT)
        .await
        .unwrap();
    exited.recv().timeout(WAIT).await.unwrap();
    assert_eq!(count(), 1, "the permitted planner starts it");
    std::fs::remove_dir_all(&ks).unwrap();
}

/// A program named `name` (its program node's name too) in `enclave` (`--ros-args --enclave`), secured or not.
fn enclaved_program(name: &str, enclave: &str, security: Option<SecurityOptions>) -> Radar {
    Radar::builder()
        .domain_id(DOMAIN)
        .discovery_range(DiscoveryRange::Subnet)
        .program(name)
        .ros_args(
            radar_ros::ros_args::RosArgs::parse([name, "--ros-args", "--enclave", enclave])
                .unwrap(),
        )
        .security(security)
        .build()
        .unwrap()
}

/// A response `name` of `radar` that counts its starts in `starts`.
fn counting_response(
    radar: &Radar,
    name: &str,
    starts: &std::sync::Arc<std::sync::atomic::AtomicUsize>,
) -> radar_ros::ResponseHandle {
    let s = starts.clone();
    radar
        .spawn_response(
            name,
            FnResponse::new(move |_: Empty| {
                s.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap()
}

/// Permissions generated from what programs declare (`Radar::policy`, what `RADAR_GENERATE_POLICY=FILE`
/// writes when a program ends): a recording run, plain, of a robot program serving a response and a planner
/// driving it (each with its `--enclave`); each policy made into its enclave's permissions
/// (`create_permission`); then, secured, the planner starts the response and hears it exit, while the robot's
/// own program, whose policy only reads the response's slots, cannot write its `start`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn permissions_generated_from_what_programs_declare_let_only_the_driver_start() {
    let _one = ONE_AT_A_TIME.lock().await;
    let ks = keystore("generated");
    let program = |name: &str, security: Option<SecurityOptions>| {
        enclaved_program(name, &format!("/{name}"), security)
    };
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let dock = |radar: &Radar| counting_response(radar, "gen_dock", &starts);
    let drive = |planner: Radar| async move {
        let d = planner.response("/gen_dock").timeout(WAIT).await.unwrap();
        let mut exited = planner
            .waiter::<Empty>(d.exited())
            .timeout(WAIT)
            .await
            .unwrap();
        planner
            .inject(d.start_slot(), Empty::default())
            .timeout(WAIT)
            .await
            .unwrap();
        exited.recv().timeout(WAIT).await.unwrap();
        planner
    };

    // the recording run, plain
    let (robot_policy, planner_policy) = {
        let robot = program("robot", None);
        let _d = dock(&robot);
        let planner = drive(program("planner", None)).await;
        (robot.policy(), planner.policy())
    };
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), 1);
    println!("robot's policy:\n{robot_policy}\nplanner's policy:\n{planner_policy}");
    let grant = |policy: &str, enclave: &str| {
        let g =
            radar_ros::security::policy::grants_from_xml(policy, std::path::Path::new("generated"))
                .unwrap();
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].0, enclave, "{policy}");
        g[0].1.clone()
    };
    let (r, p) = (
        grant(&robot_policy, "/robot"),
        grant(&planner_policy, "/planner"),
    );
    let start = "rt/gen_dock/start".to_owned();
    assert!(
        r.subscribe.contains(&start) && !r.publish.contains(&start),
        "{r:?}"
    );
    assert!(
        p.publish.contains(&start) && !p.subscribe.contains(&start),
        "{p:?}"
    );
    assert!(
        r.publish.contains(&"rt/gen_dock/exited".to_owned()),
        "{r:?}"
    );
    for (name, policy) in [("robot", &robot_policy), ("planner", &planner_policy)] {
        let file = ks.join(format!("{name}_policy.xml"));
        std::fs::write(&file, policy).unwrap();
        policy::create_permission(&ks, &format!("/{name}"), &file).unwrap();
    }

    // secured, with the generated permissions
    let robot = program("robot", Some(SecurityOptions::enforce(&ks, "/robot")));
    let _d = dock(&robot);
    let e = robot
        .signal_publisher::<Empty>("/gen_dock/start")
        .err()
        .expect("the robot's generated policy does not let it write the dock's start")
        .report()
        .to_string();
    assert!(e.contains("rt/gen_dock/start"), "{e}");
    let _planner = drive(program(
        "planner",
        Some(SecurityOptions::enforce(&ks, "/planner")),
    ))
    .await;
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), 2);
    std::fs::remove_dir_all(&ks).unwrap();
}

/// `radar security generate_policy` as sros2's: a policy of the live graph. A robot program (enclave
/// `/live_robot`) serving a response and a planner (`/live_planner`) holding a writer of its `start` run plain;
/// a third program looks at the graph (`Introspect::nodes`: each node's enclave from its participant's
/// USER_DATA, its endpoints from `ros_discovery_info`) and writes the policy; a rule already in the file (a
/// DENY) is kept. Made into each enclave's permissions, secured: the planner starts the response, the robot
/// may not write its `start`, and the DENY holds.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_policy_generated_from_the_live_graph_lets_only_the_driver_start() {
    let _one = ONE_AT_A_TIME.lock().await;
    let ks = keystore("live");
    let program = |name: &str, security: Option<SecurityOptions>| {
        enclaved_program(name, &format!("/live_{name}"), security)
    };
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let dock = |radar: &Radar| counting_response(radar, "live_dock", &starts);
    for e in ["/live_robot", "/live_planner"] {
        keystore::create_enclave(&ks, e, &keystore::Grant::all()).unwrap();
    }

    // plain: the programs run, a tool looks at the graph
    let file = ks.join("live_policy.xml");
    std::fs::write(
        &file,
        r#"<policy version="0.2.0"><enclaves><enclave path="/live_planner"><profiles>
             <profile ns="/" node="planner"><topics publish="DENY"><topic>/live_dock/exit</topic></topics></profile>
           </profiles></enclave></enclaves></policy>"#,
    )
    .unwrap();
    {
        let robot = program("robot", None);
        let _d = dock(&robot);
        // the planner drives the dock as it will secured, and still holds what it drove it with
        let planner = program("planner", None);
        let d = planner.response("/live_dock").timeout(WAIT).await.unwrap();
        let mut exited = planner
            .waiter::<Empty>(d.exited())
            .timeout(WAIT)
            .await
            .unwrap();
        planner
            .inject(d.start_slot(), Empty::default())
            .timeout(WAIT)
            .await
            .unwrap();
        exited.recv().timeout(WAIT).await.unwrap();
        // the graph shows what is there while the tool looks: the injection's writer lingers 3 s only and the
        // waiter's reader went with its signal, so the planner holds one of each, as a program that drives the
        // dock again would
        let _w = planner
            .signal_publisher::<Empty>("/live_dock/start")
            .unwrap();
        let _again = planner
            .waiter::<Empty>(d.exited())
            .timeout(WAIT)
            .await
            .unwrap();
        let tool = Radar::builder()
            .domain_id(DOMAIN)
            .discovery_range(DiscoveryRange::Subnet)
            .program("tool")
            .build()
            .unwrap();
        let nodes = tool
            .introspect()
            .nodes()
            .timeout(Duration::from_secs(5))
            .await
            .unwrap();
        println!("{nodes:#?}");
        let node = |fq: &str| {
            nodes
                .iter()
                .find(|n| n.fully_qualified() == fq)
                .unwrap_or_else(|| panic!("{fq} in {nodes:#?}"))
        };
        let d = node("/live_dock");
        assert_eq!(d.enclave, "/live_robot");
        assert!(d.subscribes.contains("/live_dock/start"), "{d:?}");
        assert!(d.publishes.contains("/live_dock/exited"), "{d:?}");
        let p = node("/planner");
        assert_eq!(p.enclave, "/live_planner");
        assert!(p.publishes.contains("/live_dock/start"), "{p:?}");
        assert!(p.subscribes.contains("/live_dock/exited"), "{p:?}");
        assert!(
            nodes.iter().all(|n| n.name != "tool"),
            "the tool's own nodes are not listed"
        );
        let existing = std::fs::read_to_string(&file).unwrap();
        let xml = radar_ros::security::policy::generate(Some((&existing, &file)), &nodes).unwrap();
        std::fs::write(&file, xml).unwrap();
    }
    let text = std::fs::read_to_string(&file).unwrap();
    println!("{text}");
    let grants = radar_ros::security::policy::grants_from_file(&file).unwrap();
    let grant = |e: &str| {
        grants
            .iter()
            .find(|(name, _)| name == e)
            .unwrap_or_else(|| panic!("{e} in {text}"))
            .1
            .clone()
    };
    let (r, p) = (grant("/live_robot"), grant("/live_planner"));
    let start = "rt/live_dock/start".to_owned();
    assert!(
        r.subscribe.contains(&start) && !r.publish.contains(&start),
        "{r:?}"
    );
    assert!(p.publish.contains(&start), "{p:?}");
    assert_eq!(
        p.deny_publish,
        ["rt/live_dock/exit"],
        "the file's DENY is kept"
    );
    for e in ["/live_robot", "/live_planner"] {
        policy::create_permission(&ks, e, &file).unwrap();
    }

    // secured, with the permissions of the generated policy
    let robot = program("robot", Some(SecurityOptions::enforce(&ks, "/live_robot")));
    let _d = dock(&robot);
    let e = robot
        .signal_publisher::<Empty>("/live_dock/start")
        .err()
        .expect("the robot's policy does not let it write the dock's start")
        .report()
        .to_string();
    assert!(e.contains("rt/live_dock/start"), "{e}");
    let planner = program(
        "planner",
        Some(SecurityOptions::enforce(&ks, "/live_planner")),
    );
    assert!(
        planner
            .signal_publisher::<Empty>("/live_dock/exit")
            .is_err(),
        "the kept DENY holds"
    );
    let d = planner.response("/live_dock").timeout(WAIT).await.unwrap();
    let mut exited = planner
        .waiter::<Empty>(d.exited())
        .timeout(WAIT)
        .await
        .unwrap();
    planner
        .inject(d.start_slot(), Empty::default())
        .timeout(WAIT)
        .await
        .unwrap();
    exited.recv().timeout(WAIT).await.unwrap();
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), 2);
    std::fs::remove_dir_all(&ks).unwrap();
}

/// `tests/fastdds/secure_peer.cpp` built with g++ against Debian's Fast DDS 2.9 (libfastrtps-dev: built with
/// DDS Security), in this test's target directory.
fn fastdds_peer() -> PathBuf {
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/fastdds/secure_peer.cpp");
    let exe = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fastdds_secure_peer");
    let out = std::process::Command::new("g++")
        .args(["-std=c++17", "-O1"])
        .arg(&src)
        .arg("-o")
        .arg(&exe)
        .args(["-lfastrtps", "-lfastcdr"])
        .output()
        .expect("g++ (apt-get install g++)");
    assert!(
        out.status.success(),
        "building the Fast DDS peer (apt-get install g++ libfastrtps-dev; .ci/run installs them):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

/// Interop with another DDS Security implementation: a secured Fast DDS 2.9 peer (the builtin PKI-DH,
/// Access-Permissions and AES-GCM-GMAC plugins, configured from an enclave of the same keystore as
/// rmw_fastrtps configures them) authenticates with a secured radar_ros program, starts its response over an
/// encrypted topic (Fast DDS writer -> RustDDS reader) and hears its `exited` (RustDDS writer -> Fast DDS
/// reader). A Fast DDS peer with an enclave of another keystore does not start it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_secured_fast_dds_peer_starts_a_secured_response_and_hears_it_exit() {
    let _one = ONE_AT_A_TIME.lock().await;
    let peer = fastdds_peer();
    let ks = keystore("fastdds");
    keystore::create_enclave(&ks, "/fastdds", &keystore::Grant::all()).unwrap();
    logged();
    let robot = radar(Some(SecurityOptions::enforce(&ks, "/robot"))).unwrap();
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let _dock = counting_response(&robot, "fastdds_dock", &starts);
    let run = |enclave: PathBuf, timeout: &str| {
        tokio::process::Command::new(&peer)
            .arg(enclave)
            .arg(DOMAIN.to_string())
            .args(["rt/fastdds_dock/start", "rt/fastdds_dock/exited", timeout])
            .kill_on_drop(true)
            .output()
    };
    let out = tokio::time::timeout(
        Duration::from_secs(60),
        run(ks.join("enclaves/fastdds"), "30"),
    )
    .await
    .expect("the Fast DDS peer ends")
    .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!(
        "fastdds peer: {stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success()
            && stdout.contains("matched start")
            && stdout.contains("exited received"),
        "the secured Fast DDS peer started the response and heard it exit"
    );
    assert!(starts.load(std::sync::atomic::Ordering::SeqCst) >= 1);
    let log = logged();
    let errors: Vec<&str> = log.lines().filter(|l| l.contains("ERROR")).collect();
    println!(
        "radar_ros logged at error level with Fast DDS: {}",
        errors.len()
    );

    // an enclave of another keystore (another CA): never matched, nothing started
    let other = keystore("fastdds_other");
    keystore::create_enclave(&other, "/fastdds", &keystore::Grant::all()).unwrap();
    let before = starts.load(std::sync::atomic::Ordering::SeqCst);
    let out = tokio::time::timeout(
        Duration::from_secs(60),
        run(other.join("enclaves/fastdds"), "4"),
    )
    .await
    .expect("the Fast DDS peer ends")
    .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("fastdds peer of another CA: {stdout}");
    assert!(
        !out.status.success() && stdout.contains("never matched"),
        "{stdout}"
    );
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), before);
    std::fs::remove_dir_all(&ks).unwrap();
    std::fs::remove_dir_all(&other).unwrap();
}

/// docs/security.md's policy ("only the planner may start the dock"), as written there (keep them the same).
const DOCK_POLICY: &str = r#"<policy version="0.2.0">
  <enclaves>
    <enclave path="/robot">
      <profiles>
        <profile ns="/" node="robot">  <!-- the program (Radar::builder().program("robot")) -->
          <topics publish="ALLOW"><topic>~/connections</topic><topic>/diagnostics</topic><topic>/rosout</topic><topic>/parameter_events</topic></topics>
          <services reply="ALLOW"><service>~/*</service></services>
        </profile>
        <profile ns="/" node="dock">   <!-- the response: reads its slots, writes its signals -->
          <topics subscribe="ALLOW"><topic>~/start</topic><topic>~/interrupt</topic><topic>~/exit</topic></topics>
          <topics publish="ALLOW"><topic>~/started</topic><topic>~/interrupted</topic><topic>~/exited</topic><topic>~/dropped</topic><topic>~/state</topic></topics>
          <topics publish="ALLOW"><topic>/rosout</topic><topic>/parameter_events</topic></topics>
          <services reply="ALLOW"><service>~/*</service></services>
        </profile>
      </profiles>
    </enclave>
    <enclave path="/planner">
      <profiles>
        <profile ns="/" node="planner"> <!-- may start and interrupt the dock, and hear it -->
          <topics publish="ALLOW"><topic>/dock/start</topic><topic>/dock/interrupt</topic></topics>
          <topics subscribe="ALLOW"><topic>/dock/*</topic></topics>
          <topics publish="ALLOW"><topic>~/connections</topic><topic>/diagnostics</topic><topic>/rosout</topic><topic>/parameter_events</topic></topics>
          <services reply="ALLOW"><service>~/*</service></services>
        </profile>
      </profiles>
    </enclave>
  </enclaves>
</policy>"#;

/// docs/security.md's policy runs as written: the dock's program (enclave /robot) serves the dock, the
/// planner (enclave /planner) starts it and hears it exit, and the robot's own program cannot start it (it
/// may only read its slots).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_documented_policy_lets_only_the_planner_start_the_dock() {
    let _one = ONE_AT_A_TIME.lock().await;
    only_the_planner_starts_the_dock("policy", DOCK_POLICY).await;
}

/// An enclave whose permissions were written before responses had `~/dropped` and programs published
/// `/diagnostics` (docs/security.md's policy without them) still runs the response and the programs, and the
/// planner still starts it and hears it exit.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_policy_from_before_dropped_still_runs_the_response() {
    let _one = ONE_AT_A_TIME.lock().await;
    let before = DOCK_POLICY
        .replace("<topic>~/dropped</topic>", "")
        .replace("<topic>/diagnostics</topic>", "");
    assert_ne!(before, DOCK_POLICY);
    only_the_planner_starts_the_dock("policy-before-dropped", &before).await;
}

/// Under `policy_xml` (in keystore `name`): the robot serves the dock and may not write its start; the planner
/// starts it and hears it exit.
async fn only_the_planner_starts_the_dock(name: &str, policy_xml: &str) {
    let ks = keystore(name);
    let policy = ks.join("policy.xml");
    std::fs::write(&policy, policy_xml).unwrap();
    for e in ["/robot", "/planner"] {
        policy::create_permission(&ks, e, &policy).unwrap();
    }
    let named = |program: &str| {
        Radar::builder()
            .domain_id(DOMAIN)
            .discovery_range(DiscoveryRange::Subnet)
            .program(program)
            .security(Some(SecurityOptions::enforce(&ks, &format!("/{program}"))))
            .build()
            .unwrap()
    };
    let robot = named("robot");
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let _dock = counting_response(&robot, "dock", &starts);
    let e = robot
        .signal_publisher::<Empty>("/dock/start")
        .err()
        .expect("the robot may not write the dock's start")
        .report()
        .to_string();
    assert!(e.contains("rt/dock/start"), "{e}");
    let planner = named("planner");
    let dock = planner.response("/dock").timeout(WAIT).await.unwrap();
    let mut exited = planner
        .waiter::<Empty>(dock.exited())
        .timeout(WAIT)
        .await
        .unwrap();
    planner
        .inject(dock.start_slot(), Empty::default())
        .timeout(WAIT)
        .await
        .unwrap();
    exited.recv().timeout(WAIT).await.unwrap();
    assert_eq!(starts.load(std::sync::atomic::Ordering::SeqCst), 1);
    std::fs::remove_dir_all(&ks).unwrap();
}

/// Publishes `std_msgs/msg/Empty` to `/secure_gate/start` and `/plain_gate/start` for 3 s from a plain rclpy
/// node, then prints how many subscribers of the secured topic it saw.
const RCLPY_PUBLISHER: &str = r#"
import time
import rclpy
from std_msgs.msg import Empty
rclpy.init()
node = rclpy.create_node("plain_intruder")
pubs = [node.create_publisher(Empty, t, 10) for t in ("/secure_gate/start", "/plain_gate/start")]
end = time.monotonic() + 3.0
while time.monotonic() < end:
    for p in pubs:
        p.publish(Empty())
    rclpy.spin_once(node, timeout_sec=0.05)
print("secure_gate subscribers seen:", node.count_subscribers("/secure_gate/start"), flush=True)
node.destroy_node()
rclpy.shutdown()
"#;

/// Every frame on this network namespace's interfaces (lo and the veth pair of tests/isolated.sh), captured
/// with an AF_PACKET socket (root in the namespace) until `stop` is set.
fn capture(
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> std::thread::JoinHandle<Vec<Vec<u8>>> {
    // SAFETY: plain socket calls on a descriptor this function owns and closes
    unsafe {
        let fd = libc::socket(
            libc::AF_PACKET,
            libc::SOCK_RAW,
            (libc::ETH_P_ALL as u16).to_be() as i32,
        );
        assert!(
            fd >= 0,
            "an AF_PACKET socket (root in tests/isolated.sh's namespace): {}",
            std::io::Error::last_os_error()
        );
        let tv = libc::timeval {
            tv_sec: 0,
            tv_usec: 50_000,
        };
        libc::setsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_RCVTIMEO,
            &tv as *const _ as *const libc::c_void,
            std::mem::size_of::<libc::timeval>() as u32,
        );
        std::thread::spawn(move || {
            let mut frames = Vec::new();
            let mut buf = vec![0u8; 65536];
            while !stop.load(std::sync::atomic::Ordering::SeqCst) {
                let n = libc::recv(fd, buf.as_mut_ptr() as *mut libc::c_void, buf.len(), 0);
                if n > 0 {
                    frames.push(buf[..n as usize].to_vec());
                }
            }
            libc::close(fd);
            frames
        })
    }
}

/// Starts a response named `name` with a `StringMsg` carrying `marker` from a second program, both secured
/// (enclaves of `ks`) or both plain, while capturing the wire; the frames captured and how many held `marker`.
async fn start_with_marker(
    ks: Option<&std::path::Path>,
    name: &str,
    marker: &str,
) -> (usize, usize) {
    use radar_ros::msg::StringMsg;
    let sec = |e: &str| ks.map(|ks| SecurityOptions::enforce(ks, e));
    let robot = radar(sec("/robot")).unwrap();
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let _r = robot
        .spawn_response(
            name,
            FnResponse::new(move |m: StringMsg| {
                let _ = tx.send(m.data);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
    let planner = radar(sec("/planner")).unwrap();
    let r = planner
        .response(&format!("/{name}"))
        .timeout(WAIT)
        .await
        .unwrap();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let cap = capture(stop.clone());
    planner
        .inject(
            r.start_slot(),
            StringMsg {
                data: marker.to_owned(),
            },
        )
        .timeout(WAIT)
        .await
        .unwrap();
    let got = tokio::time::timeout(WAIT, rx.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(got, marker, "the response got the payload");
    tokio::time::sleep(Duration::from_millis(200)).await;
    stop.store(true, std::sync::atomic::Ordering::SeqCst);
    let frames = cap.join().unwrap();
    let with = frames
        .iter()
        .filter(|f| f.windows(marker.len()).any(|w| w == marker.as_bytes()))
        .count();
    (frames.len(), with)
}

/// The wire: a secured program's payload is not readable in any frame on the network (the marker string it
/// sends is in none of the captured frames), while the same exchange between plain programs shows it (the
/// capture sees the traffic).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn secured_payloads_are_not_readable_on_the_wire() {
    let _one = ONE_AT_A_TIME.lock().await;
    let ks = keystore("wire");
    let marker = "radar-wire-marker-5e1f0c";
    let (frames, with) = start_with_marker(Some(&ks), "wire_dock", marker).await;
    println!("secured: {frames} frames captured, {with} hold the payload's text");
    assert!(frames > 0, "frames were captured");
    assert_eq!(
        with, 0,
        "the payload's text is on the wire in {with} frames"
    );
    let (frames, with) = start_with_marker(None, "wire_dock_plain", marker).await;
    println!("plain: {frames} frames captured, {with} hold the payload's text");
    assert!(
        with > 0,
        "plain, the payload is on the wire (the capture works)"
    );
    std::fs::remove_dir_all(&ks).unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bad_enclave_stops_the_program_at_start_naming_what_is_wrong() {
    let _one = ONE_AT_A_TIME.lock().await;
    let ks = keystore("bad");
    // tampered: the permissions widened after signing
    let dir = ks.join("enclaves/robot");
    let perms = std::fs::read_to_string(dir.join("permissions.p7s")).unwrap();
    std::fs::write(
        dir.join("permissions.p7s"),
        perms.replace("<max>232</max>", "<max>233</max>"),
    )
    .unwrap();
    let Err(e) = radar(Some(SecurityOptions::enforce(&ks, "/robot"))) else {
        panic!("a tampered permissions document is refused")
    };
    let e = e.to_string();
    assert!(
        e.contains("enclaves/robot") && e.contains("do not make a secure participant"),
        "{e}"
    );

    // a certificate from another keystore's CA
    let other = keystore("other");
    std::fs::copy(
        other.join("enclaves/planner/cert.pem"),
        ks.join("enclaves/planner/cert.pem"),
    )
    .unwrap();
    std::fs::copy(
        other.join("enclaves/planner/key.pem"),
        ks.join("enclaves/planner/key.pem"),
    )
    .unwrap();
    let Err(e) = radar(Some(SecurityOptions::enforce(&ks, "/planner"))) else {
        panic!("a certificate of another CA is refused")
    };
    let e = e.to_string();
    assert!(e.contains("enclaves/planner"), "{e}");

    // a missing file, under Enforce
    let Err(e) = radar(Some(SecurityOptions::enforce(&ks, "/nobody"))) else {
        panic!("a missing enclave is refused")
    };
    let e = e.to_string();
    assert!(e.contains("identity_ca.cert.pem is missing"), "{e}");
    std::fs::remove_dir_all(&ks).unwrap();
    std::fs::remove_dir_all(&other).unwrap();
}
