//! Whether a relay's source or an outlet's slot has peers: the sum of some match counts, with the grace of
//! [`GONE_AFTER`] before it counts as gone (rule C5).

use super::GONE_AFTER;

/// What a relay or outlet tells the table about its peers.
pub(super) enum Change {
    /// All of them have been gone for [`GONE_AFTER`].
    Gone,
    /// One is back after that.
    Back,
}

/// Whether a source or slot has peers (the sum of some match counts), with the grace of [`GONE_AFTER`]
/// before it counts as gone.
pub(super) struct Presence {
    counts: Vec<tokio::sync::watch::Receiver<usize>>,
    /// No peer since this moment (not yet reported).
    empty_since: Option<tokio::time::Instant>,
    /// Reported gone (and not back since).
    gone: bool,
}

impl Presence {
    pub(super) fn new(counts: Vec<tokio::sync::watch::Receiver<usize>>) -> Presence {
        let mut p = Presence {
            counts,
            empty_since: None,
            gone: false,
        };
        if p.total() == 0 {
            p.empty_since = Some(tokio::time::Instant::now());
        }
        p
    }

    fn total(&mut self) -> usize {
        self.counts.iter_mut().map(|c| *c.borrow_and_update()).sum()
    }

    /// Another count to add (a writer made later).
    pub(super) fn add(&mut self, count: tokio::sync::watch::Receiver<usize>) {
        self.counts.push(count);
    }

    /// The next change worth telling; `None` once the endpoints are gone. Cancel-safe: the state lives here.
    pub(super) async fn next(&mut self) -> Option<Change> {
        loop {
            let deadline = self.empty_since.map(|t| t + GONE_AFTER);
            let changed = async {
                if self.counts.is_empty() {
                    return std::future::pending::<bool>().await;
                }
                let all = self.counts.iter_mut().map(|c| Box::pin(c.changed()));
                futures::future::select_all(all).await.0.is_ok()
            };
            tokio::select! {
                ok = changed => {
                    if !ok {
                        return None;
                    }
                    if self.total() == 0 {
                        if !self.gone && self.empty_since.is_none() {
                            self.empty_since = Some(tokio::time::Instant::now());
                        }
                    } else {
                        self.empty_since = None;
                        if std::mem::take(&mut self.gone) {
                            return Some(Change::Back);
                        }
                    }
                }
                _ = async { tokio::time::sleep_until(deadline.expect("guarded")).await }, if deadline.is_some() => {
                    self.empty_since = None;
                    if self.total() == 0 {
                        self.gone = true;
                        return Some(Change::Gone);
                    }
                }
            }
        }
    }
}
