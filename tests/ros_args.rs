//! `--ros-args` read as rcl reads it: every command line below goes through radar_ros::ros_args and through
//! real rcl (rclpy, ROS 2 Jazzy: tests/python/ros_args_rcl.py), and both must agree on the node's name and
//! namespace, how names resolve, the parameter overrides, the log levels, and which command lines are refused.

use radar_ros::ros_args::{LogLevel, ParameterValue, RosArgs};
use radar_test_util::{python, repo};
use serde_json::{json, Value};

/// The names each case resolves.
const NAMES: [&str; 5] = ["dock", "/dock", "~/status", "left/x", "/base/cmd"];

fn cases(params_file: &str) -> Vec<Vec<String>> {
    let c: Vec<Vec<&str>> = vec![
        vec![],
        vec!["--own", "flag"],
        vec!["--ros-args", "-r", "__ns:=/robot1"],
        vec!["--ros-args", "-r", "__node:=patrol"],
        vec![
            "--ros-args",
            "--remap",
            "__name:=patrol",
            "-r",
            "__ns:=/a/b",
        ],
        vec!["--ros-args", "-r", "prog:__ns:=/mine", "-r", "__ns:=/all"],
        vec!["--ros-args", "-r", "other:__ns:=/not_mine"],
        vec!["--ros-args", "-r", "__ns:=/first", "-r", "__ns:=/second"],
        vec!["--ros-args", "-r", "dock:=left/dock", "-r", "__ns:=/r"],
        vec!["--ros-args", "-r", "/dock:=/moved"],
        vec!["--ros-args", "-r", "~/status:=/status"],
        vec!["--ros-args", "-r", "rostopic:///base/cmd:=/cmd_vel"],
        vec!["--ros-args", "-r", "prog:dock:=/only_prog"],
        vec!["--ros-args", "-r", "other:dock:=/only_other"],
        vec!["--ros-args", "-r", "dock:=/one", "-r", "dock:=/two"],
        vec!["--ros-args", "-r", "__node:=patrol", "-r", "~/status:=/s"],
        vec!["--ros-args", "-r", "__ns:=/r1", "--", "--own"],
        vec![
            "x",
            "--ros-args",
            "-r",
            "__ns:=/r1",
            "--",
            "y",
            "--ros-args",
            "-r",
            "dock:=d2",
        ],
        vec![
            "--ros-args",
            "-p",
            "period:=0.5",
            "-p",
            "limit:=10",
            "-p",
            "name:=count",
        ],
        vec![
            "--ros-args",
            "-p",
            "flag:=true",
            "-p",
            "on:=yes",
            "-p",
            "off:=Off",
            "-p",
            "s:='yes'",
        ],
        vec![
            "--ros-args",
            "-p",
            "ints:=[1, 2, 3]",
            "-p",
            "floats:=[1.0, 2.5]",
            "-p",
            "strs:=[a, b]",
        ],
        vec![
            "--ros-args",
            "-p",
            "bools:=[true, false]",
            "-p",
            "big:=1e3",
            "-p",
            "neg:=-4",
        ],
        vec!["--ros-args", "-p", "a.b.c:=1"],
        vec!["--ros-args", "-p", "prog:mine:=1", "-p", "other:theirs:=2"],
        vec!["--ros-args", "-r", "__ns:=/r1", "-p", "prog:mine:=1"],
        vec!["--ros-args", "--params-file", params_file],
        vec![
            "--ros-args",
            "-r",
            "__ns:=/robot1",
            "--params-file",
            params_file,
        ],
        vec![
            "--ros-args",
            "-p",
            "limit:=3",
            "--params-file",
            params_file,
            "-p",
            "period:=0.25",
        ],
        vec!["--ros-args", "--log-level", "debug"],
        vec!["--ros-args", "--log-level", "WARN"],
        vec!["--ros-args", "--log-level", "prog:=error"],
        vec![
            "--ros-args",
            "--log-level",
            "error",
            "--log-level",
            "prog:=debug",
        ],
        vec!["--ros-args", "-e", "/robot", "--enclave", "/robot"],
        vec![
            "--ros-args",
            "--disable-rosout-logs",
            "--enable-stdout-logs",
        ],
        vec!["--ros-args", "--disable-external-lib-logs"],
        // refused by both
        vec!["--ros-args", "--verbose"],
        vec!["--ros-args", "-r"],
        vec!["--ros-args", "-r", "nonsense"],
        vec!["--ros-args", "-r", "__ns:=relative"],
        vec!["--ros-args", "-p"],
        vec!["--ros-args", "-p", "novalue"],
        vec!["--ros-args", "--params-file", "/nonexistent/radar_ros.yaml"],
        vec!["--ros-args", "--log-level", "loud"],
        vec!["--ros-args", "-r", "__ns:=/r1", "extra"],
        vec!["--ros-args", "-p", "mixed:=[1, 2.5]"],
        vec!["--ros-args", "--log-config-file", params_file],
    ];
    c.into_iter()
        .map(|args| {
            std::iter::once("prog")
                .chain(args)
                .map(str::to_owned)
                .collect()
        })
        .collect()
}

fn param_json(v: &ParameterValue) -> Value {
    use ParameterValue as P;
    match v {
        P::Boolean(b) => json!(["BOOL", b]),
        P::Integer(i) => json!(["INTEGER", i]),
        P::Double(d) => json!(["DOUBLE", d]),
        P::String(s) => json!(["STRING", s]),
        P::BooleanArray(a) => json!(["BOOL_ARRAY", a]),
        P::IntegerArray(a) => json!(["INTEGER_ARRAY", a]),
        P::DoubleArray(a) => json!(["DOUBLE_ARRAY", a]),
        P::StringArray(a) => json!(["STRING_ARRAY", a]),
        P::ByteArray(a) => json!(["BYTE_ARRAY", a]),
        P::NotSet => json!(["NOT_SET", null]),
    }
}

fn severity(l: LogLevel) -> u64 {
    match l {
        LogLevel::Unset => 0,
        LogLevel::Debug => 10,
        LogLevel::Info => 20,
        LogLevel::Warn => 30,
        LogLevel::Error => 40,
        LogLevel::Fatal => 50,
    }
}

/// What radar_ros makes of `argv`, in the harness's terms.
fn ours(argv: &[String]) -> Value {
    let a = match RosArgs::parse(argv) {
        Ok(a) => a,
        Err(e) => return json!({ "error": e.to_string() }),
    };
    let name = a.node_name("prog").unwrap_or("prog").to_owned();
    let ns = a.namespace("prog").unwrap_or("/").to_owned();
    let fq = if ns == "/" {
        format!("/{name}")
    } else {
        format!("{ns}/{name}")
    };
    let names: serde_json::Map<String, Value> = NAMES
        .iter()
        .map(|n| (n.to_string(), json!(a.resolve_name(n, &name, &ns))))
        .collect();
    let params: serde_json::Map<String, Value> = a
        .parameters_for(&fq)
        .iter()
        .map(|(k, v)| (k.clone(), param_json(v)))
        .collect();
    let global = a.log_level().map(severity).unwrap_or(20);
    let level_of = |logger: &str| {
        a.logger_levels()
            .filter(|(l, _)| *l == logger)
            .last()
            .map(|(_, lv)| severity(lv))
            .unwrap_or(global)
    };
    json!({
        "name": name,
        "namespace": ns,
        "names": names,
        "params": params,
        "levels": { "prog": level_of("prog"), "other": level_of("other") },
    })
}

#[test]
fn ros_args_are_read_as_rcl_reads_them() {
    let dir = std::env::temp_dir().join(format!("radar_ros_args_rcl_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let params = dir.join("params.yaml");
    std::fs::write(
        &params,
        "/**:\n  ros__parameters:\n    period: 0.5\n    limits:\n      low: 1\n      high: 9\n\
         prog:\n  ros__parameters:\n    limit: 10\n    name: root_prog\n\
         /robot1/*:\n  ros__parameters:\n    robot: one\n\
         /**/prog:\n  ros__parameters:\n    anywhere: true\n\
         /other:\n  ros__parameters:\n    never: 1\n",
    )
    .unwrap();
    let cases = cases(params.to_str().unwrap());
    let input: Vec<Value> = cases
        .iter()
        .map(|argv| json!({ "argv": argv, "names": NAMES }))
        .collect();
    let cases_file = dir.join("cases.json");
    std::fs::write(&cases_file, serde_json::to_vec(&input).unwrap()).unwrap();
    let out = std::process::Command::new(python())
        .arg(repo().join("tests/python/ros_args_rcl.py"))
        .arg(&cases_file)
        .env("ROS_DOMAIN_ID", "102")
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "the rcl harness failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rcl: Vec<Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rcl.len(), cases.len(), "one answer per case");
    let mut differ = Vec::new();
    for (argv, theirs) in cases.iter().zip(&rcl) {
        let mine = ours(argv);
        let same = match (mine.get("error"), theirs.get("error")) {
            (Some(_), Some(_)) => true,
            (None, None) => &mine == theirs,
            _ => false,
        };
        if !same {
            differ.push(format!(
                "{argv:?}\n  radar_ros: {mine}\n  rcl:       {theirs}"
            ));
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        differ.is_empty(),
        "{} of {} command lines read differently:\n{}",
        differ.len(),
        cases.len(),
        differ.join("\n")
    );
}

/// Domain 103: `-r __ns:=`, `-r __node:=` and a name remapped, through `RadarBuilder::ros_args`: the component is
/// spawned where the rules put it, found there from another participant, and this program's own lookups and
/// statements by the old name follow the rule.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn components_are_spawned_and_found_where_the_rules_put_them() {
    use std::time::Duration;
    let args = RosArgs::parse([
        "prog",
        "--ros-args",
        "-r",
        "__ns:=/r1",
        "-r",
        "__node:=patrol",
        "-r",
        "dock:=left/dock",
        "-r",
        "/go:=/r1/go_remapped",
    ])
    .unwrap();
    let a = radar_test_util::radar_with(103, |b| b.ros_args(args));
    assert_eq!(a.namespace(), "/r1");
    assert_eq!(a.program_node().fully_qualified(), "/r1/patrol");
    let (dock, starts) = radar_test_util::counter(&a, "dock");
    assert_eq!(dock.name().fully_qualified(), "/r1/left/dock");
    // an absolute name is remapped when a rule names it, and left alone otherwise
    let go = a
        .spawn_event(
            "/go",
            radar_ros::TimerEvent::new(Duration::from_millis(100)),
        )
        .unwrap();
    assert_eq!(go.name().fully_qualified(), "/r1/go_remapped");
    let other = a
        .spawn_event(
            "/elsewhere",
            radar_ros::TimerEvent::new(Duration::from_millis(100)),
        )
        .unwrap();
    assert_eq!(other.name().fully_qualified(), "/elsewhere");

    let b = radar_test_util::radar(103);
    let seen = b
        .response("/r1/left/dock")
        .timeout(Duration::from_secs(10))
        .await
        .unwrap();
    assert_eq!(seen.name().fully_qualified(), "/r1/left/dock");
    // this program's own statement by the old names reaches the remapped components
    let found = a.response("dock").await.unwrap();
    assert_eq!(found.name().fully_qualified(), "/r1/left/dock");
    let _c = a.whenever(go.triggered()).start(&found).await.unwrap();
    radar_test_util::eventually(Duration::from_secs(5), "the remapped dock to start", || {
        starts.load(std::sync::atomic::Ordering::SeqCst) >= 1
    })
    .await;
}
