//! An event checks only while someone listens on `triggered`: activation and deactivation follow the DDS
//! match count, for subscribers in the same participant, in another participant, and in a child process that
//! exits cleanly or is killed; a check emitting through its own trigger from another thread, once or continuing.
//! Domains 40-46, 227, 228.

use std::{
    process::Stdio,
    sync::{
        atomic::{AtomicU64, Ordering},
        Arc,
    },
    time::{Duration, Instant},
};

use radar_ros::{
    msg::{Empty, EventState, Int32, StringMsg},
    Event, EventHandle, SlotError, TimerEvent, TopicEvent, Trigger,
};
use radar_test_util::{radar, DISCOVERY};
use tokio::io::{AsyncBufReadExt, BufReader};

/// Counts checks begun and checks cancelled; each check triggers after 20 ms.
#[derive(Clone, Default)]
struct Counting {
    checks: Arc<AtomicU64>,
    cancelled: Arc<AtomicU64>,
    fail_first: Arc<AtomicU64>,
}

struct Cancelled(Arc<AtomicU64>, bool);
impl Drop for Cancelled {
    fn drop(&mut self) {
        if !self.1 {
            self.0.fetch_add(1, Ordering::SeqCst);
        }
    }
}

impl Event for Counting {
    type Payload = Int32;
    async fn check(&mut self) -> Result<Int32, SlotError> {
        let n = self.checks.fetch_add(1, Ordering::SeqCst) + 1;
        let mut guard = Cancelled(self.cancelled.clone(), false);
        tokio::time::sleep(Duration::from_millis(20)).await;
        guard.1 = true;
        if self.fail_first.load(Ordering::SeqCst) >= n {
            return Err(SlotError::msg(format!("sensor offline ({n})")));
        }
        Ok(Int32 { data: n as i32 })
    }
    fn retry_after(&self) -> Duration {
        Duration::from_millis(10)
    }
}

async fn until_state(
    h: &EventHandle,
    timeout: Duration,
    pred: impl Fn(&EventState) -> bool,
) -> EventState {
    let mut w = h.watch_state();
    let r = tokio::time::timeout(timeout, w.wait_for(|s| pred(s))).await;
    match r {
        Ok(Ok(s)) => s.clone(),
        _ => panic!(
            "event state did not reach the expected value in {timeout:?}; last: {:?}",
            h.state()
        ),
    }
}

async fn assert_idle_for(h: &EventHandle, c: &Counting, d: Duration) {
    let before = c.checks.load(Ordering::SeqCst);
    tokio::time::sleep(d).await;
    assert!(!h.state().active, "{:?}", h.state());
    assert_eq!(
        c.checks.load(Ordering::SeqCst),
        before,
        "the check ran with no listener"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn same_participant_subscriber_activates_and_deactivates_the_event() {
    let host = radar(40);
    let c = Counting::default();
    let h = host.spawn_event("ev", c.clone()).unwrap();
    assert_idle_for(&h, &c, Duration::from_millis(300)).await;

    let t0 = Instant::now();
    let sub = host.signal_subscription::<Int32>("/ev/triggered").unwrap();
    until_state(&h, DISCOVERY, |s| s.active).await;
    let activation = t0.elapsed();
    let first = sub.recv().timeout(Duration::from_secs(5)).await.unwrap();
    assert!(first.data >= 1);
    println!("same participant: active {activation:?} after the subscription was created");
    assert!(
        activation < Duration::from_millis(500),
        "activation took {activation:?}"
    );

    let t1 = Instant::now();
    drop(sub);
    let st = until_state(&h, DISCOVERY, |s| !s.active).await;
    let deactivation = t1.elapsed();
    println!("same participant: inactive {deactivation:?} after the subscription was deleted");
    assert!(
        deactivation < Duration::from_millis(500),
        "deactivation took {deactivation:?}"
    );
    assert!(st.triggers >= 1 && st.activations == 1, "{st:?}");
    // the check that was running when the listener left was cancelled, and none runs any more
    tokio::time::sleep(Duration::from_millis(50)).await;
    assert!(c.cancelled.load(Ordering::SeqCst) <= 1);
    assert_idle_for(&h, &c, Duration::from_millis(300)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn subscriber_in_another_participant_activates_it_and_its_departure_cancels_the_check() {
    let host = radar(41);
    let c = Counting::default();
    let h = host.spawn_event("ev", c.clone()).unwrap();
    let other = radar(41);
    let sub = other.signal_subscription::<Int32>("/ev/triggered").unwrap();
    sub.wait_for_publishers(1).timeout(DISCOVERY).await.unwrap();
    let t0 = Instant::now();
    let st = until_state(&h, DISCOVERY, |s| s.active).await;
    println!(
        "other participant: active {:?} after the subscriber saw the match",
        t0.elapsed()
    );
    assert_eq!(st.listeners, 1);
    sub.recv().timeout(Duration::from_secs(5)).await.unwrap();

    // a second listener keeps it active when the first leaves
    let sub2 = host.signal_subscription::<Int32>("/ev/triggered").unwrap();
    until_state(&h, DISCOVERY, |s| s.listeners == 2).await;
    drop(sub);
    let st = until_state(&h, DISCOVERY, |s| s.listeners == 1).await;
    assert!(st.active);
    let t1 = Instant::now();
    drop(sub2);
    until_state(&h, DISCOVERY, |s| !s.active).await;
    println!(
        "other participant: inactive {:?} after the last subscriber left",
        t1.elapsed()
    );
    assert_idle_for(&h, &c, Duration::from_millis(200)).await;
}

fn peer(domain: u16, topic: &str) -> tokio::process::Child {
    tokio::process::Command::new(env!("CARGO_BIN_EXE_radar_test_peer"))
        .args(["subscribe", topic, "int32"])
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RUST_LOG", "error")
        .stdout(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .expect("start radar_test_peer")
}

async fn wait_line(child: &mut tokio::process::Child, want: &str) {
    let out = child.stdout.take().expect("stdout");
    let mut lines = BufReader::new(out).lines();
    let found = tokio::time::timeout(DISCOVERY, async {
        while let Ok(Some(l)) = lines.next_line().await {
            if l == want {
                return true;
            }
        }
        false
    })
    .await;
    assert_eq!(found, Ok(true), "peer did not print {want:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn subscriber_process_that_exits_cleanly_deactivates_the_event_at_once() {
    let host = radar(42);
    let c = Counting::default();
    let h = host.spawn_event("ev", c.clone()).unwrap();
    let mut child = peer(42, "/ev/triggered");
    wait_line(&mut child, "matched").await;
    until_state(&h, DISCOVERY, |s| s.active).await;
    let t0 = Instant::now();
    // SIGTERM: the peer drops its participant, which tells DDS peers it is gone
    let pid = child.id().unwrap() as i32;
    assert_eq!(unsafe_kill(pid, "TERM"), 0);
    until_state(&h, Duration::from_secs(10), |s| !s.active).await;
    let took = t0.elapsed();
    println!("clean exit of the subscriber process: inactive after {took:?}");
    assert!(took < Duration::from_secs(5), "took {took:?}");
    let _ = child.wait().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn killed_subscriber_process_deactivates_the_event_when_its_dds_lease_expires() {
    let host = radar(43);
    let c = Counting::default();
    let h = host.spawn_event("ev", c.clone()).unwrap();
    let mut child = peer(43, "/ev/triggered");
    wait_line(&mut child, "matched").await;
    until_state(&h, DISCOVERY, |s| s.active).await;
    let t0 = Instant::now();
    // SIGKILL: no goodbye on the wire. The dead participant is declared lost when its lease (radar_ros's
    // default, 3 s after its last announcement, sent every 0.6 s) runs out; the host checks every 0.6 s.
    child.kill().await.unwrap();
    until_state(&h, Duration::from_secs(30), |s| !s.active).await;
    let took = t0.elapsed();
    println!("SIGKILL of the subscriber process: inactive after {took:?} (DDS participant lease)");
    assert!(
        took > radar_ros::settings::DEFAULT_LEASE - Duration::from_millis(700),
        "a killed peer cannot be noticed before its lease: {took:?}"
    );
    assert!(
        took < Duration::from_secs(5),
        "a killed peer is noticed within 5 s: {took:?}"
    );
    assert_idle_for(&h, &c, Duration::from_millis(200)).await;
}

fn unsafe_kill(pid: i32, sig: &str) -> i32 {
    std::process::Command::new("kill")
        .args([&format!("-{sig}"), &pid.to_string()])
        .status()
        .map(|s| s.code().unwrap_or(-1))
        .unwrap_or(-1)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn timer_event_triggers_every_period_counted_from_activation() {
    let host = radar(44);
    let h = host
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(200)))
        .unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let sub = host
        .signal_subscription::<Empty>("/tick/triggered")
        .unwrap();
    until_state(&h, DISCOVERY, |s| s.active).await;
    let t0 = Instant::now();
    let mut at = Vec::new();
    for _ in 0..3 {
        sub.recv().timeout(Duration::from_secs(2)).await.unwrap();
        at.push(t0.elapsed().as_millis());
    }
    println!("timer triggers at {at:?} ms after activation");
    // first trigger one period after activation (not right away, not 500 ms late), then every period
    assert!((150..350).contains(&at[0]), "{at:?}");
    assert!(
        (350..550).contains(&at[1]) && (550..750).contains(&at[2]),
        "{at:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn topic_event_triggers_on_matching_messages_received_while_active() {
    let host = radar(45);
    let h = host
        .spawn_event(
            "hot",
            TopicEvent::new("/temperature", |t: &Int32| {
                (t.data > 50).then(|| StringMsg::from(format!("{} C", t.data).as_str()))
            }),
        )
        .unwrap();
    let temp = host.signal_publisher::<Int32>("/temperature").unwrap();
    temp.wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    // while inactive: a hot reading is not acted on later
    temp.publish(Int32 { data: 99 }).unwrap();
    tokio::time::sleep(Duration::from_millis(200)).await;
    let sub = host
        .signal_subscription::<StringMsg>("/hot/triggered")
        .unwrap();
    until_state(&h, DISCOVERY, |s| s.active).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    for d in [20, 60, 30, 70] {
        temp.publish(Int32 { data: d }).unwrap();
    }
    assert_eq!(
        sub.recv()
            .timeout(Duration::from_secs(5))
            .await
            .unwrap()
            .data,
        "60 C"
    );
    assert_eq!(
        sub.recv()
            .timeout(Duration::from_secs(5))
            .await
            .unwrap()
            .data,
        "70 C"
    );
    assert!(
        sub.recv()
            .timeout(Duration::from_millis(300))
            .await
            .is_err(),
        "99 C came from before activation"
    );
    assert_eq!(h.state().trigger_type, "std_msgs/msg/String");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn check_errors_are_counted_on_state_and_the_check_is_retried() {
    let host = radar(46);
    let c = Counting::default();
    c.fail_first.store(2, Ordering::SeqCst);
    let h = host.spawn_event("flaky", c.clone()).unwrap();
    let state = host
        .state_subscription::<EventState>("/flaky/state")
        .unwrap();
    let sub = host
        .signal_subscription::<Int32>("/flaky/triggered")
        .unwrap();
    assert_eq!(
        sub.recv()
            .timeout(Duration::from_secs(5))
            .await
            .unwrap()
            .data,
        3
    );
    let st = until_state(&h, DISCOVERY, |s| s.triggers >= 1).await;
    assert_eq!(st.check_errors, 2);
    assert_eq!(st.last_error, "sensor offline (2)");
    // the same is on the wire
    let wire = tokio::time::timeout(DISCOVERY, async {
        loop {
            let s = state.recv().await.unwrap();
            if s.check_errors == 2 {
                return s;
            }
        }
    })
    .await
    .unwrap();
    assert_eq!(wire.name, "/flaky");
}

/// Hands each check's trigger to the test; its check ends only when told (with a value that must not be
/// emitted again when the trigger was used).
struct Relayed {
    triggers: tokio::sync::mpsc::UnboundedSender<Trigger<Int32>>,
    resolve: Arc<tokio::sync::Notify>,
}

impl Event for Relayed {
    type Payload = Int32;
    fn before_check(&mut self, trigger: Trigger<Int32>) {
        let _ = self.triggers.send(trigger);
    }
    async fn check(&mut self) -> Result<Int32, SlotError> {
        self.resolve.notified().await;
        Ok(Int32 { data: -1 })
    }
}

/// The next check's trigger, handed over by [`Relayed::before_check`].
async fn next_trigger(
    triggers: &mut tokio::sync::mpsc::UnboundedReceiver<Trigger<Int32>>,
) -> Trigger<Int32> {
    let next = tokio::time::timeout(DISCOVERY, triggers.recv()).await;
    next.expect("a check began").expect("the event is alive")
}

/// A [`Relayed`] event `name` on a host of `domain`, and a reader of its `triggered` in another participant that
/// only observes (the wire's own count: it activates nothing), seen matched.
struct RelayedEvent {
    host: radar_ros::Radar,
    h: EventHandle,
    triggers: tokio::sync::mpsc::UnboundedReceiver<Trigger<Int32>>,
    resolve: Arc<tokio::sync::Notify>,
    _watcher: radar_ros::Radar,
    obs: radar_ros::topics::RawSubscription,
}

async fn relayed_event(domain: u16, name: &str) -> RelayedEvent {
    let host = radar(domain);
    let (tx, triggers) = tokio::sync::mpsc::unbounded_channel();
    let resolve = Arc::new(tokio::sync::Notify::new());
    let h = host
        .spawn_event(
            name,
            Relayed {
                triggers: tx,
                resolve: resolve.clone(),
            },
        )
        .unwrap();
    let watcher = radar(domain);
    let obs = watcher
        .observe_raw(&format!("/{name}/triggered"), "std_msgs/msg/Int32")
        .unwrap();
    obs.wait_for_publishers(1).timeout(DISCOVERY).await.unwrap();
    RelayedEvent {
        host,
        h,
        triggers,
        resolve,
        _watcher: watcher,
        obs,
    }
}

/// The `Int32` an observed sample carries.
fn int32_of(m: &radar_ros::topics::RawMessage) -> i32 {
    i32::from_le_bytes(m.as_bytes()[0..4].try_into().unwrap())
}

/// The `Int32` values an observer (which never activates the event) has seen so far.
async fn observed(obs: &radar_ros::topics::RawSubscription, within: Duration) -> Vec<i32> {
    let mut seen = Vec::new();
    while let Ok((m, _)) = obs.recv_stamped().timeout(within).await {
        seen.push(int32_of(&m));
    }
    seen
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_check_emits_through_its_trigger_from_another_thread_once_and_never_after_it_ended() {
    let RelayedEvent {
        host,
        h,
        mut triggers,
        resolve,
        obs,
        _watcher,
    } = relayed_event(227, "relayed").await;
    assert!(triggers.try_recv().is_err(), "no check runs unlistened");

    let sub = host
        .signal_subscription::<Int32>("/relayed/triggered")
        .unwrap();
    let t1 = next_trigger(&mut triggers).await;
    // emitted from a thread that is not the runtime's: once per check
    let t = t1.clone();
    let (first, second) =
        std::thread::spawn(move || (t.emit(Int32 { data: 7 }), t.emit(Int32 { data: 8 })))
            .join()
            .unwrap();
    assert!(first.is_ok());
    assert_eq!(
        second.unwrap_err().data,
        8,
        "a second trigger of one check is handed back"
    );
    let heard = sub.recv().timeout(Duration::from_secs(5)).await;
    assert_eq!(heard.unwrap().data, 7);
    // the check's own value, after it emitted, is not emitted again; the trigger is counted once
    resolve.notify_one();
    let t2 = next_trigger(&mut triggers).await;
    let st = until_state(&h, DISCOVERY, |s| s.triggers == 1).await;
    assert!(st.active, "{st:?}");
    assert!(!t1.is_open() && t2.is_open());
    assert_eq!(observed(&obs, Duration::from_millis(300)).await, vec![7]);
    assert!(sub.try_recv().is_none());

    // the listener leaves: the running check's trigger is refused from then on
    drop(sub);
    until_state(&h, DISCOVERY, |s| !s.active).await;
    assert_eq!(t2.emit(Int32 { data: 9 }).unwrap_err().data, 9);

    // a trigger emitted on another thread while its check is being dropped (the listener leaving at the same
    // time), 30 times with nothing to let it settle: every trigger on the wire is counted once, and none goes
    // out once the event said it is inactive
    let mut accepted = 1;
    for round in 0..30 {
        let sub = host
            .signal_subscription::<Int32>("/relayed/triggered")
            .unwrap();
        let t = next_trigger(&mut triggers).await;
        let racer = std::thread::spawn(move || {
            let sent = t.emit(Int32 { data: 100 + round }).is_ok();
            (t, sent)
        });
        drop(sub);
        let st = until_state(&h, DISCOVERY, |s| {
            !s.active && s.activations == round as u64 + 2
        })
        .await;
        let (t, sent) = racer.join().unwrap();
        accepted += u64::from(sent);
        assert_eq!(st.triggers, accepted, "round {round}: {st:?}");
        assert!(
            t.emit(Int32 { data: -2 }).is_err(),
            "round {round}: out after inactive"
        );
    }
    let seen = observed(&obs, Duration::from_millis(500)).await;
    // (the first trigger, 7, was read above)
    assert_eq!(seen.len() as u64 + 1, accepted, "on the wire: {seen:?}");
    assert!(seen.iter().all(|&d| d >= 100), "{seen:?}");
    assert_eq!(h.state().triggers, accepted);
    println!(
        "{} of 30 raced triggers went out before their check was dropped",
        accepted - 1
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_trigger_that_continues_emits_every_value_from_its_thread_with_one_check_and_never_after_it_ended(
) {
    let RelayedEvent {
        host,
        h,
        mut triggers,
        resolve,
        obs,
        _watcher,
    } = relayed_event(228, "continued").await;
    let sub = host
        .signal_subscription::<Int32>("/continued/triggered")
        .unwrap();
    let t = next_trigger(&mut triggers).await;
    // 200 values from a thread of its own, each the value of one check (the next emitted once the last was
    // heard: signal QoS keeps only the last few): all go out, in order, through the one trigger (no new check is
    // handed over), and `state` counts every one
    let emitter = t.clone();
    let (go, gone) = std::sync::mpsc::channel::<()>();
    let thread = std::thread::spawn(move || {
        let mut sent = 0;
        for i in 0..200 {
            if emitter.emit_and_continue(Int32 { data: i }).is_ok() {
                sent += 1;
            }
            if gone.recv().is_err() {
                break;
            }
        }
        sent
    });
    let mut heard = Vec::new();
    while heard.len() < 200 {
        let m = sub.recv().timeout(Duration::from_secs(5)).await;
        heard.push(m.expect("every continued trigger is delivered").data);
        // and on the wire, to a reader of another participant
        let (w, _) = obs
            .recv_stamped()
            .timeout(Duration::from_secs(5))
            .await
            .unwrap();
        assert_eq!(int32_of(&w), heard[heard.len() - 1]);
        let _ = go.send(());
    }
    assert_eq!(thread.join().unwrap(), 200);
    assert_eq!(heard, (0..200).collect::<Vec<_>>());
    let st = until_state(&h, DISCOVERY, |s| s.triggers == 200).await;
    assert!(st.active, "{st:?}");
    assert!(
        triggers.try_recv().is_err(),
        "the check went on: no new one"
    );
    assert!(t.is_open());
    // a single `emit` takes the check's own value and ends continuing; the check's own value is not emitted
    // again when it resolves, and the next check hands over a new trigger
    t.emit(Int32 { data: 500 }).unwrap();
    assert_eq!(
        t.emit_and_continue(Int32 { data: 501 }).unwrap_err().data,
        501
    );
    resolve.notify_one();
    let t2 = next_trigger(&mut triggers).await;
    until_state(&h, DISCOVERY, |s| s.triggers == 201).await;
    assert_eq!(
        sub.recv()
            .timeout(Duration::from_secs(5))
            .await
            .unwrap()
            .data,
        500
    );
    // the check resolving by itself ends the continuing trigger too: its value is emitted, counted after the
    // continued ones
    t2.emit_and_continue(Int32 { data: 600 }).unwrap();
    resolve.notify_one();
    let t3 = next_trigger(&mut triggers).await;
    until_state(&h, DISCOVERY, |s| s.triggers == 203).await;
    assert_eq!(
        t2.emit_and_continue(Int32 { data: 601 }).unwrap_err().data,
        601
    );
    let mut last = Vec::new();
    for _ in 0..2 {
        last.push(
            sub.recv()
                .timeout(Duration::from_secs(5))
                .await
                .unwrap()
                .data,
        );
    }
    assert_eq!(last, vec![600, -1]);
    assert_eq!(
        observed(&obs, Duration::from_millis(300)).await,
        vec![500, 600, -1]
    );

    // continued triggers racing the last listener's departure, 30 times with nothing to let it settle (up to 8
    // a round: the wire keeps the last 10): every trigger on the wire is counted once, and none goes out once
    // the event said it is inactive
    drop(sub);
    until_state(&h, DISCOVERY, |s| !s.active).await;
    assert!(t3.emit_and_continue(Int32 { data: 9 }).is_err());
    let mut accepted = 203;
    for round in 0..30 {
        let sub = host
            .signal_subscription::<Int32>("/continued/triggered")
            .unwrap();
        let t = next_trigger(&mut triggers).await;
        let racer = std::thread::spawn(move || {
            let mut sent = 0u64;
            while sent < 8 && t.emit_and_continue(Int32 { data: 1000 + round }).is_ok() {
                sent += 1;
            }
            (t, sent)
        });
        drop(sub);
        let st = until_state(&h, DISCOVERY, |s| {
            !s.active && s.activations == round as u64 + 2
        })
        .await;
        let (t, sent) = racer.join().unwrap();
        accepted += sent;
        assert_eq!(st.triggers, accepted, "round {round}: {st:?}");
        assert!(
            t.emit_and_continue(Int32 { data: -2 }).is_err(),
            "round {round}: out after inactive"
        );
        for _ in 0..sent {
            let (w, _) = obs
                .recv_stamped()
                .timeout(Duration::from_secs(5))
                .await
                .expect("each counted trigger is on the wire");
            let d = int32_of(&w);
            assert_eq!(d, 1000 + round, "round {round}");
        }
    }
    assert_eq!(
        observed(&obs, Duration::from_millis(500)).await,
        Vec::<i32>::new()
    );
    println!(
        "{} continued triggers went out in 30 rounds before their check was dropped",
        accepted - 203
    );
}
