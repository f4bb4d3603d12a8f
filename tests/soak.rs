//! The soak (issue 32): a two-robot deliberative system runs for `RADAR_SOAK_MINUTES` (default 2, as in the
//! test command) with steady `whenever`, `once` and `until` traffic while the world does what it does to
//! robots, and every minute it is counted from outside what the rules say must arrive against what arrived.
//!
//! Two hosts (network namespaces on a veth pair, see `TwoHosts::cable`), one role of `bin/soak.rs` per
//! process: host A runs `robot-a` (event `a_tick` every 200 ms; responses `a_arm`, `a_once`, `a_long`) and the
//! `planner` (the deliberative program: `whenever a_tick start b_drive`, `whenever b_bump start a_arm`,
//! `whenever b_bump start a_long until /poke/triggered`, all `.rearm()`, and a `once b_bump start a_once`
//! scope every second or so); host B runs `robot-b` (response `b_drive`) and the `bumper` (event `b_bump`
//! every 300 ms). Every minute, at fixed offsets:
//!
//! - +8 s: `robot-b` is killed (SIGKILL) and started again at once (a respawn well inside its lease);
//! - +20 s: one process is stopped (SIGSTOP) for 5 s, longer than the 3 s lease (bumper, planner, robot-a,
//!   robot-b in turn);
//! - +38 s: host A's link goes down for 2 s, then up;
//! - five times a minute, at seeded moments: a fresh process on host B publishes one `/poke/triggered` and
//!   exits (the `until` of the planner's third statement).
//!
//! A fault's window runs from 0.5 s before it to 6 s after it ended (the respawned process running, the
//! stopped one continued, the link up): time for the lease, rediscovery and re-arming. What the rules say must
//! arrive: every `a_tick` and `b_bump` emitted outside a window reaches `b_drive` and `a_arm` (its payload
//! echoed by the start slot) exactly once; every `once` scope outside a window fires, and starts `a_once`
//! once, with a payload emitted after the scope began; every poke outside a window interrupts `a_long`
//! within 3 s. Anywhere, windows included: no signal arrives twice, no `once` scope starts `a_once` twice, every
//! `a_long` interrupt answers a poke (the first after it, or one ending a run whose start was sent before the
//! poke: rule R14 bounds that run too). Each minute also shows what arrived inside windows, the RSS, heap
//! (what the allocator handed out and was not given back, and what it holds for that), open fds and CPU of
//! every long-lived process, and the error and warning lines they logged. `RADAR_SOAK_HEAPTRACK=ROLE=FILE`
//! runs one role under heaptrack (see `Proc::start`).
//!
//! The test fails on a lost or duplicated signal, an error line, or a process that does not stop cleanly on
//! SIGTERM at the end. The RSS figures are printed; runs of 10 minutes or more also fail if RSS grows more than
//! 1% per 10 minutes after the first two (the CI run is too short to tell growth from warm-up). Domain 225.

use std::{
    collections::{BTreeMap, HashMap},
    sync::{Arc, Mutex},
    time::{Duration, Instant},
};

use radar_test_util::{init_logs, require_isolation, NetHost, Rng, TwoHosts};
use tokio::io::AsyncBufReadExt;

const SOAK: &str = env!("CARGO_BIN_EXE_radar_test_soak");
const DOMAIN: u16 = 225;
/// Every process logs warnings and errors (RustDDS's and ros2-client's included), so that they can be counted.
const LOG: &str = "warn";
const MINUTE: i64 = 60_000_000_000;
const MS: i64 = 1_000_000;

/// The processes' `RUST_LOG`: [`LOG`], or `RADAR_SOAK_RUST_LOG` (more detail for a diagnosis; warnings and
/// errors are still counted).
fn log_filter() -> String {
    std::env::var("RADAR_SOAK_RUST_LOG").unwrap_or_else(|_| LOG.to_owned())
}

fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// What every process said, as it came.
#[derive(Default)]
struct Said {
    /// Emission times of each event's signals.
    emitted: HashMap<String, Vec<i64>>,
    /// Payloads (emission times) that reached each response's start slot.
    started: HashMap<String, Vec<i64>>,
    /// `a_long`'s runs: (when it began, the emission time of the signal that started it).
    long_runs: Vec<(i64, i64)>,
    /// `a_long`'s exits: (time, reason).
    long_exits: Vec<(i64, String)>,
    /// The planner's `once` scopes: (began, fired, ended).
    onces: Vec<(i64, bool, i64)>,
    /// Times pokes were published.
    pokes: Vec<i64>,
    /// Each long-lived role's last `heap` line: (bytes in use, bytes the allocator holds).
    heap: HashMap<String, (u64, u64)>,
    /// Lines the test did not expect.
    odd: Vec<String>,
}

impl Said {
    fn take(&mut self, line: &str) {
        let w: Vec<&str> = line.split_whitespace().collect();
        let ns = |s: &str| s.parse::<i64>().ok();
        match w.as_slice() {
            ["emit", name, t] if ns(t).is_some() => self
                .emitted
                .entry(name.to_string())
                .or_default()
                .push(ns(t).unwrap()),
            ["start", name, t] if ns(t).is_some() => self
                .started
                .entry(name.to_string())
                .or_default()
                .push(ns(t).unwrap()),
            ["start", "a_long", sent, began] if ns(sent).is_some() && ns(began).is_some() => {
                self.long_runs.push((ns(began).unwrap(), ns(sent).unwrap()))
            }
            ["exit", "a_long", t, why @ ..] if ns(t).is_some() => {
                self.long_exits.push((ns(t).unwrap(), why.join(" ")))
            }
            ["once", before, how, end, ..] if ns(before).is_some() && ns(end).is_some() => self
                .onces
                .push((ns(before).unwrap(), *how == "fired", ns(end).unwrap())),
            ["poked", t] if ns(t).is_some() => self.pokes.push(ns(t).unwrap()),
            ["heap", role, used, held]
                if used.parse::<u64>().is_ok() && held.parse::<u64>().is_ok() =>
            {
                self.heap.insert(
                    role.to_string(),
                    (used.parse().unwrap(), held.parse().unwrap()),
                );
            }
            ["ready"] => {}
            _ => self.odd.push(line.to_owned()),
        }
    }
}

/// Lines a process wrote, with when they came.
type Lines = Arc<Mutex<Vec<(i64, String)>>>;

/// A process of the soak.
struct Proc {
    role: &'static str,
    child: tokio::process::Child,
    /// Its stderr lines: (time, line).
    stderr: Lines,
    /// CPU ticks (utime + stime) once it was ready.
    ticks: u64,
    /// When it was ready.
    born: Instant,
}

impl Proc {
    /// Starts `role` on `host`; for a long-lived role, waits until it says `ready`.
    async fn start(host: &NetHost, role: &'static str, said: &Arc<Mutex<Said>>) -> Proc {
        let mut cmd = tokio::process::Command::new("nsenter");
        cmd.arg(format!("--net=/proc/{}/ns/net", host.pid));
        // RADAR_SOAK_HEAPTRACK=ROLE=FILE: that role runs under heaptrack's preload library, its raw record in
        // FILE (`heaptrack_interpret < FILE | zstd > FILE.zst`, then heaptrack_print; for finding what grows)
        if let Some((r, file)) = std::env::var("RADAR_SOAK_HEAPTRACK")
            .ok()
            .and_then(|v| v.split_once('=').map(|(r, f)| (r.to_owned(), f.to_owned())))
        {
            if r == role {
                cmd.arg("env")
                    .arg("LD_PRELOAD=/usr/lib/heaptrack/libheaptrack_preload.so")
                    .arg(format!("DUMP_HEAPTRACK_OUTPUT={file}"));
            }
        }
        let mut child = cmd
            .arg(SOAK)
            .arg(role)
            .env("ROS_DOMAIN_ID", DOMAIN.to_string())
            .env("RUST_LOG", log_filter())
            .env("NO_COLOR", "1")
            // as on a robot with ROS sourced (else ros2-client warns at start)
            .env("ROS_DISTRO", "jazzy")
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("start radar_test_soak");
        let mut out = tokio::io::BufReader::new(child.stdout.take().unwrap()).lines();
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let mut err = tokio::io::BufReader::new(child.stderr.take().unwrap()).lines();
        let keep = stderr.clone();
        tokio::spawn(async move {
            while let Ok(Some(l)) = err.next_line().await {
                eprintln!("[{role}] {l}");
                keep.lock().unwrap().push((now_ns(), l));
            }
        });
        let (tx, rx) = tokio::sync::oneshot::channel();
        let said = said.clone();
        tokio::spawn(async move {
            let mut tx = Some(tx);
            while let Ok(Some(l)) = out.next_line().await {
                if l == "ready" || l.starts_with("err ") {
                    if let Some(tx) = tx.take() {
                        let _ = tx.send(l.clone());
                    }
                }
                said.lock().unwrap().take(&l);
            }
        });
        {
            let first = tokio::time::timeout(Duration::from_secs(90), rx)
                .await
                .unwrap_or_else(|_| panic!("{role} starts within 90 s"))
                .unwrap_or_else(|_| panic!("{role} ended before it was ready"));
            assert_eq!(first, "ready", "{role} starts");
        }
        let mut p = Proc {
            role,
            child,
            stderr,
            ticks: 0,
            born: Instant::now(),
        };
        p.ticks = p.usage().map(|u| u.ticks).unwrap_or(0);
        p
    }

    fn pid(&self) -> u32 {
        self.child.id().expect("running")
    }

    fn signal(&self, sig: libc::c_int) {
        // SAFETY: kill(2) on a child of this process that has not been reaped
        let r = unsafe { libc::kill(self.pid() as i32, sig) };
        assert_eq!(r, 0, "kill {sig} {} ({})", self.pid(), self.role);
    }

    /// Its RSS, open fds and CPU ticks now.
    fn usage(&self) -> Option<Usage> {
        let pid = self.child.id()?;
        let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
        let rss_kb = status
            .lines()
            .find_map(|l| l.strip_prefix("VmRSS:"))?
            .split_whitespace()
            .next()?
            .parse()
            .ok()?;
        let fds = std::fs::read_dir(format!("/proc/{pid}/fd")).ok()?.count();
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
        // the fields after the command's closing parenthesis; utime and stime are the 14th and 15th
        let rest: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
        let ticks = rest.get(11)?.parse::<u64>().ok()? + rest.get(12)?.parse::<u64>().ok()?;
        Some(Usage { rss_kb, fds, ticks })
    }

    /// SIGTERM, and the exit status within 10 s.
    async fn stop(mut self) -> std::process::ExitStatus {
        self.signal(libc::SIGTERM);
        tokio::time::timeout(Duration::from_secs(10), self.child.wait())
            .await
            .unwrap_or_else(|_| panic!("{} stops within 10 s of SIGTERM", self.role))
            .expect("wait")
    }
}

struct Usage {
    rss_kb: u64,
    fds: usize,
    ticks: u64,
}

/// A time range in which a fault's consequences are allowed: signals emitted in it need not arrive.
#[derive(Clone, Debug)]
struct Window {
    from: i64,
    to: i64,
    what: String,
}

const BEFORE: i64 = 500 * MS;
const AFTER: i64 = 6_000 * MS;

fn in_window(windows: &[Window], t: i64) -> bool {
    window_of(windows, t).is_some()
}

fn window_of(windows: &[Window], t: i64) -> Option<usize> {
    windows.iter().position(|w| t >= w.from && t < w.to)
}

/// One minute's counts.
#[derive(Default, Debug)]
struct Minute {
    /// (must arrive, arrived of those), per flow.
    must: BTreeMap<&'static str, (usize, usize)>,
    /// (emitted in windows, arrived of those), all flows.
    windowed: (usize, usize),
    duplicates: usize,
    errors: Vec<String>,
    warnings: usize,
    /// role -> (RSS kB, fds, CPU %).
    usage: BTreeMap<&'static str, (u64, usize, f64)>,
    /// role -> (heap in use, heap the allocator holds), bytes.
    heap: BTreeMap<&'static str, (u64, u64)>,
}

fn link(host: &NetHost, up: bool) {
    host.ip(&["link", "set", "h0", if up { "up" } else { "down" }]);
    if up {
        // the kernel drops routes through a link that goes down: DDS discovery's multicast route comes back
        host.ip(&["route", "replace", "224.0.0.0/4", "dev", "h0"]);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_two_robot_system_keeps_every_promise_for_minutes_of_faults() {
    init_logs();
    require_isolation();
    let minutes: i64 = std::env::var("RADAR_SOAK_MINUTES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2);
    let seed: u64 = std::env::var("RADAR_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20261125);
    println!("soak: {minutes} min (RADAR_SOAK_MINUTES), seed {seed} (RADAR_SEED)");
    let hosts = TwoHosts::cable();
    let said = Arc::new(Mutex::new(Said::default()));
    let robot_a = Proc::start(&hosts.a, "robot-a", &said).await;
    let mut robot_b = Proc::start(&hosts.b, "robot-b", &said).await;
    let bumper = Proc::start(&hosts.b, "bumper", &said).await;
    let planner = Proc::start(&hosts.a, "planner", &said).await;
    // retired incarnations of robot-b, whose stderr still counts
    let mut killed: Vec<Proc> = Vec::new();
    let mut windows: Vec<Window> = Vec::new();
    let mut rng = Rng(seed | 1);
    let mut minutes_seen: Vec<Minute> = Vec::new();
    let mut pokes = tokio::task::JoinSet::new();

    let t0 = now_ns();
    let start = Instant::now();
    let at = |secs: f64| start + Duration::from_secs_f64(secs);
    // CPU ticks at the last sample, per process id (robot-b is a new process after each respawn)
    let mut procs_usage: HashMap<u32, u64> = HashMap::new();
    for m in 0..minutes {
        let base = 60.0 * m as f64;
        // five pokes at seeded moments, 11-13 s apart
        let mut poke_at: Vec<f64> = (0..5)
            .map(|k| base + 2.0 + 12.0 * k as f64 + (rng.next_u64() % 1000) as f64 / 1000.0)
            .collect();
        poke_at.reverse();
        let mut faults: Vec<(f64, &str)> = vec![(8.0, "kill"), (20.0, "stop"), (38.0, "link")];
        faults.reverse();
        loop {
            let next_poke = poke_at.last().copied();
            let next_fault = faults.last().map(|(s, _)| base + s);
            let next = match (next_poke, next_fault) {
                (None, None) => break,
                (Some(p), Some(f)) => p.min(f),
                (Some(p), None) => p,
                (None, Some(f)) => f,
            };
            tokio::time::sleep_until(at(next).into()).await;
            if Some(next) == next_poke {
                poke_at.pop();
                let said = said.clone();
                let host_pid = hosts.b.pid;
                pokes.spawn(async move { poke(host_pid, &said).await });
                continue;
            }
            let (_, what) = faults.pop().unwrap();
            match what {
                "kill" => {
                    let from = now_ns() - BEFORE;
                    robot_b.signal(libc::SIGKILL);
                    let _ = robot_b.child.wait().await;
                    let fresh = Proc::start(&hosts.b, "robot-b", &said).await;
                    killed.push(std::mem::replace(&mut robot_b, fresh));
                    windows.push(Window {
                        from,
                        to: now_ns() + AFTER,
                        what: "robot-b killed and respawned".into(),
                    });
                }
                "stop" => {
                    let victim = match m % 4 {
                        0 => &bumper,
                        1 => &planner,
                        2 => &robot_a,
                        _ => &robot_b,
                    };
                    let from = now_ns() - BEFORE;
                    victim.signal(libc::SIGSTOP);
                    tokio::time::sleep(Duration::from_secs(5)).await;
                    victim.signal(libc::SIGCONT);
                    windows.push(Window {
                        from,
                        to: now_ns() + AFTER,
                        what: format!("{} stopped 5 s", victim.role),
                    });
                }
                _ => {
                    let from = now_ns() - BEFORE;
                    link(&hosts.a, false);
                    tokio::time::sleep(Duration::from_secs(2)).await;
                    link(&hosts.a, true);
                    windows.push(Window {
                        from,
                        to: now_ns() + AFTER,
                        what: "host A's link down 2 s".into(),
                    });
                }
            }
        }
        tokio::time::sleep_until(at(base + 60.0).into()).await;
        // this minute's resources
        let mut minute = Minute::default();
        for p in [&robot_a, &robot_b, &bumper, &planner] {
            if let Some(u) = p.usage() {
                let before = procs_usage.get(&p.pid()).copied().unwrap_or(p.ticks);
                // SAFETY: sysconf has no preconditions
                let tick_hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
                // over the minute, or since a respawned process started
                let secs = (Instant::now() - p.born).as_secs_f64().min(60.0);
                let cpu = (u.ticks.saturating_sub(before)) as f64 / tick_hz / secs * 100.0;
                procs_usage.insert(p.pid(), u.ticks);
                minute.usage.insert(p.role, (u.rss_kb, u.fds, cpu));
            }
            if let Some(h) = said.lock().unwrap().heap.get(p.role) {
                minute.heap.insert(p.role, *h);
            }
        }
        minutes_seen.push(minute);
        println!(
            "minute {} done; windows so far: {:?}",
            m + 1,
            windows.iter().map(|w| &w.what).collect::<Vec<_>>()
        );
    }
    let t_end = now_ns();
    while let Some(r) = pokes.join_next().await {
        r.expect("a poke process");
    }
    // what is in flight arrives
    tokio::time::sleep(Duration::from_secs(3)).await;

    // the processes stop cleanly on SIGTERM, each exit slot run
    let mut stops = Vec::new();
    let all_logs: Vec<(&'static str, Lines)> = [&robot_a, &robot_b, &bumper, &planner]
        .iter()
        .chain(killed.iter().collect::<Vec<_>>().iter())
        .map(|p| (p.role, p.stderr.clone()))
        .collect();
    let end_logs = now_ns();
    for p in [planner, bumper, robot_b, robot_a] {
        let role = p.role;
        stops.push((role, p.stop().await));
    }

    // the accounts, by minute of emission
    let said = said.lock().unwrap();
    let minute_of = |t: i64| ((t - t0).max(0) / MINUTE).min(minutes - 1) as usize;
    // what is wrong beyond lost and duplicated signals
    let mut broken: Vec<String> = Vec::new();
    // per fault window: signals emitted in it, and arrived of those
    let mut tally = vec![(0usize, 0usize); windows.len()];
    let mut lost: Vec<String> = Vec::new();
    let mut dups: Vec<String> = Vec::new();
    for (flow, event, response) in [
        ("a_tick -> b_drive", "a_tick", "b_drive"),
        ("b_bump -> a_arm", "b_bump", "a_arm"),
    ] {
        let mut arrived: HashMap<i64, usize> = HashMap::new();
        for t in said.started.get(response).into_iter().flatten() {
            *arrived.entry(*t).or_default() += 1;
        }
        for (t, n) in &arrived {
            if *n > 1 {
                dups.push(format!("{flow}: signal {t} arrived {n} times"));
                minutes_seen[minute_of(*t)].duplicates += 1;
            }
        }
        let emitted = said.emitted.get(event).cloned().unwrap_or_default();
        for t in emitted.iter().filter(|t| **t >= t0 && **t < t_end) {
            let got = arrived.contains_key(t);
            let m = &mut minutes_seen[minute_of(*t)];
            if let Some(w) = window_of(&windows, *t) {
                m.windowed.0 += 1;
                m.windowed.1 += got as usize;
                tally[w].0 += 1;
                tally[w].1 += got as usize;
            } else {
                let e = m.must.entry(flow).or_default();
                e.0 += 1;
                e.1 += got as usize;
                if !got {
                    lost.push(format!("{flow}: signal emitted at +{:.3} s", secs(*t - t0)));
                }
            }
        }
        // nothing arrives that was not emitted
        let emitted: std::collections::HashSet<i64> = emitted.into_iter().collect();
        for t in arrived.keys() {
            if !emitted.contains(t) {
                broken.push(format!("{flow}: {t} arrived, never emitted"));
            }
        }
    }
    // once scopes: each outside a window fires and starts a_once once; none starts it twice
    let a_once = said.started.get("a_once").cloned().unwrap_or_default();
    for (began, fired, ended) in said.onces.iter().filter(|o| o.0 >= t0 && o.2 < t_end) {
        let within = a_once
            .iter()
            .filter(|t| **t >= *began && **t <= *ended)
            .count();
        if within > 1 {
            dups.push(format!(
                "once scope at +{:.3} s started a_once {within} times",
                secs(began - t0)
            ));
        }
        let clear = !windows
            .iter()
            .any(|w| w.from < *ended + 500 * MS && w.to > *began);
        let m = &mut minutes_seen[minute_of(*began)];
        if clear {
            let e = m.must.entry("once scopes").or_default();
            e.0 += 1;
            e.1 += (*fired && within == 1) as usize;
            if !(*fired && within == 1) {
                lost.push(format!(
                    "once scope at +{:.3} s: fired {fired}, a_once started {within} times",
                    secs(began - t0)
                ));
            }
        }
    }
    // and a_once starts only with a signal emitted within a scope: never a stale one, never after the scope
    for t in &a_once {
        if !said.onces.iter().any(|(b, _, e)| t >= b && t <= e) {
            broken.push(format!(
                "a_once started with a signal emitted at +{:.3} s, outside every once scope",
                secs(t - t0)
            ));
        }
    }
    // pokes: each outside a window interrupts a_long within 3 s; no interrupt without a poke
    let interrupts: Vec<i64> = said
        .long_exits
        .iter()
        .filter(|(_, why)| why == "interrupted")
        .map(|(t, _)| *t)
        .collect();
    // every interrupt follows a poke, and no poke is followed by two interrupts with no poke between
    let mut pokes_sorted = said.pokes.clone();
    pokes_sorted.sort();
    let mut by_poke: BTreeMap<Option<i64>, Vec<i64>> = BTreeMap::new();
    for t in &interrupts {
        let before = pokes_sorted.iter().rev().find(|p| *p <= t).copied();
        by_poke.entry(before).or_default().push(*t);
    }
    let window_at = |t: i64| {
        window_of(&windows, t)
            .map(|w| windows[w].what.clone())
            .unwrap_or_else(|| "no fault window".into())
    };
    let mut long_runs = said.long_runs.clone();
    long_runs.sort();
    // the signal that started the run an interrupt at `t` ended
    let started_by = |t: i64| {
        long_runs
            .iter()
            .rev()
            .find(|(began, _)| *began <= t)
            .map(|r| r.1)
    };
    let long_starts: Vec<i64> = long_runs.iter().map(|r| r.1).collect();
    for (poke, ts) in &by_poke {
        // rule R14: one U bounds every run of its statement whose start was sent before it, also one that
        // begins after U's first interrupt (a start on its way while U ended the run before): those are the
        // poke's too
        let extra = ts
            .iter()
            .skip(1)
            .filter(|t| poke.is_none_or(|p| started_by(**t).is_none_or(|s| s >= p)))
            .count();
        if poke.is_none() || extra > 0 {
            let starts: Vec<String> = long_starts
                .iter()
                .filter(|s| {
                    poke.is_none_or(|p| **s >= p - 1_000 * MS) && **s <= *ts.last().unwrap()
                })
                .map(|s| format!("+{:.3}", secs(s - t0)))
                .collect();
            broken.push(format!(
                "a_long interrupted {} times after the poke at {} ({}): at {:?}; runs started by signals of {:?}",
                ts.len(),
                poke.map(|p| format!("+{:.3} s", secs(p - t0)))
                    .unwrap_or_else(|| "(none)".into()),
                poke.map(window_at).unwrap_or_default(),
                ts.iter()
                    .map(|t| format!("+{:.3} s ({})", secs(t - t0), window_at(*t)))
                    .collect::<Vec<_>>(),
                starts
            ));
        }
    }
    for p in &said.pokes {
        if in_window(&windows, *p) {
            continue;
        }
        let answered = interrupts.iter().any(|t| *t >= *p && *t < p + 3_000 * MS);
        let e = minutes_seen[minute_of(*p)]
            .must
            .entry("pokes -> until")
            .or_default();
        e.0 += 1;
        e.1 += answered as usize;
        if !answered {
            lost.push(format!(
                "poke at +{:.3} s interrupted nothing",
                secs(p - t0)
            ));
        }
    }
    for (m, minute) in minutes_seen.iter_mut().enumerate() {
        let (from, to) = (t0 + m as i64 * MINUTE, t0 + (m as i64 + 1) * MINUTE);
        let to = if m as i64 == minutes - 1 {
            end_logs
        } else {
            to
        };
        for (role, log) in &all_logs {
            let lines = log.lock().unwrap();
            for (t, l) in lines.iter().filter(|(t, _)| *t >= from && *t < to) {
                let _ = t;
                if l.contains(" ERROR ") || l.contains("panicked") {
                    minute.errors.push(format!("{role}: {l}"));
                } else if l.contains(" WARN ") {
                    minute.warnings += 1;
                }
            }
        }
    }

    // the report
    println!("\nminute | must arrive / arrived per flow | in fault windows: emitted / arrived | duplicates | error lines | warnings");
    for (m, minute) in minutes_seen.iter().enumerate() {
        let flows: Vec<String> = minute
            .must
            .iter()
            .map(|(f, (n, got))| format!("{f} {got}/{n}"))
            .collect();
        println!(
            "{:>6} | {} | {} / {} | {} | {} | {}",
            m + 1,
            flows.join(", "),
            minute.windowed.0,
            minute.windowed.1,
            minute.duplicates,
            minute.errors.len(),
            minute.warnings
        );
    }
    println!("\nminute | RSS MB (heap in use / held by the allocator, MB), fds, CPU % per process");
    for (m, minute) in minutes_seen.iter().enumerate() {
        let u: Vec<String> = minute
            .usage
            .iter()
            .map(|(r, (rss, fds, cpu))| {
                let (used, held) = minute.heap.get(r).copied().unwrap_or_default();
                format!(
                    "{r} {:.2} ({:.2}/{:.2}) {fds} fds {cpu:.1}%",
                    *rss as f64 / 1024.0,
                    used as f64 / 1048576.0,
                    held as f64 / 1048576.0
                )
            })
            .collect();
        println!("{:>6} | {}", m + 1, u.join(", "));
    }
    println!("\nfault window (from 0.5 s before to 6 s after) | signals emitted in it / arrived");
    for (w, (n, got)) in windows.iter().zip(&tally) {
        println!(
            "+{:>7.1} s {:<32} {:>4.1} s | {n} / {got}",
            secs(w.from - t0),
            w.what,
            secs(w.to - w.from)
        );
    }
    let total_must: usize = minutes_seen
        .iter()
        .flat_map(|m| m.must.values())
        .map(|(n, _)| n)
        .sum();
    let total_got: usize = minutes_seen
        .iter()
        .flat_map(|m| m.must.values())
        .map(|(_, g)| g)
        .sum();
    println!(
        "\ntotal: {total_got} of {total_must} that must arrive arrived; {} lost, {} duplicated; {} pokes, {} \
         a_long interrupts; {} once scopes; windows: {}",
        lost.len(),
        dups.len(),
        said.pokes.len(),
        interrupts.len(),
        said.onces.len(),
        windows.len()
    );
    // RSS growth after warm-up (the first two minutes), per long-lived process that was not respawned
    let mut growth_report = Vec::new();
    if minutes_seen.len() >= 3 {
        let span = (minutes_seen.len() - 2) as f64;
        for role in ["robot-a", "bumper", "planner"] {
            let first = minutes_seen[1].usage.get(role).map(|u| u.0);
            let last = minutes_seen.last().unwrap().usage.get(role).map(|u| u.0);
            if let (Some(f), Some(l)) = (first, last) {
                let per10 = (l as f64 - f as f64) / f as f64 * 100.0 / span * 10.0;
                println!("RSS of {role}: {f} kB after warm-up, {l} kB at the end: {per10:+.2}% per 10 min");
                growth_report.push((role, per10));
            }
            let first = minutes_seen[1].heap.get(role).map(|h| h.0);
            let last = minutes_seen.last().unwrap().heap.get(role).map(|h| h.0);
            if let (Some(f), Some(l)) = (first, last) {
                println!(
                    "heap in use of {role}: {} kB after warm-up, {} kB at the end: {:+.1} kB per minute",
                    f / 1024,
                    l / 1024,
                    (l as f64 - f as f64) / 1024.0 / span
                );
            }
        }
    }

    assert!(broken.is_empty(), "broken promises: {broken:#?}");
    assert!(said.odd.is_empty(), "unexpected lines: {:?}", said.odd);
    assert!(lost.is_empty(), "lost: {lost:#?}");
    assert!(dups.is_empty(), "duplicated: {dups:#?}");
    let errors: Vec<&String> = minutes_seen.iter().flat_map(|m| &m.errors).collect();
    assert!(errors.is_empty(), "error lines: {errors:#?}");
    for (role, status) in &stops {
        assert!(status.success(), "{role} on SIGTERM: {status}");
    }
    assert!(total_must > 0, "something was counted");
    if minutes >= 10 {
        for (role, per10) in growth_report {
            assert!(
                per10 < 1.0,
                "{role}'s RSS grows {per10:.2}% per 10 minutes after warm-up"
            );
        }
    }
}

fn secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}

/// A fresh process on host B (`host_pid` holds its namespace) publishes one poke and exits.
async fn poke(host_pid: u32, said: &Arc<Mutex<Said>>) {
    let out = tokio::process::Command::new("nsenter")
        .arg(format!("--net=/proc/{host_pid}/ns/net"))
        .arg(SOAK)
        .arg("poke")
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env("RUST_LOG", log_filter())
        .env("NO_COLOR", "1")
        // as on a robot with ROS sourced (else ros2-client warns at start)
        .env("ROS_DISTRO", "jazzy")
        .kill_on_drop(true)
        .output();
    let out = tokio::time::timeout(Duration::from_secs(60), out)
        .await
        .expect("a poke process ends within 60 s")
        .expect("start radar_test_soak poke");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "poke: {}\n{stdout}\n{stderr}",
        out.status
    );
    for l in stdout.lines() {
        said.lock().unwrap().take(l);
    }
    assert!(
        !stderr.contains(" ERROR "),
        "a poke process logged an error: {stderr}"
    );
}
