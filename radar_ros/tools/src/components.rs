//! Which topics show a component's activity, and the components a `watch` or `record` follows.

use radar_ros::{graph::Component, Radar};

use crate::common::Fallible;

/// The signals that show a component's activity, `(topic, type, label)`: a response's three; an event's
/// `triggered`.
pub(crate) fn signal_topics(c: &Component) -> Vec<(String, String, &'static str)> {
    let of = |s: radar_ros::Signal, label| (s.topic().to_owned(), s.ros_type().to_owned(), label);
    match c {
        Component::Response(r) => vec![
            of(r.started(), "started"),
            of(r.interrupted(), "interrupted"),
            of(r.exited(), "exited"),
        ],
        Component::Event(e) => vec![of(e.triggered(), "triggered")],
    }
}

/// What else of a component `radar record` keeps for `radar verify`, `(topic, type, label)`: a response's
/// slots (the statements' slot signals, with their causes) and its `dropped`.
pub(crate) fn slot_topics(c: &Component) -> Vec<(String, String, &'static str)> {
    match c {
        Component::Response(r) => {
            let of =
                |s: radar_ros::Slot, label| (s.topic().to_owned(), s.ros_type().to_owned(), label);
            let d = r.dropped();
            vec![
                of(r.start_slot(), "start"),
                of(r.interrupt_slot(), "interrupt"),
                of(r.exit_slot(), "exit"),
                (d.topic().to_owned(), d.ros_type().to_owned(), "dropped"),
            ]
        }
        Component::Event(_) => Vec::new(),
    }
}

/// A sample of one of a component's signals: its topic, type and label ([`signal_topics`]), its body and its
/// source time (ns since the epoch, 0: unknown).
pub(crate) struct SignalSample<'a> {
    pub(crate) topic: &'a str,
    pub(crate) ros_type: &'a str,
    pub(crate) label: &'static str,
    pub(crate) body: radar_ros::topics::RawMessage,
    pub(crate) stamp: i64,
    /// The statement's cause it carries.
    pub(crate) cause: Option<(u128, u64)>,
    /// Its writer.
    pub(crate) writer: [u8; 16],
}

/// Subscribes to the signals that show `c`'s activity ([`signal_topics`]) and forwards each sample, made into
/// what the verb keeps by `make`, to `tx` until it closes: one task per signal. What `watch` and `record`
/// share.
pub(crate) fn forward_signals<T: Send + 'static>(
    radar: &Radar,
    c: &Component,
    activate: bool,
    tx: &tokio::sync::mpsc::UnboundedSender<T>,
    make: impl Fn(SignalSample<'_>) -> T + Clone + Send + 'static,
) -> Fallible<Vec<tokio::task::JoinHandle<()>>> {
    forward(radar, signal_topics(c), activate, tx, make)
}

/// [`forward_signals`] for the topics given. An event's `triggered` is only observed (a reader no one counts as
/// a peer), unless `activate`; a response's slots and `dropped` always are (a recorder on a slot would keep its
/// outlets from seeing the response leave).
pub(crate) fn forward<T: Send + 'static>(
    radar: &Radar,
    topics: Vec<(String, String, &'static str)>,
    activate: bool,
    tx: &tokio::sync::mpsc::UnboundedSender<T>,
    make: impl Fn(SignalSample<'_>) -> T + Clone + Send + 'static,
) -> Fallible<Vec<tokio::task::JoinHandle<()>>> {
    let mut tasks = Vec::new();
    for (topic, ros_type, label) in topics {
        // an event's `triggered` is only observed (the event does not count this reader as a listener, so
        // watching changes nothing), unless `activate`
        let observe = (label == "triggered" && !activate)
            || matches!(label, "start" | "interrupt" | "exit" | "dropped");
        let sub = if observe {
            radar.observe_raw(&topic, &ros_type)
        } else {
            radar.raw_subscription(&topic, &ros_type)
        }?;
        let (tx, make) = (tx.clone(), make.clone());
        tasks.push(tokio::spawn(async move {
            while let Ok(s) = sub.recv_sample().await {
                let sample = SignalSample {
                    topic: &topic,
                    ros_type: &ros_type,
                    label,
                    body: s.body,
                    stamp: s.stamp,
                    cause: s.cause,
                    writer: s.writer,
                };
                if tx.send(make(sample)).is_err() {
                    break;
                }
            }
        }));
    }
    Ok(tasks)
}

/// The type of a component's `state` topic.
pub(crate) fn state_type(c: &Component) -> &'static str {
    match c {
        Component::Response(_) => "radar_msgs/msg/ResponseState",
        Component::Event(_) => "radar_msgs/msg/EventState",
    }
}

/// The components a `watch` or `record` follows: those named (all if none), each once, as they appear.
pub(crate) struct Following {
    /// The names asked for (none: every component).
    pub(crate) wanted: Vec<String>,
    seen: std::collections::BTreeSet<String>,
}

impl Following {
    pub(crate) fn new(radar: &Radar, names: &[String]) -> Fallible<Following> {
        let wanted = names
            .iter()
            .map(|n| {
                radar
                    .resolve(n)
                    .map(|c| c.fully_qualified())
                    .map_err(crate::Error::from)
            })
            .collect::<Fallible<_>>()?;
        Ok(Following {
            wanted,
            seen: Default::default(),
        })
    }

    /// Components on the graph now that are wanted and not followed yet.
    pub(crate) fn new_components(&mut self, radar: &Radar) -> Vec<Component> {
        radar
            .components()
            .into_iter()
            .filter(|c| {
                let fq = c.name().fully_qualified();
                (self.wanted.is_empty() || self.wanted.contains(&fq)) && self.seen.insert(fq)
            })
            .collect()
    }
}
