//! The child processes of a benchmark run. Each role sets up its endpoints, prints `ready`, then serves the
//! coordinator's commands ([`crate::proto`]). Latencies are taken with the shared monotonic clock
//! ([`crate::clock`]): stamped right before a publish (or when an event's check resolves), read where the
//! receiving code begins to run. The roles by kind: [`raw`] (the baseline), [`signals`] (latency), [`setup`]
//! (connecting), [`scale`], [`view`] (the system `radar view` watches).

mod futex;
mod raw;
mod scale;
mod setup;
mod signals;
mod view;
#[cfg(feature = "zenoh")]
mod zenoh;

use std::{
    collections::HashMap,
    sync::{
        atomic::{AtomicU64, Ordering},
        Arc, Mutex,
    },
    time::Duration,
};

use anyhow::{anyhow, bail, Context as _, Result};
use futures::{StreamExt, TryStreamExt};
use radar_ros::{
    msg::{Empty, EventState, Header},
    ConnectionGuard, Event, EventHandle, FnResponse, Radar, Response, SlotError, Trigger,
};
use serde_json::json;
use tokio::sync::mpsc;

use crate::{
    baseline::{raw_node, raw_publisher, raw_subscription, WAIT},
    clock::{age_ns, now_ns, stamped, unstamp},
    proto::{reply, rss_bytes, Commands},
    robustness,
};

/// Runs the child role `role` with its arguments.
pub async fn run(role: &str, args: &[String]) -> Result<()> {
    let opt = |flag: &str| -> Option<String> {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let flag = |f: &str| args.iter().any(|a| a == f);
    let req = |flag: &str| opt(flag).ok_or_else(|| anyhow!("role {role} needs {flag} VALUE"));
    let num = |flag: &str| -> Result<usize> {
        req(flag)?
            .parse()
            .with_context(|| format!("{flag} must be a number"))
    };
    match role {
        "raw-sink" => raw::raw_sink(&req("--topic")?).await,
        "raw-source" => raw::raw_source(&req("--topic")?).await,
        "raw-forward" => raw::raw_forward(&req("--from")?, &req("--to")?).await,
        "udp-sink" => raw::udp_sink(num("--port")? as u16).await,
        "udp-source" => raw::udp_source(num("--port")? as u16).await,
        "futex-sink" => futex::futex_sink(&req("--shm")?).await,
        "futex-source" => futex::futex_source(&req("--shm")?).await,
        "events" => {
            signals::events(
                &req("--names")?,
                opt("--connect"),
                opt("--local-response"),
                flag("--relay"),
                opt("--born").map(|b| b.parse()).transpose()?,
                flag("--trigger"),
            )
            .await
        }
        "response" => signals::response(&req("--name")?, opt("--connect"), flag("--relay")).await,
        "long-response" => signals::long_response(&req("--name")?).await,
        "interrupter" => signals::interrupter(&req("--name")?).await,
        "action-driver" => signals::action_driver(&req("--action")?).await,
        "manager" => setup::manager().await,
        "sources" => scale::sources(&req("--prefix")?, num("--count")?).await,
        "sinks" => scale::sinks(&req("--prefix")?, num("--count")?).await,
        "state-churn" => robustness::state_churn(num("--changes")? as u64).await,
        "raw-latched" => robustness::raw_latched(num("--writes")? as u64).await,
        "service-manager" => robustness::service_manager(&req("--name")?).await,
        "service-caller" => {
            robustness::service_caller(&req("--manager")?, &req("--source")?, &req("--target")?)
                .await
        }
        "scale" => {
            scale::scale(
                num("--events")?,
                num("--responses")?,
                num("--connections")?,
                Duration::from_millis(num("--idle-ms")? as u64),
                (
                    Duration::from_millis(num("--settle-ms")? as u64),
                    Duration::from_millis(num("--settled-ms")? as u64),
                ),
            )
            .await
        }
        "view-system" => view::view_system(num("--events")?, num("--responses")?).await,
        "components" => scale::components(num("--events")?, num("--responses")?).await,
        "discover" => scale::discover().await,
        #[cfg(feature = "zenoh")]
        "zenoh-sink" => zenoh::zenoh_sink(&req("--topic")?).await,
        #[cfg(feature = "zenoh")]
        "zenoh-source" => zenoh::zenoh_source(&req("--topic")?).await,
        #[cfg(feature = "zenoh")]
        "zenoh-router" => zenoh::zenoh_router().await,
        #[cfg(feature = "zenoh")]
        "zenoh-floor-sink" => zenoh::zenoh_floor_sink(&req("--topic")?).await,
        #[cfg(feature = "zenoh")]
        "zenoh-floor-source" => zenoh::zenoh_floor_source(&req("--topic")?).await,
        other => bail!("unknown role {other:?}"),
    }
}

/// Serves commands with `f` until `quit`; an error answers `error ...` and the role goes on.
async fn serve<F, Fut>(mut f: F)
where
    F: FnMut(Vec<String>) -> Fut,
    Fut: std::future::Future<Output = Result<String>>,
{
    reply("ready");
    let mut cmds = Commands::new();
    while let Some(words) = cmds.next().await {
        if words[0] == "probe" {
            reply(probe_report());
            continue;
        }
        match f(words).await {
            Ok(answer) => reply(answer),
            Err(e) => reply(format!("error {e:#}").replace('\n', " ")),
        }
    }
}

fn word<T: std::str::FromStr>(words: &[String], i: usize) -> Result<T> {
    words
        .get(i)
        .ok_or_else(|| anyhow!("command {:?} needs argument {i}", words.join(" ")))?
        .parse()
        .map_err(|_| anyhow!("argument {i} of {:?} is not valid", words.join(" ")))
}

/// Calls `f(i)` for `i` in `0..n`, one every `period`, on schedule (late calls are not bunched up).
async fn paced(n: u64, period: Duration, mut f: impl FnMut(u64)) {
    let start = tokio::time::Instant::now();
    for i in 0..n {
        tokio::time::sleep_until(start + period * i as u32).await;
        f(i);
    }
}

/// Calls `f(i)` at `rate` per second for `window`, in 1 ms batches; returns how many calls were made.
async fn at_rate(rate: f64, window: Duration, mut f: impl FnMut(u64)) -> u64 {
    let start = tokio::time::Instant::now();
    let mut sent = 0u64;
    loop {
        let elapsed = start.elapsed();
        if elapsed >= window {
            return sent;
        }
        let due = (rate * elapsed.as_secs_f64()) as u64;
        while sent < due {
            f(sent);
            sent += 1;
        }
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
}

/// `probe`, answered by every role: the stamps RustDDS's latency probe took in this process since the last
/// `probe` (`[[stage, sequence number, t_ns], ...]`; empty unless the role runs with `RUSTDDS_PROBE_TOPIC`).
fn probe_report() -> String {
    let stamps: Vec<(&str, i64, u64)> = radar_ros::transport::rustdds::probe::drain()
        .into_iter()
        .map(|s| (s.stage.name(), s.sn, s.t_ns))
        .collect();
    json!({ "stamps": stamps }).to_string()
}

/// Serves `report WARMUP` from `rec` until the coordinator says `quit` (the sinks whose samples a thread of
/// their own records).
async fn serve_reports(rec: Record) {
    serve(|w| {
        let rec = rec.clone();
        async move {
            match w[0].as_str() {
                "report" => Ok(rec.report(word(&w, 1)?, json!({}))),
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
}

/// Latencies recorded by a receiver: `(sequence, nanoseconds, when it was recorded)`.
#[derive(Clone, Default)]
struct Record(Arc<Mutex<Vec<(u64, u64, u64)>>>);

impl Record {
    fn push(&self, seq: u64, ns: u64) {
        let now = now_ns();
        self.0.lock().unwrap().push((seq, ns, now));
    }
    /// The latencies of samples at or after `warmup`, as JSON, and forgets all. Under RustDDS's probe also
    /// each sample's send and receive times (`at`: `[[seq, t0, t1], ...]`) for the stage breakdown.
    fn report(&self, warmup: u64, extra: serde_json::Value) -> String {
        let all = std::mem::take(&mut *self.0.lock().unwrap());
        let kept = || {
            all.iter()
                .filter(|(s, _, _)| *s >= warmup && *s != u64::MAX)
        };
        let lat: Vec<u64> = kept().map(|(_, l, _)| *l).collect();
        let mut report = json!({ "lat_ns": lat, "received": all.len(), "extra": extra });
        if radar_ros::transport::rustdds::probe::on() {
            let at: Vec<(u64, u64, u64)> = kept()
                .map(|(s, l, t1)| (*s, t1.saturating_sub(*l), *t1))
                .collect();
            report["at"] = json!(at);
        }
        report.to_string()
    }
}

fn radar() -> Result<Radar> {
    Radar::new().context("a RADAR participant")
}

/// A participant whose manager, with `relay`, writes every delivery on the slot's topic even to a response
/// of its own process (two DDS hops), as a manager in another process does.
fn radar_relaying(relay: bool) -> Result<Radar> {
    Radar::builder()
        .local_delivery(!relay)
        .build()
        .context("a RADAR participant")
}
