//! Component parameters as ROS 2 serves a node's: declared with descriptors, started from the command line,
//! listed, read, described and set by real rclpy's parameter client (what `ros2 param` uses), refused with a
//! reason when a set breaks the declaration, published on `/parameter_events`, and seen by the component.
//! Domain 104.

use std::time::Duration;

use radar_ros::{
    msg::{Empty, Float64},
    nodes::ResponseNode,
    params::{ParamDecl, ParameterValue, Params},
    ros_args::RosArgs,
    Response, SlotError,
};
use radar_test_util::{python, radar_with, repo};
use serde_json::{json, Value};

/// Its settings are parameters; a run answers with the `period` it read when it began.
struct CountUp(std::sync::Arc<std::sync::Mutex<Option<Params>>>);

impl Response for CountUp {
    type Start = Empty;
    type Output = Float64;
    fn attach(&mut self, node: &mut ResponseNode<'_>) -> radar_ros::Result<()> {
        let p = node.declare([
            ParamDecl::new("period", 0.5)
                .description("seconds between counts")
                .float_range(0.01, 60.0),
            ParamDecl::new("limit", 10).integer_range(1, 100, 1),
            ParamDecl::new("name", "count").read_only(),
        ])?;
        *self.0.lock().unwrap() = Some(p);
        Ok(())
    }
    async fn start(&mut self, _: Empty) -> Result<Float64, SlotError> {
        let p = self.0.lock().unwrap().clone();
        Ok(Float64 {
            data: p.and_then(|p| p.f64("period")).unwrap_or(f64::NAN),
        })
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rclpy_lists_gets_describes_and_sets_a_components_parameters() {
    let args = RosArgs::parse(["prog", "--ros-args", "-p", "limit:=20"]).unwrap();
    let radar = radar_with(104, |b| b.ros_args(args));
    let slot = std::sync::Arc::new(std::sync::Mutex::new(None));
    let count = radar
        .spawn_response("count", CountUp(slot.clone()))
        .unwrap();
    let params = slot.lock().unwrap().clone().expect("declared in attach");
    assert_eq!(
        params.i64("limit"),
        Some(20),
        "the command line's -p limit:=20"
    );
    assert_eq!(params.f64("period"), Some(0.5), "the default");
    let mut watch = params.watch();

    let out = tokio::process::Command::new(python())
        .arg(repo().join("tests/python/params_client.py"))
        .arg("/count")
        .env("ROS_DOMAIN_ID", "104")
        .kill_on_drop(true)
        .output();
    let out = tokio::time::timeout(Duration::from_secs(90), out)
        .await
        .expect("the rclpy client ends")
        .unwrap();
    assert!(
        out.status.success(),
        "params_client.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let seen: Value = serde_json::from_slice(&out.stdout).unwrap();
    println!("{seen:#}");
    assert_eq!(seen["list"], json!(["limit", "name", "period"]));
    assert_eq!(seen["get"], json!([0.5, 20, "count", null]));
    // ParameterType: DOUBLE 3, INTEGER 2, STRING 4, NOT_SET 0
    assert_eq!(seen["types"], json!([3, 2, 4, 0]));
    assert_eq!(
        seen["describe"]["period"],
        json!({"type": 3, "description": "seconds between counts", "read_only": false,
               "float_range": [[0.01, 60.0]], "integer_range": []})
    );
    assert_eq!(
        seen["describe"]["limit"]["integer_range"],
        json!([[1, 100, 1]])
    );
    assert_eq!(seen["describe"]["name"]["read_only"], json!(true));
    let set = seen["set"].as_array().unwrap();
    assert_eq!(set[0], json!([true, ""]), "period 2.0 is allowed");
    for (i, why) in [
        (1, "must be in [0.01, 60]"),
        (2, "of type integer, not string"),
        (3, "read-only"),
        (4, "not declared"),
    ] {
        assert_eq!(set[i][0], json!(false), "set {i} refused: {set:?}");
        assert!(
            set[i][1].as_str().unwrap().contains(why),
            "set {i} says why ({why}): {set:?}"
        );
    }
    assert_eq!(seen["atomic"][0], json!(false), "all or none");
    assert_eq!(
        seen["after"],
        json!([2.0, 20]),
        "only the valid set took effect"
    );
    let events = seen["events"].as_array().unwrap();
    assert!(
        events
            .iter()
            .any(|e| e["changed"] == json!({"period": 2.0})),
        "the change on /parameter_events: {events:?}"
    );
    // the component sees it
    tokio::time::timeout(Duration::from_secs(1), watch.changed())
        .await
        .expect("the watch wakes");
    assert_eq!(params.f64("period"), Some(2.0));
    // and acts on it: the next run reads 2.0
    let exited = radar
        .signal_subscription::<Float64>(count.reference().exited().topic())
        .unwrap();
    exited
        .wait_for_publishers(1)
        .timeout(Duration::from_secs(10))
        .await
        .unwrap();
    radar
        .inject(count.reference().start_slot(), Empty::default())
        .timeout(Duration::from_secs(10))
        .await
        .unwrap();
    let out = exited
        .recv()
        .timeout(Duration::from_secs(10))
        .await
        .unwrap();
    assert_eq!(out.data, 2.0, "the run used rclpy's period");
    // set from code: checked the same way
    assert!(params.set("limit", 0).is_err());
    params.set("limit", 5).unwrap();
    assert_eq!(params.get("limit"), Some(ParameterValue::Integer(5)));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_command_line_value_of_the_wrong_type_fails_the_spawn_naming_the_parameter() {
    let args = RosArgs::parse(["prog", "--ros-args", "-p", "count2:period:=fast"]).unwrap();
    let radar = radar_with(104, |b| b.ros_args(args));
    let e = radar
        .spawn_response(
            "count2",
            CountUp(std::sync::Arc::new(std::sync::Mutex::new(None))),
        )
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("period") && e.contains("double") && e.contains("string"),
        "{e}"
    );
    // other components of the program are not affected
    let slot = std::sync::Arc::new(std::sync::Mutex::new(None));
    let _c3 = radar
        .spawn_response("count3", CountUp(slot.clone()))
        .unwrap();
    let p = slot.lock().unwrap().clone().unwrap();
    assert_eq!(p.f64("period"), Some(0.5));
}

/// A configurable timer's period is its `period` parameter: the command line's 50 ms, not the code's 10 s.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_configurable_timer_takes_its_period_from_the_command_line() {
    let args = RosArgs::parse(["prog", "--ros-args", "-p", "tick:period:=0.05"]).unwrap();
    let radar = radar_with(104, |b| b.ros_args(args));
    let tick = radar
        .spawn_event(
            "tick",
            radar_ros::TimerEvent::new(Duration::from_secs(10)).configurable(),
        )
        .unwrap();
    let n = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let seen = n.clone();
    let _w = radar
        .whenever(tick.triggered())
        .call(move |_: Empty| {
            seen.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        })
        .await
        .unwrap();
    radar_test_util::eventually(Duration::from_secs(5), "3 triggers at 50 ms", || {
        n.load(std::sync::atomic::Ordering::SeqCst) >= 3
    })
    .await;
}
