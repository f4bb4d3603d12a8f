//! Where one hop's time goes: the latency runs of raw ros2-client and of radar_ros's one-hop paths again,
//! with RustDDS's latency probe on (`RUSTDDS_PROBE_TOPIC`, RADAR patch 21). Each sample's stamps from the
//! writing and the reading process are joined by the writer's sequence number and cut into stages.

use std::collections::HashMap;

use super::{latency::Host, *};

/// The stages a hop is cut into: `(name, from, to)`, where `app_send`/`app_start` are the benchmark's own
/// stamps (the payload's send time and the receiving code's first instruction) and the rest are probe stages.
pub const SEGMENTS: [(&str, &str, &str); 11] = [
    ("app -> DataWriter::write", "app_send", "write"),
    ("serialize + admit to the send buffer", "write", "admitted"),
    (
        "hand-off to the sending thread (event loop wake; none when the writer sends)",
        "admitted",
        "loop_send",
    ),
    ("build and send the datagram", "loop_send", "socket_sent"),
    (
        "kernel + wake of the receiving event loop",
        "socket_sent",
        "loop_woke",
    ),
    ("read the socket", "loop_woke", "socket_read"),
    ("parse the RTPS message", "socket_read", "parsed"),
    ("into the topic cache", "parsed", "cached"),
    ("notify the data reader", "cached", "notified"),
    (
        "hand-off to the reading task (wake + take)",
        "notified",
        "taken",
    ),
    ("taken -> the receiving code runs", "taken", "app_start"),
];

impl Bench {
    /// The stage breakdown of raw one hop and radar_ros's two one-hop paths.
    pub(super) async fn breakdown(&mut self) -> Result<()> {
        let (n, p) = (self.plan.latency_n + self.plan.warmup, self.plan.period_us);
        let probe = |topic: &str| vec![("RUSTDDS_PROBE_TOPIC".to_owned(), topic.to_owned())];
        // raw, the sample sent by the event loop as before RustDDS patch 22, then by the writing thread
        for inline in [false, true] {
            self.child_env = probe("rt/bench/lat");
            if !inline {
                self.child_env
                    .push(("RUSTDDS_INLINE_SEND".into(), "0".into()));
            }
            let hop = self.raw_hop(&format!("run {n} {p}"), false).await;
            let raw = self.probe_children(hop).await;
            let (key, label) = if inline {
                ("raw_1hop", "raw ros2-client, 1 hop")
            } else {
                (
                    "raw_1hop_loop_send",
                    "raw ros2-client, 1 hop, sent by the event loop (RUSTDDS_INLINE_SEND=0)",
                )
            };
            self.push_breakdown(key, label, raw);
        }
        // radar, manager in the response's process: the event's triggered writer to the manager's reader
        self.child_env = probe("rt/bench/ev/triggered");
        let hop = self.radar_hop(n, p, Host::Response).await;
        let r = self.probe_children(hop).await;
        self.push_breakdown(
            "radar_embedded",
            "radar_ros, manager in the response's process",
            r,
        );
        // radar, manager in the event's process: the manager's writer on the response's start
        self.child_env = probe("rt/bench/resp/start");
        let hop = self.radar_hop(n, p, Host::Event).await;
        let r = self.probe_children(hop).await;
        self.push_breakdown(
            "radar_embedded_event",
            "radar_ros, manager in the event's process",
            r,
        );
        self.child_env.clear();
        Ok(())
    }

    /// Collects the probe's stamps of a run's processes (the first is the writer's side, the one that
    /// reported is the reader's) and joins them with the report.
    pub(super) async fn probe_children(
        &mut self,
        hop: Result<(Value, Vec<Child>)>,
    ) -> Result<Value> {
        let (report, mut children) = hop?;
        let mut stamps = Vec::new();
        for c in &mut children {
            let s = c.ask_json("probe", START).await?;
            stamps.push(s["stamps"].clone());
        }
        for c in children {
            c.quit().await;
        }
        // the writing process is the first child; the reading one is the sink (raw) or the response (radar),
        // the last or second: stamps are kept by stage, so every reader-side stage comes from the process that
        // has it
        let writer = parse_stamps(&stamps[0])?;
        let mut reader = HashMap::new();
        for s in &stamps[1..] {
            for (k, v) in parse_stamps(s)? {
                reader.entry(k).or_insert(v);
            }
        }
        let at: Vec<(u64, u64, u64)> =
            serde_json::from_value(report["at"].clone()).context("a report without `at`")?;
        Ok(join(&at, self.plan.warmup, &writer, &reader))
    }

    pub(super) fn push_breakdown(&mut self, key: &str, label: &str, r: Result<Value>) {
        match r {
            Ok(mut v) => {
                v["key"] = json!(key);
                v["label"] = json!(label);
                self.results.breakdown.push(v);
            }
            Err(e) => self.results.errors.push(format!("breakdown {key}: {e:#}")),
        }
    }
}

/// `(stage, sequence number) -> t_ns`, the first stamp of each.
fn parse_stamps(v: &Value) -> Result<HashMap<(String, i64), u64>> {
    let list: Vec<(String, i64, u64)> =
        serde_json::from_value(v.clone()).context("probe stamps")?;
    let mut m = HashMap::new();
    for (stage, sn, t) in list {
        m.entry((stage, sn)).or_insert(t);
    }
    Ok(m)
}

/// Joins each sample (`[seq, t0, t1]`, from `warmup` on) with the probe's stamps: the writer's `write` stamp
/// that follows `t0` (the next sample is sent a pacing period later) names the sequence number. Returns
/// `{ n, joined, segments: [{ name, p50_us, p90_us, p99_us }], total: {...} }`.
pub fn join(
    at: &[(u64, u64, u64)],
    warmup: u64,
    writer: &HashMap<(String, i64), u64>,
    reader: &HashMap<(String, i64), u64>,
) -> Value {
    let mut writes: Vec<(u64, i64)> = writer
        .iter()
        .filter(|((stage, _), _)| stage == "write")
        .map(|((_, sn), t)| (*t, *sn))
        .collect();
    writes.sort_unstable();
    let mut per_segment: Vec<Vec<u64>> = vec![Vec::new(); SEGMENTS.len()];
    let mut totals = Vec::new();
    let mut joined = 0;
    for &(_, t0, t1) in at.iter().filter(|(s, _, _)| *s >= warmup) {
        let i = writes.partition_point(|(t, _)| *t < t0);
        let Some(&(tw, sn)) = writes.get(i) else {
            continue;
        };
        if tw > t1 {
            continue;
        }
        let time = |stage: &str| -> Option<u64> {
            match stage {
                "app_send" => Some(t0),
                "app_start" => Some(t1),
                s => writer
                    .get(&(s.to_owned(), sn))
                    .or_else(|| reader.get(&(s.to_owned(), sn)))
                    .copied(),
            }
        };
        let times: Option<Vec<u64>> = SEGMENTS
            .iter()
            .map(|(_, a, b)| Some(time(b)?.saturating_sub(time(a)?)))
            .collect();
        let Some(times) = times else { continue };
        joined += 1;
        totals.push(t1 - t0);
        for (k, d) in times.into_iter().enumerate() {
            per_segment[k].push(d);
        }
    }
    let segments: Vec<Value> = SEGMENTS
        .iter()
        .zip(&per_segment)
        .map(|((name, _, _), v)| json!({ "name": name, "summary": summarize(v) }))
        .collect();
    json!({
        "n": at.iter().filter(|(s, _, _)| *s >= warmup).count(),
        "joined": joined,
        "segments": segments,
        "total": summarize(&totals),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamps(list: &[(&str, i64, u64)]) -> HashMap<(String, i64), u64> {
        list.iter()
            .map(|(s, n, t)| ((s.to_string(), *n), *t))
            .collect()
    }

    #[test]
    fn a_sample_is_joined_by_the_write_that_follows_its_send_and_cut_into_stages() {
        let w = stamps(&[
            ("write", 1, 110),
            ("admitted", 1, 120),
            ("loop_send", 1, 140),
            ("socket_sent", 1, 150),
            ("write", 2, 1110),
            ("admitted", 2, 1120),
            ("loop_send", 2, 1130),
            ("socket_sent", 2, 1150),
        ]);
        let r = stamps(&[
            ("loop_woke", 1, 170),
            ("socket_read", 1, 175),
            ("parsed", 1, 180),
            ("cached", 1, 185),
            ("notified", 1, 190),
            ("taken", 1, 200),
            // sample 2 lost its reader-side stamps: not joined
        ]);
        let v = join(&[(0, 100, 230), (1, 1100, 1300)], 0, &w, &r);
        assert_eq!(v["n"], 2);
        assert_eq!(v["joined"], 1);
        let p50 = |k: usize| v["segments"][k]["summary"]["p50_us"].as_f64().unwrap();
        assert_eq!(p50(0), 0.010); // app -> write: 10 ns
        assert_eq!(p50(2), 0.020); // admitted -> loop_send
        assert_eq!(p50(4), 0.020); // socket_sent -> loop_woke
        assert_eq!(p50(10), 0.030); // taken -> app
        assert_eq!(v["total"]["p50_us"].as_f64().unwrap(), 0.130);
    }
}
