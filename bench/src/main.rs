//! `radar_bench`: how fast radar_ros reacts, against raw ros2-client and rclpy, measured in the same run.
//!
//! ```text
//! tests/isolated.sh cargo run --release -p radar_bench -- all      # full: minutes
//! tests/isolated.sh cargo run --release -p radar_bench -- quick    # seconds
//! ```
//!
//! Options: `--out DIR` (default `target/radar_bench/<mode>`), `--domain N` (first `ROS_DOMAIN_ID`, default
//! 70; each scenario takes the next), `--only latency,setup,...`, `--venv DIR` (rclpy venv, default
//! `$RADAR_VENV` or `target/ros2-venv`). Every scenario runs its parts as separate processes (this program
//! with `child ROLE`), talking real DDS. `oneshot`, `memory` and `kill` try what ROS users do to a system: a
//! fresh process per one-shot publish, a long run of state changes, a program killed with SIGKILL. See
//! `docs/benchmarks.md`.

mod baseline;
mod clock;
mod coord;
mod proto;
mod report;
mod robustness;
mod roles;
mod stats;

use std::path::PathBuf;

use anyhow::{bail, Context as _, Result};

fn usage() -> ! {
    eprintln!(
        "usage: radar_bench all|full|quick [--out DIR] [--domain N] [--only a,b] [--venv DIR]\n\
         scenarios: latency, breakdown, interrupt, setup, throughput, scale, oneshot, memory, kill, action, codec, view, security (--features security), zenoh (--features zenoh)"
    );
    std::process::exit(2)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(mode) = args.first() else { usage() };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("a tokio runtime")?;
    if mode == "child" {
        tracing_subscriber::fmt()
            .with_writer(std::io::stderr)
            .with_env_filter(
                tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                    "warn,rustdds=error,ros2_client::distributions=error,ros2_client::service::wrappers=error"
                        .into()
                }),
            )
            .init();
        let role = args.get(1).cloned().unwrap_or_default();
        return rt.block_on(roles::run(&role, &args[2..]));
    }
    let quick = match mode.as_str() {
        "all" | "full" => false,
        "quick" => true,
        _ => usage(),
    };
    let opt = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = opt("--out").map(PathBuf::from).unwrap_or_else(|| {
        root.join("target/radar_bench")
            .join(if quick { "quick" } else { "full" })
    });
    let domain = match opt("--domain") {
        Some(d) => d.parse().context("--domain must be a number")?,
        None => 70,
    };
    let venv = opt("--venv")
        .or_else(|| std::env::var("RADAR_VENV").ok())
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/ros2-venv"));
    let only = opt("--only")
        .map(|s| s.split(',').map(str::to_owned).collect())
        .unwrap_or_default();
    if std::env::var("RADAR_ISOLATED").as_deref() != Ok("1")
        && std::env::var("RADAR_ALLOW_NETWORK").as_deref() != Ok("1")
    {
        bail!(
            "run the benchmarks inside tests/isolated.sh (a private network namespace), so their DDS \
             traffic stays on this machine; set RADAR_ALLOW_NETWORK=1 to use the host network on purpose"
        );
    }
    let opts = coord::Opts {
        quick,
        domain,
        only,
        venv,
    };
    let results = rt.block_on(async {
        let mut b = coord::Bench::new(opts)?;
        b.run_all().await;
        Ok::<_, anyhow::Error>(b.results)
    })?;
    let table = report::table(&results);
    println!("{table}");
    report::write(&results, &out)?;
    println!("written: {}", out.display());
    if !results.errors.is_empty() {
        bail!("{} scenario(s) failed (listed above)", results.errors.len());
    }
    Ok(())
}
