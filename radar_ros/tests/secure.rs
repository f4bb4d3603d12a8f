//! Issue 25: two radar_ros programs secured with enclaves of one keystore (made by
//! `radar_ros::security::keystore`, sros2's layout) talk over DDS Security; a plain participant neither sees
//! nor starts their components; a tampered permissions document, a certificate from another CA and a missing
//! file stop a program at start, naming what is wrong. Runs only with the `security` feature
//! (`tests/security_feature.rs` runs it), over real DDS inside tests/isolated.sh. Domain 109.
#![cfg(feature = "security")]

use std::{path::PathBuf, time::Duration};

use radar_ros::{
    msg::Empty,
    security::{keystore, SecurityOptions},
    DiscoveryRange, FnResponse, Radar,
};

const DOMAIN: u16 = 109;
const WAIT: Duration = Duration::from_secs(15);

/// What the process logged at warn level or above (RustDDS's `log` records too), since [`logged`] was last
/// called. The tests run one at a time (`--test-threads=1`, as tests/security_feature.rs runs them).
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
    let ks = keystore("pair");
    logged();
    let robot = radar(Some(SecurityOptions::enforce(&ks, "/robot"))).unwrap();
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let s = starts.clone();
    let _dock = robot
        .spawn_response(
            "secure_dock",
            FnResponse::new(move |_: Empty| {
                s.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
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
    let ks = keystore("own");
    logged();
    let robot = radar(Some(SecurityOptions::enforce(&ks, "/robot"))).unwrap();
    let starts = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let s = starts.clone();
    let _counter = robot
        .spawn_response(
            "secure_counter",
            FnResponse::new(move |_: Empty| {
                s.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                async { Ok(Empty::default()) }
            }),
        )
        .unwrap();
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

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bad_enclave_stops_the_program_at_start_naming_what_is_wrong() {
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
