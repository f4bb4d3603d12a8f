//! `radar replay`: publish the signals recorded in an MCAP file again, with their timing (like rtlog).

use std::{collections::BTreeMap, time::Duration};

use radar_ros::Radar;
use serde_json::json;

use crate::common::{Fallible, Out};

/// Whether a topic is a RADAR signal (what `replay` publishes again), not a state.
fn is_signal(topic: &str) -> bool {
    radar_ros::graph::Endpoint::of_topic(topic).is_some_and(|(_, e)| e.is_signal())
}

/// A recorded signal: when it was logged, its topic and type, its CDR body.
type Planned = (u64, String, String, radar_ros::topics::RawMessage);

/// The signals in an MCAP file, in file order, and, if the file ends in the middle of a record (a recording
/// cut off by a recorder that wrote it all at the end), what was wrong there: the signals before it are kept.
fn signals_in(bytes: &[u8]) -> Fallible<(Vec<Planned>, Option<String>)> {
    let mut plan = Vec::new();
    let stream =
        mcap::MessageStream::new(bytes).map_err(|e| crate::Error::other("not an MCAP file", e))?;
    for m in stream {
        let m = match m {
            Ok(m) => m,
            Err(e) if plan.is_empty() => {
                return Err(crate::Error::other(
                    "not an MCAP file, or one cut off before its first signal",
                    e,
                ))
            }
            Err(e) => return Ok((plan, Some(e.to_string()))),
        };
        let Some(schema) = m.channel.schema.as_ref() else {
            continue;
        };
        if !is_signal(&m.channel.topic) || m.data.len() < 4 {
            continue;
        }
        plan.push((
            m.log_time,
            m.channel.topic.clone(),
            schema.name.clone(),
            radar_ros::topics::RawMessage::from_bytes(m.data[4..].to_vec()),
        ));
    }
    Ok((plan, None))
}

/// `radar replay`: publishes the signals of `input` (not the states) with their recorded spacing divided by
/// `rate`, after waiting up to `wait` for each topic's subscribers.
pub(crate) async fn replay(
    radar: &Radar,
    out: &Out,
    input: std::path::PathBuf,
    rate: f64,
    wait: Duration,
) -> Fallible<()> {
    if !(rate.is_finite() && rate > 0.0) {
        return Err(format!("--rate {rate}: give a speed above 0 (1 is as recorded)").into());
    }
    let bytes = std::fs::read(&input)
        .map_err(|e| crate::Error::io(format!("read {}", input.display()), e))?;
    let (mut plan, cut) =
        signals_in(&bytes).map_err(|e| crate::Error::other(input.display().to_string(), e))?;
    if let Some(e) = cut {
        eprintln!(
            "radar: {} ends early ({e}): a recording that was cut off; replaying the {} signals before",
            input.display(),
            plan.len()
        );
    }
    plan.sort_by_key(|p| p.0);
    let Some(first) = plan.first().map(|p| p.0) else {
        return Err(format!("{} holds no RADAR signals to replay", input.display()).into());
    };
    let mut publishers = BTreeMap::new();
    for (_, topic, ty, _) in &plan {
        if !publishers.contains_key(topic) {
            let p = radar.raw_publisher(topic, ty)?;
            publishers.insert(topic.clone(), p);
        }
    }
    // whoever listens now should hear all of it
    let ready = futures::future::join_all(
        publishers
            .values()
            .map(|p| async move { p.wait_for_subscribers(1).timeout(wait).await.is_ok() }),
    )
    .await;
    let unheard: Vec<&String> = publishers
        .keys()
        .zip(ready)
        .filter(|(_, ok)| !ok)
        .map(|(t, _)| t)
        .collect();
    let t0 = tokio::time::Instant::now();
    let mut sent = 0u64;
    for (at, topic, _, body) in &plan {
        let offset = Duration::from_nanos(((at - first) as f64 / rate) as u64);
        tokio::time::sleep_until(t0 + offset).await;
        publishers[topic].publish(body.clone())?;
        sent += 1;
    }
    // let reliable delivery finish before the writers go
    tokio::time::sleep(Duration::from_millis(200)).await;
    if out.json {
        println!(
            "{}",
            json!({ "file": input, "published": sent, "topics": publishers.len(), "without_subscribers": unheard })
        );
    } else {
        println!(
            "replayed {sent} signals on {} topics from {}",
            publishers.len(),
            input.display()
        );
        for t in unheard {
            println!("  nobody listened on {t}");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mcap_out::{ChunkLimits, McapOut, MessageOut};

    /// A recording of `n` triggers, a commit after each; the file's bytes.
    fn recording(n: u32) -> Vec<u8> {
        let path = std::env::temp_dir().join(format!("replay_{}_{n}.mcap", std::process::id()));
        let f = std::fs::OpenOptions::new()
            .create(true)
            .truncate(true)
            .read(true)
            .write(true)
            .open(&path)
            .unwrap();
        let mut w = McapOut::create(f, ChunkLimits::default()).unwrap();
        let s = w.add_schema("std_msgs/msg/Empty", "ros2msg", b"");
        let c = w.add_channel(s, "/tick/triggered", "cdr");
        let st = w.add_channel(s, "/tick/state", "cdr");
        for k in 0..n {
            for channel in [c, st] {
                let m = MessageOut {
                    channel,
                    sequence: k,
                    log_time: 10 + k as u64,
                    publish_time: 10 + k as u64,
                    data: &[0, 1, 0, 0, 0],
                };
                w.write(m).unwrap();
            }
            w.commit().unwrap();
        }
        w.finish().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        bytes
    }

    #[test]
    fn the_signals_of_a_recording_are_replayed_not_its_states() {
        let (plan, cut) = signals_in(&recording(3)).unwrap();
        assert!(cut.is_none());
        assert_eq!(plan.iter().map(|p| p.0).collect::<Vec<_>>(), [10, 11, 12]);
        assert!(plan
            .iter()
            .all(|p| p.1 == "/tick/triggered" && p.2 == "std_msgs/msg/Empty"));
    }

    #[test]
    fn a_file_cut_in_the_middle_of_a_record_replays_what_comes_before() {
        let whole = recording(4);
        // cut inside the last chunk: each commit's chunk holds one trigger
        let summary = mcap::Summary::read(&whole).unwrap().unwrap();
        let last = summary.chunk_indexes.last().unwrap();
        let cut_at = (last.chunk_start_offset + last.chunk_length / 2) as usize;
        let (plan, cut) = signals_in(&whole[..cut_at]).unwrap();
        assert_eq!(plan.len(), 3, "the three whole chunks");
        assert!(cut.is_some(), "the cut is said");
        assert!(signals_in(b"not mcap").is_err());
    }
}
