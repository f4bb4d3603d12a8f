//! The radar_ros roles of the latency scenarios: events, responses, an interrupter, an action driver.

use super::*;

/// An event whose check resolves when the coordinator feeds it a sequence number, stamped at that moment:
/// the time the condition "became true".
pub(super) struct Fed {
    rx: mpsc::UnboundedReceiver<u64>,
    /// The first check resolves at once, stamped with this time (sequence number 0): when the coordinator
    /// started this process (`--born`); later ones never do. A condition already true when the program
    /// connects it: its one trigger is emitted as the statement's reader activates the event, before the
    /// statement is armed, and is delivered (C1 counts from when the statement began).
    born: Option<u64>,
    /// With `--trigger`: each check's [`Trigger`] goes to the pacing loop, which emits through it itself and
    /// continues (`Trigger::emit_and_continue`: each emission is one check's value and begins the next), and
    /// the check never resolves by itself (instead of resolving with a value fed through `rx`).
    triggers: Option<mpsc::UnboundedSender<Trigger<Header>>>,
}

/// The pacing loop's end of a `--trigger` event: the triggers its checks hand over, and the one it emits
/// through now.
pub(super) struct Paced {
    from_checks: mpsc::UnboundedReceiver<Trigger<Header>>,
    current: Option<Trigger<Header>>,
}

impl Event for Fed {
    type Payload = Header;
    fn before_check(&mut self, trigger: Trigger<Header>) {
        if let Some(t) = &self.triggers {
            let _ = t.send(trigger);
        }
    }
    async fn check(&mut self) -> Result<Header, SlotError> {
        if let Some(t) = self.born.take() {
            let mut h = stamped(0);
            h.stamp.sec = (t / 1_000_000_000) as i32;
            h.stamp.nanosec = (t % 1_000_000_000) as u32;
            return Ok(h);
        }
        if self.triggers.is_some() {
            // the loop emits through this check's trigger and continues
            return futures::future::pending().await;
        }
        match self.rx.recv().await {
            Some(seq) => Ok(stamped(seq)),
            None => futures::future::pending().await,
        }
    }
}

/// `run` of a `--trigger` event: `n` triggers `period` apart, each stamped and emitted by this (the pacing)
/// task through the running check's trigger, which continues, as raw ros2-client's source publishes from its
/// pacing loop. A trigger whose check was dropped meanwhile (the event deactivated) is left for the next
/// check's.
async fn run_triggers(paced: &tokio::sync::Mutex<Paced>, n: u64, period: Duration) -> Result<()> {
    let mut paced = paced.lock().await;
    let start = tokio::time::Instant::now();
    for i in 0..n {
        tokio::time::sleep_until(start + period * i as u32).await;
        let mut h = stamped(i);
        loop {
            let t = match paced.current.take() {
                Some(t) => t,
                None => paced
                    .from_checks
                    .recv()
                    .await
                    .ok_or_else(|| anyhow!("the event stopped"))?,
            };
            match t.emit_and_continue(h) {
                Ok(()) => {
                    paced.current = Some(t);
                    break;
                }
                Err(back) => h = back,
            }
        }
    }
    Ok(())
}

/// A running [`Fed`] event and the way to feed it.
type FedEvent = (EventHandle, mpsc::UnboundedSender<u64>);

/// Events named in `names` (comma-separated); `run NAME N PERIOD_US` makes NAME trigger N times,
/// `spawn NAME` starts another event (answering the clock time the spawn began), `active NAME` waits until
/// NAME has a listener, `inactive NAME` until it has none (answering when). With `--connect RESPONSE` this
/// process makes `whenever FIRST start RESPONSE` itself (the manager embedded in the event's process); with
/// `--local-response NAME` it also runs the recording response NAME (as the role `response` does, answering
/// `report`) and connects FIRST to it: event, manager and response in one process. With `--born NS` (when
/// the coordinator started this process) FIRST triggers once, as soon as something listens, stamped NS. With
/// `--trigger`, `run FIRST N PERIOD_US` emits FIRST's triggers from the pacing task itself, through each
/// check's [`Trigger`] (as raw ros2-client's source publishes from its pacing loop), instead of feeding them to
/// the check.
pub(super) async fn events(
    names: &str,
    connect: Option<String>,
    local_response: Option<String>,
    relay: bool,
    born: Option<u64>,
    trigger: bool,
) -> Result<()> {
    let radar = radar_relaying(relay)?;
    let all: Arc<Mutex<HashMap<String, FedEvent>>> = Default::default();
    let born = Arc::new(Mutex::new(born));
    // with `--trigger`, the first event's checks hand their triggers to `run`
    let (to_loop, from_checks) = mpsc::unbounded_channel();
    let by_trigger = Arc::new(tokio::sync::Mutex::new(Paced {
        from_checks,
        current: None,
    }));
    let pacing = Arc::new(Mutex::new(trigger.then_some(to_loop)));
    let paced_name = names.split(',').next().unwrap_or_default().to_owned();
    let spawn = {
        let (radar, all) = (radar.clone(), all.clone());
        move |name: &str| -> Result<()> {
            let (tx, rx) = mpsc::unbounded_channel();
            let born = born.lock().unwrap().take();
            let triggers = match name == paced_name {
                true => pacing.lock().unwrap().take(),
                false => None,
            };
            let h = radar.spawn_event(name, Fed { rx, born, triggers })?;
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
        let by_trigger = by_trigger.clone();
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
                "run" if trigger => {
                    let (n, period): (u64, u64) = (word(&w, 2)?, word(&w, 3)?);
                    run_triggers(&by_trigger, n, Duration::from_micros(period)).await?;
                    Ok(format!("sent {n}"))
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
pub(super) async fn response(name: &str, connect: Option<String>, relay: bool) -> Result<()> {
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
pub(super) fn recorder(radar: &Radar, name: &str) -> Result<(radar_ros::ResponseHandle, Record)> {
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
pub(super) struct Long {
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

pub(super) async fn long_response(name: &str) -> Result<()> {
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
                    let all: Vec<(u64, u64)> = std::mem::take(&mut *rec.0.lock().unwrap())
                        .into_iter()
                        .map(|(seq, t, _)| (seq, t))
                        .collect();
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
pub(super) async fn interrupter(name: &str) -> Result<()> {
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
pub(super) async fn action_driver(action: &str) -> Result<()> {
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
