//! The processes of the soak (`tests/soak.rs`): a two-robot deliberative system, one role per process. Every
//! process prints what it does and what reaches it on stdout, one line each, so that the soak can count, from
//! outside, what the rules say must arrive against what arrived:
//!
//! - `robot-a` (host A): event `a_tick` (every 200 ms; its payload, a std_msgs/msg/Int64, is its emission time
//!   in ns: `emit a_tick NS`); responses `a_arm` and `a_once` (each run echoes its Int64 start at once:
//!   `start a_arm NS`), `a_long` (a run lasts 30 s: `start a_long NS BEGAN_NS` as it begins, `exit a_long NS REASON` from its exit slot).
//! - `robot-b` (host B): response `b_drive` (echoes its Int64 start: `start b_drive NS`). The soak kills it
//!   (SIGKILL) and starts it again at once.
//! - `bumper` (host B): event `b_bump` (every 300 ms, Int64 emission time: `emit b_bump NS`).
//! - `planner` (host A): the deliberative program. For the life of the process: `whenever a_tick start
//!   b_drive`, `whenever b_bump start a_arm`, `whenever b_bump start a_long until /poke/triggered` (each
//!   `.rearm()`, so a respawned target is armed again). In a loop: `once b_bump start a_once` in a scope that
//!   ends when it fired or after 5 s, then 1 s without (`once BEFORE_NS fired|timeout END_NS`).
//! - `poke` (a fresh process each time): publishes one `/poke/triggered` once a subscriber matched, prints
//!   `poked NS` (the time just before publishing) and exits, as `ros2 topic pub --once` does.
//!
//! Every long-lived role prints `ready` once it runs and then runs until SIGINT or SIGTERM (radar_ros runs the
//! exit slots, leaves the graph and ends the process). Every 5 s it also prints the bytes its allocator has
//! handed out and not had back (`heap ROLE IN_USE ARENA`, glibc's `mallinfo2`), so that the soak can tell memory
//! the program keeps from pages the allocator keeps. Logs go to stderr (`RUST_LOG`).

use std::{io::Write, time::Duration};

use radar_ros::{
    msg::{Empty, Int64},
    Event, ExitAction, ExitReason, FnResponse, Radar, Response, Signal, SlotError,
};

fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// One line on stdout, written at once (the soak reads them as they come; a killed process loses none).
fn say(s: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{s}");
    let _ = out.flush();
}

/// Triggers every `period` with its emission time as payload, and says so.
struct Ticker {
    name: &'static str,
    period: Duration,
}

impl Event for Ticker {
    type Payload = Int64;
    async fn check(&mut self) -> Result<Int64, SlotError> {
        tokio::time::sleep(self.period).await;
        let t = now_ns();
        say(&format!("emit {} {t}", self.name));
        Ok(Int64 { data: t })
    }
}

/// Echoes its start at once, and says so.
fn echo(name: &'static str) -> impl Response<Start = Int64, Output = Int64> {
    FnResponse::new(move |m: Int64| {
        say(&format!("start {name} {}", m.data));
        async move { Ok(m) }
    })
}

/// A long run that only an interrupt (or the end of the program) cuts short.
struct Long;

impl Response for Long {
    type Start = Int64;
    type Output = Empty;
    async fn start(&mut self, m: Int64) -> Result<Empty, SlotError> {
        say(&format!("start a_long {} {}", m.data, now_ns()));
        tokio::time::sleep(Duration::from_secs(30)).await;
        Ok(Empty::default())
    }
    async fn exit(&mut self, why: ExitReason) -> ExitAction {
        say(&format!("exit a_long {} {}", now_ns(), why.describe()));
        ExitAction::Done
    }
}

/// Every 5 s: `heap ROLE IN_USE ARENA`: bytes allocated and not freed (small blocks and mmapped ones), and the
/// bytes the allocator holds from the system for them.
async fn report_heap(role: String) {
    loop {
        // SAFETY: mallinfo2 only reads the allocator's counters
        let m = unsafe { libc::mallinfo2() };
        say(&format!(
            "heap {role} {} {}",
            m.uordblks + m.hblkhd,
            m.arena + m.hblkhd
        ));
        tokio::time::sleep(Duration::from_secs(5)).await;
    }
}

#[tokio::main]
async fn main() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .with_ansi(false)
        .try_init();
    let role = std::env::args().nth(1).unwrap_or_default();
    if let Err(e) = run(&role).await {
        say(&format!("err {e}"));
        std::process::exit(1);
    }
}

async fn run(role: &str) -> radar_ros::Result<()> {
    let radar = Radar::new()?;
    let find = Duration::from_secs(60);
    if role != "poke" {
        tokio::spawn(report_heap(role.to_owned()));
    }
    match role {
        "robot-a" => {
            let _e = radar.spawn_event(
                "a_tick",
                Ticker {
                    name: "a_tick",
                    period: Duration::from_millis(200),
                },
            )?;
            let _arm = radar.spawn_response("a_arm", echo("a_arm"))?;
            let _once = radar.spawn_response("a_once", echo("a_once"))?;
            let _long = radar.spawn_response("a_long", Long)?;
            say("ready");
            std::future::pending::<()>().await;
        }
        "robot-b" => {
            let _drive = radar.spawn_response("b_drive", echo("b_drive"))?;
            say("ready");
            std::future::pending::<()>().await;
        }
        "bumper" => {
            let _e = radar.spawn_event(
                "b_bump",
                Ticker {
                    name: "b_bump",
                    period: Duration::from_millis(300),
                },
            )?;
            say("ready");
            std::future::pending::<()>().await;
        }
        "planner" => {
            let a_tick = radar.event("a_tick").timeout(find).await?;
            let b_bump = radar.event("b_bump").timeout(find).await?;
            let b_drive = radar.response("b_drive").timeout(find).await?;
            let a_arm = radar.response("a_arm").timeout(find).await?;
            let a_long = radar.response("a_long").timeout(find).await?;
            let a_once = radar.response("a_once").timeout(find).await?;
            let _drive = radar
                .whenever(a_tick.triggered())
                .start(&b_drive)
                .rearm()
                .timeout(find)
                .await?;
            let _arm = radar
                .whenever(b_bump.triggered())
                .start(&a_arm)
                .rearm()
                .timeout(find)
                .await?;
            let _long = radar
                .whenever(b_bump.triggered())
                .start(&a_long)
                .until(Signal::new("/poke/triggered", "std_msgs/msg/Empty"))
                .rearm()
                .timeout(find)
                .await?;
            say("ready");
            loop {
                let before = now_ns();
                match radar
                    .once(b_bump.triggered())
                    .start(&a_once)
                    .timeout(Duration::from_secs(5))
                    .await
                {
                    Ok(once) => {
                        let fired = once.closed().timeout(Duration::from_secs(5)).await.is_ok();
                        drop(once);
                        let how = if fired { "fired" } else { "timeout" };
                        say(&format!("once {before} {how} {}", now_ns()));
                    }
                    Err(e) => say(&format!("once {before} unarmed {} {e}", now_ns())),
                }
                tokio::time::sleep(Duration::from_secs(1)).await;
            }
        }
        "poke" => {
            let p = radar.signal_publisher::<Empty>("/poke/triggered")?;
            p.wait_for_subscribers(1)
                .timeout(Duration::from_secs(20))
                .await?;
            say(&format!("poked {}", now_ns()));
            p.publish(Empty::default())?;
            // dropping the publisher waits (briefly) for the subscribers' acknowledgements
            drop(p);
            radar.shutdown().timeout(Duration::from_secs(10)).await?;
        }
        _ => {
            eprintln!("usage: radar_test_soak robot-a | robot-b | bumper | planner | poke");
            std::process::exit(64);
        }
    }
    Ok(())
}
