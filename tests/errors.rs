//! Bad input gets a clear error and loses nothing: invalid ROS names, bad ROS_DOMAIN_ID values, malformed
//! and mistyped messages on slot topics, malformed CDR from raw DDS writers on every slot and service of a
//! component in another process. Domains 50-52, 54.

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Int32, ResponseState},
    ros_message, Error, FnResponse, Radar, TimerEvent, TopicEvent,
};
use radar_test_util::{eventually, radar, ResponseProbe, Seen, DISCOVERY};
use serde::{Deserialize, Serialize};

/// The first state message on `state` that satisfies `want` (within [`DISCOVERY`]).
async fn first_state(
    state: &radar_ros::topics::SignalSubscription<ResponseState>,
    want: impl Fn(&ResponseState) -> bool,
) -> ResponseState {
    let last = std::sync::Mutex::new(None);
    let found = tokio::time::timeout(DISCOVERY, async {
        loop {
            let s = state.recv().await.unwrap();
            if want(&s) {
                return s;
            }
            *last.lock().unwrap() = Some(s);
        }
    })
    .await;
    found.unwrap_or_else(|_| {
        panic!(
            "no such state in time; the last was {:?}",
            last.lock().unwrap()
        )
    })
}

fn noop() -> FnResponse<Empty, Empty> {
    FnResponse::new(|_: Empty| async { Ok(Empty::default()) })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn invalid_names_fail_before_anything_is_created() {
    let r = radar(50);
    for bad in ["count-up", "1st", "a//b", "", "~/x", "ns/"] {
        let e = r.spawn_response(bad, noop()).unwrap_err();
        assert!(matches!(e, Error::InvalidName { .. }), "{bad:?}: {e:?}");
        assert!(
            e.to_string()
                .starts_with(&format!("invalid ROS name \"{bad}\"")),
            "{e}"
        );
        let e = r
            .spawn_event(bad, TimerEvent::new(Duration::from_secs(1)))
            .unwrap_err();
        assert!(matches!(e, Error::InvalidName { .. }), "{bad:?}: {e:?}");
    }
    let e = r
        .spawn_response("count-up", noop())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("'-' is not allowed") && e.contains("count_up"),
        "suggests a fix: {e}"
    );
    // a topic event with a bad topic name fails as well, and its node name stays free
    let e = r
        .spawn_event(
            "hot",
            TopicEvent::new("temp erature", |_: &Int32| Some(Empty::default())),
        )
        .unwrap_err();
    assert!(e.to_string().contains("' ' is not allowed"), "{e}");
    let e = Radar::builder()
        .domain_id(50)
        .namespace("/bad-ns")
        .build()
        .unwrap_err();
    assert!(e.to_string().contains("bad-ns"), "{e}");

    // nothing was claimed by the failures: valid names still work, and duplicates are refused
    let _ok = r.spawn_response("count_up", noop()).unwrap();
    let e = r.spawn_response("/count_up", noop()).unwrap_err();
    assert!(matches!(e, Error::DuplicateName(_)), "{e:?}");
    assert!(
        e.to_string().contains("already runs in this process"),
        "{e}"
    );
    let _hot = r
        .spawn_event("hot", TimerEvent::new(Duration::from_secs(1)))
        .unwrap();
}

fn check_env(value: &str) -> (i32, String, String) {
    check_env_with(&[("ROS_DOMAIN_ID", value)])
}

/// `radar_test_peer check-env` run with `vars` set (and `RMW_IMPLEMENTATION` unset unless given).
fn check_env_with(vars: &[(&str, &str)]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_radar_test_peer"))
        .arg("check-env")
        .env_remove("RMW_IMPLEMENTATION")
        .envs(vars.iter().copied())
        .output()
        .expect("run radar_test_peer");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn wrong_ros_domain_id_values_fail_with_a_clear_error() {
    radar_test_util::require_isolation();
    for (value, why) in [
        ("abc", "not a whole number"),
        ("300", "above 232"),
        ("-3", "not a whole number"),
        ("4.5", "not a whole number"),
    ] {
        let (code, _, err) = check_env(value);
        assert_eq!(code, 2, "ROS_DOMAIN_ID={value:?} must fail");
        assert!(
            err.contains(&format!("invalid ROS_DOMAIN_ID \"{value}\"")) && err.contains(why),
            "ROS_DOMAIN_ID={value:?}: {err}"
        );
        assert!(err.contains("0 to 232"), "says what to do: {err}");
    }
    let (code, out, err) = check_env("57");
    assert_eq!((code, out.trim()), (0, "ok domain=57"), "{err}");
    let (code, out, _) = check_env("");
    assert_eq!((code, out.trim()), (0, "ok domain=0"));
}

/// `RMW_IMPLEMENTATION`, as ROS 2 chooses its middleware: a program started in a shell set up for a middleware
/// radar_ros does not speak stops at once saying so and what to set, instead of running on DDS and seeing none
/// of its peers; a DDS middleware's name (as a Fast DDS or Cyclone DDS system sets) runs, and so does
/// `rmw_zenoh_cpp` in this build, which has the `zenoh` feature (tests/Cargo.toml; a build without it refuses
/// it, saying to build with the feature: tests/user_crate.rs runs one).
#[test]
fn a_middleware_this_build_does_not_speak_stops_the_program_saying_what_to_set() {
    radar_test_util::require_isolation();
    let domain = std::env::var("ROS_DOMAIN_ID").unwrap_or_default();
    let (code, _, err) = check_env_with(&[
        ("ROS_DOMAIN_ID", &domain),
        ("RMW_IMPLEMENTATION", "rmw_nothing_cpp"),
    ]);
    assert_eq!(
        code, 2,
        "RMW_IMPLEMENTATION=rmw_nothing_cpp must fail: {err}"
    );
    assert!(
        err.contains("invalid RMW_IMPLEMENTATION \"rmw_nothing_cpp\"")
            && err.contains("not a ROS 2 middleware radar_ros knows")
            && err.contains("unset RMW_IMPLEMENTATION"),
        "{err}"
    );
    for rmw in [
        "rmw_fastrtps_cpp",
        "rmw_cyclonedds_cpp",
        "",
        "rmw_zenoh_cpp",
    ] {
        let (code, out, err) =
            check_env_with(&[("ROS_DOMAIN_ID", &domain), ("RMW_IMPLEMENTATION", rmw)]);
        assert_eq!(
            (code, out.trim().starts_with("ok")),
            (0, true),
            "{rmw}: {err}"
        );
    }
}

/// Four bytes on the wire under the name std_msgs/msg/Empty's neighbour String: a string length with no text.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
struct Garbage {
    claimed_len: u32,
}
ros_message!(Garbage, "std_msgs", "String");

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_slot_messages_are_dropped_and_the_response_keeps_serving() {
    let host = radar(51);
    let h = host
        .spawn_response(
            "echo",
            radar_ros::FnResponse::new(|s: radar_ros::msg::StringMsg| async move { Ok(s) }),
        )
        .unwrap();
    let probe_radar = radar(51);
    let bad = probe_radar
        .signal_publisher::<Garbage>("/echo/start")
        .unwrap();
    let probe = ResponseProbe::<radar_ros::msg::StringMsg, radar_ros::msg::StringMsg>::connect(
        &probe_radar,
        "/echo",
    )
    .await;
    bad.wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    // the Garbage writer has type std_msgs/msg/String, like the slot: it counts
    h.wait_for_peers(1, 1).timeout(DISCOVERY).await.unwrap();
    eventually(DISCOVERY, "two publishers on start", || {
        h.slot_publishers()[0] == 2
    })
    .await;
    bad.publish(Garbage {
        claimed_len: 1_000_000,
    })
    .unwrap();
    probe.assert_quiet(Duration::from_millis(300)).await;
    assert_eq!(h.state().starts, 0);
    probe.start.publish("fine".into()).unwrap();
    assert_eq!(
        probe.signals(2, Duration::from_secs(10)).await,
        [Seen::Started("fine".into()), Seen::Exited("fine".into())]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_slot_published_with_the_wrong_type_does_not_match_and_changes_nothing() {
    let host = radar(52);
    let h = host.spawn_response("r", noop()).unwrap();
    let other = radar(52);
    let state = other
        .state_subscription::<ResponseState>("/r/state")
        .unwrap();
    state.recv().timeout(DISCOVERY).await.unwrap();
    let wrong = other.signal_publisher::<Int32>("/r/start").unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(
        wrong.subscribers(),
        0,
        "a String/Int32 reader must not match an Empty slot"
    );
    wrong.publish(Int32 { data: 1 }).unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(h.state().starts, 0);
    // the right type still works
    let right = other.signal_publisher::<Empty>("/r/start").unwrap();
    right
        .wait_for_subscribers(1)
        .timeout(DISCOVERY)
        .await
        .unwrap();
    eventually(DISCOVERY, "the Empty publisher on start", || {
        h.slot_publishers()[0] >= 1
    })
    .await;
    assert_eq!(
        h.slot_publishers()[0],
        1,
        "the Int32 publisher is not counted"
    );
    right.publish(Empty::default()).unwrap();
    let st = first_state(&state, |s| s.exits == 1).await;
    assert_eq!(st.starts, 1);
}

/// Whether `bytes` decode as a `T` as the server reads them: little-endian CDR, after the transport padded
/// the payload to a multiple of 4 bytes with zeros.
fn decodes<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> bool {
    let mut padded = bytes.to_vec();
    padded.resize(bytes.len().div_ceil(4) * 4, 0);
    ros2_client::dds::rustdds::cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(&padded)
        .is_ok()
}

/// A request body sent as is, under whatever service type the client names.
#[derive(Clone, Debug)]
struct Bytes(Vec<u8>);

impl Serialize for Bytes {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(self.0.len())?;
        for b in &self.0 {
            t.serialize_element(b)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Bytes {
    fn deserialize<D: serde::Deserializer<'de>>(_: D) -> Result<Self, D::Error> {
        Ok(Bytes(Vec::new())) // no answer is expected
    }
}

impl ros2_client::Message for Bytes {}

/// Bodies that claim a string of 1 MB, 16 bytes, 0x7fffffff bytes, or are cut short: none decodes as a
/// std_msgs/msg/String (or anything with a string first), whatever follows.
fn garbage(rng: &mut u64) -> Vec<radar_ros::topics::RawMessage> {
    let mut next = move || {
        // xorshift
        *rng ^= *rng << 13;
        *rng ^= *rng >> 7;
        *rng ^= *rng << 17;
        *rng
    };
    let mut random = |n: usize, claim: u32| {
        let mut v = claim.to_le_bytes().to_vec();
        v.extend((0..n).map(|_| next() as u8));
        radar_ros::topics::RawMessage::from_bytes(v)
    };
    vec![
        radar_ros::topics::RawMessage::from_bytes(vec![]), // nothing at all
        radar_ros::topics::RawMessage::from_bytes(vec![0x10, 0, 0]), // a length cut short
        radar_ros::topics::RawMessage::from_bytes(vec![0x10, 0, 0, 0, b'a']), // claims 16 bytes, has 1
        random(64, 1_000_000),        // random, claiming 1 MB
        random(200_000, 0x7fff_ffff), // oversized, claiming 2 GB
    ]
}

/// RADAR issue 11: a raw DDS writer with the right type name sends truncated, oversized and random CDR on
/// every slot of a response and on every service of a manager, from two publishers. The component (another
/// process) does not crash, counts each per publisher, logs each publisher once per topic, and valid traffic
/// on the same topics keeps flowing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_cdr_on_every_slot_and_service_is_counted_logged_once_and_valid_traffic_flows() {
    use radar_test_util::{HostPeer, ManagerClient};
    const PEER: &str = env!("CARGO_BIN_EXE_radar_test_peer");
    let seed: u64 = std::env::var("RADAR_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed_1234_abcd_0001);
    println!("seed {seed} (RADAR_SEED to repeat)");
    let mut host = HostPeer::start_logging(PEER, 54, "warn,rustdds=error,ros2_client=error").await;
    host.run("echo echo").await;
    host.run("manager mgr").await;
    let a = radar(54);
    let b = radar(54);
    let mut rng = seed | 1;
    let mut sent_start = 0;
    let mut sent_empty = 0;
    for sender in [&a, &b] {
        let start = sender
            .raw_publisher("/echo/start", "std_msgs/msg/String")
            .unwrap();
        let interrupt = sender
            .raw_publisher("/echo/interrupt", "std_msgs/msg/Empty")
            .unwrap();
        let exit = sender
            .raw_publisher("/echo/exit", "std_msgs/msg/Empty")
            .unwrap();
        for p in [&start, &interrupt, &exit] {
            p.wait_for_subscribers(1).timeout(DISCOVERY).await.unwrap();
        }
        for g in garbage(&mut rng) {
            start.publish(g).unwrap();
            sent_start += 1;
        }
        for p in [&interrupt, &exit] {
            // an Empty is one byte; nothing at all does not decode
            p.publish(radar_ros::topics::RawMessage::from_bytes(vec![]))
                .unwrap();
            sent_empty += 1;
        }
        // keep the writers until their samples are acknowledged
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
    // the services: raw bodies under the request types' names
    let garbage_client = {
        use ros2_client::{dds::ServiceMapping, Name, NodeName, NodeOptions, ServiceTypeName};
        let mut node = a
            .dds_context()
            .expect("a DDS Radar")
            .new_node(
                NodeName::new("/", "garbage").unwrap(),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .unwrap();
        let q = radar_ros::qos::signal_qos();
        let mut clients = Vec::new();
        for (svc, ty) in [
            ("connect", "Connect"),
            ("disconnect", "Disconnect"),
            ("list", "List"),
        ] {
            let c: ros2_client::dds::Client<Bytes, Bytes> = node
                .create_client(
                    ServiceMapping::Enhanced,
                    &Name::new("/mgr", svc).unwrap(),
                    &ServiceTypeName::new("radar_msgs", ty),
                    q.clone(),
                    q.clone(),
                )
                .unwrap();
            clients.push((svc, c));
        }
        (node, clients)
    };
    let mut sent_requests = 0;
    for (svc, c) in &garbage_client.1 {
        // a valid request first, repeated until answered: the service is matched, nothing is lost
        let valid = match *svc {
            "connect" => radar_ros::topics::RawMessage::encode(&radar_ros::msg::ConnectRequest {
                kind: radar_ros::msg::Connection::WHENEVER,
                source: "not a topic".into(),
                target: "/echo/start".into(),
                ..Default::default()
            }),
            "disconnect" => {
                radar_ros::topics::RawMessage::encode(&radar_ros::msg::DisconnectRequest {
                    id: 424242,
                })
            }
            _ => radar_ros::topics::RawMessage::encode(&radar_ros::msg::ListRequest::default()),
        }
        .unwrap();
        radar_test_util::call_service(c, Bytes(valid.into_bytes()), DISCOVERY).await;
        // List's request is one padding byte: only an empty body fails to decode
        let bodies = if *svc == "list" {
            vec![radar_ros::topics::RawMessage::from_bytes(vec![])]
        } else {
            garbage(&mut rng)
        };
        for body in bodies {
            // bodies that happen to decode as the request (random bytes are a fine u64 id) are valid
            let bad = match *svc {
                "connect" => !decodes::<radar_ros::msg::ConnectRequest>(body.as_bytes()),
                "disconnect" => !decodes::<radar_ros::msg::DisconnectRequest>(body.as_bytes()),
                _ => !decodes::<radar_ros::msg::ListRequest>(body.as_bytes()),
            };
            c.send_request(Bytes(body.into_bytes())).unwrap();
            sent_requests += u64::from(bad);
        }
    }
    tokio::time::sleep(Duration::from_millis(500)).await;

    // valid traffic still flows: a start, a manager list and a connect
    let probe =
        ResponseProbe::<radar_ros::msg::StringMsg, radar_ros::msg::StringMsg>::connect(&a, "/echo")
            .await;
    // the response's signal writers have matched the probe's readers too (a volatile writer sends only to
    // readers it has matched)
    host.run("wait-peers echo 0 1").await;
    let state = a
        .state_subscription::<ResponseState>("/echo/state")
        .unwrap();
    probe.start.publish("fine".into()).unwrap();
    // the run, as the response's state tells it, then as its signals do
    let st = first_state(&state, |s| s.exits == 1).await;
    assert_eq!(
        probe.signals(2, Duration::from_secs(10)).await,
        [Seen::Started("fine".into()), Seen::Exited("fine".into())]
    );
    let client = ManagerClient::new(&b, "/mgr", "valid").await;
    let listed = radar_test_util::call_once(&client.list, Default::default(), DISCOVERY).await;
    assert!(listed.connections.is_empty());

    // counted per topic and publisher
    assert_eq!(st.malformed, sent_start + sent_empty, "{st:?}");
    assert_eq!(st.starts, 1);
    let counts = host.query("malformed").await;
    println!("{counts:#?}");
    let count_of = |topic: &str| -> Vec<u64> {
        let mut v: Vec<u64> = counts
            .iter()
            .filter(|l| l.split(' ').next() == Some(topic))
            .map(|l| l.rsplit(' ').next().unwrap().parse().unwrap())
            .collect();
        v.sort();
        v
    };
    assert_eq!(count_of("/echo/start"), [5, 5], "two publishers, five each");
    assert_eq!(count_of("/echo/interrupt"), [1, 1]);
    assert_eq!(count_of("/echo/exit"), [1, 1]);
    let service_total: u64 = ["/mgr/connect", "/mgr/disconnect", "/mgr/list"]
        .iter()
        .flat_map(|t| count_of(t))
        .sum();
    assert_eq!(
        service_total, sent_requests,
        "every request that does not decode is counted"
    );

    // logged once per topic and publisher (services: once per service, the sender is not known)
    let warnings: Vec<String> = host
        .stderr()
        .into_iter()
        .filter(|l| l.contains("does not decode"))
        .collect();
    assert_eq!(warnings.len(), 2 + 2 + 2 + 3, "{warnings:#?}");
    assert!(
        host.stderr()
            .iter()
            .all(|l| !l.contains("panicked") && !l.contains("ERROR")),
        "{:#?}",
        host.stderr()
    );
    // and it is alive
    host.run("publisher /still/here").await;
    host.send("quit").await;
    assert!(host.wait().await.success());
}
