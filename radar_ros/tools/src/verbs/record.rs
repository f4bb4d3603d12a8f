//! `radar record`: signals, their payloads and state changes to MCAP (like rtlog); beside them, on the
//! `/radar/trace` channel, what `radar verify` needs that CDR does not carry (causes, writers; `crate::seen`).

use std::{
    collections::{BTreeMap, BTreeSet},
    time::Duration,
};

use radar_ros::{
    graph::Component,
    msg::{EventState, ResponseState},
    Radar,
};
use serde_json::json;

use crate::{
    common::{epoch_ns, stamp_ns, Fallible, Out, Stop},
    components::{forward, forward_signals, slot_topics, state_type, Following},
    mcap_out::{ChunkLimits, McapOut, MessageOut},
    schemas,
    seen::{self, Seen, SeenConnection},
};

/// One recorded message, and what `radar verify` keeps of it.
struct Recorded {
    topic: String,
    ros_type: String,
    body: radar_ros::topics::RawMessage,
    /// Source timestamp, nanoseconds since the epoch (0: unknown).
    published: i64,
    seen: Option<Seen>,
}

/// A CDR message as MCAP stores it: the 4-byte encapsulation header (little-endian CDR), then the body.
fn cdr(body: &radar_ros::topics::RawMessage) -> Vec<u8> {
    let mut v = vec![0, 1, 0, 0];
    v.extend_from_slice(body.as_bytes());
    v
}

/// The file being written: a channel per topic, a schema per type, and how many messages each topic gave.
struct Recording {
    path: std::path::PathBuf,
    out: McapOut,
    channels: BTreeMap<String, u16>,
    schemas: BTreeMap<String, u16>,
    counts: BTreeMap<String, u64>,
    unknown: BTreeSet<String>,
    /// The `/radar/trace` channel, once made.
    trace: Option<u16>,
}

impl Recording {
    fn create(path: std::path::PathBuf) -> Fallible<Recording> {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(true)
            .read(true)
            .write(true)
            .open(&path)
            .map_err(|e| crate::Error::io(format!("create {}", path.display()), e))?;
        let out = McapOut::create(file, ChunkLimits::default())
            .map_err(|e| crate::Error::io(format!("write {}", path.display()), e))?;
        Ok(Recording {
            path,
            out,
            channels: BTreeMap::new(),
            schemas: BTreeMap::new(),
            counts: BTreeMap::new(),
            unknown: BTreeSet::new(),
            trace: None,
        })
    }

    fn failed(&self, e: std::io::Error) -> crate::Error {
        crate::Error::io(
            format!(
                "write {} (what was committed before is readable)",
                self.path.display()
            ),
            e,
        )
    }

    /// Adds `m` to the open chunk, with its topic's channel and type's schema the first time, and what
    /// `radar verify` keeps of it.
    fn add(&mut self, mut m: Recorded) -> Fallible<()> {
        if let Some(s) = m.seen.take() {
            self.add_seen(&s)?;
        }
        self.add_message(m)
    }

    /// One line of the `/radar/trace` channel.
    fn add_seen(&mut self, s: &Seen) -> Fallible<()> {
        let channel = match self.trace {
            Some(c) => c,
            None => {
                let schema = self.out.add_schema(
                    "radar_tools/trace",
                    "jsonschema",
                    br#"{"type":"object","description":"what radar record saw of a RADAR system (radar verify reads it)"}"#,
                );
                let c = self.out.add_channel(schema, seen::CHANNEL, "json");
                self.trace = Some(c);
                c
            }
        };
        let n = self.counts.entry(seen::CHANNEL.to_owned()).or_default();
        *n += 1;
        let data = serde_json::to_vec(s)?;
        let message = MessageOut {
            channel,
            sequence: *n as u32,
            log_time: s.log().max(0) as u64,
            publish_time: s.stamp().max(0) as u64,
            data: &data,
        };
        self.out.write(message).map_err(|e| self.failed(e))
    }

    fn add_message(&mut self, m: Recorded) -> Fallible<()> {
        let Some(def) = schemas::definition(&m.ros_type) else {
            // a type radar cannot describe (a user's own): said once, not recorded
            if self.unknown.insert(m.ros_type.clone()) {
                eprintln!(
                    "radar: not recording {} ({}): radar has no ROS 2 schema for that type",
                    m.topic, m.ros_type
                );
            }
            return Ok(());
        };
        let schema = match self.schemas.get(&m.ros_type) {
            Some(id) => *id,
            None => {
                let id = self.out.add_schema(&m.ros_type, "ros2msg", def.as_bytes());
                *self.schemas.entry(m.ros_type.clone()).or_insert(id)
            }
        };
        let channel = match self.channels.get(&m.topic) {
            Some(id) => *id,
            None => {
                let id = self.out.add_channel(schema, &m.topic, "cdr");
                *self.channels.entry(m.topic.clone()).or_insert(id)
            }
        };
        let n = self.counts.entry(m.topic.clone()).or_default();
        *n += 1;
        let now = epoch_ns();
        let message = MessageOut {
            channel,
            sequence: *n as u32,
            log_time: now,
            publish_time: if m.published > 0 {
                m.published as u64
            } else {
                now
            },
            data: &cdr(&m.body),
        };
        self.out.write(message).map_err(|e| self.failed(e))
    }

    fn commit_if_due(&mut self) -> Fallible<()> {
        self.out.commit_if_due().map_err(|e| self.failed(e))
    }

    /// Writes the summary; says what was recorded.
    fn finish(self, out: &Out) -> Fallible<()> {
        let Recording {
            path,
            counts,
            out: mcap,
            ..
        } = self;
        mcap.finish()
            .map_err(|e| crate::Error::io(format!("finish {}", path.display()), e))?;
        let total: u64 = counts.values().sum();
        if out.json {
            println!(
                "{}",
                json!({ "file": path, "messages": total, "topics": counts })
            );
        } else {
            println!(
                "{}: {total} messages on {} topics",
                path.display(),
                counts.len()
            );
        }
        Ok(())
    }
}

/// `radar record`: until the duration ends, Ctrl-C or SIGTERM, writes what the components followed emit to
/// `output`, a chunk at least every half second: a recording that is killed keeps all but its last moments.
pub(crate) async fn record(
    radar: &Radar,
    out: &Out,
    output: std::path::PathBuf,
    names: Vec<String>,
    activate: bool,
    duration: Option<f64>,
) -> Fallible<()> {
    let mut stop = Stop::catch()?;
    if output.extension().and_then(|e| e.to_str()) != Some("mcap") {
        return Err("the output file ends in .mcap".into());
    }
    let mut following = Following::new(radar, &names)?;
    let mut recording = Recording::create(output)?;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Recorded>();
    let mut tasks = Vec::new();
    let mut lists: BTreeSet<String> = BTreeSet::new();
    let end = stop.after(duration);
    tokio::pin!(end);
    let mut rescan = tokio::time::interval(Duration::from_millis(250));
    let mut commit = tokio::time::interval(ChunkLimits::default().age / 2);
    if !out.json {
        println!("recording to {} (Ctrl-C to stop)", recording.path.display());
    }
    let result = loop {
        let step = tokio::select! {
            _ = &mut end => break Ok(()),
            _ = rescan.tick() => following.new_components(radar).iter().try_for_each(|c| {
                tasks.extend(tap(radar, c, activate, tx.clone())?);
                Ok(())
            }).and_then(|()| {
                // the managers' connection lists: which statements there are, and when each began
                for topic in radar.introspect().connection_topics() {
                    if lists.insert(topic.clone()) {
                        tasks.push(tap_connections(radar, topic, tx.clone())?);
                    }
                }
                Ok(())
            }),
            Some(m) = rx.recv() => recording.add(m),
            _ = commit.tick() => recording.commit_if_due(),
        };
        if let Err(e) = step {
            break Err(e);
        }
    };
    for t in tasks {
        t.abort();
    }
    // what came in before the stop is kept, whatever ended the recording
    while let Ok(m) = rx.try_recv() {
        recording.add(m)?;
    }
    let finished = recording.finish(out);
    result.and(finished)
}

/// Subscribes to what `record` keeps of `c`: a response's signals and state, an event's state (and, with
/// `activate`, its triggered signal), each forwarded raw with its type and source time.
fn tap(
    radar: &Radar,
    c: &Component,
    activate: bool,
    tx: tokio::sync::mpsc::UnboundedSender<Recorded>,
) -> Fallible<Vec<tokio::task::JoinHandle<()>>> {
    let state_type = state_type(c);
    let make = |s: crate::components::SignalSample<'_>| Recorded {
        topic: s.topic.to_owned(),
        ros_type: s.ros_type.to_owned(),
        seen: Some(Seen::Signal {
            topic: s.topic.to_owned(),
            stamp: s.stamp,
            log: epoch_ns() as i64,
            cause: seen::cause(s.cause),
            writer: seen::hex(&s.writer),
            len: s.body.len(),
        }),
        body: s.body,
        published: s.stamp,
    };
    let mut tasks = forward_signals(radar, c, activate, &tx, make)?;
    tasks.extend(forward(radar, slot_topics(c), activate, &tx, make)?);
    // the state, from its transient-local topic (the current one first)
    let topic = c.name().topic("state");
    macro_rules! state_task {
        ($t:ty) => {{
            let sub = radar.state_subscription::<$t>(&topic)?;
            let tx = tx.clone();
            tokio::spawn(async move {
                while let Ok((m, published)) = sub.recv_stamped().await {
                    let Ok(body) = radar_ros::topics::RawMessage::encode(&m) else {
                        continue;
                    };
                    let r = Recorded {
                        topic: topic.clone(),
                        ros_type: state_type.into(),
                        seen: Some(seen_state(&m)),
                        body,
                        published,
                    };
                    if tx.send(r).is_err() {
                        break;
                    }
                }
            })
        }};
    }
    tasks.push(match c {
        Component::Response(_) => state_task!(ResponseState),
        Component::Event(_) => state_task!(EventState),
    });
    Ok(tasks)
}

/// What `radar verify` keeps of a state.
trait SeenState {
    fn seen(&self) -> Seen;
}

fn seen_state(s: &impl SeenState) -> Seen {
    s.seen()
}

impl SeenState for ResponseState {
    fn seen(&self) -> Seen {
        Seen::ResponseState {
            name: self.name.clone(),
            stamp: stamp_ns(&self.stamp),
            log: epoch_ns() as i64,
            state: self.state_label.clone(),
            last_exit_reason: self.last_exit_reason.clone(),
            policy: self.start_policy.clone(),
            restarts: self.restarts,
        }
    }
}

impl SeenState for EventState {
    fn seen(&self) -> Seen {
        Seen::EventState {
            name: self.name.clone(),
            stamp: stamp_ns(&self.stamp),
            log: epoch_ns() as i64,
            active: self.active,
            listeners: self.listeners,
        }
    }
}

/// Records a manager's connection list (`<manager>/connections`, transient-local): the list, and the
/// statements in it for `radar verify`.
fn tap_connections(
    radar: &Radar,
    topic: String,
    tx: tokio::sync::mpsc::UnboundedSender<Recorded>,
) -> Fallible<tokio::task::JoinHandle<()>> {
    let sub = radar.state_subscription::<radar_ros::msg::ConnectionList>(&topic)?;
    Ok(tokio::spawn(async move {
        while let Ok((m, published)) = sub.recv_stamped().await {
            let Ok(body) = radar_ros::topics::RawMessage::encode(&m) else {
                continue;
            };
            let seen = Seen::Connections {
                manager: m.manager.clone(),
                stamp: stamp_ns(&m.stamp),
                log: epoch_ns() as i64,
                connections: m.connections.iter().map(SeenConnection::of).collect(),
            };
            let r = Recorded {
                topic: topic.clone(),
                ros_type: "radar_msgs/msg/ConnectionList".into(),
                body,
                published,
                seen: Some(seen),
            };
            if tx.send(r).is_err() {
                break;
            }
        }
    }))
}
