//! The benchmark harness itself works: `radar_bench quick` runs every scenario across processes over real
//! DDS (rclpy included) and writes a complete, self-consistent report. Numbers are not judged here (the
//! goals in docs/benchmarks.md are not asserted); what is checked is that every figure was really measured,
//! and that none of its processes logs an error.
//! Uses ROS_DOMAIN_ID 70-101 (a scenario takes the next; other test binaries use some of them too, but cargo runs test binaries one at a time; 102-214 map to ephemeral UDP ports).

use std::path::Path;

use serde_json::Value;

fn keys(list: &Value) -> Vec<String> {
    list.as_array()
        .unwrap()
        .iter()
        .map(|x| x["key"].as_str().unwrap().to_owned())
        .collect()
}

fn check_distribution(x: &Value) {
    let s = &x["summary"];
    let f = |k: &str| s[k].as_f64().unwrap();
    assert!(s["n"].as_u64().unwrap() > 0, "{x}");
    assert!(f("p50_us") > 0.0, "{x}");
    assert!(
        f("p50_us") <= f("p90_us") && f("p90_us") <= f("p99_us") && f("p99_us") <= f("max_us"),
        "percentiles out of order: {x}"
    );
}

#[test]
fn quick_mode_measures_every_scenario_and_writes_table_json_and_plots() {
    let out = std::env::temp_dir().join(format!("radar_bench_quick_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_radar_bench"))
        .args(["quick", "--domain", "70", "--out"])
        .arg(&out)
        .env_remove("RUST_LOG")
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("run radar_bench");
    let stderr = String::from_utf8_lossy(&run.stderr);
    eprintln!("{stderr}");
    assert!(
        run.status.success(),
        "radar_bench quick failed (its output is above; outside tests/isolated.sh it refuses to run)"
    );
    // the coordinator and all its child processes ended normally: no error-level log line
    let errors: Vec<&str> = stderr.lines().filter(|l| l.contains("ERROR")).collect();
    assert!(
        errors.is_empty(),
        "{} error line(s) on a normal run, e.g. {:?}",
        errors.len(),
        &errors[..errors.len().min(3)]
    );
    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(r["meta"]["mode"], "quick");
    assert!(
        r["errors"].as_array().unwrap().is_empty(),
        "{}",
        r["errors"]
    );

    assert_eq!(
        keys(&r["latency"]),
        [
            "udp_floor",
            "futex_floor",
            "raw_1hop",
            "raw_2hop",
            "rclpy_1hop",
            "fastdds_1hop",
            "fastdds_1hop_default",
            "radar_manager_process",
            "radar_embedded_relay",
            "radar_embedded",
            "radar_embedded_event",
            "radar_manager_process_trigger",
            "radar_embedded_trigger",
            "radar_embedded_event_trigger",
            "radar_one_process",
            "radar_interrupt",
            "oneshot_radar",
            "oneshot_rclpy",
            "action_goal_rclpy",
            "action_cancel_rclpy",
            "action_goal_radar",
            "action_cancel_radar"
        ]
    );
    for l in r["latency"].as_array().unwrap() {
        check_distribution(l);
    }
    // the wire's floor, and a futex wake's, are below anything DDS does on the same host
    let p50 = |i: usize| r["latency"][i]["summary"]["p50_us"].as_f64().unwrap();
    for floor in [0, 1] {
        assert!(
            p50(floor) < p50(2),
            "{} {} us vs raw ros2-client {} us",
            r["latency"][floor]["key"],
            p50(floor),
            p50(2)
        );
    }
    // the futex floor measures every signal, those sent in a burst too (its ring; a one-slot sink lost ~1%)
    assert_eq!(r["latency"][1]["key"], "futex_floor");
    assert_eq!(r["latency"][1]["missing"], 0, "{}", r["latency"][1]);
    // the paced latency runs send 300 signals each; nearly all must have been measured
    for l in &r["latency"].as_array().unwrap()[..15] {
        assert!(l["summary"]["n"].as_u64().unwrap() >= 290, "{l}");
        // and what each signal cost their processes on the cores: every process ran, every signal made some
        // thread run somewhere (the sink's at least)
        let procs = l["usage"]["processes"]
            .as_array()
            .unwrap_or_else(|| panic!("no usage: {l}"));
        let want = match l["key"].as_str().unwrap() {
            "raw_2hop" => 3,
            "radar_one_process" => 1,
            k if k.starts_with("radar_manager_process") => 3,
            _ => 2,
        };
        assert_eq!(procs.len(), want, "{l}");
        for p in procs {
            assert!(p["cpu_us"].as_f64().unwrap() > 0.0, "{l}");
        }
        assert!(
            l["usage"]["total"]["slices"].as_f64().unwrap() >= 1.0,
            "{l}"
        );
    }
    // the stage breakdown (RustDDS's probe, patch 21) joined the stamps of both processes for nearly every
    // sample of each path, and every stage was measured
    assert_eq!(
        keys(&r["breakdown"]),
        [
            "raw_1hop_loop_send",
            "raw_1hop",
            "radar_embedded",
            "radar_embedded_event"
        ]
    );
    for b in r["breakdown"].as_array().unwrap() {
        assert!(b["joined"].as_u64().unwrap() >= 250, "{b}");
        for seg in b["segments"].as_array().unwrap() {
            assert!(seg["summary"]["n"].as_u64().unwrap() >= 250, "{seg}");
        }
    }
    assert_eq!(
        keys(&r["setup"]),
        [
            "setup_known",
            "setup_live",
            "setup_fresh",
            "setup_fresh_found",
            "activate",
            "disconnect",
            "deactivate"
        ]
    );
    for s in r["setup"].as_array().unwrap() {
        check_distribution(s);
    }

    assert_eq!(
        keys(&r["throughput"]),
        ["raw_1hop", "raw_2hop", "radar_1", "radar_100"]
    );
    for t in r["throughput"].as_array().unwrap() {
        let steps = t["steps"].as_array().unwrap();
        assert!(!steps.is_empty(), "{t}");
        // the lowest offered rate (500/s) goes through every path without loss, even in a debug build
        assert_eq!(steps[0]["sent"], steps[0]["received"], "{t}");
        assert!(t["max_lossless"].as_f64().unwrap() >= 500.0, "{t}");
    }
    assert_eq!(r["throughput"][3]["connections"], 100);
    assert!(r["throughput"][2]["relay_cpu"].as_f64().unwrap() > 0.0);

    // the scale curve: every step measured
    let steps = r["scale"].as_array().unwrap();
    assert_eq!(steps.len(), 2);
    for (sc, connections) in steps.iter().zip([10, 50]) {
        assert_eq!(sc["connections"], connections);
        assert_eq!(sc["active_while_connected"], sc["events"], "{sc}");
        assert_eq!(sc["still_active_after_teardown"], 0, "{sc}");
        for k in [
            "bytes_per_event",
            "bytes_per_response",
            "spawn_ms",
            "settle_ms",
        ] {
            assert!(sc[k].as_f64().unwrap() > 0.0, "{k}: {sc}");
        }
        // idle CPU once discovery settled was measured (a process never uses less than nothing)
        assert!(
            sc["cpu_idle_connected_settled"].as_f64().unwrap() >= 0.0,
            "{sc}"
        );
    }

    // one-shot publishes from fresh processes: every one arrived
    let rows = |prefix: &str| -> Vec<Value> {
        r["latency"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|l| l["key"].as_str().unwrap().starts_with(prefix))
            .cloned()
            .collect()
    };
    for l in rows("oneshot_") {
        assert_eq!(l["missing"], 0, "{l}");
        assert_eq!(l["summary"]["n"], r["meta"]["oneshot_publishes"], "{l}");
    }
    // actions, radar_ros and the rclpy baseline: every goal (after the warm-up) and every cancel measured
    let actions = rows("action_");
    assert_eq!(actions.len(), 4);
    for l in actions {
        assert_eq!(l["missing"], 0, "{l}");
    }
    // memory along a run of state changes, and its raw baseline: sampled from start to end
    let mem = r["state_memory"].as_array().unwrap();
    assert_eq!(
        mem.iter()
            .map(|m| m["key"].as_str().unwrap())
            .collect::<Vec<_>>(),
        ["radar_response", "raw_latched"]
    );
    for m in mem {
        let rss = m["rss"].as_array().unwrap();
        assert!(rss.len() >= 10, "{m}");
        assert_eq!(rss.last().unwrap()[0], r["meta"]["state_changes"], "{m}");
        assert!(rss.iter().all(|x| x[1].as_u64().unwrap() > 0), "{m}");
    }
    // a killed caller: its connection and its event's listener go within the lease
    assert_eq!(
        keys(&r["kill"]),
        ["kill_connections_removed", "kill_event_inactive"]
    );
    for k in r["kill"].as_array().unwrap() {
        check_distribution(k);
    }

    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    for heading in [
        "### Latency",
        "### Connections",
        "### Throughput",
        "### Scale",
        "### Memory over a long run",
        "### A deliberative program killed",
    ] {
        assert!(table.contains(heading), "{heading} missing from:\n{table}");
    }
    assert!(!table.contains("### Failed"));
    for svg in ["latency_cdf.svg", "setup_cdf.svg"] {
        let s = std::fs::read_to_string(Path::new(&out).join(svg)).unwrap();
        assert!(s.starts_with("<svg"), "{svg}");
        // one line per series, each with its legend entry
        assert!(
            s.matches("<polyline").count() >= 4,
            "{svg} has too few lines"
        );
        assert!(
            s.contains("raw_1hop") || s.contains("setup_known"),
            "{svg} has no legend"
        );
    }
    // the scale curve: four panels, five series, a point per step
    let s = std::fs::read_to_string(Path::new(&out).join("scale_curve.svg")).unwrap();
    assert!(s.starts_with("<svg"));
    for legend in [
        "event",
        "response",
        "spawn",
        "unconnected",
        "connected",
        "with components",
    ] {
        assert!(s.contains(legend), "scale_curve.svg has no {legend}");
    }
    assert!(
        s.matches("<polyline").count() >= 6,
        "scale_curve.svg has too few lines"
    );
    assert!(table.contains("### Scale curve"));
    let _ = std::fs::remove_dir_all(&out);
}
