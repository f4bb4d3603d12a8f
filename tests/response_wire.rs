//! Drives a response through every numbered rule (R1-R10 of `radar_semantics::response`; R11-R13 are in
//! `ordering_cases.rs`) over real DDS: the response runs on one participant, the test publishes on its slot
//! topics from another, and asserts the exact signals and state messages seen on the wire. Domains 20-31, 12.

use std::{
    sync::{Arc, Mutex},
    time::{Duration, SystemTime, UNIX_EPOCH},
};

use radar_ros::{
    msg::{Empty, StringMsg},
    ExitAction, ExitReason, Radar, Response, SlotError, StartPolicy,
};
use radar_test_util::{radar, ResponseProbe, Seen, DISCOVERY};
use tokio::sync::Notify;

const T: Duration = Duration::from_secs(10);

type Log = Arc<Mutex<Vec<String>>>;

/// A response whose behaviour is chosen by its start payload, logging every slot.
#[derive(Clone, Default)]
struct Scripted {
    log: Log,
    release: Arc<Notify>,
    interrupt_delay: Duration,
    exit_delay: Duration,
    restart_once: Arc<Mutex<bool>>,
    panic_in_exit: Arc<Mutex<bool>>,
    policy: StartPolicy,
    /// Wall-clock ns when the exit slot finished, last run.
    exit_done_at: Arc<Mutex<i64>>,
}

fn now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64
}

struct CancelGuard(Log, bool);
impl Drop for CancelGuard {
    fn drop(&mut self) {
        if !self.1 && !std::thread::panicking() {
            self.0.lock().unwrap().push("start_cancelled".into());
        }
    }
}

impl Response for Scripted {
    type Start = StringMsg;
    type Output = StringMsg;

    async fn start(&mut self, p: StringMsg) -> Result<StringMsg, SlotError> {
        self.log.lock().unwrap().push(format!("start:{}", p.data));
        let mut guard = CancelGuard(self.log.clone(), false);
        let out = match p.data.as_str() {
            "wait" => {
                self.release.notified().await;
                Ok(StringMsg::from("done:wait"))
            }
            "forever" => {
                tokio::time::sleep(Duration::from_secs(3600)).await;
                Ok(StringMsg::default())
            }
            "fail" => Err(SlotError::msg("no path")),
            "panic" => panic!("boom"),
            "sleep" => {
                tokio::time::sleep(Duration::from_millis(500)).await;
                Ok(StringMsg::from("done:sleep"))
            }
            other => Ok(StringMsg::from(format!("done:{other}").as_str())),
        };
        guard.1 = true;
        out
    }

    async fn interrupt(&mut self) {
        self.log.lock().unwrap().push("interrupt".into());
        tokio::time::sleep(self.interrupt_delay).await;
    }

    async fn exit(&mut self, reason: ExitReason) -> ExitAction {
        self.log
            .lock()
            .unwrap()
            .push(format!("exit:{}", reason.describe()));
        tokio::time::sleep(self.exit_delay).await;
        if std::mem::take(&mut *self.panic_in_exit.lock().unwrap()) {
            panic!("exit boom");
        }
        *self.exit_done_at.lock().unwrap() = now_ns();
        self.log.lock().unwrap().push("exit_done".into());
        if std::mem::take(&mut *self.restart_once.lock().unwrap()) {
            ExitAction::Restart
        } else {
            ExitAction::Done
        }
    }

    fn start_policy(&self) -> StartPolicy {
        self.policy
    }
}

struct Rig {
    _host: Radar,
    _handle: radar_ros::ResponseHandle,
    probe: ResponseProbe<StringMsg, StringMsg>,
    _probe_radar: Radar,
    r: Scripted,
}

async fn rig(domain: u16, r: Scripted) -> Rig {
    let host = radar(domain);
    let handle = host.spawn_response("scripted", r.clone()).unwrap();
    let probe_radar = radar(domain);
    let probe = ResponseProbe::connect(&probe_radar, "/scripted").await;
    handle
        .wait_for_peers(1, 1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    // the transient-local state gives the current state on subscribing
    let (labels, s) = probe
        .states_until(DISCOVERY, |s| s.state_label == "idle")
        .await;
    assert_eq!(labels, ["idle"]);
    assert_eq!(s.name, "/scripted");
    assert_eq!(s.start_type, "std_msgs/msg/String");
    Rig {
        _host: host,
        _handle: handle,
        probe,
        _probe_radar: probe_radar,
        r,
    }
}

fn s(x: &str) -> StringMsg {
    StringMsg::from(x)
}

fn log(r: &Scripted) -> Vec<String> {
    r.log.lock().unwrap().clone()
}

/// The log once it has `n` lines (or what it has after `T`).
async fn log_until(r: &Scripted, n: usize) -> Vec<String> {
    let deadline = tokio::time::Instant::now() + T;
    while log(r).len() < n && tokio::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    log(r)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r1_r2_start_runs_with_the_payload_and_exited_follows_the_exit_slot() {
    let rig = rig(
        20,
        Scripted {
            exit_delay: Duration::from_millis(150),
            ..Default::default()
        },
    )
    .await;
    rig.probe.start.publish(s("wait")).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Started(s("wait"))]);
    // `started` is emitted as the run begins, just before the start behaviour's first line runs: over a fast
    // hop the probe can see it first
    assert_eq!(
        log_until(&rig.r, 1).await,
        ["start:wait"],
        "the start behaviour received the payload"
    );
    rig.r.release.notify_one();
    assert_eq!(
        rig.probe.signals(1, T).await,
        [Seen::Exited(s("done:wait"))],
        "exited carries the start behaviour's output"
    );
    assert_eq!(log(&rig.r), ["start:wait", "exit:completed", "exit_done"]);
    let (labels, st) = rig.probe.states_until(T, |s| s.exits == 1).await;
    assert_eq!(labels, ["running", "exiting", "idle"]);
    assert_eq!(
        (st.starts, st.completed, st.last_exit_reason.as_str()),
        (1, 1, "completed")
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r2_exited_is_sent_after_the_exit_slot_completes() {
    let rig = rig(
        21,
        Scripted {
            exit_delay: Duration::from_millis(200),
            ..Default::default()
        },
    )
    .await;
    let exited = rig
        ._probe_radar
        .signal_subscription::<StringMsg>("/scripted/exited")
        .unwrap();
    exited
        .wait_for_publishers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    rig.probe.start.publish(s("quick")).unwrap();
    let (m, sent_at) = tokio::time::timeout(T, exited.recv_stamped())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(m, s("done:quick"));
    let exit_done = *rig.r.exit_done_at.lock().unwrap();
    assert!(
        exit_done > 0 && sent_at >= exit_done,
        "exited stamped {sent_at}, exit slot done {exit_done}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r3_interrupt_cancels_start_then_interrupt_and_exit_slots_run() {
    let rig = rig(22, Scripted::default()).await;
    rig.probe.start.publish(s("forever")).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Started(s("forever"))]);
    rig.probe.interrupt.publish(Empty::default()).unwrap();
    assert_eq!(
        rig.probe.signals(2, T).await,
        [Seen::Interrupted, Seen::Exited(s(""))]
    );
    assert_eq!(
        log(&rig.r),
        [
            "start:forever",
            "start_cancelled",
            "interrupt",
            "exit:interrupted",
            "exit_done"
        ]
    );
    let (labels, st) = rig.probe.states_until(T, |s| s.exits == 1).await;
    assert_eq!(labels, ["running", "interrupting", "exiting", "idle"]);
    assert_eq!(st.interrupts, 1);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r4_exit_signal_cancels_start_and_skips_the_interrupt_slot() {
    let rig = rig(23, Scripted::default()).await;
    rig.probe.start.publish(s("forever")).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Started(s("forever"))]);
    rig.probe.exit.publish(Empty::default()).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Exited(s(""))]);
    rig.probe.assert_quiet(Duration::from_millis(300)).await;
    assert_eq!(
        log(&rig.r),
        [
            "start:forever",
            "start_cancelled",
            "exit:exit_signal",
            "exit_done"
        ]
    );
    let (labels, st) = rig.probe.states_until(T, |s| s.exits == 1).await;
    assert_eq!(labels, ["running", "exiting", "idle"]);
    assert_eq!((st.exit_signals, st.interrupts), (1, 0));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r5_interrupt_and_exit_are_ignored_unless_running() {
    let rig = rig(
        24,
        Scripted {
            interrupt_delay: Duration::from_millis(600),
            ..Default::default()
        },
    )
    .await;
    // idle
    rig.probe.interrupt.publish(Empty::default()).unwrap();
    rig.probe.exit.publish(Empty::default()).unwrap();
    let (_, st) = rig
        .probe
        .states_until(T, |s| s.ignored_interrupts == 1 && s.ignored_exits == 1)
        .await;
    assert_eq!(st.state_label, "idle");
    rig.probe.assert_quiet(Duration::from_millis(200)).await;
    // interrupting: the interrupt slot takes 600 ms
    rig.probe.start.publish(s("forever")).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Started(s("forever"))]);
    rig.probe.interrupt.publish(Empty::default()).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Interrupted]);
    rig.probe.interrupt.publish(Empty::default()).unwrap();
    rig.probe.exit.publish(Empty::default()).unwrap();
    let (_, st) = rig.probe.states_until(T, |s| s.exits == 1).await;
    assert_eq!(
        (st.ignored_interrupts, st.ignored_exits, st.interrupts),
        (2, 2, 1)
    );
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Exited(s(""))]);
    assert_eq!(
        log(&rig.r),
        [
            "start:forever",
            "start_cancelled",
            "interrupt",
            "exit:interrupted",
            "exit_done"
        ]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r6_start_while_running_is_ignored_by_default() {
    let rig = rig(25, Scripted::default()).await;
    rig.probe.start.publish(s("wait")).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Started(s("wait"))]);
    rig.probe.start.publish(s("other")).unwrap();
    let (_, st) = rig.probe.states_until(T, |s| s.ignored_starts == 1).await;
    assert_eq!(st.state_label, "running");
    rig.r.release.notify_one();
    assert_eq!(
        rig.probe.signals(1, T).await,
        [Seen::Exited(s("done:wait"))]
    );
    rig.probe.assert_quiet(Duration::from_millis(300)).await;
    assert_eq!(log(&rig.r), ["start:wait", "exit:completed", "exit_done"]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r6_restart_policy_interrupts_and_starts_the_new_payload() {
    let rig = rig(
        26,
        Scripted {
            policy: StartPolicy::Restart,
            ..Default::default()
        },
    )
    .await;
    rig.probe.start.publish(s("forever")).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Started(s("forever"))]);
    rig.probe.start.publish(s("quick")).unwrap();
    assert_eq!(
        rig.probe.signals(4, T).await,
        [
            Seen::Interrupted,
            Seen::Exited(s("")),
            Seen::Started(s("quick")),
            Seen::Exited(s("done:quick"))
        ]
    );
    assert_eq!(
        log(&rig.r),
        [
            "start:forever",
            "start_cancelled",
            "interrupt",
            "exit:interrupted",
            "exit_done",
            "start:quick",
            "exit:completed",
            "exit_done"
        ]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r6_queue_one_keeps_the_newest_start_for_after_exited() {
    let rig = rig(
        27,
        Scripted {
            policy: StartPolicy::QueueOne,
            ..Default::default()
        },
    )
    .await;
    rig.probe.start.publish(s("wait")).unwrap();
    assert_eq!(rig.probe.signals(1, T).await, [Seen::Started(s("wait"))]);
    rig.probe.start.publish(s("second")).unwrap();
    rig.probe.start.publish(s("third")).unwrap();
    let (_, st) = rig.probe.states_until(T, |s| s.ignored_starts == 1).await;
    assert!(st.start_queued);
    rig.r.release.notify_one();
    assert_eq!(
        rig.probe.signals(3, T).await,
        [
            Seen::Exited(s("done:wait")),
            Seen::Started(s("third")),
            Seen::Exited(s("done:third"))
        ]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r7_exit_slot_runs_after_error_and_panic_and_the_node_keeps_serving() {
    let rig = rig(28, Scripted::default()).await;
    rig.probe.start.publish(s("fail")).unwrap();
    assert_eq!(
        rig.probe.signals(2, T).await,
        [Seen::Started(s("fail")), Seen::Exited(s(""))]
    );
    rig.probe.start.publish(s("panic")).unwrap();
    assert_eq!(
        rig.probe.signals(2, T).await,
        [Seen::Started(s("panic")), Seen::Exited(s(""))]
    );
    let (_, st) = rig.probe.states_until(T, |s| s.exits == 2).await;
    assert_eq!((st.failures, st.panics), (1, 1));
    assert_eq!(st.last_exit_reason, "panicked: boom");
    // a panic in the exit slot still ends with exited
    *rig.r.panic_in_exit.lock().unwrap() = true;
    rig.probe.start.publish(s("quick")).unwrap();
    assert_eq!(
        rig.probe.signals(2, T).await,
        [Seen::Started(s("quick")), Seen::Exited(s("done:quick"))]
    );
    // and the node still serves
    rig.probe.start.publish(s("again")).unwrap();
    assert_eq!(
        rig.probe.signals(2, T).await,
        [Seen::Started(s("again")), Seen::Exited(s("done:again"))]
    );
    assert_eq!(
        log(&rig.r),
        [
            "start:fail",
            "exit:failed: no path",
            "exit_done",
            "start:panic",
            "exit:panicked: boom",
            "exit_done",
            "start:quick",
            "exit:completed",
            "start:again",
            "exit:completed",
            "exit_done"
        ]
    );
    let (_, st) = rig.probe.states_until(T, |s| s.exits == 4).await;
    assert_eq!(st.panics, 2);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r8_exit_slot_restart_starts_again_with_the_same_payload() {
    let r = Scripted::default();
    *r.restart_once.lock().unwrap() = true;
    let rig = rig(29, r).await;
    rig.probe.start.publish(s("quick")).unwrap();
    assert_eq!(
        rig.probe.signals(4, T).await,
        [
            Seen::Started(s("quick")),
            Seen::Exited(s("done:quick")),
            Seen::Started(s("quick")),
            Seen::Exited(s("done:quick"))
        ]
    );
    let (_, st) = rig.probe.states_until(T, |s| s.exits == 2).await;
    assert_eq!((st.restarts, st.starts), (1, 2));
}

#[tokio::test(flavor = "current_thread")]
async fn slots_sleep_on_the_runtime_without_blocking_each_other() {
    // one runtime thread, three responses sleeping 500 ms each at the same time
    let host = radar(30);
    let probe_radar = radar(30);
    let mut handles = Vec::new();
    let mut probes = Vec::new();
    for i in 0..3 {
        let name = format!("sleeper{i}");
        handles.push(host.spawn_response(&name, Scripted::default()).unwrap());
        probes.push(
            ResponseProbe::<StringMsg, StringMsg>::connect(&probe_radar, &format!("/{name}")).await,
        );
        handles[i]
            .wait_for_peers(1, 1)
            .timeout(DISCOVERY)
            .await
            .unwrap();
    }
    let t0 = std::time::Instant::now();
    for p in &probes {
        p.start.publish(s("sleep")).unwrap();
    }
    for p in &probes {
        assert_eq!(
            p.signals(2, T).await,
            [Seen::Started(s("sleep")), Seen::Exited(s("done:sleep"))]
        );
    }
    let took = t0.elapsed();
    assert!(
        took < Duration::from_millis(1400),
        "three 500 ms slots took {took:?}: they ran one after another"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_ends_a_running_start_through_the_exit_slot() {
    let host = radar(31);
    let r = Scripted::default();
    let handle = host.spawn_response("scripted", r.clone()).unwrap();
    let probe_radar = radar(31);
    let probe = ResponseProbe::<StringMsg, StringMsg>::connect(&probe_radar, "/scripted").await;
    handle
        .wait_for_peers(1, 1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    probe.start.publish(s("forever")).unwrap();
    assert_eq!(probe.signals(1, T).await, [Seen::Started(s("forever"))]);
    handle.shutdown().timeout(T).await.unwrap();
    assert_eq!(probe.signals(1, T).await, [Seen::Exited(s(""))]);
    assert_eq!(
        log(&r),
        [
            "start:forever",
            "start_cancelled",
            "exit:exit_signal",
            "exit_done"
        ]
    );
    // the node left the graph
    probe
        .start
        .wait_for_no_subscribers()
        .timeout(T)
        .await
        .unwrap();
}

/// R7 (issue 19, B5): a start closure that panics before it returns its future is a start behaviour that
/// panicked: the exit slot runs, `exited` is sent, and the response keeps serving. Before, the panic happened
/// outside the unwind guard: no exit slot, no `exited`, and the response was gone.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn r7_a_start_closure_that_panics_before_returning_its_future_still_runs_the_exit_slot() {
    use std::sync::atomic::{AtomicU64, Ordering};
    let host = radar(12);
    let exits = Arc::new(AtomicU64::new(0));
    let e = exits.clone();
    let _resp = host
        .spawn_response(
            "b5",
            radar_ros::FnResponse::new(|p: StringMsg| {
                if p.data == "panic" {
                    panic!("sync boom");
                }
                async move { Ok(p) }
            })
            .on_exit(move |_| {
                e.fetch_add(1, Ordering::SeqCst);
                async { ExitAction::Done }
            }),
        )
        .unwrap();
    let probe_radar = radar(12);
    let probe = ResponseProbe::<StringMsg, StringMsg>::connect(&probe_radar, "/b5").await;
    probe.start.publish(s("panic")).unwrap();
    assert_eq!(
        probe.signals(2, T).await,
        [Seen::Started(s("panic")), Seen::Exited(s(""))]
    );
    let (_, st) = probe.states_until(T, |st| st.exits == 1).await;
    assert_eq!(
        (st.panics, st.last_exit_reason.as_str()),
        (1, "panicked: sync boom")
    );
    assert_eq!(exits.load(Ordering::SeqCst), 1, "the exit slot ran");
    // and the response keeps serving
    probe.start.publish(s("again")).unwrap();
    assert_eq!(
        probe.signals(2, T).await,
        [Seen::Started(s("again")), Seen::Exited(s("again"))]
    );
}
