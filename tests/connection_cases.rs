//! The connection tests, run by `connections.rs` (signals handed to this process's responses directly: one
//! DDS hop) and by `connections_relay.rs` (every delivery written on the slot's topic: two hops, as a manager
//! in another process does). Whenever, once (bursts, races), until windows, waitfor, anonymous slots,
//! injection, type errors, scope exit, and no stale or duplicate deliveries when connections come and go.

use std::{
    sync::{
        atomic::{AtomicU64, Ordering},
        Arc, Mutex,
    },
    time::Duration,
};

use super::radar;
use radar_ros::{
    msg::{Empty, Int32, StringMsg},
    Error, Event, EventHandle, ExitAction, FnResponse, Radar, ResponseHandle, Signal, SlotError,
    TimerEvent,
};
use radar_test_util::{counter, eventually};

const T: Duration = Duration::from_secs(10);

async fn inactive(h: &EventHandle) {
    eventually(T, "the event to deactivate", || !h.state().active).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn whenever_delivers_every_trigger_until_its_guard_drops() {
    let r = radar(80);
    let ev = r
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(100)))
        .unwrap();
    let (resp, runs) = counter(&r, "count");
    assert!(!ev.state().active);
    let c = r.whenever(ev.triggered()).start(&resp).await.unwrap();
    eventually(T, "three runs", || runs.load(Ordering::SeqCst) >= 3).await;
    assert!(c.delivered() >= 3);
    drop(c);
    let after = runs.load(Ordering::SeqCst);
    inactive(&ev).await;
    tokio::time::sleep(Duration::from_millis(400)).await;
    assert!(
        runs.load(Ordering::SeqCst) <= after + 1,
        "nothing after the drop (one may be in flight)"
    );
}

/// 300 ms after it is activated (so that several statements can be armed), emits `n` signals as fast as it
/// can, then waits.
struct Burst(u32, i32);
impl Event for Burst {
    type Payload = Int32;
    fn on_activate(&mut self) {
        self.1 = -1;
    }
    async fn check(&mut self) -> Result<Int32, SlotError> {
        if self.1 == -1 {
            tokio::time::sleep(Duration::from_millis(300)).await;
            self.1 = self.0 as i32;
        }
        if self.1 > 0 {
            self.1 -= 1;
            Ok(Int32 { data: self.1 })
        } else {
            std::future::pending().await
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn once_delivers_exactly_one_of_a_burst_to_each_racing_statement() {
    let r = radar(81);
    let burst = r.spawn_event("burst", Burst(50, 0)).unwrap();
    let got: Arc<Mutex<Vec<(usize, i32)>>> = Default::default();
    let mut guards = Vec::new();
    for k in 0..3 {
        let g = got.clone();
        guards.push(
            r.once(burst.triggered())
                .call(move |m: Int32| g.lock().unwrap().push((k, m.data)))
                .await
                .unwrap(),
        );
    }
    eventually(T, "three deliveries", || got.lock().unwrap().len() >= 3).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let mut got = got.lock().unwrap().clone();
    got.sort();
    assert_eq!(got.len(), 3, "each once gets exactly one: {got:?}");
    assert_eq!(got.iter().map(|(k, _)| *k).collect::<Vec<_>>(), [0, 1, 2]);
    assert!(guards.iter().all(|g| !g.is_live()));
    inactive(&burst).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn once_start_until_interrupts_only_the_run_it_started() {
    let r = radar(82);
    let start_event = r
        .spawn_event("start_event", TimerEvent::new(Duration::from_millis(200)))
        .unwrap();
    let end_event = r
        .spawn_event("end_event", TimerEvent::new(Duration::from_millis(700)))
        .unwrap();
    let restarted = Arc::new(AtomicU64::new(0));
    let rs = restarted.clone();
    let resp = r
        .spawn_response(
            "worker",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_secs(30)).await;
                Ok(Empty::default())
            })
            .on_exit(move |_| {
                let first = rs.fetch_add(1, Ordering::SeqCst) == 0;
                async move {
                    if first {
                        ExitAction::Restart
                    } else {
                        ExitAction::Done
                    }
                }
            }),
        )
        .unwrap();
    let c = r
        .once(start_event.triggered())
        .start(&resp)
        .until(end_event.triggered())
        .await
        .unwrap();
    // U is armed with the statement: the event activates at once (its own task sets the state)
    eventually(Duration::from_millis(200), "end_event to be active", || {
        end_event.state().active
    })
    .await;
    eventually(T, "the interrupt", || resp.state().interrupts == 1).await;
    eventually(T, "the restart", || resp.state().starts == 2).await;
    inactive(&start_event).await; // the once has fired
                                  // its run has ended: the once is spent (C3) and lets go of end_event, guard or not (issue 32; before,
                                  // end_event kept triggering every 0.7 s until the guard dropped)
    inactive(&end_event).await;
    assert!(!c.is_live(), "the spent once is gone");
    c.closed().timeout(T).await.unwrap();
    // the restarted run is not the statement's, and nothing interrupts it
    tokio::time::sleep(Duration::from_millis(1600)).await;
    let st = resp.state();
    assert_eq!(
        (st.interrupts, st.state_label.as_str()),
        (1, "running"),
        "{st:?}"
    );
    assert_eq!(end_event.state().triggers, 1, "end_event triggered once");
    drop(c);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waitfor_returns_the_next_payload_and_inject_feeds_a_slot() {
    let r = radar(83);
    let echo = r
        .spawn_response(
            "echo",
            FnResponse::new(|s: StringMsg| async move {
                tokio::time::sleep(Duration::from_millis(100)).await;
                Ok(StringMsg::from(format!("done:{}", s.data).as_str()))
            }),
        )
        .unwrap();
    let refs = echo.reference().clone();
    let (out, injected) = tokio::join!(r.waitfor::<StringMsg>(refs.exited()).timeout(T), async {
        tokio::time::sleep(Duration::from_millis(300)).await;
        r.inject(refs.start_slot(), StringMsg::from("x"))
            .timeout(T)
            .await
    });
    injected.unwrap();
    assert_eq!(
        out.unwrap().data,
        "done:x",
        "data in through start, back out through exited"
    );
    // without a timeout it waits as long as it takes
    let (out, injected) = tokio::join!(r.waitfor::<StringMsg>(refs.exited()), async {
        tokio::time::sleep(Duration::from_millis(1500)).await;
        r.inject(refs.start_slot(), StringMsg::from("late"))
            .timeout(T)
            .await
    });
    injected.unwrap();
    assert_eq!(out.unwrap().data, "done:late");
    // nothing comes: a timeout
    let e = r
        .waitfor::<StringMsg>(refs.exited())
        .timeout(Duration::from_millis(300))
        .await
        .unwrap_err();
    assert!(matches!(e, Error::Timeout { .. }), "{e:?}");
    // injecting the wrong type is refused
    let e = r
        .inject(refs.start_slot(), Int32 { data: 1 })
        .timeout(T)
        .await
        .unwrap_err();
    assert!(e.to_string().contains("std_msgs/msg/Int32"), "{e}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mismatched_types_and_meaningless_statements_fail_with_clear_errors() {
    let r = radar(84);
    let ev = r.spawn_event("num", Burst(1, 0)).unwrap();
    let echo = r
        .spawn_response("echo", FnResponse::new(|s: StringMsg| async move { Ok(s) }))
        .unwrap();
    let e = r
        .whenever(ev.triggered())
        .start(&echo)
        .await
        .unwrap_err()
        .to_string();
    for part in [
        "/num/triggered",
        "std_msgs/msg/Int32",
        "/echo/start",
        "std_msgs/msg/String",
    ] {
        assert!(e.contains(part), "{part} missing from: {e}");
    }
    let e = r
        .once(ev.triggered())
        .call(|_: StringMsg| {})
        .await
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("anonymous slot") && e.contains("std_msgs/msg/Int32"),
        "{e}"
    );
    // (`until` after `interrupt` does not compile: ConnectionRequest's compile_fail doctests)
    // an Empty slot takes any signal: the payload is dropped, the signal counts
    let _ok = r.whenever(ev.triggered()).interrupt(&echo).await.unwrap();
    // nobody publishes on a made-up source: arming times out and says what it waited for
    let e = r
        .once(radar_ros::Signal::new(
            "/nobody/triggered",
            "std_msgs/msg/Empty",
        ))
        .start(&echo)
        .timeout(Duration::from_millis(300))
        .await;
    assert!(e.is_err());
}

/// A block that arms a connection and then fails with `?`.
async fn arm_then_fail(r: &Radar, ev: &EventHandle, hits: Arc<AtomicU64>) -> Result<(), Error> {
    let _c = r
        .whenever(ev.triggered())
        .call(move |_: Empty| {
            hits.fetch_add(1, Ordering::SeqCst);
        })
        .await?;
    tokio::time::sleep(Duration::from_millis(250)).await;
    Err(Error::InvalidStatement("the block fails".into()))?;
    unreachable!("the ? above returns")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connections_end_with_their_scope_on_error_and_on_panic() {
    let r = radar(85);
    let ev = r
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(50)))
        .unwrap();
    let hits = Arc::new(AtomicU64::new(0));
    assert!(arm_then_fail(&r, &ev, hits.clone()).await.is_err());
    let n = hits.load(Ordering::SeqCst);
    assert!(n >= 2, "it delivered while in scope: {n}");
    inactive(&ev).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(
        hits.load(Ordering::SeqCst),
        n,
        "nothing after `?` left the scope"
    );

    let h2 = Arc::new(AtomicU64::new(0));
    let (r2, sig, h) = (r.clone(), ev.triggered(), h2.clone());
    let task = tokio::spawn(async move {
        let _c = r2
            .whenever(sig)
            .call(move |_: Empty| {
                h.fetch_add(1, Ordering::SeqCst);
            })
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(250)).await;
        panic!("the deliberative code panics");
    });
    assert!(task.await.unwrap_err().is_panic());
    let n = h2.load(Ordering::SeqCst);
    assert!(n >= 2);
    inactive(&ev).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(
        h2.load(Ordering::SeqCst),
        n,
        "nothing after the panic unwound the scope"
    );
}

/// Emits an increasing counter every 5 ms while active.
struct Counter(i32);
impl Event for Counter {
    type Payload = Int32;
    async fn check(&mut self) -> Result<Int32, SlotError> {
        tokio::time::sleep(Duration::from_millis(5)).await;
        self.0 += 1;
        Ok(Int32 { data: self.0 })
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connections_made_fired_dropped_and_remade_never_see_stale_or_duplicate_signals() {
    let r = radar(86);
    let ev = r.spawn_event("counter", Counter(0)).unwrap();
    // a second listener keeps the event running between cycles, so old samples exist to be replayed
    let keep = r
        .signal_subscription::<Int32>("/counter/triggered")
        .unwrap();
    let mut last_seen = 0;
    for cycle in 0..60 {
        // the newest value emitted before arming
        while let Some(m) = keep.try_recv() {
            last_seen = last_seen.max(m.data);
        }
        let got: Arc<Mutex<Vec<i32>>> = Default::default();
        let g = got.clone();
        let c = r
            .once(ev.triggered())
            .call(move |m: Int32| g.lock().unwrap().push(m.data))
            .await
            .unwrap();
        eventually(T, "the once to fire", || !got.lock().unwrap().is_empty()).await;
        tokio::time::sleep(Duration::from_millis(20)).await;
        let got = got.lock().unwrap().clone();
        assert_eq!(
            got.len(),
            1,
            "cycle {cycle}: exactly one delivery, got {got:?}"
        );
        assert!(
            got[0] > last_seen,
            "cycle {cycle}: {} was emitted before arming (last seen {last_seen})",
            got[0]
        );
        last_seen = got[0];
        drop(c);
    }
}

/// Listing 3's `do_loop`: a `once` that lives for the function's body, plus an anonymous slot.
async fn do_loop(
    r: &Radar,
    ev2: &EventHandle,
    resp: &ResponseHandle,
    hits: Arc<AtomicU64>,
) -> Result<(), Error> {
    radar_ros::once!(r, ev2 interrupt resp);
    radar_ros::whenever!(r, ev2 => move |_: Empty| {
        hits.fetch_add(1, Ordering::SeqCst);
    });
    // Wait for TestEvent2 rather than for `interrupted`: the once is armed before this waitfor, so a
    // trigger falling between the two arms fires the once while the waitfor is not yet listening.
    // Waiting for the trigger is race-free: the once has fired by the time any later trigger arrives.
    let _: Empty = radar_ros::waitfor!(r, (ev2.triggered()), Duration::from_secs(5));
    eventually(T, "the once to interrupt the response", || {
        resp.state().interrupts >= 1
    })
    .await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn paper_syntax_macros_bind_connections_to_the_enclosing_block() -> Result<(), Error> {
    let r = radar(89);
    let tick = r.spawn_event("test_event", TimerEvent::new(Duration::from_millis(150)))?;
    let ev2 = r.spawn_event("test_event2", TimerEvent::new(Duration::from_millis(400)))?;
    let resp = r.spawn_response(
        "test_response",
        FnResponse::new(|_: Empty| async {
            tokio::time::sleep(Duration::from_secs(30)).await;
            Ok(Empty::default())
        }),
    )?;
    // main: whenever TestEvent start TestResponse
    radar_ros::whenever!(r, tick start resp);
    eventually(T, "the first run", || resp.state().starts >= 1).await;
    let hits = Arc::new(AtomicU64::new(0));
    do_loop(&r, &ev2, &resp, hits.clone()).await?;
    assert_eq!(resp.state().interrupts, 1);
    let n = hits.load(Ordering::SeqCst);
    assert!(n >= 1, "the anonymous slot ran inside do_loop");
    // back in main: do_loop's connections are gone, main's is not
    inactive(&ev2).await;
    tokio::time::sleep(Duration::from_millis(900)).await;
    assert_eq!(resp.state().interrupts, 1, "the once ended with do_loop");
    assert_eq!(hits.load(Ordering::SeqCst), n, "so did the anonymous slot");
    assert!(
        resp.state().starts >= 2,
        "whenever tick start still restarts the response"
    );
    assert!(tick.state().active);
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn connection_properties_filter_and_transform_payloads() {
    let r = radar(78);
    let counter = r.spawn_event("counter", Counter(0)).unwrap();
    let echo = r
        .spawn_response("echo", FnResponse::new(|s: StringMsg| async move { Ok(s) }))
        .unwrap();
    // only even counts, turned into text for a String slot
    let seen: Arc<Mutex<Vec<String>>> = Default::default();
    let s2 = seen.clone();
    let _out = r
        .whenever(echo.reference().started())
        .call(move |m: StringMsg| s2.lock().unwrap().push(m.data))
        .await
        .unwrap();
    let _c = r
        .whenever(counter.triggered())
        .slot(echo.reference().start_slot())
        .filter(|m: &Int32| m.data % 2 == 0)
        .map(|m: Int32| StringMsg::from(format!("count {}", m.data).as_str()))
        .await
        .unwrap();
    eventually(T, "three transformed starts", || {
        seen.lock().unwrap().len() >= 3
    })
    .await;
    for s in seen.lock().unwrap().iter() {
        let n: i32 = s.strip_prefix("count ").unwrap().parse().unwrap();
        assert_eq!(n % 2, 0, "{s} passed the filter");
    }
    // a once with a filter waits for a signal it accepts
    let got: Arc<Mutex<Vec<i32>>> = Default::default();
    let g = got.clone();
    let once = r
        .once(counter.triggered())
        .call(move |m: Int32| g.lock().unwrap().push(m.data))
        .filter(|m: &Int32| m.data % 10 == 7)
        .await
        .unwrap();
    once.closed().await.unwrap();
    // closed: nothing more will be delivered; the slot's call for the one delivery runs in its own task
    eventually(T, "the once's anonymous slot to run", || {
        !got.lock().unwrap().is_empty()
    })
    .await;
    let got = got.lock().unwrap().clone();
    assert!(got.len() == 1 && got[0] % 10 == 7, "{got:?}");
    // a filter or map of the wrong type is refused with both types named
    let e = r
        .whenever(counter.triggered())
        .call(|_: Int32| {})
        .filter(|_: &StringMsg| true)
        .await
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("std_msgs/msg/Int32") && e.contains("std_msgs/msg/String"),
        "{e}"
    );
    let e = r
        .whenever(counter.triggered())
        .slot(echo.reference().start_slot())
        .await
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("type mismatch"),
        "without the map the types differ: {e}"
    );
}

/// A `once` that fires leaves its slot's writer unneeded, and a guard dropped right after a delivery does the
/// same. The delivered signal must still arrive: the writer may not be deleted before its sample is sent.
/// Each round uses a new response, so each round's writer is new.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_delivery_arrives_even_when_its_writer_is_no_longer_needed() {
    let r = radar(79);
    let tick = r
        .spawn_event("tick", TimerEvent::new(Duration::from_millis(30)))
        .unwrap();
    let mut targets = Vec::new();
    for round in 0..40 {
        let resp = r
            .spawn_response(
                format!("target_{round}").as_str(),
                FnResponse::new(|_: Empty| async { Ok(Empty::default()) }),
            )
            .unwrap();
        if round % 2 == 0 {
            // a once fires and its writer is retired at once
            let c = r.once(tick.triggered()).start(&resp).await.unwrap();
            c.closed().await.unwrap();
        } else {
            // a whenever whose guard is dropped right after its first delivery
            let w = r.whenever(tick.triggered()).start(&resp).await.unwrap();
            eventually(T, "a delivery", || w.delivered() >= 1).await;
            drop(w);
        }
        eventually(
            T,
            &format!("round {round}: the delivered start to arrive"),
            || resp.state().starts >= 1,
        )
        .await;
        targets.push(resp);
    }
    // the writers kept for the sake of their last sample are deleted a few seconds later
    eventually(T, "the retired writers to be deleted", || {
        targets.iter().all(|t| t.slot_publishers()[0] == 0)
    })
    .await;
}

/// Connection property: QoS depth, keep-last like a ROS subscription. An anonymous slot slower than its source
/// sees the newest `depth` signals queued behind the one it is handling; a deeper connection keeps all of a
/// burst. A connection with another depth gets relay endpoints of its own; the list shows each depth.
// four workers: the two slow calls below block theirs, the relay must keep running meanwhile
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn qos_depth_sets_how_many_signals_a_slow_slot_keeps() {
    let r = radar(77);
    let source = Signal::new("/burst/triggered", "std_msgs/msg/Int32");
    let burst = r.signal_publisher::<Int32>(source.topic()).unwrap();
    let mut seen = Vec::new();
    let mut guards = Vec::new();
    for depth in [None, Some(200)] {
        let got: Arc<Mutex<Vec<i32>>> = Default::default();
        let g = got.clone();
        let statement = r.whenever(source.clone()).call(move |m: Int32| {
            if m.data == 0 {
                // a slow slot: the rest of the burst queues meanwhile
                std::thread::sleep(Duration::from_millis(1500));
            }
            g.lock().unwrap().push(m.data);
        });
        let statement = match depth {
            Some(d) => statement.depth(std::num::NonZeroUsize::new(d).unwrap()),
            None => statement,
        };
        guards.push(statement.await.unwrap());
        seen.push(got);
    }
    let listed: Vec<u32> = r.connections().iter().map(|c| c.depth).collect();
    assert_eq!(
        listed,
        vec![10, 200],
        "the list shows each connection's depth"
    );
    assert_eq!(burst.subscribers(), 2, "one relay reader per depth");
    for i in 0..100 {
        burst.publish(Int32 { data: i }).unwrap();
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    eventually(T, "the deep connection to deliver the whole burst", || {
        seen[1].lock().unwrap().len() == 100
    })
    .await;
    assert_eq!(*seen[1].lock().unwrap(), (0..100).collect::<Vec<_>>());
    eventually(T, "the default connection to deliver the newest", || {
        seen[0].lock().unwrap().last() == Some(&99)
    })
    .await;
    let shallow = seen[0].lock().unwrap().clone();
    assert_eq!(
        shallow,
        [0].into_iter().chain(90..100).collect::<Vec<_>>(),
        "keep-last 10 behind the slow first call"
    );
    // the deep connection gone, its relay reader goes too
    guards.pop();
    eventually(T, "the depth-200 reader to go", || burst.subscribers() == 1).await;
    // (a depth of 0 does not compile: ConnectionRequest's compile_fail doctests)
}

/// `waitfor` cannot miss: a waiter armed, then a signal emitted at once, then `recv` gets that signal, 200
/// times in a row (each time a fresh waiter on the same source, in this participant).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_waiter_sees_the_signal_emitted_right_after_it_is_armed() {
    let r = radar(35);
    let source = r.signal_publisher::<Int32>("/wf/value").unwrap();
    let signal = Signal::new("/wf/value", "std_msgs/msg/Int32");
    for i in 0..200 {
        let mut waiter = r.waiter::<Int32>(&signal).timeout(T).await.unwrap();
        source.publish(Int32 { data: i }).unwrap();
        let got = waiter
            .recv()
            .timeout(T)
            .await
            .unwrap_or_else(|e| panic!("round {i}: {e}"));
        assert_eq!(
            got.data, i,
            "round {i}: the signal emitted after arming, not an older one"
        );
    }
}

/// Rule 3 when R is busy: `once E start R until U` delivers its start while R runs another run, so R drops it
/// (it ignores starts while running, R6) and says so on `dropped`. The statement is then over (C3, issue 69:
/// before, it never ended: U went on checking and `closed()` never resolved), and U is let go; R's next run,
/// started by something else once R is idle again, is not this statement's run, and U must not interrupt it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn until_opens_no_window_for_a_start_the_busy_response_dropped() {
    let r = radar(36);
    let resp = r
        .spawn_response(
            "/ub/r",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_millis(600)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    let e = r.signal_publisher::<Empty>("/ub/e").unwrap();
    let u = r.signal_publisher::<Empty>("/ub/u").unwrap();
    let empty = "std_msgs/msg/Empty";
    // R is busy with a run no statement started
    r.inject(resp.reference().start_slot(), Empty::default())
        .timeout(T)
        .await
        .unwrap();
    eventually(T, "run 1", || resp.state().starts == 1).await;
    let c = r
        .once(Signal::new("/ub/e", empty))
        .start(&resp)
        .until(Signal::new("/ub/u", empty))
        .await
        .unwrap();
    e.publish(Empty::default()).unwrap();
    eventually(T, "the start to be dropped", || {
        resp.state().ignored_starts == 1
    })
    .await;
    c.closed()
        .timeout(T)
        .await
        .expect("the once ... until is over once R dropped its start");
    assert!(resp.state().starts == 1, "before run 1 ended");
    u.wait_for_no_subscribers()
        .timeout(T)
        .await
        .expect("U let go by the statement that is over");
    eventually(T, "run 1 to end", || resp.state().exits == 1).await;
    // later, something else starts R
    tokio::time::sleep(Duration::from_millis(100)).await;
    r.inject(resp.reference().start_slot(), Empty::default())
        .timeout(T)
        .await
        .unwrap();
    eventually(T, "run 2", || resp.state().starts == 2).await;
    // let the relay read R's `started` (another topic than U's) before U comes; the run lasts 600 ms
    tokio::time::sleep(Duration::from_millis(200)).await;
    u.publish(Empty::default()).unwrap();
    eventually(T, "run 2 to end", || resp.state().exits == 2).await;
    let s = resp.state();
    assert_eq!(
        (s.interrupts, s.completed),
        (0, 2),
        "U did not interrupt a run this statement did not start: {s:?}"
    );
}

/// Rule C6 when R is busy with the statement's own run: `whenever E start R until U` starts R's run 1; E again
/// while it goes on, and R drops that start (it ignores starts while running, R6) and says so; U then must
/// still interrupt run 1, which the statement began (issue 70's session: issue 69's first fix took the dropped
/// start for the end of the statement's run, and U interrupted nothing; the soak's pokes found it). 10 rounds.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_whenever_until_interrupts_its_run_after_a_later_start_was_dropped() {
    let r = radar(135);
    let resp = r
        .spawn_response(
            "/wd/r",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_secs(30)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    let e = r.signal_publisher::<Empty>("/wd/e").unwrap();
    let u = r.signal_publisher::<Empty>("/wd/u").unwrap();
    let empty = "std_msgs/msg/Empty";
    let _c = r
        .whenever(Signal::new("/wd/e", empty))
        .start(&resp)
        .until(Signal::new("/wd/u", empty))
        .await
        .unwrap();
    for round in 1..=10u64 {
        e.publish(Empty::default()).unwrap();
        eventually(T, "the statement's run", || resp.state().starts == round).await;
        e.publish(Empty::default()).unwrap();
        eventually(T, "the second start to be dropped", || {
            resp.state().ignored_starts == round
        })
        .await;
        u.publish(Empty::default()).unwrap();
        eventually(T, "U to interrupt the statement's run", || {
            resp.state().interrupts == round
        })
        .await;
        eventually(T, "the run to end", || resp.state().exits == round).await;
    }
}

/// Rule 5 for a target of this process: a response that stops takes its connection out of `Armed` naming
/// it; a plain connection is then lost for good, a rearming one delivers to a response of the same name
/// started later, and only what comes after.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_response_of_this_process_that_stops_loses_its_connections_and_a_rearming_one_finds_the_next(
) {
    use radar_ros::manager::Link;
    let r = radar(0);
    let go = r.signal_publisher::<Empty>("/go").unwrap();
    let src = Signal::new("/go", "std_msgs/msg/Empty");
    let (resp, runs) = counter(&r, "arm");
    let plain = r.whenever(&src).start(&resp).await.unwrap();
    let rearming = r.whenever(&src).start(&resp).rearm().await.unwrap();
    go.publish(Empty::default()).unwrap();
    eventually(T, "two runs (one per connection)", || {
        runs.load(Ordering::SeqCst) == 2
    })
    .await;
    resp.shutdown().await.unwrap();
    for c in [&plain, &rearming] {
        let d = c
            .departed()
            .timeout(T)
            .await
            .expect("the response's leaving noticed in time")
            .expect("departed");
        assert_eq!(d.component(), "/arm", "{d}");
    }
    assert_eq!(plain.link(), Some(Link::TargetLost));
    assert_eq!(rearming.link(), Some(Link::WaitingForTarget));
    // sent while there is no target: dropped, not kept for the next one
    go.publish(Empty::default()).unwrap();
    tokio::time::sleep(Duration::from_millis(200)).await;

    let (again, runs_again) = counter(&r, "arm");
    eventually(T, "the rearming connection armed again", || {
        rearming.link() == Some(Link::Armed)
    })
    .await;
    assert_eq!(plain.link(), Some(Link::TargetLost));
    assert_eq!(again.state().starts, 0, "nothing kept from before");
    go.publish(Empty::default()).unwrap();
    eventually(T, "the new response runs once", || {
        runs_again.load(Ordering::SeqCst) >= 1
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(
        runs_again.load(Ordering::SeqCst),
        1,
        "only the rearming connection delivers to it"
    );
    assert_eq!(runs.load(Ordering::SeqCst), 2);
}

/// Issue 32: a connection's own code (filter, map, anonymous slot) is user code; one that panics is caught like
/// a panicking slot. The signal it was called for is not delivered (a filter or map) or its call is over (a
/// call), the connection goes on, its panics are counted on it and in the manager's list, and the rest of the
/// program works: a new statement arms at once, and dropping the guards does not panic. (Before: the panic
/// poisoned the manager's lock, the next statement failed after 5 s, and the guards' drop panicked again.)
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_panicking_filter_map_or_call_is_caught_reported_and_the_program_goes_on() {
    let r = radar(111);
    let src = r.signal_publisher::<Int32>("/pn/n").unwrap();
    let signal = Signal::new("/pn/n", "std_msgs/msg/Int32");
    let took = Arc::new(Mutex::new(Vec::new()));
    let t = took.clone();
    let echo = r
        .spawn_response(
            "/pn/echo",
            FnResponse::new(move |n: Int32| {
                t.lock().unwrap().push(n.data);
                async { Ok(Empty::default()) }
            })
            .start_policy(radar_ros::StartPolicy::QueueOne),
        )
        .unwrap();
    let (count, runs) = counter(&r, "/pn/count");
    let filtered = r
        .whenever(&signal)
        .start(&echo)
        .filter(|n: &Int32| {
            assert!(n.data % 2 == 0, "odd {}", n.data);
            true
        })
        .await
        .unwrap();
    let mapped = r
        .whenever(&signal)
        .start(&count)
        .map(|n: Int32| {
            assert!(n.data != 1, "one");
            Empty::default()
        })
        .await
        .unwrap();
    let calls = Arc::new(Mutex::new(Vec::new()));
    let c = calls.clone();
    let called = r
        .whenever(&signal)
        .call(move |n: Int32| {
            assert!(n.data != 3, "three");
            c.lock().unwrap().push(n.data);
        })
        .await
        .unwrap();
    // a once whose filter panics is not used up by that signal
    let (once_target, once_runs) = counter(&r, "/pn/once");
    let once = r
        .once(&signal)
        .start(&once_target)
        .filter(|n: &Int32| {
            assert!(n.data != 1, "one");
            true
        })
        .await
        .unwrap();
    for data in 1..=4 {
        src.publish(Int32 { data }).unwrap();
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    eventually(T, "every delivery", || {
        took.lock().unwrap().len() == 2
            && runs.load(Ordering::SeqCst) == 3
            && calls.lock().unwrap().len() == 3
            && once_runs.load(Ordering::SeqCst) == 1
    })
    .await;
    assert_eq!(
        *took.lock().unwrap(),
        [2, 4],
        "the filter refused 1 and 3 by panicking"
    );
    assert_eq!(
        *calls.lock().unwrap(),
        [1, 2, 4],
        "the call after the one that panicked ran"
    );
    assert_eq!(
        (filtered.panics(), mapped.panics(), called.panics()),
        (2, 1, 1)
    );
    assert_eq!((filtered.delivered(), mapped.delivered()), (2, 3));
    let listed = r.connections();
    let entry = listed
        .iter()
        .find(|k| k.id == filtered.id())
        .expect("the connection is listed");
    assert_eq!(entry.panics, 2);
    assert!(
        entry.panic.starts_with("filter: odd 3"),
        "the last panic, named: {:?}",
        entry.panic
    );
    assert_eq!(entry.state_label, "armed");
    // the rest of the program works: a new statement arms at once and delivers
    let (after, after_runs) = counter(&r, "/pn/after");
    let _later = r
        .whenever(&signal)
        .start(&after)
        .timeout(Duration::from_secs(3))
        .await
        .expect("a statement after the panics arms");
    src.publish(Int32 { data: 6 }).unwrap();
    eventually(T, "the new statement's delivery", || {
        after_runs.load(Ordering::SeqCst) == 1
    })
    .await;
    drop((filtered, mapped, called, once));
}

/// Issue 32, rule R14: `once E start R until U` while R is busy with another run. R's start waits (QueueOne),
/// or waits for the run before to go through its interrupt and exit slots (Restart); U comes while it waits.
/// The run that start then begins is the statement's, and U, sent after its start, bounds it: it is
/// interrupted at once. (Before: U reached R while the other run went on, was dropped as not for that run,
/// and the queued run ran unbounded.) Five rounds per policy, no settling sleep between E and U.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn until_bounds_the_run_of_a_start_that_waited_for_another_run() {
    use radar_ros::StartPolicy;
    let r = radar(112);
    let empty = "std_msgs/msg/Empty";
    for (policy, tag) in [(StartPolicy::QueueOne, "q"), (StartPolicy::Restart, "x")] {
        for round in 0..5 {
            let name = format!("/qb/{tag}{round}");
            let resp = r
                .spawn_response(
                    &name,
                    FnResponse::new(|_: Empty| async {
                        tokio::time::sleep(Duration::from_millis(600)).await;
                        Ok(Empty::default())
                    })
                    .start_policy(policy)
                    // Restart: the run before spends 300 ms in its exit slot after the start interrupted it
                    .on_exit(|_| async {
                        tokio::time::sleep(Duration::from_millis(300)).await;
                        ExitAction::Done
                    }),
                )
                .unwrap();
            let e = r.signal_publisher::<Empty>(&format!("{name}/e")).unwrap();
            let u = r.signal_publisher::<Empty>(&format!("{name}/u")).unwrap();
            r.inject(resp.reference().start_slot(), Empty::default())
                .timeout(T)
                .await
                .unwrap();
            eventually(T, "run 1", || resp.state().starts == 1).await;
            let _c = r
                .once(Signal::new(format!("{name}/e"), empty))
                .start(&resp)
                .until(Signal::new(format!("{name}/u"), empty))
                .await
                .unwrap();
            e.publish(Empty::default()).unwrap();
            u.publish(Empty::default()).unwrap();
            eventually(T, "the statement's run to end", || resp.state().exits == 2).await;
            let s = resp.state();
            let interrupted_by_start = u64::from(policy == StartPolicy::Restart);
            assert_eq!(
                (s.starts, s.interrupts, s.completed),
                (2, 1 + interrupted_by_start, 1 - interrupted_by_start),
                "{policy:?} round {round}: U bounds the run its statement's start began after waiting: {s:?}"
            );
            assert_eq!(
                s.last_exit_reason, "interrupted",
                "{policy:?} round {round}: {s:?}"
            );
        }
    }
}

/// Issue 32 (found by the soak): `whenever E start R until U` where U comes from one-shot publishers, as an
/// operator's `ros2 topic pub --once` or a fresh process per stop: nobody publishes U when the statement is
/// armed. It arms at once (before: it waited for a publisher of U and failed after its timeout), and each U
/// that a fresh process sends later interrupts the run the statement started.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn until_armed_before_anyone_publishes_its_signal_hears_one_shot_publishers() {
    const PEER: &str = env!("CARGO_BIN_EXE_radar_test_peer");
    let r = radar(113);
    let resp = r
        .spawn_response(
            "/oneshot/long",
            FnResponse::new(|_: Empty| async {
                tokio::time::sleep(Duration::from_secs(30)).await;
                Ok(Empty::default())
            }),
        )
        .unwrap();
    let e = r.signal_publisher::<Empty>("/oneshot/go").unwrap();
    let _c = r
        .whenever(Signal::new("/oneshot/go", "std_msgs/msg/Empty"))
        .start(&resp)
        .until(Signal::new("/oneshot/stop", "std_msgs/msg/Empty"))
        .timeout(Duration::from_secs(3))
        .await
        .expect("armed with no publisher of the until's signal");
    for n in 1..=2u64 {
        e.publish(Empty::default()).unwrap();
        eventually(T, "a run", || resp.state().starts == n).await;
        // `ros2 topic pub --once /oneshot/stop`: a fresh process, one signal, gone
        let mut p = radar_test_util::HostPeer::start(PEER, 113).await;
        p.run("publisher /oneshot/stop").await;
        p.send("emit-exit /oneshot/stop").await;
        assert!(p.wait().await.success());
        eventually(T, "the one-shot U interrupts the run", || {
            resp.state().interrupts == n
        })
        .await;
    }
}

/// Holds at once when it begins to check, and never again: a condition already true when a statement
/// connects it (a door already open, a battery already low). Its one trigger is emitted as soon as the
/// statement's reader activates it, which is before the statement is fully armed.
struct AlreadyTrue(bool);
impl Event for AlreadyTrue {
    type Payload = Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        if std::mem::replace(&mut self.0, true) {
            std::future::pending::<()>().await;
        }
        Ok(Empty::default())
    }
}

/// An event whose condition already holds when the statement connects it triggers as the statement's reader
/// activates it, before the statement is armed (its writer to the slot matched): `once` and `whenever` still
/// deliver that trigger (it was emitted after the statement ran: C1 counts from when the statement began),
/// and `waitfor` returns it. The event lives in this participant (the in-process tap) or in another one
/// (DDS); 10 rounds each, a fresh event each round.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_event_already_true_when_connected_delivers_its_first_trigger() {
    let r = radar(226);
    let other = radar(226);
    let (resp, runs) = counter(&r, "already/count");
    for round in 0..20u64 {
        let home = if round % 2 == 0 { &r } else { &other };
        let ev = home
            .spawn_event(&format!("already/e{round}"), AlreadyTrue(false))
            .unwrap();
        let src = r
            .event(&format!("/already/e{round}"))
            .timeout(T)
            .await
            .unwrap()
            .triggered();
        let started = runs.load(Ordering::SeqCst);
        let c = if round % 4 < 2 {
            r.once(src).start(&resp).await.unwrap()
        } else {
            r.whenever(src).start(&resp).await.unwrap()
        };
        eventually(
            T,
            &format!("round {round}: the first trigger's run"),
            || runs.load(Ordering::SeqCst) == started + 1,
        )
        .await;
        // the state follows the signal (the run may come first)
        eventually(T, &format!("round {round}: one trigger"), || {
            ev.state().triggers == 1
        })
        .await;
        drop(c);
    }
    // waitfor: the waiter's own reader activates the event
    for round in 0..10u64 {
        let home = if round % 2 == 0 { &r } else { &other };
        let _ev = home
            .spawn_event(&format!("already/w{round}"), AlreadyTrue(false))
            .unwrap();
        let signal = Signal::new(format!("/already/w{round}/triggered"), "std_msgs/msg/Empty");
        let mut waiter = r.waiter::<Empty>(&signal).timeout(T).await.unwrap();
        waiter
            .recv()
            .timeout(T)
            .await
            .unwrap_or_else(|e| panic!("waitfor round {round}: {e}"));
    }
}

/// Rule C4 (issue 69): a fired `once ... call` whose guard is dropped before its call began begins no call
/// after that. The once fires (its payload waits in the anonymous slot's queue, for the slot's own task) and its
/// scope ends at once, 200 times in a row with no pause between: a call that begins after the guard dropped is
/// counted (before: the table no longer knew the spent connection's queue, so the drop did not cancel it, and
/// the call came after the scope had ended).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fired_once_call_begins_no_call_after_its_scope_ended() {
    let r = radar(127);
    let source = r.signal_publisher::<Empty>("/oc/e").unwrap();
    let signal = Signal::new("/oc/e", "std_msgs/msg/Empty");
    let late = Arc::new(AtomicU64::new(0));
    let (mut called, mut dropped_first) = (0, 0);
    for _ in 0..200 {
        let scope_over = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let calls = Arc::new(AtomicU64::new(0));
        let (over, late2, calls2) = (scope_over.clone(), late.clone(), calls.clone());
        let c = r
            .once(&signal)
            .call(move |_: Empty| {
                calls2.fetch_add(1, Ordering::SeqCst);
                if over.load(Ordering::SeqCst) {
                    late2.fetch_add(1, Ordering::SeqCst);
                }
            })
            .timeout(T)
            .await
            .unwrap();
        source.publish(Empty::default()).unwrap();
        // the once fires: gone from the table; its scope ends at once
        let began = std::time::Instant::now();
        while c.is_live() {
            assert!(began.elapsed() < T, "the once never fired");
            std::hint::spin_loop();
        }
        let before = calls.load(Ordering::SeqCst);
        drop(c);
        // from here no call may begin
        scope_over.store(true, Ordering::SeqCst);
        if before == 0 && calls.load(Ordering::SeqCst) == 0 {
            dropped_first += 1;
        }
        tokio::task::yield_now().await;
        called += calls.load(Ordering::SeqCst);
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    println!("{dropped_first} of 200 scopes ended before the call could begin; {called} calls began before");
    assert_eq!(
        late.load(Ordering::SeqCst),
        0,
        "calls began after their statement's scope had ended ({dropped_first} of 200 rounds dropped first)"
    );
}

/// `.timeout(d)` bounds the whole of arming, not each wait in it: a source whose publisher appears at 0.7 d and
/// a target nobody serves fail after about d (each wait given all of d took 1.7 d).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_arming_timeout_bounds_the_whole_arming_not_each_wait() {
    let r = radar(130);
    let d = Duration::from_millis(1500);
    let source = Signal::new("/late_source/triggered", "std_msgs/msg/Empty");
    let nobody = radar_ros::ResponseRef::new(
        radar_ros::graph::ComponentName::resolve("/nobody_serves", "/").unwrap(),
        "std_msgs/msg/Empty",
        "std_msgs/msg/Empty",
    );
    let began = std::time::Instant::now();
    let (armed, _publisher) = tokio::join!(r.once(&source).start(&nobody).timeout(d), async {
        tokio::time::sleep(d.mul_f64(0.7)).await;
        r.signal_publisher::<Empty>(source.topic()).unwrap()
    });
    let took = began.elapsed();
    let e = armed.expect_err("nobody serves the target");
    assert!(matches!(e, Error::Timeout { .. }), "{e:?}");
    assert!(
        e.to_string().contains("/nobody_serves/start"),
        "the error names what it waited for last: {e}"
    );
    assert!(
        took < d.mul_f64(1.3),
        "arming with .timeout({d:?}) took {took:?}"
    );
}
