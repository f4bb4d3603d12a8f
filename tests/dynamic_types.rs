//! Issue 24, step 1: components whose message types are known only at run time ([`DynMessage`] payloads
//! with their types given as names, as the Python package makes them) are spawned, connected, started and
//! heard like typed ones, their payloads passed through byte for byte; one that does not say its types is
//! refused with an error that says what to do.

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Int32, StringMsg},
    topics::DynMessage,
    topics::RawMessage,
    Error, Event, Response, SlotError,
};
use radar_test_util::{radar, DISCOVERY};

/// Echoes its start payload (a `std_msgs/msg/String`, by its bytes) as its output, prefixed.
struct Echo {
    ty: &'static str,
}

impl Response for Echo {
    type Start = DynMessage;
    type Output = DynMessage;

    async fn start(&mut self, p: DynMessage) -> Result<DynMessage, SlotError> {
        let s: StringMsg = p.0.decode().map_err(|e| SlotError::msg(e.to_string()))?;
        let out = StringMsg::from(format!("echo:{}", s.data).as_str());
        Ok(DynMessage(RawMessage::encode(&out).expect("encodes")))
    }

    fn start_type(&self) -> String {
        self.ty.to_owned()
    }

    fn output_type(&self) -> String {
        self.ty.to_owned()
    }
}

/// Triggers with 1, 2, 3, ... (as `std_msgs/msg/Int32` bytes) every 20 ms while listened to.
struct Counter(i32);

impl Event for Counter {
    type Payload = DynMessage;

    async fn check(&mut self) -> Result<DynMessage, SlotError> {
        tokio::time::sleep(Duration::from_millis(20)).await;
        self.0 += 1;
        Ok(DynMessage(
            RawMessage::encode(&Int32 { data: self.0 }).expect("encodes"),
        ))
    }

    fn payload_type(&self) -> String {
        "std_msgs/msg/Int32".to_owned()
    }
}

/// A response typed at run time is found by another participant with its given types, started by a typed
/// publisher's payload through `once`, and its `started`/`exited` carry the bytes a typed peer reads.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_response_typed_at_run_time_is_started_and_heard_as_a_typed_one() {
    let host = radar(108);
    let user = radar(108);
    let echo_handle = host
        .spawn_response(
            "echo",
            Echo {
                ty: "std_msgs/msg/String",
            },
        )
        .unwrap();
    let echo = user.response("/echo").timeout(DISCOVERY).await.unwrap();
    assert_eq!(echo.started().ros_type(), "std_msgs/msg/String");
    assert_eq!(echo.exited().ros_type(), "std_msgs/msg/String");

    // a typed caller: waiter on exited, inject a typed payload into start
    let mut started = user
        .waiter::<StringMsg>(echo.started())
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let mut exited = user
        .waiter::<StringMsg>(echo.exited())
        .timeout(DISCOVERY)
        .await
        .unwrap();
    user.inject(echo.start_slot(), StringMsg::from("kitchen"))
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let s = started.recv().timeout(DISCOVERY).await.unwrap();
    assert_eq!(s.data, "kitchen");
    let out = exited.recv().timeout(DISCOVERY).await.unwrap();
    assert_eq!(out.data, "echo:kitchen");
    assert_eq!(
        echo_handle.state().start_type,
        "std_msgs/msg/String",
        "the state says the type given at run time"
    );
}

/// An event typed at run time drives a typed anonymous slot and a run-time typed one (`DynMessage` takes
/// any source), with the same payload bytes; a typed slot of another type is refused.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_event_typed_at_run_time_drives_typed_and_dynamic_slots() {
    use std::sync::{Arc, Mutex};
    let r = radar(108);
    let ev = r.spawn_event("dyn_counter", Counter(0)).unwrap();
    assert_eq!(ev.triggered().ros_type(), "std_msgs/msg/Int32");
    let typed: Arc<Mutex<Vec<i32>>> = Default::default();
    let raw: Arc<Mutex<Vec<RawMessage>>> = Default::default();
    let (t, w) = (typed.clone(), raw.clone());
    let _a = r
        .whenever(ev.triggered())
        .call(move |m: Int32| t.lock().unwrap().push(m.data))
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let _b = r
        .whenever(ev.triggered())
        .call(move |m: DynMessage| w.lock().unwrap().push(m.0))
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let wrong = r
        .whenever(ev.triggered())
        .call(|_: StringMsg| {})
        .timeout(DISCOVERY)
        .await;
    assert!(
        matches!(&wrong, Err(Error::PayloadType { expected, .. }) if expected == "std_msgs/msg/Int32"),
        "{wrong:?}"
    );
    let deadline = tokio::time::Instant::now() + DISCOVERY;
    while typed.lock().unwrap().len() < 3 || raw.lock().unwrap().len() < 3 {
        assert!(tokio::time::Instant::now() < deadline, "3 triggers each");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let typed = typed.lock().unwrap().clone();
    let raw: Vec<i32> = raw
        .lock()
        .unwrap()
        .iter()
        .map(|m| m.decode::<Int32>().unwrap().data)
        .collect();
    assert_eq!(&typed[..3], &[1, 2, 3]);
    assert_eq!(&raw[..3], &[1, 2, 3]);
}

/// A `DynMessage` component that does not say its types, or says a malformed one, is not spawned; the error
/// names what to say.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_component_that_does_not_say_its_run_time_types_is_refused() {
    struct Silent;
    impl Response for Silent {
        type Start = DynMessage;
        type Output = Empty;
        async fn start(&mut self, _: DynMessage) -> Result<Empty, SlotError> {
            Ok(Empty::default())
        }
    }
    struct SilentEvent;
    impl Event for SilentEvent {
        type Payload = DynMessage;
        async fn check(&mut self) -> Result<DynMessage, SlotError> {
            std::future::pending().await
        }
    }
    let r = radar(108);
    let Err(e) = r.spawn_response("silent", Silent) else {
        panic!("refused")
    };
    assert!(e.to_string().contains("Response::start_type"), "{e}");
    let Err(e) = r.spawn_event("silent_event", SilentEvent) else {
        panic!("refused")
    };
    assert!(e.to_string().contains("Event::payload_type"), "{e}");
    let Err(e) = r.spawn_response(
        "bad_type",
        Echo {
            ty: "std_msgs/String/Extra",
        },
    ) else {
        panic!("refused")
    };
    assert!(e.to_string().contains("std_msgs/String/Extra"), "{e}");
    // nothing was left behind: the names are free
    let _ok = r
        .spawn_response(
            "silent",
            Echo {
                ty: "std_msgs/msg/String",
            },
        )
        .unwrap();
}

/// A run typed at run time that does not complete sends the response's `incomplete_output` on `exited` (a
/// `DynMessage`'s own default has no bytes, which no peer could read).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_incomplete_run_typed_at_run_time_exits_with_the_types_default() {
    struct Slow;
    impl Response for Slow {
        type Start = DynMessage;
        type Output = DynMessage;
        async fn start(&mut self, _: DynMessage) -> Result<DynMessage, SlotError> {
            std::future::pending().await
        }
        fn start_type(&self) -> String {
            "std_msgs/msg/Empty".into()
        }
        fn output_type(&self) -> String {
            "std_msgs/msg/Int32".into()
        }
        fn incomplete_output(&self) -> Option<DynMessage> {
            Some(DynMessage(RawMessage::encode(&Int32 { data: -1 }).unwrap()))
        }
    }
    let r = radar(108);
    let slow = r.spawn_response("dyn_slow", Slow).unwrap();
    let slow = slow.reference().clone();
    let mut exited = r
        .waiter::<Int32>(slow.exited())
        .timeout(DISCOVERY)
        .await
        .unwrap();
    let mut started = r
        .waiter::<Empty>(slow.started())
        .timeout(DISCOVERY)
        .await
        .unwrap();
    r.inject(slow.start_slot(), Empty::default())
        .timeout(DISCOVERY)
        .await
        .unwrap();
    started.recv().timeout(DISCOVERY).await.unwrap();
    r.inject(slow.interrupt_slot(), Empty::default())
        .timeout(DISCOVERY)
        .await
        .unwrap();
    assert_eq!(exited.recv().timeout(DISCOVERY).await.unwrap().data, -1);
}
