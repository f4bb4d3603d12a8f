//! The child processes of a benchmark run. Each role sets up its endpoints, prints `ready`, then serves the
//! coordinator's commands ([`crate::proto`]). Latencies are taken with the shared monotonic clock
//! ([`crate::clock`]): stamped right before a publish (or when an event's check resolves), read where the
//! receiving code begins to run.

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
    ConnectionGuard, Event, EventHandle, FnResponse, Radar, Response, SlotError,
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
        "raw-sink" => raw_sink(&req("--topic")?).await,
        "raw-source" => raw_source(&req("--topic")?).await,
        "raw-forward" => raw_forward(&req("--from")?, &req("--to")?).await,
        "events" => {
            events(
                &req("--names")?,
                opt("--connect"),
                opt("--local-response"),
                flag("--relay"),
            )
            .await
        }
        "response" => response(&req("--name")?, opt("--connect"), flag("--relay")).await,
        "long-response" => long_response(&req("--name")?).await,
        "interrupter" => interrupter(&req("--name")?).await,
        "action-driver" => action_driver(&req("--action")?).await,
        "manager" => manager().await,
        "sources" => sources(&req("--prefix")?, num("--count")?).await,
        "sinks" => sinks(&req("--prefix")?, num("--count")?).await,
        "state-churn" => robustness::state_churn(num("--changes")? as u64).await,
        "raw-latched" => robustness::raw_latched(num("--writes")? as u64).await,
        "service-manager" => robustness::service_manager(&req("--name")?).await,
        "service-caller" => {
            robustness::service_caller(&req("--manager")?, &req("--source")?, &req("--target")?)
                .await
        }
        "scale" => {
            scale(
                num("--events")?,
                num("--responses")?,
                num("--connections")?,
                Duration::from_millis(num("--idle-ms")? as u64),
            )
            .await
        }
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

/// Latencies recorded by a receiver: `(sequence, nanoseconds)`.
#[derive(Clone, Default)]
struct Record(Arc<Mutex<Vec<(u64, u64)>>>);

impl Record {
    fn push(&self, seq: u64, ns: u64) {
        self.0.lock().unwrap().push((seq, ns));
    }
    /// The latencies of samples at or after `warmup`, as JSON, and forgets all.
    fn report(&self, warmup: u64, extra: serde_json::Value) -> String {
        let all = std::mem::take(&mut *self.0.lock().unwrap());
        let lat: Vec<u64> = all
            .iter()
            .filter(|(s, _)| *s >= warmup && *s != u64::MAX)
            .map(|(_, l)| *l)
            .collect();
        json!({ "lat_ns": lat, "received": all.len(), "extra": extra }).to_string()
    }
}

// ---------------------------------------------------------------- raw ros2-client (the baselines)

/// Subscribes to `topic` and records each sample's age when it is taken.
async fn raw_sink(topic: &str) -> Result<()> {
    let (_ctx, mut node) = raw_node("raw_sink")?;
    let sub = raw_subscription(&mut node, topic)?;
    let rec = Record::default();
    let count = Arc::new(AtomicU64::new(0));
    let (r, c) = (rec.clone(), count.clone());
    tokio::spawn(async move {
        let stream = sub.async_stream();
        futures::pin_mut!(stream);
        while let Some(Ok((h, _))) = stream.next().await {
            let age = age_ns(&h);
            r.push(unstamp(&h).0, age);
            c.fetch_add(1, Ordering::Relaxed);
        }
    });
    serve(|w| {
        let (rec, count) = (rec.clone(), count.clone());
        async move {
            match w[0].as_str() {
                "report" => Ok(rec.report(word(&w, 1)?, json!({}))),
                "count" => Ok(count.load(Ordering::Relaxed).to_string()),
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// Publishes stamped samples on `topic`: `wait` (for a subscriber), `run N PERIOD_US` (paced, for latency),
/// `rate PER_SECOND WINDOW_MS` (for throughput).
async fn raw_source(topic: &str) -> Result<()> {
    let (_ctx, mut node) = raw_node("raw_source")?;
    let publisher = Arc::new(raw_publisher(&mut node, topic)?);
    let node = Arc::new(node);
    serve(|w| {
        let (p, node) = (publisher.clone(), node.clone());
        async move {
            match w[0].as_str() {
                "wait" => {
                    tokio::time::timeout(WAIT, p.wait_for_subscription(&node))
                        .await
                        .map_err(|_| anyhow!("no subscriber within {WAIT:?}"))?;
                    Ok("ok".into())
                }
                "run" => {
                    let (n, period): (u64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    paced(n, Duration::from_micros(period), |i| {
                        let _ = p.publish(stamped(i));
                    })
                    .await;
                    Ok(format!("sent {n}"))
                }
                "rate" => {
                    let (rate, ms): (f64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    let sent = at_rate(rate, Duration::from_millis(ms), |i| {
                        let _ = p.publish(stamped(i));
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

/// A plain forwarding node: every sample on `from` is published unchanged on `to` (the floor for any relay).
async fn raw_forward(from: &str, to: &str) -> Result<()> {
    let (_ctx, mut node) = raw_node("raw_forward")?;
    let sub = raw_subscription(&mut node, from)?;
    let publisher = raw_publisher(&mut node, to)?;
    tokio::spawn(async move {
        let stream = sub.async_stream();
        futures::pin_mut!(stream);
        while let Some(Ok((h, _))) = stream.next().await {
            let _ = publisher.publish(h);
        }
    });
    serve(|w| async move { bail!("unknown command {}", w[0]) }).await;
    Ok(())
}

// ---------------------------------------------------------------- radar_ros components

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

/// An event whose check resolves when the coordinator feeds it a sequence number, stamped at that moment:
/// the time the condition "became true".
struct Fed {
    rx: mpsc::UnboundedReceiver<u64>,
}

impl Event for Fed {
    type Payload = Header;
    async fn check(&mut self) -> Result<Header, SlotError> {
        match self.rx.recv().await {
            Some(seq) => Ok(stamped(seq)),
            None => futures::future::pending().await,
        }
    }
}

/// A running [`Fed`] event and the way to feed it.
type FedEvent = (EventHandle, mpsc::UnboundedSender<u64>);

/// Events named in `names` (comma-separated); `run NAME N PERIOD_US` makes NAME trigger N times,
/// `spawn NAME` starts another event (answering the clock time the spawn began), `active NAME` waits until
/// NAME has a listener, `inactive NAME` until it has none (answering when). With `--connect RESPONSE` this
/// process makes `whenever FIRST start RESPONSE` itself (the manager embedded in the event's process); with
/// `--local-response NAME` it also runs the recording response NAME (as the role `response` does, answering
/// `report`) and connects FIRST to it: event, manager and response in one process.
async fn events(
    names: &str,
    connect: Option<String>,
    local_response: Option<String>,
    relay: bool,
) -> Result<()> {
    let radar = radar_relaying(relay)?;
    let all: Arc<Mutex<HashMap<String, FedEvent>>> = Default::default();
    let spawn = {
        let (radar, all) = (radar.clone(), all.clone());
        move |name: &str| -> Result<()> {
            let (tx, rx) = mpsc::unbounded_channel();
            let h = radar.spawn_event(name, Fed { rx })?;
            all.lock().unwrap().insert(name.to_owned(), (h, tx));
            Ok(())
        }
    };
    for n in names.split(',').filter(|n| !n.is_empty()) {
        spawn(n)?;
    }
    let first = names.split(',').next().unwrap_or_default();
    let recorder = match &local_response {
        Some(name) => Some(recorder(&radar, name)?),
        None => None,
    };
    let _conn: Option<ConnectionGuard> = match connect.or(local_response) {
        None => None,
        Some(resp) => {
            let r = radar.response(&resp).timeout(WAIT).await?;
            let triggered = all.lock().unwrap()[first].0.triggered();
            Some(radar.whenever(triggered).start(&r).timeout(WAIT).await?)
        }
    };
    serve(|w| {
        let (all, spawn) = (all.clone(), spawn.clone());
        let rec = recorder.as_ref().map(|(h, rec)| (rec.clone(), h.state()));
        async move {
            if let (Some((rec, state)), "report") = (rec, w[0].as_str()) {
                return Ok(rec.report(
                    word(&w, 1)?,
                    json!({ "ignored_starts": state.ignored_starts, "starts": state.starts }),
                ));
            }
            let name: String = word(&w, 1)?;
            match w[0].as_str() {
                "spawn" => {
                    let t = now_ns();
                    spawn(&name)?;
                    Ok(format!("spawned {t}"))
                }
                "run" => {
                    let (n, period): (u64, u64) = (word(&w, 2)?, word(&w, 3)?);
                    let tx = all
                        .lock()
                        .unwrap()
                        .get(&name)
                        .map(|(_, tx)| tx.clone())
                        .ok_or_else(|| anyhow!("no event {name}"))?;
                    paced(n, Duration::from_micros(period), |i| {
                        let _ = tx.send(i);
                    })
                    .await;
                    Ok(format!("sent {n}"))
                }
                "active" => {
                    let mut st = all
                        .lock()
                        .unwrap()
                        .get(&name)
                        .map(|(h, _)| h.watch_state())
                        .ok_or_else(|| anyhow!("no event {name}"))?;
                    tokio::time::timeout(WAIT, st.wait_for(|s| s.active))
                        .await
                        .map_err(|_| anyhow!("{name} got no listener within {WAIT:?}"))??;
                    Ok("ok".into())
                }
                // waits (up to 2 min: a dead listener goes with its lease) until NAME has no listener, and
                // answers when that was noticed, on the shared clock
                "inactive" => {
                    let mut st = all
                        .lock()
                        .unwrap()
                        .get(&name)
                        .map(|(h, _)| h.watch_state())
                        .ok_or_else(|| anyhow!("no event {name}"))?;
                    tokio::time::timeout(Duration::from_secs(120), st.wait_for(|s| !s.active))
                        .await
                        .map_err(|_| anyhow!("{name} kept a listener for 2 min"))??;
                    Ok(now_ns().to_string())
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// A response whose start behaviour records how long ago its payload was stamped, the moment it begins to
/// run. With `--connect EVENT` this process also makes `whenever EVENT start` itself (the embedded manager);
/// `--relay`: through a DDS writer on its own `start` (two hops), not directly.
async fn response(name: &str, connect: Option<String>, relay: bool) -> Result<()> {
    let radar = radar_relaying(relay)?;
    let (handle, rec) = recorder(&radar, name)?;
    let _conn: Option<ConnectionGuard> = match connect {
        None => None,
        Some(ev) => {
            let ev = radar.event(&ev).timeout(WAIT).await?;
            Some(
                radar
                    .whenever(ev.triggered())
                    .start(&handle)
                    .timeout(WAIT)
                    .await?,
            )
        }
    };
    serve(|w| {
        let (rec, state) = (rec.clone(), handle.state());
        async move {
            match w[0].as_str() {
                "report" => Ok(rec.report(
                    word(&w, 1)?,
                    json!({ "ignored_starts": state.ignored_starts, "starts": state.starts }),
                )),
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// The response `name` whose start behaviour records how long ago its payload was stamped.
fn recorder(radar: &Radar, name: &str) -> Result<(radar_ros::ResponseHandle, Record)> {
    let rec = Record::default();
    let r = rec.clone();
    let handle = radar.spawn_response(
        name,
        FnResponse::new(move |h: Header| {
            let r = r.clone();
            async move {
                r.push(unstamp(&h).0, age_ns(&h));
                Ok::<_, SlotError>(Empty::default())
            }
        }),
    )?;
    Ok((handle, rec))
}

/// A response whose start behaviour runs until interrupted; its interrupt slot records when it begins (that
/// is when `interrupted` is emitted), with the sequence number of the run.
struct Long {
    seq: u64,
    rec: Record,
}

impl Response for Long {
    type Start = Header;
    type Output = Empty;
    async fn start(&mut self, h: Header) -> Result<Empty, SlotError> {
        self.seq = unstamp(&h).0;
        futures::future::pending().await
    }
    async fn interrupt(&mut self) {
        self.rec.push(self.seq, now_ns());
    }
}

async fn long_response(name: &str) -> Result<()> {
    let radar = radar()?;
    let rec = Record::default();
    let _h = radar.spawn_response(
        name,
        Long {
            seq: 0,
            rec: rec.clone(),
        },
    )?;
    serve(|w| {
        let rec = rec.clone();
        async move {
            match w[0].as_str() {
                // the interrupt times themselves (not ages): the coordinator pairs them with the send times
                "report" => {
                    let all = std::mem::take(&mut *rec.0.lock().unwrap());
                    Ok(json!({ "at": all }).to_string())
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// Drives a response through start, `started`, interrupt, `interrupted`, `exited`, N times: `run N`
/// answers the clock time each interrupt was published, by run.
async fn interrupter(name: &str) -> Result<()> {
    let radar = radar()?;
    let resp = radar.response(name).timeout(WAIT).await?;
    let topic = |e: &str| resp.name().topic(e);
    let start = radar.signal_publisher::<Header>(&topic("start"))?;
    let interrupt = radar.signal_publisher::<Empty>(&topic("interrupt"))?;
    let started = radar.signal_subscription::<Header>(&topic("started"))?;
    let interrupted = radar.signal_subscription::<Empty>(&topic("interrupted"))?;
    let exited = radar.signal_subscription::<Empty>(&topic("exited"))?;
    start.wait_for_subscribers(1).timeout(WAIT).await?;
    interrupt.wait_for_subscribers(1).timeout(WAIT).await?;
    for s in [&interrupted, &exited] {
        s.wait_for_publishers(1).timeout(WAIT).await?;
    }
    started.wait_for_publishers(1).timeout(WAIT).await?;
    let step = Duration::from_secs(2);
    serve(|w| {
        let (start, interrupt, started, interrupted, exited) =
            (&start, &interrupt, &started, &interrupted, &exited);
        async move {
            if w[0] != "run" {
                bail!("unknown command {}", w[0]);
            }
            let n: u64 = word(&w, 1)?;
            let mut sent = Vec::new();
            let mut lost = 0u64;
            for i in 0..n {
                start.publish(stamped(i))?;
                match started.recv().timeout(step).await {
                    Ok(h) if unstamp(&h).0 == i => {}
                    _ => {
                        lost += 1;
                        continue;
                    }
                }
                // let the start behaviour reach its await point, as a running behaviour would be
                tokio::time::sleep(Duration::from_millis(1)).await;
                let t0 = now_ns();
                interrupt.publish(Empty::default())?;
                if interrupted.recv().timeout(step).await.is_err()
                    || exited.recv().timeout(step).await.is_err()
                {
                    lost += 1;
                    continue;
                }
                sent.push((i, t0));
            }
            Ok(json!({ "sent": sent, "lost": lost }).to_string())
        }
    })
    .await;
    Ok(())
}

/// An action server driven as a RADAR response (`Radar::action_response`): `run N` publishes `start` with
/// goals 0..N, one after the other (each to its `exited`); `cancel-run N` starts long goals (order -(k+1)) and
/// publishes `interrupt` once each one's first feedback arrives. Answers when each `start` / `interrupt` was
/// published, for the server's record to be matched against.
async fn action_driver(action: &str) -> Result<()> {
    use radar_ros::action::{Fibonacci, FibonacciFeedback, FibonacciGoal, FibonacciResult};
    let radar = radar()?;
    let fib = radar.action_response_with::<Fibonacci>(
        action,
        radar_ros::action::ActionResponseOptions::default()
            .named("/bench/action_driver")
            .server_timeout(WAIT),
    )?;
    let r = fib.reference();
    let start = radar.signal_publisher::<FibonacciGoal>(r.start_slot().topic())?;
    let interrupt = radar.signal_publisher::<Empty>(r.interrupt_slot().topic())?;
    let started = radar.signal_subscription::<FibonacciGoal>(r.started().topic())?;
    let exited = radar.signal_subscription::<FibonacciResult>(r.exited().topic())?;
    let feedback = radar.signal_subscription::<FibonacciFeedback>(fib.feedback().topic())?;
    start.wait_for_subscribers(1).timeout(WAIT).await?;
    interrupt.wait_for_subscribers(1).timeout(WAIT).await?;
    started.wait_for_publishers(1).timeout(WAIT).await?;
    exited.wait_for_publishers(1).timeout(WAIT).await?;
    feedback.wait_for_publishers(1).timeout(WAIT).await?;
    serve(|w| {
        let (start, interrupt, started, exited, feedback) =
            (&start, &interrupt, &started, &exited, &feedback);
        async move {
            let n: u64 = word(&w, 1)?;
            let mut sent = Vec::new();
            for i in 0..n as i32 {
                match w[0].as_str() {
                    "run" => {
                        let t0 = now_ns();
                        start.publish(FibonacciGoal { order: i })?;
                        exited.recv().timeout(WAIT).await?;
                        sent.push((i, t0));
                    }
                    "cancel-run" => {
                        start.publish(FibonacciGoal { order: -(i + 1) })?;
                        started.recv().timeout(WAIT).await?;
                        feedback.recv().timeout(WAIT).await?;
                        let t0 = now_ns();
                        interrupt.publish(Empty::default())?;
                        exited.recv().timeout(WAIT).await?;
                        sent.push((i, t0));
                    }
                    c => bail!("unknown command {c}"),
                }
            }
            Ok(json!({ "sent": sent }).to_string())
        }
    })
    .await;
    Ok(())
}

/// A deliberative program with the embedded manager, in its own process: makes and drops connections
/// between components in other processes, and times it.
async fn manager() -> Result<()> {
    let radar = radar()?;
    let held: Arc<Mutex<Vec<ConnectionGuard>>> = Default::default();
    serve(|w| {
        let (radar, held) = (radar.clone(), held.clone());
        async move {
            match w[0].as_str() {
                "connect" => {
                    let (ev, resp): (String, String) = (word(&w, 1)?, word(&w, 2)?);
                    let ev = radar.event(&ev).timeout(WAIT).await?;
                    let resp = radar.response(&resp).timeout(WAIT).await?;
                    let c = radar
                        .whenever(ev.triggered())
                        .start(&resp)
                        .timeout(WAIT)
                        .await?;
                    held.lock().unwrap().push(c);
                    Ok("armed".into())
                }
                "connect-many" => {
                    let (src, sink, n): (String, String, usize) =
                        (word(&w, 1)?, word(&w, 2)?, word(&w, 3)?);
                    let t = now_ns();
                    let made: Vec<ConnectionGuard> = futures::stream::iter(0..n)
                        .map(|i| {
                            let (radar, src, sink) = (radar.clone(), src.clone(), sink.clone());
                            async move {
                                let ev = radar.event(&format!("{src}_{i}")).timeout(WAIT).await?;
                                let r =
                                    radar.response(&format!("{sink}_{i}")).timeout(WAIT).await?;
                                radar
                                    .whenever(ev.triggered())
                                    .start(&r)
                                    .timeout(WAIT)
                                    .await
                                    .map_err(anyhow::Error::from)
                            }
                        })
                        .buffer_unordered(32)
                        .try_collect()
                        .await?;
                    held.lock().unwrap().extend(made);
                    Ok(format!("armed {}", (now_ns() - t) / 1_000_000))
                }
                "drop" => {
                    held.lock().unwrap().clear();
                    Ok("ok".into())
                }
                "setup-live" | "setup-known" => {
                    let (ev, resp, m): (String, String, usize) =
                        (word(&w, 1)?, word(&w, 2)?, word(&w, 3)?);
                    setup_loop(&radar, &ev, &resp, m, w[0] == "setup-live").await
                }
                "setup-fresh" => {
                    let (ev, resp): (String, String) = (word(&w, 1)?, word(&w, 2)?);
                    let r = radar.response(&resp).timeout(WAIT).await?;
                    let e = radar.event(&ev).timeout(WAIT).await?;
                    let found = now_ns();
                    let c = radar
                        .whenever(e.triggered())
                        .start(&r)
                        .timeout(WAIT)
                        .await?;
                    let armed = now_ns();
                    drop(c);
                    Ok(json!({ "found": found, "armed": armed }).to_string())
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// Times `whenever EV start RESP` to armed, dropping the guard, and the drop to the event going inactive,
/// `m` times. `live`: another connection from EV stays armed meanwhile (its relay reader is reused; the event
/// never deactivates, so that time is not taken).
async fn setup_loop(radar: &Radar, ev: &str, resp: &str, m: usize, live: bool) -> Result<String> {
    let e = radar.event(ev).timeout(WAIT).await?;
    let r = radar.response(resp).timeout(WAIT).await?;
    let state = radar.state_subscription::<EventState>(&e.name().topic("state"))?;
    state.wait_for_publishers(1).timeout(WAIT).await?;
    let keep = if live {
        Some(
            radar
                .whenever(e.triggered())
                .start(&r)
                .timeout(WAIT)
                .await?,
        )
    } else {
        None
    };
    let wait_state = |active: bool| {
        let state = &state;
        async move {
            let deadline = tokio::time::Instant::now() + WAIT;
            loop {
                let left = deadline.saturating_duration_since(tokio::time::Instant::now());
                let s = state.recv().timeout(left).await?;
                if s.active == active {
                    return Ok::<(), anyhow::Error>(());
                }
            }
        }
    };
    let (mut setup, mut activate, mut disconnect, mut deactivate) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for _ in 0..m {
        let t0 = now_ns();
        let c = radar
            .whenever(e.triggered())
            .start(&r)
            .timeout(WAIT)
            .await?;
        let t1 = now_ns();
        setup.push(t1 - t0);
        if !live {
            wait_state(true).await?;
            activate.push(now_ns() - t1);
        }
        let t2 = now_ns();
        drop(c);
        let t3 = now_ns();
        disconnect.push(t3 - t2);
        if !live {
            wait_state(false).await?;
            deactivate.push(now_ns() - t3);
        }
    }
    drop(keep);
    Ok(
        json!({ "setup": setup, "activate": activate, "disconnect": disconnect,
               "deactivate": deactivate })
        .to_string(),
    )
}

/// Publishers on `PREFIX_i/triggered` (what an event looks like on the graph), driven at a fixed total rate
/// spread over all of them: `wait`, `rate PER_SECOND WINDOW_MS`.
async fn sources(prefix: &str, count: usize) -> Result<()> {
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
async fn sinks(prefix: &str, count: usize) -> Result<()> {
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

// ---------------------------------------------------------------- scale, in one process

/// An event that never triggers: checking costs nothing but its await.
struct Idle;

impl Event for Idle {
    type Payload = radar_ros::msg::Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        futures::future::pending().await
    }
}

fn cpu_self() -> Duration {
    crate::proto::cpu_time(std::process::id()).unwrap_or_default()
}

/// Raises this process's open-file limit as far as allowed (to 65536 when permitted; RustDDS holds a few
/// descriptors per reader and writer), and returns the soft limit in force.
fn raise_fd_limit() -> libc::rlim_t {
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
fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd")
        .map(|d| d.count())
        .unwrap_or(0)
}

/// CPU share of one core this process used over `window` of doing nothing.
async fn idle_cpu(window: Duration) -> f64 {
    let c0 = cpu_self();
    tokio::time::sleep(window).await;
    (cpu_self() - c0).as_secs_f64() / window.as_secs_f64()
}

/// `events` events, `responses` responses and `connections` connections in one process: memory, idle CPU,
/// time to create and tear down. Answers one JSON line as its `ready`-time report to `report`.
async fn scale(events: usize, responses: usize, connections: usize, idle: Duration) -> Result<()> {
    let fd_limit = raise_fd_limit();
    let radar = radar()?;
    let rss0 = rss_bytes();
    let fds0 = open_fds();
    let cpu_empty = idle_cpu(idle).await;
    let t = now_ns();
    let evs: Vec<EventHandle> = (0..events)
        .map(|i| radar.spawn_event(&format!("/scale/ev_{i}"), Idle))
        .collect::<radar_ros::Result<_>>()?;
    let events_ms = (now_ns() - t) as f64 / 1e6;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let rss_events = rss_bytes();
    let t_resp = now_ns();
    let resps: Vec<_> = (0..responses)
        .map(|i| {
            radar.spawn_response(
                &format!("/scale/resp_{i}"),
                FnResponse::new(|_: Empty| async { Ok::<_, SlotError>(Empty::default()) }),
            )
        })
        .collect::<radar_ros::Result<_>>()?;
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
    tokio::time::sleep(Duration::from_millis(500)).await;
    let rss2 = rss_bytes();
    let active = evs.iter().filter(|e| e.state().active).count();
    let cpu_connected = idle_cpu(idle).await;
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
        "spawn_ms": spawn_ms, "connect_ms": connect_ms, "drop_ms": drop_ms,
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
