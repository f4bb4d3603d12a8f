//! Bad input gets a clear error and loses nothing: invalid ROS names, bad ROS_DOMAIN_ID values, malformed
//! and mistyped messages on slot topics. Domains 50-52.

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Int32, ResponseState},
    ros_message, Error, FnResponse, Radar, TimerEvent, TopicEvent,
};
use radar_test_util::{eventually, radar, ResponseProbe, Seen, DISCOVERY};
use serde::{Deserialize, Serialize};

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
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_radar_test_peer"))
        .arg("check-env")
        .env("ROS_DOMAIN_ID", value)
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
    let st = tokio::time::timeout(DISCOVERY, async {
        loop {
            let s = state.recv().await.unwrap();
            if s.exits == 1 {
                return s;
            }
        }
    })
    .await
    .unwrap();
    assert_eq!(st.starts, 1);
}
