//! The scale roles: many sources and sinks, and many components in one process with their idle cost.

use super::*;

/// Publishers on `PREFIX_i/triggered` (what an event looks like on the graph), driven at a fixed total rate
/// spread over all of them: `wait`, `rate PER_SECOND WINDOW_MS`.
pub(super) async fn sources(prefix: &str, count: usize) -> Result<()> {
    let radar = radar()?;
    let pubs: Arc<Vec<_>> = Arc::new(
        (0..count)
            .map(|i| radar.signal_publisher::<Header>(&format!("{prefix}_{i}/triggered")))
            .collect::<radar_ros::Result<_>>()?,
    );
    serve(|w| {
        let pubs = pubs.clone();
        async move {
            match w[0].as_str() {
                "wait" => {
                    for p in pubs.iter() {
                        p.wait_for_subscribers(1).timeout(WAIT).await?;
                    }
                    Ok("ok".into())
                }
                "rate" => {
                    let (rate, ms): (f64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    let n = pubs.len() as u64;
                    let sent = at_rate(rate, Duration::from_millis(ms), |i| {
                        let _ = pubs[(i % n) as usize].publish(stamped(i));
                    })
                    .await;
                    Ok(sent.to_string())
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// What a response looks like on the graph (a `PREFIX_i/start` subscription and a `PREFIX_i/exited`
/// publisher), counting every `start` it receives: `count`.
pub(super) async fn sinks(prefix: &str, count: usize) -> Result<()> {
    let radar = radar()?;
    let total = Arc::new(AtomicU64::new(0));
    let mut keep = Vec::new();
    for i in 0..count {
        let sub = radar.signal_subscription::<Header>(&format!("{prefix}_{i}/start"))?;
        keep.push(radar.signal_publisher::<Empty>(&format!("{prefix}_{i}/exited"))?);
        let t = total.clone();
        tokio::spawn(async move {
            while sub.recv().await.is_ok() {
                t.fetch_add(1, Ordering::Relaxed);
            }
        });
    }
    serve(|w| {
        let total = total.clone();
        async move {
            match w[0].as_str() {
                "count" => Ok(total.load(Ordering::Relaxed).to_string()),
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    drop(keep);
    Ok(())
}

/// An event that never triggers: checking costs nothing but its await.
pub(super) struct Idle;

impl Event for Idle {
    type Payload = radar_ros::msg::Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        futures::future::pending().await
    }
}

/// Spawns `n` components with `spawn`, one after the other, and times the first and the last tenth of them:
/// milliseconds per component in each (flat in N when the two are alike; the process holds nine tenths more
/// in the last).
fn spawn_timed<T>(
    n: usize,
    mut spawn: impl FnMut(usize) -> radar_ros::Result<T>,
) -> radar_ros::Result<(Vec<T>, (f64, f64))> {
    let tenth = (n / 10).max(1);
    let mut made = Vec::with_capacity(n);
    let (mut first, mut last) = (f64::NAN, f64::NAN);
    let mut t = now_ns();
    for i in 0..n {
        if i == n.saturating_sub(tenth) {
            t = now_ns();
        }
        made.push(spawn(i)?);
        if i + 1 == tenth {
            first = (now_ns() - t) as f64 / 1e6 / tenth as f64;
        }
    }
    if n > 0 {
        last = (now_ns() - t) as f64 / 1e6 / tenth as f64;
    }
    Ok((made, (first, last)))
}

pub(super) fn cpu_self() -> Duration {
    crate::proto::cpu_time(std::process::id()).unwrap_or_default()
}

/// Raises this process's open-file limit as far as allowed (to 65536 when permitted; RustDDS holds a few
/// descriptors per reader and writer), and returns the soft limit in force.
pub(super) fn raise_fd_limit() -> libc::rlim_t {
    let mut l = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit/setrlimit read and write the struct we own.
    unsafe {
        libc::getrlimit(libc::RLIMIT_NOFILE, &mut l);
        let want = l.rlim_max.max(65536);
        let raised = libc::rlimit {
            rlim_cur: want,
            rlim_max: want,
        };
        if libc::setrlimit(libc::RLIMIT_NOFILE, &raised) != 0 {
            // not allowed above the hard limit: go up to it
            l.rlim_cur = l.rlim_max;
            libc::setrlimit(libc::RLIMIT_NOFILE, &l);
        }
        libc::getrlimit(libc::RLIMIT_NOFILE, &mut l);
    }
    l.rlim_cur
}

/// File descriptors this process holds.
pub(super) fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd")
        .map(|d| d.count())
        .unwrap_or(0)
}

/// CPU share of one core this process used over `window` of doing nothing.
pub(super) async fn idle_cpu(window: Duration) -> f64 {
    let c0 = cpu_self();
    tokio::time::sleep(window).await;
    (cpu_self() - c0).as_secs_f64() / window.as_secs_f64()
}

/// `events` events, `responses` responses and `connections` connections in one process: memory, idle CPU,
/// time to create and tear down. Answers one JSON line as its `ready`-time report to `report`.
pub(super) async fn scale(
    events: usize,
    responses: usize,
    connections: usize,
    idle: Duration,
    (settle, settled): (Duration, Duration),
) -> Result<()> {
    let fd_limit = raise_fd_limit();
    let radar = radar()?;
    let rss0 = rss_bytes();
    let fds0 = open_fds();
    let cpu_empty = idle_cpu(idle).await;
    let t = now_ns();
    let (evs, ev_tenths): (Vec<EventHandle>, _) = spawn_timed(events, |i| {
        radar.spawn_event(&format!("/scale/ev_{i}"), Idle)
    })?;
    let events_ms = (now_ns() - t) as f64 / 1e6;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let rss_events = rss_bytes();
    let t_resp = now_ns();
    let (resps, resp_tenths): (Vec<_>, _) = spawn_timed(responses, |i| {
        radar.spawn_response(
            &format!("/scale/resp_{i}"),
            FnResponse::new(|_: Empty| async { Ok::<_, SlotError>(Empty::default()) }),
        )
    })?;
    let spawn_ms = events_ms + (now_ns() - t_resp) as f64 / 1e6;
    let fds1 = open_fds();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let rss1 = rss_bytes();
    let cpu_components = idle_cpu(idle).await;
    // event e connects to responses e, e+1, ...: distinct pairs, every component used
    let pairs: Vec<(usize, usize)> = (0..connections)
        .map(|j| (j % events, (j % events + j / events) % responses))
        .collect();
    let t = now_ns();
    let made: Vec<ConnectionGuard> = futures::stream::iter(pairs)
        .map(|(e, r)| {
            let radar = radar.clone();
            let (sig, resp) = (evs[e].triggered(), resps[r].reference().clone());
            async move {
                radar
                    .whenever(sig)
                    .start(&resp)
                    .timeout(Duration::from_secs(60))
                    .await
            }
        })
        .buffer_unordered(64)
        .try_collect()
        .await?;
    let connect_ms = (now_ns() - t) as f64 / 1e6;
    let connected_at = tokio::time::Instant::now();
    if std::env::var_os("RADAR_BENCH_HOLD_S").is_some() {
        eprintln!("scale: connected");
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let rss2 = rss_bytes();
    let active = evs.iter().filter(|e| e.state().active).count();
    let cpu_connected = idle_cpu(idle).await;
    // the same once discovery has settled: what the new matches set going (a first heartbeat per matched
    // writer, cache cleaning, `ros_discovery_info`) is over within about 10 s; measured `settle` after the last
    // connection was armed, over `settled`
    tokio::time::sleep_until(connected_at + settle).await;
    let cpu_settled = idle_cpu(settled).await;
    let settle_ms = settle.as_secs_f64() * 1e3;
    // for profiling the idle connected process (`perf record -p PID`): stay so this long
    if let Some(hold) = std::env::var("RADAR_BENCH_HOLD_S")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        eprintln!(
            "scale: {} components connected and settled in process {}; holding {hold} s",
            events + responses,
            std::process::id()
        );
        tokio::time::sleep(Duration::from_secs(hold)).await;
    }
    let t = now_ns();
    drop(made);
    let drop_ms = (now_ns() - t) as f64 / 1e6;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
    while evs.iter().any(|e| e.state().active) && tokio::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let inactive_ms = (now_ns() - t) as f64 / 1e6;
    let still_active = evs.iter().filter(|e| e.state().active).count();
    let report = json!({
        "events": events, "responses": responses, "connections": connections,
        "rss_empty_bytes": rss0, "rss_components_bytes": rss1, "rss_connected_bytes": rss2,
        "bytes_per_connection": (rss2 as f64 - rss1 as f64) / connections.max(1) as f64,
        "bytes_per_component": (rss1 as f64 - rss0 as f64) / (events + responses).max(1) as f64,
        "bytes_per_event": (rss_events as f64 - rss0 as f64) / events.max(1) as f64,
        "bytes_per_response": (rss1 as f64 - rss_events as f64) / responses.max(1) as f64,
        "rss_events_bytes": rss_events,
        "fd_limit": fd_limit, "fds_participant": fds0, "fds_components": fds1,
        "cpu_idle_empty": cpu_empty, "cpu_idle_components": cpu_components,
        "cpu_idle_connected": cpu_connected,
        "cpu_idle_connected_settled": cpu_settled, "settle_ms": settle_ms,
        "spawn_ms": spawn_ms, "connect_ms": connect_ms, "drop_ms": drop_ms,
        "spawn_event_first_tenth_ms": ev_tenths.0, "spawn_event_last_tenth_ms": ev_tenths.1,
        "spawn_response_first_tenth_ms": resp_tenths.0,
        "spawn_response_last_tenth_ms": resp_tenths.1,
        "all_inactive_ms": inactive_ms, "active_while_connected": active,
        "still_active_after_teardown": still_active,
    });
    serve(|w| {
        let report = report.clone();
        async move {
            match w[0].as_str() {
                "report" => Ok(report.to_string()),
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    drop((evs, resps));
    Ok(())
}

/// `events` events and `responses` responses under `/disc/` (the graph a joining program discovers), up before
/// `ready`; then serves until `quit`.
pub(super) async fn components(events: usize, responses: usize) -> Result<()> {
    raise_fd_limit();
    let radar = radar()?;
    let _evs = (0..events)
        .map(|i| radar.spawn_event(&format!("/disc/ev_{i}"), Idle))
        .collect::<radar_ros::Result<Vec<_>>>()?;
    let _resps = (0..responses)
        .map(|i| {
            radar.spawn_response(
                &format!("/disc/resp_{i}"),
                FnResponse::new(|_: Empty| async { Ok::<_, SlotError>(Empty::default()) }),
            )
        })
        .collect::<radar_ros::Result<Vec<_>>>()?;
    serve(|w| async move { bail!("unknown command {:?}", w.join(" ")) }).await;
    Ok(())
}

/// A program joining a graph: `wait N` answers how long after this process made its `Radar` it listed at least
/// `N` components (`Radar::components`, looked at every 5 ms), as `{"ns": .., "seen": ..}`.
pub(super) async fn discover() -> Result<()> {
    let t0 = now_ns();
    let radar = radar()?;
    serve(|w| {
        let radar = radar.clone();
        async move {
            match w[0].as_str() {
                "wait" => {
                    let n: usize = word(&w, 1)?;
                    let deadline = tokio::time::Instant::now() + Duration::from_secs(300);
                    loop {
                        let seen = radar.components().len();
                        if seen >= n {
                            return Ok(json!({ "ns": now_ns() - t0, "seen": seen }).to_string());
                        }
                        if tokio::time::Instant::now() > deadline {
                            bail!("saw {seen} of {n} components in 300 s");
                        }
                        tokio::time::sleep(Duration::from_millis(5)).await;
                    }
                }
                other => bail!("unknown command {other:?}"),
            }
        }
    })
    .await;
    Ok(())
}
