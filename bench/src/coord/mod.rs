//! The coordinator: starts the processes of each scenario, drives them, and collects the numbers. One file per
//! kind of scenario: [`latency`] (signal hops, interrupts, actions), [`setup`] (making connections),
//! [`throughput`], [`scale`] (many components, memory), [`failures`] (one-shot publishers, kills),
//! [`breakdown`] (one hop's stages inside RustDDS), [`codec`] (payload encoding, in this process), [`view`]
//! (`radar view` with 2,000 components).

mod breakdown;
mod codec;
pub use breakdown::SEGMENTS;
mod failures;
mod latency;
mod scale;
mod security;
mod setup;
mod throughput;
mod view;
#[cfg(feature = "zenoh")]
mod zenoh;

use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
    time::{Duration, Instant},
};

use anyhow::{anyhow, bail, Context as _, Result};
use serde::Serialize;
use serde_json::{json, Value};

use crate::{
    proto::{cpu_time, sched_by_thread, udp_datagrams, Child, Sched},
    stats::{summarize, Summary},
};

/// What to run and where to write.
#[derive(Clone, Debug)]
pub struct Opts {
    /// Seconds instead of minutes: fewer samples, shorter windows, smaller scale.
    pub quick: bool,
    /// First `ROS_DOMAIN_ID`; each scenario uses the next one.
    pub domain: u16,
    /// Only scenarios whose name starts with one of these (all when empty).
    pub only: Vec<String>,
    /// The venv with rclpy (for the rclpy baseline).
    pub venv: PathBuf,
}

/// Sizes of one mode.
struct Plan {
    latency_n: u64,
    warmup: u64,
    period_us: u64,
    interrupt_n: u64,
    setup_n: usize,
    fresh_n: usize,
    /// Components a joining program discovers (the `zenoh` scenario's discovery rows), and how many joins.
    #[cfg_attr(not(feature = "zenoh"), allow(dead_code))]
    discovery_n: usize,
    #[cfg_attr(not(feature = "zenoh"), allow(dead_code))]
    discovery_runs: usize,
    rates: Vec<f64>,
    window_ms: u64,
    fanouts: Vec<usize>,
    /// (events, responses, connections) per step of the scale curve.
    scale: Vec<(usize, usize, usize)>,
    idle_ms: u64,
    /// How long after the last connection is armed the settled idle cost is measured (over `settled_ms`).
    settle_ms: u64,
    /// The settled idle cost's window.
    settled_ms: u64,
    /// One-shot publishes, each from a fresh process.
    oneshot_n: u64,
    /// State changes of the memory run.
    state_changes: u64,
    /// SIGKILL rounds.
    kill_rounds: usize,
    /// Goals, and canceled goals, per action client.
    action_goals: u64,
    action_cancels: u64,
}

impl Plan {
    fn new(quick: bool) -> Plan {
        if quick {
            Plan {
                latency_n: 300,
                warmup: 20,
                period_us: 2000,
                interrupt_n: 50,
                setup_n: 20,
                fresh_n: 5,
                discovery_n: 100,
                discovery_runs: 2,
                rates: vec![500.0, 2000.0],
                window_ms: 300,
                fanouts: vec![1, 100],
                scale: vec![(5, 5, 10), (25, 25, 50)],
                idle_ms: 300,
                settle_ms: 1000,
                settled_ms: 500,
                oneshot_n: 4,
                state_changes: 3_000,
                kill_rounds: 1,
                action_goals: 30,
                action_cancels: 10,
            }
        } else {
            Plan {
                latency_n: 10_000,
                warmup: 200,
                period_us: 1000,
                interrupt_n: 2000,
                setup_n: 200,
                fresh_n: 30,
                discovery_n: 1000,
                discovery_runs: 3,
                rates: vec![
                    1000.0, 2000.0, 5000.0, 10_000.0, 15_000.0, 20_000.0, 30_000.0, 50_000.0,
                    100_000.0,
                ],
                window_ms: 2000,
                fanouts: vec![1, 100, 1000],
                // 10, 100, 1,000 and 2,000 components, half events, half responses, each event in two
                // connections
                scale: vec![
                    (5, 5, 10),
                    (50, 50, 100),
                    (500, 500, 1000),
                    (1000, 1000, 2000),
                ],
                idle_ms: 3000,
                settle_ms: 15000,
                settled_ms: 10000,
                oneshot_n: 100,
                state_changes: 100_000,
                kill_rounds: 5,
                action_goals: 500,
                action_cancels: 200,
            }
        }
    }
}

/// One latency distribution.
#[derive(Clone, Debug, Serialize)]
pub struct Latency {
    /// Short key, e.g. `radar_manager_process`.
    pub key: String,
    /// What was measured.
    pub label: String,
    /// The distribution.
    pub summary: Summary,
    /// Samples expected but not measured (lost, ignored, timed out).
    pub missing: u64,
    /// Notes for the table.
    pub note: String,
    /// What each signal cost the run's processes on the cores (see [`Bench::paced_with`]), where measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub usage: Option<Value>,
    /// The raw samples (ns), for plots; not written to JSON.
    #[serde(skip)]
    pub samples: Vec<u64>,
}

/// One step of a throughput ladder.
#[derive(Clone, Debug, Serialize)]
pub struct Step {
    /// Offered rate (signals per second, all connections together).
    pub rate: f64,
    /// Published.
    pub sent: u64,
    /// Arrived at the sinks.
    pub received: u64,
    /// CPU of the relaying process (share of one core) during the step; 0 for one hop.
    pub relay_cpu: f64,
}

/// One throughput ladder.
#[derive(Clone, Debug, Serialize)]
pub struct Throughput {
    /// Short key.
    pub key: String,
    /// What was measured.
    pub label: String,
    /// Live connections (relayed topics).
    pub connections: usize,
    /// Highest offered rate with every signal delivered (0 if none).
    pub max_lossless: f64,
    /// Relay CPU at that rate.
    pub relay_cpu: f64,
    /// Time to make all the connections from the manager's process, each found by name, the components'
    /// processes settled (their own discovery of each other over; ms; none for raw).
    pub connect_ms: Option<f64>,
    /// The same from a first manager started as soon as the components' processes were (ms; none for raw).
    pub connect_fresh_ms: Option<f64>,
    /// Every step run.
    pub steps: Vec<Step>,
}

/// Everything one run measured.
#[derive(Debug, Default, Serialize)]
pub struct Results {
    /// Mode, build profile, machine.
    pub meta: Value,
    /// Latencies of signals (trigger to start, interrupt, baselines).
    pub latency: Vec<Latency>,
    /// Connection setup and teardown times.
    pub setup: Vec<Latency>,
    /// Throughput ladders.
    pub throughput: Vec<Throughput>,
    /// The scale scenario's report, one per step.
    pub scale: Vec<Value>,
    /// Memory over a long run of state changes, radar_ros and the raw baseline.
    pub state_memory: Vec<Value>,
    /// SIGKILL of a deliberative program -> its connections and listeners gone (milliseconds).
    pub kill: Vec<Latency>,
    /// One hop cut into stages by RustDDS's latency probe, per path.
    pub breakdown: Vec<Value>,
    /// Encoding and decoding one payload: hand-written, generated and run-time types (ns per message).
    pub codec: Vec<Latency>,
    /// `radar view` with many components: first picture, update rates, a browser's memory.
    pub view: Vec<Value>,
    /// Scenarios that failed, with why.
    pub errors: Vec<String>,
}

/// The whole run.
pub struct Bench {
    opts: Opts,
    plan: Plan,
    exe: PathBuf,
    next_domain: u16,
    /// Environment of the children started now (RustDDS's latency probe, its inline send switch).
    child_env: Vec<(String, String)>,
    /// The latency runs' events emit from the pacing thread (`events --trigger`) instead of being fed.
    event_trigger: bool,
    /// The C++ Fast DDS baseline (`bench/fastdds/fastdds_hop.cpp`), once built in this run.
    fastdds_exe: Option<PathBuf>,
    /// What was measured so far.
    pub results: Results,
}

const START: Duration = Duration::from_secs(30);

impl Bench {
    /// A run with `opts`.
    pub fn new(opts: Opts) -> Result<Bench> {
        let exe = std::env::current_exe().context("finding this program")?;
        let plan = Plan::new(opts.quick);
        let meta = serde_json::json!({
            "mode": if opts.quick { "quick" } else { "full" },
            "profile": if cfg!(debug_assertions) { "debug" } else { "release" },
            "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(0),
            "latency_signals": plan.latency_n,
            "latency_period_us": plan.period_us,
            "throughput_window_ms": plan.window_ms,
            "oneshot_publishes": plan.oneshot_n,
            "state_changes": plan.state_changes,
            "lease_s": radar_ros::settings::DEFAULT_LEASE.as_secs_f64(),
        });
        Ok(Bench {
            next_domain: opts.domain,
            child_env: Vec::new(),
            event_trigger: false,
            fastdds_exe: None,
            opts,
            plan,
            exe,
            results: Results {
                meta,
                ..Default::default()
            },
        })
    }

    fn wants(&self, key: &str) -> bool {
        self.opts.only.is_empty() || self.opts.only.iter().any(|o| key.starts_with(o.as_str()))
    }

    fn domain(&mut self) -> u16 {
        let d = self.next_domain;
        // Fast DDS (rclpy) cannot compute ports above 232
        assert!(
            d <= 232,
            "the scenarios need more ROS domains than remain above --domain: start lower"
        );
        self.next_domain += 1;
        d
    }

    async fn child(&self, domain: u16, args: &[&str]) -> Result<Child> {
        self.child_with(domain, args, &[]).await
    }

    /// [`Bench::child`] with `extra` variables in its environment.
    async fn child_with(
        &self,
        domain: u16,
        args: &[&str],
        extra: &[(&str, &str)],
    ) -> Result<Child> {
        let mut all = vec!["child"];
        all.extend_from_slice(args);
        let mut envs: Vec<(&str, &str)> = self
            .child_env
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        envs.extend_from_slice(extra);
        Child::start(&self.exe, &all, domain, &envs, START).await
    }

    async fn python(&self, domain: u16, args: &[&str]) -> Result<Child> {
        let py = self.opts.venv.join("bin/python");
        if !py.exists() {
            bail!(
                "the rclpy venv is missing at {}: run tests/python_env.sh (or pass --venv DIR)",
                self.opts.venv.display()
            );
        }
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/rclpy_hop.py");
        let script = script.to_string_lossy().into_owned();
        let mut all = vec![script.as_str()];
        all.extend_from_slice(args);
        Child::start(
            &py,
            &all,
            domain,
            &[
                ("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp"),
                ("PYTHONUNBUFFERED", "1"),
            ],
            START,
        )
        .await
    }

    /// A child of the C++ Fast DDS baseline (`bench/fastdds/fastdds_hop.cpp`), built with g++ against Debian's
    /// Fast DDS beside this program the first time a run needs it (again when the source is newer).
    async fn fastdds(&mut self, domain: u16, args: &[&str]) -> Result<Child> {
        let exe = match &self.fastdds_exe {
            Some(exe) => exe.clone(),
            None => {
                let exe = build_fastdds_hop(&self.exe)?;
                self.fastdds_exe = Some(exe.clone());
                exe
            }
        };
        Child::start(&exe, args, domain, &[], START).await
    }

    /// Runs every scenario (or those `--only` names); a failing scenario is recorded and the rest go on.
    pub async fn run_all(&mut self) {
        type Scenario = (
            &'static str,
            fn(&mut Bench) -> futures::future::BoxFuture<'_, Result<()>>,
        );
        let scenarios: Vec<Scenario> = vec![
            ("latency", |b| Box::pin(b.latency())),
            ("python", |b| Box::pin(b.python_package())),
            ("breakdown", |b| Box::pin(b.breakdown())),
            ("interrupt", |b| Box::pin(b.interrupt())),
            ("setup", |b| Box::pin(b.setup())),
            ("throughput", |b| Box::pin(b.throughput())),
            ("scale", |b| Box::pin(b.scale())),
            ("oneshot", |b| Box::pin(b.oneshot())),
            ("memory", |b| Box::pin(b.state_memory())),
            ("kill", |b| Box::pin(b.kill())),
            ("action", |b| Box::pin(b.action())),
            ("security", |b| Box::pin(b.security())),
            ("codec", |b| Box::pin(b.codec())),
            ("view", |b| Box::pin(b.view())),
            #[cfg(feature = "zenoh")]
            ("zenoh", |b| Box::pin(b.zenoh())),
        ];
        for (key, f) in scenarios {
            if !self.wants(key) {
                continue;
            }
            // the quick run (a test of the harness) needs no Python package built: `--only python` runs it
            if key == "python" && self.opts.quick && self.opts.only.is_empty() {
                eprintln!(
                    "radar_bench: python left out of quick (it needs the package in the venv: \
                     tests/python_package.sh); `--only python` runs it"
                );
                continue;
            }
            // the Zenoh hops start a router and peers of their own: `--only zenoh` runs them in a quick run
            if key == "zenoh" && self.opts.quick && self.opts.only.is_empty() {
                eprintln!("radar_bench: zenoh left out of quick (`--only zenoh` runs it)");
                continue;
            }
            // secured runs need the `security` feature (OpenSSL); `--only security` says so if it is missing
            if key == "security"
                && (self.opts.quick || !cfg!(feature = "security"))
                && self.opts.only.is_empty()
            {
                if cfg!(feature = "security") {
                    eprintln!(
                        "radar_bench: security left out of quick (`--only security` runs it)"
                    );
                } else {
                    eprintln!(
                        "radar_bench: security left out (built without its `security` feature: \
                         `cargo run --release -p radar_bench -- all --only security` has it)"
                    );
                }
                continue;
            }
            eprintln!("radar_bench: {key} ...");
            let t = Instant::now();
            if let Err(e) = f(self).await {
                eprintln!("radar_bench: {key} FAILED: {e:#}");
                self.results.errors.push(format!("{key}: {e:#}"));
            }
            eprintln!("radar_bench: {key} took {:.1} s", t.elapsed().as_secs_f64());
        }
        eprintln!(
            "radar_bench: ROS domains {}-{} used",
            self.opts.domain,
            self.next_domain.saturating_sub(1).max(self.opts.domain)
        );
    }

    fn run_timeout(&self, n: u64) -> Duration {
        Duration::from_micros(n * self.plan.period_us) + Duration::from_secs(60)
    }

    /// Sends `run` to `source`, waits for the deliveries to drain, and reads `sink`'s report.
    async fn paced(&self, source: &mut Child, run: &str, sink: &mut Child) -> Result<Value> {
        self.paced_with(source, run, sink, &[]).await
    }

    /// [`Bench::paced`], with the scheduler's figures of the run's processes (`source`, `sink` and `others`)
    /// added to the report as `usage`: what each signal cost them on the cores, over the whole run.
    async fn paced_with(
        &self,
        source: &mut Child,
        run: &str,
        sink: &mut Child,
        others: &[u32],
    ) -> Result<Value> {
        let n = self.plan.latency_n + self.plan.warmup;
        let pids: Vec<u32> = [source.pid(), sink.pid()]
            .into_iter()
            .chain(others.iter().copied())
            .collect();
        let (before, sent_before) = (sched_now(&pids)?, udp_datagrams());
        source.ask(run, self.run_timeout(n)).await?;
        tokio::time::sleep(Duration::from_millis(500)).await;
        let (after, sent_after) = (sched_now(&pids)?, udp_datagrams());
        let mut r = sink
            .ask_json(&format!("report {}", self.plan.warmup), START)
            .await?;
        r["usage"] = usage_per_signal(before, after, n);
        add_datagrams(&mut r["usage"], sent_before, sent_after, n);
        Ok(r)
    }

    /// A baseline's latency row, or why it could not be measured in the run's errors (the rest goes on).
    fn push_baseline(&mut self, key: &str, label: &str, measured: Result<Value>) -> Result<()> {
        match measured {
            Ok(r) => self.push_latency(key, label, &r, ""),
            Err(e) => {
                self.results.errors.push(format!("{key}: {e:#}"));
                Ok(())
            }
        }
    }

    fn push_latency(
        &mut self,
        key: &str,
        label: &str,
        report: &Value,
        extra_note: &str,
    ) -> Result<()> {
        let samples: Vec<u64> =
            serde_json::from_value(report["lat_ns"].clone()).context("a report without lat_ns")?;
        let summary =
            summarize(&samples).ok_or_else(|| anyhow!("{label}: no signal arrived ({report})"))?;
        let missing = self.plan.latency_n.saturating_sub(samples.len() as u64);
        let usage = report.get("usage").cloned();
        let mut note = extra_note.to_owned();
        if let Some(t) = usage.as_ref().map(|u| &u["total"]) {
            let f = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
            let procs = usage
                .as_ref()
                .map_or(0, |u| u["processes"].as_array().map_or(0, Vec::len));
            if !note.is_empty() {
                note.push_str("; ");
            }
            note.push_str(&format!(
                "per signal, its {procs} processes: {:.1} us on a core, {:.1} us waiting for one, on a core {:.2} times",
                f("cpu_us"),
                f("wait_us"),
                f("slices")
            ));
            if t.get("datagrams_sent").is_some() {
                note.push_str(&format!(", {:.2} UDP datagrams sent", f("datagrams_sent")));
            }
        }
        self.results.latency.push(Latency {
            key: key.into(),
            label: label.into(),
            summary,
            missing,
            note,
            usage,
            samples,
        });
        Ok(())
    }
}

/// The scheduler's figures of a run's processes per signal sent (`n`): in all, and by process in the run's
/// order (the source first, the sink second).
/// Adds to `usage`'s total the UDP datagrams sent in the namespace per signal between two
/// [`udp_datagrams`] reads (`datagrams_sent`, `datagrams_received`); nothing if either read failed.
fn add_datagrams(usage: &mut Value, before: Option<(u64, u64)>, after: Option<(u64, u64)>, n: u64) {
    if let (Some((out0, in0)), Some((out1, in1))) = (before, after) {
        let n = n.max(1) as f64;
        usage["total"]["datagrams_sent"] = json!(out1.saturating_sub(out0) as f64 / n);
        usage["total"]["datagrams_received"] = json!(in1.saturating_sub(in0) as f64 / n);
    }
}

/// The scheduler's figures of each of `pids` now, by thread name.
fn sched_now(pids: &[u32]) -> Result<Vec<BTreeMap<String, Sched>>> {
    pids.iter().map(|p| sched_by_thread(*p)).collect()
}

/// The figures per signal ([`usage_per_signal_of`]) of what happened between two [`sched_now`] reads of the
/// same processes (a thread that began in between counts from zero).
fn usage_per_signal(
    before: Vec<BTreeMap<String, Sched>>,
    after: Vec<BTreeMap<String, Sched>>,
    n: u64,
) -> Value {
    let used: Vec<BTreeMap<String, Sched>> = after
        .into_iter()
        .zip(&before)
        .map(|(a, b)| {
            a.into_iter()
                .map(|(name, s)| {
                    let was = b.get(&name).copied().unwrap_or_default();
                    (name, s.since(was))
                })
                .collect()
        })
        .collect();
    usage_per_signal_of(&used, n)
}

fn usage_per_signal_of(used: &[BTreeMap<String, Sched>], n: u64) -> Value {
    let per = |s: &Sched| {
        let n = n.max(1) as f64;
        json!({
            "cpu_us": s.run_ns as f64 / 1e3 / n,
            "wait_us": s.wait_ns as f64 / 1e3 / n,
            "slices": s.slices as f64 / n,
        })
    };
    let sum = |m: &BTreeMap<String, Sched>| m.values().fold(Sched::default(), |a, b| a + *b);
    let total = used.iter().map(sum).fold(Sched::default(), |a, b| a + b);
    let processes: Vec<Value> = used
        .iter()
        .map(|m| {
            let mut p = per(&sum(m));
            p["threads"] = m.iter().map(|(name, s)| (name.clone(), per(s))).collect();
            p
        })
        .collect();
    json!({ "total": per(&total), "processes": processes })
}

/// Latencies `t1 - t0` of the sequence numbers in both `sent` (`[[seq, t0], ...]`) and `at` (`[[seq, t1], ...]`),
/// skipping the first `warmup`.
fn pair_latencies(sent: &Value, at: &Value, warmup: u64) -> Result<Vec<u64>> {
    let sent: Vec<(u64, u64)> =
        serde_json::from_value(sent.clone()).context("a report without sent")?;
    let at: std::collections::HashMap<u64, u64> =
        serde_json::from_value::<Vec<(u64, u64)>>(at.clone())
            .context("a server report")?
            .into_iter()
            .collect();
    Ok(sent
        .iter()
        .filter(|(seq, _)| *seq >= warmup)
        .filter_map(|(seq, t0)| at.get(seq).map(|t1| t1.saturating_sub(*t0)))
        .collect())
}

/// Builds `bench/fastdds/fastdds_hop.cpp` into `fastdds_hop` beside `bench_exe` unless it is there and newer than
/// its sources (the file and the security header it shares with radar_ros's interop test).
fn build_fastdds_hop(bench_exe: &Path) -> Result<PathBuf> {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = here.join("fastdds/fastdds_hop.cpp");
    let header = here.join("../tests/fastdds/security_properties.hpp");
    let exe = bench_exe.with_file_name("fastdds_hop");
    let modified = |p: &Path| std::fs::metadata(p).and_then(|m| m.modified()).ok();
    let written = [&src, &header]
        .into_iter()
        .map(|p| modified(p))
        .max()
        .flatten();
    if let (Some(built), Some(written)) = (modified(&exe), written) {
        if built >= written {
            return Ok(exe);
        }
    }
    let out = std::process::Command::new("g++")
        .args(["-std=c++17", "-O2"])
        .arg(&src)
        .arg("-o")
        .arg(&exe)
        .args(["-lfastrtps", "-lfastcdr"])
        .output()
        .context("running g++ for the Fast DDS baseline (apt-get install g++ libfastrtps-dev)")?;
    if !out.status.success() {
        bail!(
            "building the Fast DDS baseline {} failed (apt-get install g++ libfastrtps-dev; .ci/run installs them):\n{}",
            src.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(exe)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(threads: &[(&str, u64, u64, u64)]) -> BTreeMap<String, Sched> {
        threads
            .iter()
            .map(|(n, run_ns, wait_ns, slices)| {
                (
                    n.to_string(),
                    Sched {
                        run_ns: *run_ns,
                        wait_ns: *wait_ns,
                        slices: *slices,
                    },
                )
            })
            .collect()
    }

    #[test]
    fn usage_is_what_each_signal_cost_by_process_and_thread_and_a_new_thread_counts_from_zero() {
        let before = vec![
            at(&[("worker", 1_000, 0, 10)]),
            at(&[("loop", 5_000, 100, 1)]),
        ];
        let after = vec![
            at(&[("worker", 21_000, 4_000, 30), ("new", 2_000, 0, 4)]),
            at(&[("loop", 15_000, 2_100, 11)]),
        ];
        let u = usage_per_signal(before, after, 2);
        // 2 signals: process 0 used 20 + 2 us, waited 4 us, 24 slices; process 1: 10 us, 2 us, 10
        assert_eq!(u["processes"][0]["cpu_us"], 11.0);
        assert_eq!(u["processes"][0]["slices"], 12.0);
        assert_eq!(u["processes"][0]["threads"]["new"]["slices"], 2.0);
        assert_eq!(u["processes"][1]["wait_us"], 1.0);
        assert_eq!(u["total"]["cpu_us"], 16.0);
        assert_eq!(u["total"]["slices"], 17.0);
    }
}
