//! Run-time message types judged by ROS 2's own fixtures (issue 34): every fixture of every `test_msgs` message
//! type (`test_msgs.message_fixtures`, from the ros-jazzy-test-msgs wheel in the rclpy venv), with definitions
//! found as a sourced ROS 2 installation finds them (`AMENT_PREFIX_PATH` = the venv, which holds
//! `share/test_msgs/msg/*.msg`). The oracle is rclpy's own serialization (`tests/python/fixtures.py`), never
//! radar_ros's code. Domain 114.

use std::{path::PathBuf, process::Stdio, time::Duration};

use radar_ros::{codec::Interfaces, topics::RawMessage};
use radar_test_util::{python, repo, Py};
use serde_json::{json, Value};

const DOMAIN: u16 = 114;

/// The venv: a prefix as `AMENT_PREFIX_PATH` lists them (`<prefix>/share/<pkg>/msg/`).
fn venv() -> PathBuf {
    python().parent().unwrap().parent().unwrap().to_owned()
}

fn fixtures_py(mode: &str, input: Option<String>) -> Vec<Value> {
    let mut child = std::process::Command::new(python())
        .arg(repo().join("tests/python/fixtures.py"))
        .arg(mode)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run the venv's python");
    // written from a thread of its own: the script answers line by line, and a pipe holds only so much
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        use std::io::Write;
        stdin.write_all(input.unwrap_or_default().as_bytes())
    });
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().expect("write to fixtures.py");
    assert!(
        out.status.success(),
        "fixtures.py {mode}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect()
}

/// The JSON lines a Python script of `tests/python/` prints (venv interpreter, nothing on its stdin).
fn python_lines(script: &str, args: &[&str]) -> Vec<Value> {
    let out = std::process::Command::new(python())
        .arg(repo().join("tests/python").join(script))
        .args(args)
        .output()
        .expect("run the venv's python");
    assert!(
        out.status.success(),
        "{script} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect()
}

/// Values under `char_value*` keys (test_msgs' `char` fields) as unsigned bytes.
fn chars_unsigned(v: &mut Value, in_char_field: bool) {
    match v {
        Value::Object(m) => {
            for (k, x) in m.iter_mut() {
                chars_unsigned(x, k.starts_with("char_value"));
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| chars_unsigned(x, in_char_field)),
        Value::Number(n) if in_char_field => {
            if let Some(i) = n.as_i64().filter(|i| *i < 0) {
                *v = json!(i & 0xff);
            }
        }
        _ => {}
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

/// Every fixture of every test_msgs message type, as JSON lines from `fixtures.py dump`.
fn fixtures() -> Vec<Value> {
    let all = fixtures_py("dump", None);
    let types: std::collections::BTreeSet<&str> =
        all.iter().map(|f| f["type"].as_str().unwrap()).collect();
    assert_eq!(types.len(), 13, "every test_msgs message type: {types:?}");
    all
}

#[test]
fn every_test_msgs_fixture_is_read_and_written_as_rclpy_does() {
    let types = Interfaces::from_env().with_dir(venv().join("share"));
    let mut written = String::new();
    for f in fixtures() {
        let (ty, i) = (f["type"].as_str().unwrap(), &f["index"]);
        let theirs = RawMessage::from_bytes(unhex(f["cdr"].as_str().unwrap()));
        let read = types
            .decode(ty, &theirs)
            .unwrap_or_else(|e| panic!("{ty} #{i}: {e}"));
        assert_eq!(read, f["value"], "{ty} #{i}: rclpy's bytes read");
        let yaml: yaml_serde::Value = yaml_serde::to_value(&f["value"]).unwrap();
        let ours = types
            .encode(ty, &yaml)
            .unwrap_or_else(|e| panic!("{ty} #{i}: {e}"));
        written
            .push_str(&json!({ "type": ty, "index": i, "cdr": hex(ours.as_bytes()) }).to_string());
        written.push('\n');
    }
    let checked = fixtures_py("check", Some(written));
    assert_eq!(checked.len(), 31, "every fixture checked: {checked:?}");
    let wrong: Vec<&Value> = checked.iter().filter(|c| c["equal"] != true).collect();
    assert!(
        wrong.is_empty(),
        "rclpy read other messages from what radar_ros wrote: {wrong:#?}"
    );
}

#[test]
fn fields_left_out_take_the_definitions_defaults_and_bad_input_says_what_is_wrong() {
    let types = Interfaces::from_env().with_dir(venv().join("share"));
    let y = |s: &str| yaml_serde::from_str::<yaml_serde::Value>(s).unwrap();
    // Defaults.msg gives every field a default ("int32 int32_value -30000", ...): rclpy's Defaults() has them
    let raw = types.encode("test_msgs/msg/Defaults", &y("{}")).unwrap();
    let v = types.decode("test_msgs/msg/Defaults", &raw).unwrap();
    let rclpy_default = fixtures()
        .into_iter()
        .find(|f| f["type"] == "test_msgs/msg/Defaults")
        .unwrap();
    assert_eq!(v, rclpy_default["value"], "Defaults() as rclpy makes it");
    assert_eq!(v["int32_value"], -30000);
    let raw = types
        .encode("test_msgs/msg/Defaults", &y("{int8_value: 7}"))
        .unwrap();
    let v = types.decode("test_msgs/msg/Defaults", &raw).unwrap();
    assert_eq!(
        (v["int8_value"].clone(), v["uint8_value"].clone()),
        (json!(7), json!(200))
    );
    let raw = types
        .encode("test_msgs/msg/Strings", &y("{string_value: hi}"))
        .unwrap();
    let v = types.decode("test_msgs/msg/Strings", &raw).unwrap();
    assert_eq!(v["string_value"], "hi");
    assert_eq!(v["string_value_default1"], "Hello world!");
    // errors name the field, the type and what to do
    let e = types
        .encode("test_msgs/msg/BasicTypes", &y("{int32_valu: 5}"))
        .unwrap_err();
    assert!(e.contains("int32_valu") && e.contains("int32_value"), "{e}");
    let e = types
        .encode("test_msgs/msg/BasicTypes", &y("{int8_value: 300}"))
        .unwrap_err();
    assert!(e.contains("int8_value") && e.contains("300"), "{e}");
    let e = types
        .encode("test_msgs/msg/Arrays", &y("{int32_values: [1, 2]}"))
        .unwrap_err();
    assert!(e.contains("exactly 3"), "{e}");
    let e = types
        .encode(
            "test_msgs/msg/BoundedSequences",
            &y("{int32_values: [1, 2, 3, 4]}"),
        )
        .unwrap_err();
    assert!(e.contains("at most 3"), "{e}");
    let e = types
        .encode("no_such_msgs/msg/Thing", &y("{}"))
        .unwrap_err();
    assert!(
        e.contains("no_such_msgs/msg/Thing") && e.contains("share/no_such_msgs/msg/Thing.msg"),
        "names the type and every place looked in: {e}"
    );
    // a message cut short is an error, not a panic
    let raw = types
        .encode("test_msgs/msg/Strings", &y("{string_value: hello}"))
        .unwrap();
    let cut = RawMessage::from_bytes(raw.as_bytes()[..6].to_vec());
    assert!(types.decode("test_msgs/msg/Strings", &cut).is_err());
}

/// `radar inject` of every fixture, written as flow YAML, into an rclpy subscriber of its type, with
/// `AMENT_PREFIX_PATH` set as a sourced installation sets it: the subscriber receives that very fixture.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_inject_writes_every_test_msgs_fixture_into_an_rclpy_subscriber() {
    assert!(
        std::env::var("RADAR_ISOLATED").as_deref() == Ok("1")
            || std::env::var("RADAR_ALLOW_NETWORK").is_ok(),
        "run inside tests/isolated.sh (see README.md)"
    );
    let mut listener = Py::start(DOMAIN, "tests/python/fixtures.py", &["listen"]);
    assert_eq!(listener.json().await["ready"], true);
    let prefix = venv();
    for f in fixtures() {
        let (ty, i) = (f["type"].as_str().unwrap(), f["index"].as_u64().unwrap());
        let name = ty.rsplit('/').next().unwrap();
        let flow = f["value"].to_string(); // JSON is flow YAML
                                           // a payload too long for a command line (UnboundedSequences #3 is 350 kB) goes through stdin (`-`)
        let long = flow.len() > 64 * 1024;
        let mut cmd = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"));
        cmd.args(["inject", &format!("/fx/{name}")])
            .arg(if long { "-" } else { flow.as_str() })
            .env("ROS_DOMAIN_ID", DOMAIN.to_string())
            .env("AMENT_PREFIX_PATH", &prefix)
            .env_remove("RUST_LOG")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .kill_on_drop(true);
        let mut child = cmd.spawn().unwrap();
        let mut stdin = child.stdin.take().unwrap();
        let input = if long { flow.clone() } else { String::new() };
        let feed = tokio::spawn(async move {
            use tokio::io::AsyncWriteExt;
            stdin.write_all(input.as_bytes()).await
        });
        let out = tokio::time::timeout(Duration::from_secs(30), child.wait_with_output())
            .await
            .unwrap_or_else(|_| panic!("radar inject of {ty} #{i} did not end"))
            .unwrap();
        feed.await
            .unwrap()
            .expect("write the payload to radar inject");
        assert!(
            out.status.success(),
            "radar inject {ty} #{i}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let got = listener.json().await;
        assert_eq!(got["type"], ty, "{got}");
        let matches: Vec<u64> = got["matches"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m.as_u64().unwrap())
            .collect();
        assert!(
            matches.contains(&i),
            "{ty} #{i}: the rclpy subscriber received another message: {}",
            got["got"]
        );
    }
}

/// The MCAP schema of a type found at run time is its definition and every type it uses, as rosbag2 writes it.
#[test]
fn a_run_time_types_schema_holds_its_definition_and_every_type_it_uses() {
    let types = Interfaces::from_env().with_dir(venv().join("share"));
    let s = types.schema("test_msgs/msg/MultiNested").unwrap();
    let own = std::fs::read_to_string(venv().join("share/test_msgs/msg/MultiNested.msg")).unwrap();
    assert!(s.starts_with(&own), "its own definition first, as written");
    for used in [
        "Arrays",
        "BoundedSequences",
        "UnboundedSequences",
        "BasicTypes",
        "Constants",
        "Defaults",
    ] {
        let def = std::fs::read_to_string(venv().join(format!("share/test_msgs/msg/{used}.msg")))
            .unwrap();
        let block = format!("\nMSG: test_msgs/{used}\n{def}");
        assert_eq!(
            s.matches(&block).count(),
            1,
            "{used} once, after its MSG line: {s}"
        );
    }
    assert!(types.schema("no_such_msgs/msg/Thing").is_err());
}

/// A response typed at run time that answers with its start payload.
struct Echo(String);

impl radar_ros::Response for Echo {
    type Start = radar_ros::topics::DynMessage;
    type Output = radar_ros::topics::DynMessage;

    async fn start(
        &mut self,
        p: radar_ros::topics::DynMessage,
    ) -> Result<radar_ros::topics::DynMessage, radar_ros::SlotError> {
        Ok(p)
    }

    fn start_type(&self) -> String {
        self.0.clone()
    }

    fn output_type(&self) -> String {
        self.0.clone()
    }
}

/// `radar record` of signals of every test_msgs type (responses typed at run time, started with rclpy's own
/// bytes of each fixture), read back by Python's `mcap-ros2-support` decoder with the schemas in the file: every
/// `started` payload equals its fixture. Domain 115.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_record_of_test_msgs_signals_reads_back_as_the_fixtures() {
    radar_ros_examples::test_support::require_isolation();
    const DOMAIN: u16 = 115;
    let r = radar_ros::Radar::builder()
        .domain_id(DOMAIN)
        .discovery_range(radar_ros::settings::DiscoveryRange::Subnet)
        .build()
        .unwrap();
    let fixtures = fixtures();
    let names: std::collections::BTreeSet<String> = fixtures
        .iter()
        .map(|f| {
            f["type"]
                .as_str()
                .unwrap()
                .rsplit('/')
                .next()
                .unwrap()
                .to_owned()
        })
        .collect();
    let mut handles = std::collections::BTreeMap::new();
    for n in &names {
        let h = r
            .spawn_response(&format!("/fxr/{n}"), Echo(format!("test_msgs/msg/{n}")))
            .unwrap();
        handles.insert(n.clone(), h);
    }
    let dir = std::env::temp_dir().join(format!("radar_fixtures_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("fixtures.mcap");
    let mut args: Vec<String> = [
        "record",
        "-o",
        file.to_str().unwrap(),
        "--duration",
        "60",
        "--json",
    ]
    .map(str::to_owned)
    .to_vec();
    args.extend(names.iter().map(|n| format!("/fxr/{n}")));
    let recorder = tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(&args)
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env("AMENT_PREFIX_PATH", venv())
        .env_remove("RUST_LOG")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .unwrap();
    // the recorder has subscribed to every response's started signal
    for h in handles.values() {
        radar_test_util::eventually(Duration::from_secs(15), "the recorder listens", || {
            h.signal_subscribers()[0] > 0
        })
        .await;
    }
    for f in &fixtures {
        let name = f["type"].as_str().unwrap().rsplit('/').next().unwrap();
        let h = &handles[name];
        let before = h.state().exits;
        let slot = h.reference().start_slot();
        let p = r.raw_publisher(slot.topic(), slot.ros_type()).unwrap();
        // the response and the recorder (which reads the slots too, for `radar verify`)
        p.wait_for_subscribers(2)
            .timeout(Duration::from_secs(10))
            .await
            .unwrap();
        p.publish(RawMessage::from_bytes(unhex(f["cdr"].as_str().unwrap())))
            .unwrap();
        radar_test_util::eventually(Duration::from_secs(10), "the run ended", || {
            h.state().exits > before
        })
        .await;
    }
    // every run has ended (and its started was sent before it): stopped as a user stops it, with SIGTERM
    tokio::time::sleep(Duration::from_millis(500)).await;
    let pid = recorder.id().expect("the recorder runs") as i32;
    // SAFETY: kill(2) on a child process of this test, which it still waits for
    unsafe { libc::kill(pid, libc::SIGTERM) };
    let out = tokio::time::timeout(Duration::from_secs(30), recorder.wait_with_output())
        .await
        .expect("radar record ends on SIGTERM")
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read = python_lines("mcap_read.py", &[file.to_str().unwrap()]);
    // rosbag2's way (rclpy deserializes the CDR into the class the schema names), for every type
    let by_rclpy = python_lines("fixtures.py", &["mcap", file.to_str().unwrap()]);
    for name in &names {
        let topic = format!("/fxr/{name}/started");
        let want: Vec<&Value> = fixtures
            .iter()
            .filter(|f| f["type"] == format!("test_msgs/msg/{name}"))
            .collect();
        for (reader, read) in [("mcap-ros2-support", &read), ("rclpy", &by_rclpy)] {
            let got: Vec<&Value> = read.iter().filter(|m| m["topic"] == topic).collect();
            assert_eq!(
                got.len(),
                want.len(),
                "{reader}, {topic}: one started per fixture"
            );
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(g["schema"], format!("test_msgs/msg/{name}"));
                if let Some(why) = g.get("undecodable") {
                    // the Python mcap reader implements no wstring: only WStrings may be beyond it
                    assert!(
                        reader == "mcap-ros2-support"
                            && name == "WStrings"
                            && why.as_str().unwrap().contains("wstring"),
                        "{reader} could not read {topic}: {why}"
                    );
                    continue;
                }
                let mut msg = g["msg"].clone();
                if reader == "mcap-ros2-support" {
                    // that reader reads `char` as a signed byte; ROS 2 defines it as uint8 (rosidl maps .msg
                    // `char` to IDL `uint8`, and rclpy reads 255): same byte, compared as ROS 2 reads it
                    chars_unsigned(&mut msg, false);
                }
                assert_eq!(
                    msg, w["value"],
                    "{reader}, {topic}: the payload is the fixture"
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `radar --interfaces DIR`: a package of a program's own that is not installed. `radar inject` writes a
/// payload of its type (fields left out take the definition's defaults) into a response typed at run time.
/// Domain 116.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn radar_inject_finds_a_programs_own_interfaces_in_a_directory_given() {
    radar_ros_examples::test_support::require_isolation();
    const DOMAIN: u16 = 116;
    let own = std::env::temp_dir().join(format!("radar_own_msgs_{}", std::process::id()));
    std::fs::create_dir_all(own.join("my_robot_msgs/msg")).unwrap();
    std::fs::write(
        own.join("my_robot_msgs/msg/Dock.msg"),
        "# where to dock\nstring station\nfloat64 speed 0.5\nDockBay[] bays\n",
    )
    .unwrap();
    std::fs::write(own.join("my_robot_msgs/msg/DockBay.msg"), "uint8 number\n").unwrap();
    let r = radar_ros::Radar::builder()
        .domain_id(DOMAIN)
        .discovery_range(radar_ros::settings::DiscoveryRange::Subnet)
        .build()
        .unwrap();
    let dock = r
        .spawn_response("/dock", Echo("my_robot_msgs/msg/Dock".into()))
        .unwrap();
    let mut exited = r
        .waiter::<radar_ros::topics::DynMessage>(dock.reference().exited())
        .await
        .unwrap();
    let inject = |args: Vec<String>| {
        tokio::process::Command::new(env!("CARGO_BIN_EXE_radar"))
            .args(args)
            .env("ROS_DOMAIN_ID", DOMAIN.to_string())
            .env_remove("AMENT_PREFIX_PATH")
            .env_remove("RUST_LOG")
            .kill_on_drop(true)
            .output()
    };
    let dir = own.to_str().unwrap().to_owned();
    let args = [
        "--interfaces",
        &dir,
        "inject",
        "/dock/start",
        "{station: left, bays: [{number: 3}]}",
    ];
    let out = inject(args.map(str::to_owned).to_vec()).await.unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let got = tokio::time::timeout(Duration::from_secs(10), exited.recv())
        .await
        .expect("the run ends")
        .unwrap();
    let types = Interfaces::from_env().with_dir(&own);
    assert_eq!(
        types.decode("my_robot_msgs/msg/Dock", &got.0).unwrap(),
        json!({ "station": "left", "speed": 0.5, "bays": [{ "number": 3 }] })
    );
    // without the directory the type is found nowhere, and the error says where radar looked
    let out = inject(
        ["inject", "/dock/start", "{station: left}"]
            .map(str::to_owned)
            .to_vec(),
    )
    .await
    .unwrap();
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("my_robot_msgs/msg/Dock") && e.contains("AMENT_PREFIX_PATH"),
        "{e}"
    );
    let out = inject(
        ["--interfaces", "/no/such/dir", "inject", "/dock/start"]
            .map(str::to_owned)
            .to_vec(),
    )
    .await
    .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/no/such/dir"));
    let _ = std::fs::remove_dir_all(&own);
}

/// RIHS01 hashes computed from the definitions equal rosidl's: every `share/<pkg>/msg|srv|action/<Name>.json`
/// the ROS 2 wheels in the venv ship (std_msgs, geometry_msgs, test_msgs, builtin_interfaces, ...): a message's
/// own hash and those of the messages it uses, a service's request and response, an action's goal, result and
/// feedback (the hashes generated types carry), and the types rosidl makes up around them: a service as a whole
/// (what rmw_zenoh names in a service's key and tokens), its `_Event`, an action as a whole, its `_SendGoal`
/// and `_GetResult` services with their parts, and its `_FeedbackMessage`.
#[test]
fn type_hashes_equal_those_rosidl_wrote_for_every_message_in_the_venv() {
    let share = venv().join("share");
    let types = Interfaces::from_env().with_dir(&share);
    let mut checked = std::collections::BTreeSet::new();
    let mut wrong = Vec::new();
    for pkg in std::fs::read_dir(&share).unwrap() {
        let pkg = pkg.unwrap().path();
        for kind in ["msg", "srv", "action"] {
            let Ok(entries) = std::fs::read_dir(pkg.join(kind)) else {
                continue;
            };
            for e in entries {
                let path = e.unwrap().path();
                if path.extension().is_none_or(|x| x != "json") {
                    continue;
                }
                let doc: Value =
                    serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
                let base = format!(
                    "{}/{kind}/{}",
                    pkg.file_name().unwrap().to_string_lossy(),
                    path.file_stem().unwrap().to_string_lossy()
                );
                for hash in doc["type_hashes"].as_array().unwrap() {
                    let ty = hash["type_name"].as_str().unwrap();
                    assert!(
                        ty.starts_with(&base) || ty.contains("/msg/"),
                        "{ty} in {}",
                        path.display()
                    );
                    match types.type_hash(ty) {
                        Ok(h) if h == hash["hash_string"] => {
                            checked.insert(ty.to_owned());
                        }
                        other => wrong.push(format!(
                            "{ty} (in {}): {other:?}, rosidl {}",
                            path.display(),
                            hash["hash_string"]
                        )),
                    }
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
    for must in [
        "test_msgs/msg/MultiNested",
        "geometry_msgs/msg/PoseStamped",
        "std_msgs/msg/Empty",
        "std_srvs/srv/SetBool_Request",
        "test_msgs/srv/Arrays_Response",
        "test_msgs/action/Fibonacci_Goal",
        "test_msgs/action/NestedMessage_Feedback",
        "radar_demo_msgs/action/Dock_Result",
        "std_srvs/srv/SetBool",
        "std_srvs/srv/SetBool_Event",
        "radar_msgs/srv/Connect",
        "test_msgs/action/Fibonacci",
        "test_msgs/action/Fibonacci_SendGoal",
        "test_msgs/action/Fibonacci_GetResult_Event",
        "test_msgs/action/Fibonacci_SendGoal_Response",
        "test_msgs/action/Fibonacci_FeedbackMessage",
    ] {
        assert!(checked.contains(must), "{must} checked: {checked:?}");
    }
    assert!(checked.len() > 130, "{} checked", checked.len());
}

/// radar_ros's hand-written `test_msgs/action/Fibonacci` carries the hashes rosidl wrote for it: its parts'
/// and those of the types made up around it (what its endpoints name over Zenoh).
#[test]
fn fibonaccis_hashes_are_those_rosidl_wrote() {
    use radar_ros::action::{Action, Fibonacci};
    use radar_ros::msg::RosMessage;
    let path = venv().join("share/test_msgs/action/Fibonacci.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let rosidl = |ty: &str| {
        doc["type_hashes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|h| h["type_name"] == ty)
            .unwrap_or_else(|| panic!("{ty} in {}", path.display()))["hash_string"]
            .as_str()
            .unwrap()
            .to_owned()
    };
    let h = Fibonacci::TYPE_HASHES.expect("Fibonacci's hashes");
    for (ty, ours) in [
        ("Fibonacci_SendGoal", h.send_goal),
        ("Fibonacci_GetResult", h.get_result),
        ("Fibonacci_FeedbackMessage", h.feedback_message),
        (
            "Fibonacci_Goal",
            <Fibonacci as Action>::Goal::TYPE_HASH.unwrap(),
        ),
        (
            "Fibonacci_Result",
            <Fibonacci as Action>::Result::TYPE_HASH.unwrap(),
        ),
        (
            "Fibonacci_Feedback",
            <Fibonacci as Action>::Feedback::TYPE_HASH.unwrap(),
        ),
    ] {
        assert_eq!(ours, rosidl(&format!("test_msgs/action/{ty}")), "{ty}");
    }
}

/// The interfaces radar_ros ships (`radar_ros/idl/interfaces/`) are the Jazzy packages' own files, byte for
/// byte (as the venv's wheels install them), and work with no installation: encoded, decoded and hashed as
/// rosidl hashes them.
#[test]
fn the_bundled_interfaces_are_jazzys_and_work_without_an_installation() {
    let bundled = repo().join("radar_ros/idl/interfaces");
    let share = venv().join("share");
    let mut compared = 0;
    for pkg in std::fs::read_dir(&bundled).unwrap() {
        let pkg = pkg.unwrap().path();
        if !pkg.is_dir() {
            continue;
        }
        for kind in std::fs::read_dir(&pkg).unwrap() {
            for file in std::fs::read_dir(kind.unwrap().path()).unwrap() {
                let file = file.unwrap().path();
                let rel = file.strip_prefix(&bundled).unwrap();
                let installed = std::fs::read(share.join(rel))
                    .unwrap_or_else(|e| panic!("{}: not in the venv ({e})", rel.display()));
                assert_eq!(
                    std::fs::read(&file).unwrap(),
                    installed,
                    "{}",
                    rel.display()
                );
                compared += 1;
            }
        }
    }
    assert!(compared > 100, "{compared} files compared");
    // nothing installed: only what radar_ros ships
    let none = Interfaces::empty();
    for ty in [
        "sensor_msgs/msg/LaserScan",
        "nav_msgs/msg/Odometry",
        "geometry_msgs/msg/PoseStamped",
        "diagnostic_msgs/msg/DiagnosticArray",
        "action_msgs/msg/GoalStatusArray",
    ] {
        let (pkg, name) = ty.split_once("/msg/").unwrap();
        let doc: Value = serde_json::from_str(
            &std::fs::read_to_string(share.join(format!("{pkg}/msg/{name}.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(
            none.type_hash(ty).unwrap(),
            doc["type_hashes"][0]["hash_string"],
            "{ty}"
        );
        let raw = none.encode(ty, &yaml_serde::Value::Null).unwrap();
        none.decode(ty, &raw).unwrap();
    }
    let scan = none
        .encode(
            "sensor_msgs/msg/LaserScan",
            &yaml_serde::from_str("{header: {frame_id: laser}, ranges: [1.5, 2.0]}").unwrap(),
        )
        .unwrap();
    let v = none.decode("sensor_msgs/msg/LaserScan", &scan).unwrap();
    assert_eq!(
        (v["header"]["frame_id"].clone(), v["ranges"].clone()),
        (json!("laser"), json!([1.5, 2.0]))
    );
}
