//! The coordinator: starts the processes of each scenario, drives them, and collects the numbers.

use std::{
    path::{Path, PathBuf},
    time::{Duration, Instant},
};

use anyhow::{anyhow, bail, Context as _, Result};
use serde::Serialize;
use serde_json::{json, Value};

use crate::{
    proto::{cpu_time, Child},
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
    rates: Vec<f64>,
    window_ms: u64,
    fanouts: Vec<usize>,
    /// (events, responses, connections) per step of the scale curve.
    scale: Vec<(usize, usize, usize)>,
    idle_ms: u64,
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
                rates: vec![500.0, 2000.0],
                window_ms: 300,
                fanouts: vec![1, 100],
                scale: vec![(5, 5, 10), (25, 25, 50)],
                idle_ms: 300,
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
    /// Time to make all the connections from the manager's process, each found by name (ms; none for raw).
    pub connect_ms: Option<f64>,
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
    /// Scenarios that failed, with why.
    pub errors: Vec<String>,
}

/// The whole run.
pub struct Bench {
    opts: Opts,
    plan: Plan,
    exe: PathBuf,
    next_domain: u16,
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
            "lease_s": radar_ros::DEFAULT_LEASE.as_secs_f64(),
        });
        Ok(Bench {
            next_domain: opts.domain,
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
        let mut all = vec!["child"];
        all.extend_from_slice(args);
        Child::start(&self.exe, &all, domain, &[], START).await
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

    /// Runs every scenario (or those `--only` names); a failing scenario is recorded and the rest go on.
    pub async fn run_all(&mut self) {
        type Scenario = (
            &'static str,
            fn(&mut Bench) -> futures::future::BoxFuture<'_, Result<()>>,
        );
        let scenarios: Vec<Scenario> = vec![
            ("latency", |b| Box::pin(b.latency())),
            ("interrupt", |b| Box::pin(b.interrupt())),
            ("setup", |b| Box::pin(b.setup())),
            ("throughput", |b| Box::pin(b.throughput())),
            ("scale", |b| Box::pin(b.scale())),
            ("oneshot", |b| Box::pin(b.oneshot())),
            ("memory", |b| Box::pin(b.state_memory())),
            ("kill", |b| Box::pin(b.kill())),
            ("action", |b| Box::pin(b.action())),
        ];
        for (key, f) in scenarios {
            if !self.wants(key) {
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
    }

    fn run_timeout(&self, n: u64) -> Duration {
        Duration::from_micros(n * self.plan.period_us) + Duration::from_secs(60)
    }

    /// Sends `run` to `source`, waits for the deliveries to drain, and reads `sink`'s report.
    async fn paced(&self, source: &mut Child, run: &str, sink: &mut Child) -> Result<Value> {
        let n = self.plan.latency_n + self.plan.warmup;
        source.ask(run, self.run_timeout(n)).await?;
        tokio::time::sleep(Duration::from_millis(500)).await;
        sink.ask_json(&format!("report {}", self.plan.warmup), START)
            .await
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
        self.results.latency.push(Latency {
            key: key.into(),
            label: label.into(),
            summary,
            missing,
            note: extra_note.into(),
            samples,
        });
        Ok(())
    }

    /// Trigger -> start latency through radar_ros, and the three baselines.
    async fn latency(&mut self) -> Result<()> {
        let (n, p) = (self.plan.latency_n + self.plan.warmup, self.plan.period_us);
        let run = format!("run {n} {p}");
        self.raw_latency(&run, false).await?;
        self.raw_latency(&run, true).await?;
        // rclpy, one hop
        let d = self.domain();
        let py = async {
            let mut sink = self.python(d, &["sink", "--topic", "/bench/lat"]).await?;
            let mut src = self.python(d, &["source", "--topic", "/bench/lat"]).await?;
            src.ask("wait", START).await?;
            let r = self.paced(&mut src, &run, &mut sink).await?;
            src.quit().await;
            sink.quit().await;
            Ok::<_, anyhow::Error>(r)
        }
        .await;
        match py {
            Ok(r) => self.push_latency(
                "rclpy_1hop",
                "rclpy, 1 hop (publisher -> subscriber)",
                &r,
                "",
            )?,
            Err(e) => self
                .results
                .errors
                .push(format!("latency rclpy_1hop: {e:#}")),
        }
        for host in [
            Host::Third,
            Host::ResponseRelaying,
            Host::Response,
            Host::Event,
        ] {
            self.radar_latency(n, p, host).await?;
        }
        // all in one process: what radar_ros itself adds, without DDS
        let d = self.domain();
        let mut all = self
            .child(
                d,
                &[
                    "events",
                    "--names",
                    "/bench/ev",
                    "--local-response",
                    "/bench/resp",
                ],
            )
            .await?;
        all.ask("active /bench/ev", START).await?;
        all.ask(&format!("run /bench/ev {n} {p}"), self.run_timeout(n))
            .await?;
        tokio::time::sleep(Duration::from_millis(500)).await;
        let r = all
            .ask_json(&format!("report {}", self.plan.warmup), START)
            .await?;
        let note = format!(
            "{} starts ignored (response busy)",
            r["extra"]["ignored_starts"]
        );
        self.push_latency(
            "radar_one_process",
            "radar_ros trigger -> start, event, manager and response in one process (no DDS hop)",
            &r,
            &note,
        )?;
        all.quit().await;
        Ok(())
    }

    /// Paced latency from a raw ros2-client publisher to a raw subscriber: one hop, or two through a plain
    /// forwarding node.
    async fn raw_latency(&mut self, run: &str, forward: bool) -> Result<()> {
        let d = self.domain();
        let mut sink = self
            .child(d, &["raw-sink", "--topic", "/bench/lat"])
            .await?;
        let (fwd, topic) = if forward {
            let args = [
                "raw-forward",
                "--from",
                "/bench/lat_in",
                "--to",
                "/bench/lat",
            ];
            (Some(self.child(d, &args).await?), "/bench/lat_in")
        } else {
            (None, "/bench/lat")
        };
        let mut src = self.child(d, &["raw-source", "--topic", topic]).await?;
        src.ask("wait", START).await?;
        let r = self.paced(&mut src, run, &mut sink).await?;
        let (key, label) = if forward {
            (
                "raw_2hop",
                "raw ros2-client, 2 hops (through a forwarding node)",
            )
        } else {
            (
                "raw_1hop",
                "raw ros2-client, 1 hop (publisher -> subscriber)",
            )
        };
        self.push_latency(key, label, &r, "")?;
        for c in [Some(src), fwd, Some(sink)].into_iter().flatten() {
            c.quit().await;
        }
        Ok(())
    }

    /// Paced trigger -> start latency from a radar_ros event to a response in another process, connected by
    /// the manager of `host`.
    async fn radar_latency(&mut self, n: u64, p: u64, host: Host) -> Result<()> {
        let d = self.domain();
        let mut ev_args = vec!["events", "--names", "/bench/ev"];
        let mut args = vec!["response", "--name", "/bench/resp"];
        match host {
            Host::Third => {}
            Host::Response => args.extend(["--connect", "/bench/ev"]),
            Host::ResponseRelaying => args.extend(["--connect", "/bench/ev", "--relay"]),
            Host::Event => ev_args.extend(["--connect", "/bench/resp"]),
        }
        // the response first: an event that connects looks it up
        let mut resp_slot = None;
        let mut ev = if host == Host::Event {
            resp_slot = Some(self.child(d, &args).await?);
            self.child(d, &ev_args).await?
        } else {
            self.child(d, &ev_args).await?
        };
        let mut resp = match resp_slot {
            Some(r) => r,
            None => self.child(d, &args).await?,
        };
        let mgr = if host == Host::Third {
            let mut m = self.child(d, &["manager"]).await?;
            m.ask("connect /bench/ev /bench/resp", START).await?;
            Some(m)
        } else {
            None
        };
        ev.ask("active /bench/ev", START).await?;
        let r = self
            .paced(&mut ev, &format!("run /bench/ev {n} {p}"), &mut resp)
            .await?;
        let note = format!(
            "{} starts ignored (response busy)",
            r["extra"]["ignored_starts"]
        );
        let (key, label) = match host {
            Host::Third => (
                "radar_manager_process",
                "radar_ros trigger -> start, manager in a third process (2 hops)",
            ),
            Host::ResponseRelaying => (
                "radar_embedded_relay",
                "radar_ros trigger -> start, manager in the response's process, relayed (2 hops; `local_delivery(false)`)",
            ),
            Host::Response => (
                "radar_embedded",
                "radar_ros trigger -> start, manager in the response's process (1 hop)",
            ),
            Host::Event => (
                "radar_embedded_event",
                "radar_ros trigger -> start, manager in the event's process (1 hop)",
            ),
        };
        self.push_latency(key, label, &r, &note)?;
        for c in [mgr, Some(resp), Some(ev)].into_iter().flatten() {
            c.quit().await;
        }
        Ok(())
    }
}

/// Which process hosts the manager of a latency run's connection.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Host {
    /// A third process (two DDS hops).
    Third,
    /// The response's, writing on the response's `start` anyway (two hops).
    ResponseRelaying,
    /// The response's (one hop: the event's writer to the manager's reader).
    Response,
    /// The event's (one hop: the manager's writer to the response's reader).
    Event,
}

impl Bench {
    /// `interrupt` published -> `interrupted` emitted (the start behaviour cancelled, the slot begun).
    async fn interrupt(&mut self) -> Result<()> {
        let d = self.domain();
        let mut long = self
            .child(d, &["long-response", "--name", "/bench/long"])
            .await?;
        let mut drv = self
            .child(d, &["interrupter", "--name", "/bench/long"])
            .await?;
        let (n, w) = (
            self.plan.interrupt_n,
            self.plan.warmup.min(self.plan.interrupt_n / 5),
        );
        let sent = drv
            .ask_json(&format!("run {}", n + w), Duration::from_secs(60 + n / 50))
            .await?;
        tokio::time::sleep(Duration::from_millis(200)).await;
        let at = long.ask_json("report", START).await?;
        let sent: Vec<(u64, u64)> = serde_json::from_value(sent["sent"].clone())?;
        let at: std::collections::HashMap<u64, u64> =
            serde_json::from_value::<Vec<(u64, u64)>>(at["at"].clone())?
                .into_iter()
                .collect();
        let lat: Vec<u64> = sent
            .iter()
            .filter(|(seq, _)| *seq >= w)
            .filter_map(|(seq, t0)| at.get(seq).map(|t1| t1.saturating_sub(*t0)))
            .collect();
        let report = serde_json::json!({ "lat_ns": lat });
        self.push_latency(
            "radar_interrupt",
            "radar_ros interrupt -> interrupted (start behaviour cancelled), 1 hop",
            &report,
            "",
        )?;
        let last = self.results.latency.last_mut().unwrap();
        last.missing = n.saturating_sub(lat.len() as u64);
        drv.quit().await;
        long.quit().await;
        Ok(())
    }

    fn push_setup(&mut self, key: &str, label: &str, samples: Vec<u64>) -> Result<()> {
        let summary = summarize(&samples).ok_or_else(|| anyhow!("{label}: no samples"))?;
        self.results.setup.push(Latency {
            key: key.into(),
            label: label.into(),
            summary,
            missing: 0,
            note: String::new(),
            samples,
        });
        Ok(())
    }

    /// Connection setup (known source, source with a live relay, never-seen source) and disconnect.
    async fn setup(&mut self) -> Result<()> {
        let d = self.domain();
        let mut ev = self
            .child(d, &["events", "--names", "/bench/setup_a,/bench/setup_b"])
            .await?;
        let resp = self
            .child(d, &["response", "--name", "/bench/resp"])
            .await?;
        let mut mgr = self.child(d, &["manager"]).await?;
        let m = self.plan.setup_n;
        let long = Duration::from_secs(60 + m as u64);
        let known = mgr
            .ask_json(&format!("setup-known /bench/setup_b /bench/resp {m}"), long)
            .await?;
        let live = mgr
            .ask_json(&format!("setup-live /bench/setup_a /bench/resp {m}"), long)
            .await?;
        let mut fresh = Vec::new();
        let mut fresh_found = Vec::new();
        for i in 0..self.plan.fresh_n {
            let name = format!("/bench/fresh_{i}");
            mgr.send(&format!("setup-fresh {name} /bench/resp")).await?;
            // the manager is looking for it before it exists
            tokio::time::sleep(Duration::from_millis(50)).await;
            let spawned: u64 = ev
                .ask(&format!("spawn {name}"), START)
                .await?
                .strip_prefix("spawned ")
                .and_then(|t| t.parse().ok())
                .ok_or_else(|| anyhow!("bad spawn answer"))?;
            let a: Value = serde_json::from_str(&mgr.answer(START).await?)?;
            let (found, armed) = (
                a["found"].as_u64().unwrap_or(0),
                a["armed"].as_u64().unwrap_or(0),
            );
            fresh_found.push(found.saturating_sub(spawned));
            fresh.push(armed.saturating_sub(spawned));
        }
        let v =
            |j: &Value, k: &str| -> Result<Vec<u64>> { Ok(serde_json::from_value(j[k].clone())?) };
        self.push_setup(
            "setup_known",
            "whenever -> armed, source known (looked up before, no relay reader yet)",
            v(&known, "setup")?,
        )?;
        self.push_setup(
            "setup_live",
            "whenever -> armed, source already relayed by another connection",
            v(&live, "setup")?,
        )?;
        self.push_setup(
            "setup_fresh",
            "event starts in another process -> connection armed (source never seen)",
            fresh,
        )?;
        self.push_setup(
            "setup_fresh_found",
            "event starts in another process -> found by name (part of the line above)",
            fresh_found,
        )?;
        self.push_setup(
            "activate",
            "armed -> the event reports itself active (its state topic, 1 hop)",
            v(&known, "activate")?,
        )?;
        self.push_setup(
            "disconnect",
            "guard dropped (disconnect call returns)",
            v(&known, "disconnect")?,
        )?;
        self.push_setup(
            "deactivate",
            "guard dropped -> the event reports itself inactive (checking stopped)",
            v(&known, "deactivate")?,
        )?;
        for c in [mgr, resp, ev] {
            c.quit().await;
        }
        Ok(())
    }

    /// Steps through the offered rates until a step loses signals.
    async fn ladder(
        &self,
        src: &mut Child,
        sink: &mut Child,
        relay: Option<u32>,
    ) -> Result<(f64, f64, Vec<Step>)> {
        let mut steps = Vec::new();
        let (mut best, mut best_cpu) = (0.0, 0.0);
        let count = |s: String| s.parse::<u64>().map_err(|_| anyhow!("bad count {s:?}"));
        for &rate in &self.plan.rates {
            let base = count(sink.ask("count", START).await?)?;
            let cpu0 = relay.map(cpu_time).transpose()?.unwrap_or_default();
            let t = Instant::now();
            let sent = count(
                src.ask(
                    &format!("rate {rate} {}", self.plan.window_ms),
                    Duration::from_millis(self.plan.window_ms) + START,
                )
                .await?,
            )?;
            // wait until everything arrived, or nothing more arrives for 500 ms
            let (mut last, mut since) = (u64::MAX, Instant::now());
            let mut got;
            loop {
                got = count(sink.ask("count", START).await?)? - base;
                if got >= sent || since.elapsed() > Duration::from_millis(500) {
                    break;
                }
                if got != last {
                    last = got;
                    since = Instant::now();
                }
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
            let wall = t.elapsed().as_secs_f64();
            let cpu = match relay {
                Some(pid) => (cpu_time(pid)? - cpu0).as_secs_f64() / wall,
                None => 0.0,
            };
            steps.push(Step {
                rate,
                sent,
                received: got,
                relay_cpu: cpu,
            });
            if got < sent {
                break;
            }
            (best, best_cpu) = (rate, cpu);
        }
        Ok((best, best_cpu, steps))
    }

    fn push_throughput(
        &mut self,
        key: &str,
        label: &str,
        n: usize,
        r: (f64, f64, Vec<Step>),
        connect_ms: Option<f64>,
    ) {
        self.results.throughput.push(Throughput {
            key: key.into(),
            label: label.into(),
            connections: n,
            max_lossless: r.0,
            relay_cpu: r.1,
            connect_ms,
            steps: r.2,
        });
    }

    /// The most signals per second forwarded with no loss.
    async fn throughput(&mut self) -> Result<()> {
        // raw one hop
        let d = self.domain();
        let mut sink = self
            .child(d, &["sinks", "--prefix", "/bench/sink", "--count", "1"])
            .await?;
        let mut src = self
            .child(d, &["raw-source", "--topic", "/bench/sink_0/start"])
            .await?;
        src.ask("wait", START).await?;
        let r = self.ladder(&mut src, &mut sink, None).await?;
        self.push_throughput("raw_1hop", "raw ros2-client, 1 hop", 1, r, None);
        src.quit().await;
        sink.quit().await;
        // raw two hops
        let d = self.domain();
        let mut sink = self
            .child(d, &["sinks", "--prefix", "/bench/sink", "--count", "1"])
            .await?;
        let fwd = self
            .child(
                d,
                &[
                    "raw-forward",
                    "--from",
                    "/bench/src_0/triggered",
                    "--to",
                    "/bench/sink_0/start",
                ],
            )
            .await?;
        let mut src = self
            .child(d, &["raw-source", "--topic", "/bench/src_0/triggered"])
            .await?;
        src.ask("wait", START).await?;
        tokio::time::sleep(Duration::from_millis(300)).await;
        let pid = fwd.pid();
        let r = self.ladder(&mut src, &mut sink, Some(pid)).await?;
        self.push_throughput(
            "raw_2hop",
            "raw ros2-client, 2 hops (forwarding node)",
            1,
            r,
            None,
        );
        for c in [src, fwd, sink] {
            c.quit().await;
        }
        // through a radar_ros manager in its own process, with N live connections
        for n in self.plan.fanouts.clone() {
            let d = self.domain();
            let ns = n.to_string();
            let mut sink = self
                .child(d, &["sinks", "--prefix", "/bench/sink", "--count", &ns])
                .await?;
            let mut src = self
                .child(d, &["sources", "--prefix", "/bench/src", "--count", &ns])
                .await?;
            let mut mgr = self.child(d, &["manager"]).await?;
            let armed = mgr
                .ask(
                    &format!("connect-many /bench/src /bench/sink {n}"),
                    Duration::from_secs(300),
                )
                .await?;
            eprintln!("radar_bench: {n} connections {armed}");
            let connect_ms = armed
                .strip_prefix("armed ")
                .and_then(|ms| ms.trim().parse::<f64>().ok());
            src.ask("wait", Duration::from_secs(60)).await?;
            tokio::time::sleep(Duration::from_millis(300)).await;
            let pid = mgr.pid();
            let r = self.ladder(&mut src, &mut sink, Some(pid)).await?;
            self.push_throughput(
                &format!("radar_{n}"),
                &format!("radar_ros manager process, {n} live connection(s), load spread over all"),
                n,
                r,
                connect_ms,
            );
            for c in [mgr, src, sink] {
                c.quit().await;
            }
        }
        Ok(())
    }

    /// Many events, responses and connections in one process.
    async fn scale(&mut self) -> Result<()> {
        let d = self.domain();
        for (e, r, c) in self.plan.scale.clone() {
            eprintln!("radar_bench: scale step {e} events + {r} responses, {c} connections");
            let report = self.scale_step(d, e, r, c).await?;
            self.results.scale.push(report);
        }
        Ok(())
    }

    /// One step of the scale curve, in a fresh process (one at a time, so one domain serves them all).
    async fn scale_step(&mut self, d: u16, e: usize, r: usize, c: usize) -> Result<Value> {
        let (es, rs, cs, idle) = (
            e.to_string(),
            r.to_string(),
            c.to_string(),
            self.plan.idle_ms.to_string(),
        );
        let mut s = Child::start(
            &self.exe,
            &[
                "child",
                "scale",
                "--events",
                &es,
                "--responses",
                &rs,
                "--connections",
                &cs,
                "--idle-ms",
                &idle,
            ],
            d,
            &[],
            Duration::from_secs(1200),
        )
        .await?;
        let report = s.ask_json("report", START).await?;
        s.quit().await;
        Ok(report)
    }

    /// Runs one fresh rclpy process that publishes a stamped Header once into `topic`, exactly as
    /// `ros2 topic pub --once` does, and waits for it to exit.
    async fn oneshot_process(&self, domain: u16, topic: &str, seq: u64) -> Result<()> {
        let py = self.opts.venv.join("bin/python");
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/rclpy_hop.py");
        let out = tokio::time::timeout(
            START,
            tokio::process::Command::new(&py)
                .arg(&script)
                .args(["oneshot", "--topic", topic, "--seq", &seq.to_string()])
                .env("ROS_DOMAIN_ID", domain.to_string())
                .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
                .kill_on_drop(true)
                .output(),
        )
        .await
        .map_err(|_| anyhow!("a one-shot publisher did not finish within {START:?}"))??;
        if !out.status.success() {
            bail!(
                "a one-shot publisher failed ({}): {}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            );
        }
        Ok(())
    }

    /// `ros2 topic pub --once` from a fresh process: publish -> the response's start behaviour runs (and the
    /// same into a plain rclpy subscriber, the baseline). Lost = published but never arrived.
    async fn oneshot(&mut self) -> Result<()> {
        let n = self.plan.oneshot_n;
        let d = self.domain();
        let mut resp = self
            .child(d, &["response", "--name", "/bench/oneshot"])
            .await?;
        for i in 0..n {
            self.oneshot_process(d, "/bench/oneshot/start", i).await?;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
        let r = resp.ask_json("report 0", START).await?;
        resp.quit().await;
        self.push_latency(
            "oneshot_radar",
            "fresh rclpy process, one publish (`ros2 topic pub --once`) -> radar_ros response started",
            &r,
            "one process per sample",
        )?;
        let last = self.results.latency.last_mut().unwrap();
        last.missing = n.saturating_sub(last.summary.n as u64);

        // the baseline in the same domain, on its own topic (domains are few)
        let mut sink = self
            .python(d, &["sink", "--topic", "/bench/oneshot_base"])
            .await?;
        for i in 0..n {
            self.oneshot_process(d, "/bench/oneshot_base", i).await?;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
        let r = sink.ask_json("report 0", START).await?;
        sink.quit().await;
        self.push_latency(
            "oneshot_rclpy",
            "fresh rclpy process, one publish -> rclpy subscriber (baseline)",
            &r,
            "one process per sample",
        )?;
        let last = self.results.latency.last_mut().unwrap();
        last.missing = n.saturating_sub(last.summary.n as u64);
        Ok(())
    }

    /// RSS of a process whose response goes through many state changes (nobody subscribed to `state`), and
    /// of a raw ros2-client latched writer written as often.
    async fn state_memory(&mut self) -> Result<()> {
        let n = self.plan.state_changes.to_string();
        // one process after the other, in one domain
        let d = self.domain();
        for (key, role, flag, label) in [
            (
                "radar_response",
                "state-churn",
                "--changes",
                "radar_ros response, state changes (3 per run), nobody subscribed",
            ),
            (
                "raw_latched",
                "raw-latched",
                "--writes",
                "raw ros2-client transient-local keep-last-1 writer, writes (baseline)",
            ),
        ] {
            let mut c = self.child(d, &[role, flag, &n]).await?;
            let mut r = c.ask_json("run", Duration::from_secs(1800)).await?;
            c.quit().await;
            r["key"] = key.into();
            r["label"] = label.into();
            self.results.state_memory.push(r);
        }
        Ok(())
    }

    /// Action latency against one rclpy `test_msgs/action/Fibonacci` server: `start` published -> the
    /// server's execute callback begins, and `interrupt` published -> the server's cancel callback, through
    /// `Radar::action_response`; next to rclpy's own ActionClient doing the same (`send_goal_async`,
    /// `cancel_goal_async`) in the same run.
    async fn action(&mut self) -> Result<()> {
        let d = self.domain();
        let (n, m) = (self.plan.action_goals, self.plan.action_cancels);
        let warm = (n / 10).max(2);
        let mut server = self
            .python(d, &["action-server", "--topic", "/bench/fib"])
            .await?;
        let timeout = Duration::from_secs(60 + n / 5);
        for radar_side in [false, true] {
            let mut client = if radar_side {
                self.child(d, &["action-driver", "--action", "/bench/fib"])
                    .await?
            } else {
                let mut c = self
                    .python(d, &["action-client", "--topic", "/bench/fib"])
                    .await?;
                c.ask("wait", START).await?;
                c
            };
            let goals = client.ask_json(&format!("run {n}"), timeout).await?;
            let at = server.ask_json("report", START).await?;
            let goal_lat = pair_latencies(&goals["sent"], &at["exec"], warm)?;
            let cancels = client.ask_json(&format!("cancel-run {m}"), timeout).await?;
            let at = server.ask_json("report", START).await?;
            let cancel_lat = pair_latencies(&cancels["sent"], &at["cancel"], 1)?;
            let (who, what) = if radar_side {
                (
                    "radar",
                    "radar_ros `start` -> rclpy server's execute callback (Radar::action_response)",
                )
            } else {
                (
                    "rclpy",
                    "rclpy ActionClient send_goal -> rclpy server's execute callback (baseline)",
                )
            };
            let key = format!("action_goal_{who}");
            self.push_latency(&key, what, &json!({ "lat_ns": goal_lat }), "")?;
            self.results.latency.last_mut().unwrap().missing =
                (n - warm).saturating_sub(goal_lat.len() as u64);
            let (key, what) = if radar_side {
                (
                    "action_cancel_radar",
                    "radar_ros `interrupt` -> rclpy server's cancel callback",
                )
            } else {
                (
                    "action_cancel_rclpy",
                    "rclpy ActionClient cancel_goal -> rclpy server's cancel callback (baseline)",
                )
            };
            self.push_latency(key, what, &json!({ "lat_ns": cancel_lat }), "")?;
            self.results.latency.last_mut().unwrap().missing =
                (m - 1).saturating_sub(cancel_lat.len() as u64);
            client.quit().await;
        }
        server.quit().await;
        Ok(())
    }

    /// SIGKILL of a deliberative program that made `whenever` through a standalone manager's service: time
    /// until the manager has removed its connection, and until the event it listened to reports inactive.
    async fn kill(&mut self) -> Result<()> {
        let (mut removed, mut inactive) = (Vec::new(), Vec::new());
        // round after round in one domain (every process of a round is gone before the next)
        let d = self.domain();
        for _ in 0..self.plan.kill_rounds {
            let mut ev = self
                .child(d, &["events", "--names", "/bench/kill_ev"])
                .await?;
            let resp = self
                .child(d, &["response", "--name", "/bench/kill_resp"])
                .await?;
            let mut mgr = self
                .child(d, &["service-manager", "--name", "/bench_manager"])
                .await?;
            let caller = self
                .child(
                    d,
                    &[
                        "service-caller",
                        "--manager",
                        "/bench_manager",
                        "--source",
                        "/bench/kill_ev/triggered",
                        "--target",
                        "/bench/kill_resp/start",
                    ],
                )
                .await?;
            ev.ask("active /bench/kill_ev", START).await?;
            if mgr.ask("count", START).await? != "1" {
                bail!("the manager does not hold the caller's connection");
            }
            mgr.send("wait-empty").await?;
            ev.send("inactive /bench/kill_ev").await?;
            // the manager and the event must be waiting before the kill
            tokio::time::sleep(Duration::from_millis(100)).await;
            let t0 = crate::clock::now_ns();
            caller.kill().await;
            let long = Duration::from_secs(130);
            let gone: u64 = mgr.answer(long).await?.parse()?;
            let idle: u64 = ev.answer(long).await?.parse()?;
            removed.push(gone.saturating_sub(t0));
            inactive.push(idle.saturating_sub(t0));
            for c in [mgr, resp, ev] {
                c.quit().await;
            }
        }
        for (key, label, samples) in [
            (
                "kill_connections_removed",
                "SIGKILL of the caller -> its connection removed by the standalone manager",
                removed,
            ),
            (
                "kill_event_inactive",
                "SIGKILL of the caller -> the event it listened to reports inactive",
                inactive,
            ),
        ] {
            let summary = summarize(&samples).ok_or_else(|| anyhow!("{label}: no samples"))?;
            self.results.kill.push(Latency {
                key: key.into(),
                label: label.into(),
                summary,
                missing: 0,
                note: String::new(),
                samples,
            });
        }
        Ok(())
    }
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
