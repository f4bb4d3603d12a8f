//! A program as its user writes it, for `tests/shutdown.rs`: one response whose start behaviour runs for a
//! minute (a robot driving) and whose exit slot prints `exit slot begins` and `exit slot: REASON` (stopping
//! the motors, say), nothing else about signals.
//!
//! `radar_test_stopper NAME MODE [--exit-ms MS] [--shutdown-timeout-ms MS]`: prints `ready` once the response
//! runs on the graph, then by MODE:
//! - `wait`: waits for ever (until SIGINT or SIGTERM: radar_ros's own handling);
//! - `return`: returns from `main` as soon as the response runs (its handle is dropped on the way out);
//! - `return-current-thread`: the same on a current-thread runtime;
//! - `shutdown`: calls `Radar::shutdown` as soon as the response runs, then prints `shut down` and returns;
//! - `manual`: handles SIGINT itself (`RadarBuilder::handle_signals(false)`), then calls `Radar::shutdown`;
//! - `relay`: also `whenever NAME_tick start NAME_remote` (an event and a response of another program, found
//!   by name), prints `relaying`, then waits as `wait` does.
//!
//! `--exit-ms`: the exit slot works that long before it prints its reason. `--exit-starts OTHER`: the exit slot
//! first finds the response OTHER by name (a lookup on the ROS graph) and starts it, printing
//! `exit slot started OTHER` (or why it could not). `--shutdown-timeout-ms`: the limit
//! a stop may take (`RadarBuilder::shutdown_timeout`).

use std::{io::Write, time::Duration};

use radar_ros::{msg::Empty, ExitAction, FnResponse, Radar};

fn say(s: &str) {
    let mut out = std::io::stdout();
    let _ = writeln!(out, "{s}");
    let _ = out.flush();
}

fn arg(flag: &str) -> Option<u64> {
    std::env::args()
        .skip_while(|a| a != flag)
        .nth(1)
        .map(|s| s.parse().expect("a number"))
}

async fn run(name: String, mode: String) {
    let exit_ms = arg("--exit-ms").unwrap_or(0);
    let mut b = Radar::builder().handle_signals(mode != "manual");
    if let Some(ms) = arg("--shutdown-timeout-ms") {
        b = b.shutdown_timeout(Duration::from_millis(ms));
    }
    let radar = b.build().expect("a participant");
    // `--exit-starts NAME`: the exit slot finds response NAME (never looked up before) and starts it
    let exit_starts = std::env::args().skip_while(|a| a != "--exit-starts").nth(1);
    let in_exit = radar.clone();
    let drive = FnResponse::new(|_: Empty| async {
        tokio::time::sleep(Duration::from_secs(60)).await;
        Ok(Empty::default())
    })
    .on_exit(move |why| {
        let (radar, exit_starts) = (in_exit.clone(), exit_starts.clone());
        async move {
            say("exit slot begins");
            if let Some(other) = exit_starts {
                let started = async {
                    let r = radar
                        .response(&other)
                        .timeout(Duration::from_secs(5))
                        .await?;
                    radar
                        .inject(r.start_slot(), Empty::default())
                        .timeout(Duration::from_secs(5))
                        .await
                };
                match started.await {
                    Ok(()) => say(&format!("exit slot started {other}")),
                    Err(e) => say(&format!("exit slot could not start {other}: {e}")),
                }
            }
            tokio::time::sleep(Duration::from_millis(exit_ms)).await;
            say(&format!("exit slot: {}", why.describe()));
            ExitAction::Done
        }
    });
    let r = radar.spawn_response(&name, drive).expect("the response");
    say("ready");
    let mut state = r.watch_state();
    match mode.as_str() {
        "wait" => std::future::pending::<()>().await,
        "return" | "return-current-thread" => {
            let _ = state.wait_for(|s| s.state_label == "running").await;
            say("returning");
        }
        "shutdown" => {
            let _ = state.wait_for(|s| s.state_label == "running").await;
            radar.shutdown().await.expect("shut down in time");
            say("shut down");
        }
        "manual" => {
            tokio::signal::ctrl_c().await.expect("SIGINT handler");
            say("told to stop");
            radar.shutdown().await.expect("shut down in time");
            say("shut down");
        }
        "relay" => {
            // `whenever NAME_tick start NAME_remote`, both of another program
            let tick = radar
                .event(&format!("{name}_tick"))
                .timeout(Duration::from_secs(30))
                .await
                .expect("the tick");
            let remote = radar
                .response(&format!("{name}_remote"))
                .timeout(Duration::from_secs(30))
                .await
                .expect("the remote response");
            let _c = radar
                .whenever(&tick)
                .start(&remote)
                .await
                .expect("the statement");
            say("relaying");
            std::future::pending::<()>().await
        }
        other => panic!("unknown mode {other}"),
    }
}

fn main() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "info,rustdds=error".into()),
        )
        .with_writer(std::io::stderr)
        .with_ansi(false)
        .try_init();
    let mut args = std::env::args().skip(1);
    let (name, mode) = (args.next().expect("NAME"), args.next().expect("MODE"));
    let rt = match mode.as_str() {
        "return-current-thread" => tokio::runtime::Builder::new_current_thread(),
        _ => tokio::runtime::Builder::new_multi_thread(),
    }
    .enable_all()
    .build()
    .expect("a runtime");
    rt.block_on(run(name, mode));
}
