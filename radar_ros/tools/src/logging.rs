//! How the `radar` and `radar_manager` binaries log: `RUST_LOG` if set, else their defaults, to stderr. One
//! thing more: a Zenoh peer whose clock is ahead of this host's by more than Zenoh's 500 ms makes Zenoh log a
//! warning (`uhlc`) and an error (`zenoh::net::routing::dispatcher::pubsub`) for every sample it routes from
//! that peer (`radar router` next to such a peer printed two lines per sample). The samples still arrive,
//! re-stamped with this host's time (their source time, in rmw_zenoh's attachment, is kept), so it is not an
//! error of this program: the defaults turn those two targets off and say it once per peer session instead,
//! as a warning that says what to do.

use std::{collections::HashSet, fmt, sync::Mutex};

use tracing::{field::Field, Event, Subscriber};
use tracing_subscriber::{
    filter::{EnvFilter, Targets},
    layer::{Context, SubscriberExt},
    util::SubscriberInitExt,
    Layer,
};

/// The targets Zenoh reports a peer's clock ahead of this host's from, once per sample.
const CLOCK_TARGETS: [&str; 2] = ["uhlc", "zenoh::net::routing::dispatcher::pubsub"];

/// Logs to stderr: `RUST_LOG`'s filter if set, else `default` with Zenoh's per-sample clock reports off; a
/// peer's clock ahead of this host's is said once per peer session whatever the filter.
pub fn init(default: &str) {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        let quiet: Vec<String> = CLOCK_TARGETS.iter().map(|t| format!("{t}=off")).collect();
        EnvFilter::new(format!("{default},{}", quiet.join(",")))
    });
    let _ = tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_filter(filter),
        )
        .with(
            ClockNotice::default()
                .with_filter(Targets::new().with_target("uhlc", tracing::Level::WARN)),
        )
        .try_init();
}

/// Says once per peer session that its clock is ahead of this host's (from uhlc's warning, which names it).
#[derive(Default)]
struct ClockNotice {
    told: Mutex<HashSet<String>>,
}

impl<S: Subscriber> Layer<S> for ClockNotice {
    fn on_event(&self, event: &Event<'_>, _: Context<'_, S>) {
        let mut message = Message::default();
        event.record(&mut message);
        if let Some(notice) = clock_notice(&message.0, &mut self.told.lock().unwrap()) {
            // written here, not logged: an event logged inside a subscriber's callback is dropped
            eprintln!("{notice}");
        }
    }
}

/// The notice for uhlc's `message` ("incoming timestamp from <session> exceeding delta 500ms is rejected:
/// <its time> vs. now: <ours>"), if it names a session not `told` of yet.
fn clock_notice(message: &str, told: &mut HashSet<String>) -> Option<String> {
    let rest = message.split("incoming timestamp from ").nth(1)?;
    let session = rest.split_whitespace().next()?;
    let times = rest.split("is rejected: ").nth(1).unwrap_or("?");
    told.insert(session.to_owned()).then(|| {
        format!(
            "WARN radar: the clock of Zenoh session {session} is ahead of this host's by more than 500 ms \
             ({times}). Its samples still arrive, re-stamped with this host's time as Zenoh routes them (the \
             source time in their attachment is kept); set both hosts' clocks (NTP, chrony). Said once per \
             session (RUST_LOG=uhlc=warn shows every sample)."
        )
    })
}

#[derive(Default)]
struct Message(String);

impl tracing::field::Visit for Message {
    fn record_debug(&mut self, field: &Field, value: &dyn fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clock_ahead_is_said_once_per_session() {
        // uhlc 0.8's message, as radar router printed it next to a peer under libfaketime +1h
        let line = |zid: &str| {
            format!(
                "incoming timestamp from {zid} exceeding delta 500ms is rejected: \
                 2026-11-28T05:39:45.944371868Z vs. now: 2026-11-28T04:39:45.945060004Z"
            )
        };
        let mut told = HashSet::new();
        let first = clock_notice(&line("c64a9d68"), &mut told).unwrap();
        assert!(
            first.contains("c64a9d68") && first.contains("05:39:45") && first.contains("NTP"),
            "{first}"
        );
        assert_eq!(clock_notice(&line("c64a9d68"), &mut told), None);
        assert!(clock_notice(&line("0b1e"), &mut told).is_some());
        assert_eq!(clock_notice("something else", &mut told), None);
    }
}
