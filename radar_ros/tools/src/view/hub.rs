//! The hub: the one task that owns the [`Model`], so that a page's snapshot and the changes after it are
//! taken in one order (a page that joins gets the snapshot in the same step that adds it to the pages sent
//! changes: nothing falls between them). It sends one changes message per tick, `rate` ticks a second.

use std::time::Duration;

use tokio::sync::mpsc;

use super::model::{Limits, Model, Seen};

/// What a page's connection receives: JSON text, or the hub giving up on it (it fell behind).
pub(crate) type ToPage = mpsc::Sender<std::sync::Arc<str>>;

/// Messages a page may fall behind before the hub drops it (the page reconnects and takes a new snapshot).
pub(crate) const PAGE_BACKLOG: usize = 32;

/// What the hub is asked.
pub(crate) enum Ask {
    /// A page joins: send it the snapshot, then every changes message.
    Join(ToPage),
}

/// Runs the hub until both `seen` and `asks` close: applies what the feed saw, answers joins (the snapshot
/// with `info` added: what the page shows about the view itself), and every `1/rate` s sends what changed to
/// every page.
pub(crate) async fn run(
    limits: Limits,
    rate: f64,
    info: serde_json::Map<String, serde_json::Value>,
    mut seen: mpsc::UnboundedReceiver<Seen>,
    mut asks: mpsc::UnboundedReceiver<Ask>,
) {
    let mut model = Model::new(limits);
    let mut pages: Vec<ToPage> = Vec::new();
    let mut tick = tokio::time::interval(Duration::from_secs_f64(1.0 / rate));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let (mut seen_open, mut asks_open) = (true, true);
    while seen_open || asks_open {
        tokio::select! {
            s = seen.recv(), if seen_open => match s {
                Some(s) => {
                    model.apply(s);
                    // take in what else is waiting before anything else (a burst is one step)
                    while let Ok(s) = seen.try_recv() {
                        model.apply(s);
                    }
                }
                None => seen_open = false,
            },
            a = asks.recv(), if asks_open => match a {
                Some(Ask::Join(page)) => {
                    let mut snapshot = model.snapshot();
                    for (k, v) in &info {
                        snapshot[k] = v.clone();
                    }
                    if page.try_send(snapshot.to_string().into()).is_ok() {
                        pages.push(page);
                    }
                }
                None => asks_open = false,
            },
            _ = tick.tick() => {
                pages.retain(|p| !p.is_closed());
                if let Some(c) = model.changes() {
                    // written once, whatever the number of pages
                    let text: std::sync::Arc<str> = c.to_string().into();
                    pages.retain(|p| p.try_send(text.clone()).is_ok());
                }
            }
        }
    }
}
