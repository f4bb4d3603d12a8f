//! Issue 37, failure semantics over Zenoh as over DDS (`tests/failure.rs`): a target killed (SIGKILL) and
//! started again at once, as `ros2 launch` with `respawn=True` does, over Zenoh through a router.
//!
//! Another program on Zenoh (this binary again, `ZS_ROLE=remote`) runs a response `/zs/arm` that prints
//! `RUN` on its stdout each time it starts. This program holds `whenever go start /zs/arm`, once plain and once
//! re-arming. Checked: both deliver to the first process; it is SIGKILLed and a new one started at once; the plain
//! connection is lost (it delivers nothing more: its target is gone, `departed` says so and why) within 10 s,
//! seen *replaced* (the new process's tokens name the same component; as over DDS, not at the lease),
//! and the re-arming one arms again and delivers to the new process. Times are printed. No settling
//! sleeps: each wait is on a connection's link, a departure or the target's own output.
//!
//! Domain 147. Needs the venv (RADAR_VENV, for the router) and the tests' own network namespace
//! (tests/isolated.sh); run by `cargo test --workspace`, whose build has the feature (tests/Cargo.toml).
#![cfg(feature = "zenoh")]

mod zenoh_util;

use std::time::{Duration, Instant};

use radar_ros::{graph::LossCause, manager::Link, msg::Empty, FnResponse, Radar, Signal};
use tokio::io::{AsyncBufReadExt, BufReader};
use zenoh_util::{local_router, start_role, until_line, RoleLines, WAIT};

const DOMAIN: u16 = 147;
const NAME: &str =
    "a_target_respawned_over_zenoh_is_seen_gone_and_a_rearming_connection_follows_it";

/// The other program, started: its stdout's lines (`ZS_UP` read).
async fn target() -> (tokio::process::Child, RoleLines) {
    start_role(NAME, "ZS_ROLE", "ZS_UP").await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_target_respawned_over_zenoh_is_seen_gone_and_a_rearming_connection_follows_it() {
    // the one test of this binary: its environment is its own
    std::env::set_var("ROS_DOMAIN_ID", DOMAIN.to_string());
    std::env::set_var("RMW_IMPLEMENTATION", "rmw_zenoh_cpp");
    if std::env::var("ZS_ROLE").as_deref() == Ok("remote") {
        return remote_program().await;
    }
    // this program's own lines on stderr (RUST_LOG, default warnings), to read a failure by
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let _router = local_router().await;
    let (mut first, mut first_out) = target().await;
    let radar = Radar::builder()
        .program("zs_program")
        .handle_signals(false)
        .build()
        .unwrap();
    let go = radar.signal_publisher::<Empty>("/zs/go").unwrap();
    let arm = radar.response("/zs/arm").timeout(WAIT).await.unwrap();
    let go_signal = || Signal::new("/zs/go", "std_msgs/msg/Empty");
    let plain = radar
        .whenever(go_signal())
        .start(&arm)
        .timeout(WAIT)
        .await
        .unwrap();
    let rearming = radar
        .whenever(go_signal())
        .start(&arm)
        .rearm()
        .timeout(WAIT)
        .await
        .unwrap();
    go.publish(Empty::default()).unwrap();
    until_line(&mut first_out, "RUN").await;
    assert_eq!(
        (plain.link(), rearming.link()),
        (Some(Link::Armed), Some(Link::Armed))
    );

    // killed, and started again at once
    first.kill().await.unwrap();
    let killed = Instant::now();
    let (mut second, mut second_out) = target().await;
    println!(
        "zenoh_respawn: respawned {:?} after the kill",
        killed.elapsed()
    );
    let d = plain
        .departed()
        .timeout(Duration::from_secs(10))
        .await
        .expect("the killed target seen gone within 10 s")
        .expect("a whenever lives until dropped");
    println!(
        "zenoh_respawn: the plain connection lost {:?} after the kill: {d}",
        killed.elapsed()
    );
    assert_eq!(d.component(), "/zs/arm", "{d}");
    assert!(
        matches!(d.cause(), LossCause::Replaced),
        "seen replaced by the new process (its tokens), not at the lease: {d}"
    );
    assert_eq!(plain.link(), Some(Link::TargetLost));
    let t = Instant::now();
    while rearming.link() != Some(Link::Armed) {
        assert!(
            t.elapsed() < WAIT,
            "the re-arming connection arms again: {:?}",
            rearming.link()
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    println!(
        "zenoh_respawn: the re-arming connection armed again {:?} after the kill",
        killed.elapsed()
    );
    // what comes from now on reaches the new process, through the re-arming connection only
    let plain_before = plain.delivered();
    go.publish(Empty::default()).unwrap();
    until_line(&mut second_out, "RUN").await;
    assert_eq!(
        plain.delivered(),
        plain_before,
        "the lost connection delivers nothing more"
    );
    drop(second.stdin.take());
    let _ = tokio::time::timeout(Duration::from_secs(10), second.wait()).await;
}

/// The target: the response `/zs/arm`, saying `RUN` on stdout at each start, until its stdin closes.
async fn remote_program() {
    let radar = Radar::builder()
        .program("zs_remote")
        .handle_signals(false)
        .build()
        .unwrap();
    assert!(radar.over_zenoh());
    let _arm = radar
        .spawn_response(
            "/zs/arm",
            FnResponse::new(|_: Empty| async move {
                println!("RUN");
                Ok(Empty::default())
            }),
        )
        .unwrap();
    println!("ZS_UP");
    let mut lines = BufReader::new(tokio::io::stdin()).lines();
    while let Ok(Some(_)) = lines.next_line().await {}
}
