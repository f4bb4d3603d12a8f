//! The `until` part of a connection: which signals make it, and the window in which U interrupts R (C3, C6,
//! C7).

use std::collections::BTreeSet;

use crate::time::HOLD;

/// The `until U` part of a statement that starts response R.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Until<S, T> {
    /// U: the signal that interrupts.
    pub source: S,
    /// R's `started`.
    pub started: S,
    /// R's `exited`.
    pub exited: S,
    /// R's `dropped`: a start R did not take (R6). A response that keeps no causes has none.
    pub dropped: S,
    /// R's `interrupt` slot.
    pub interrupt: T,
    /// R keeps causes (a RADAR response: response rules R11-R13): C6. Otherwise (rclpy): the table decides
    /// the window (C7).
    pub causes: bool,
}

/// The window of C3, for one `until`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct UntilWindow {
    causes: bool,
    /// C6: the start deliveries whose run may be going or still come: each from its delivery until R's
    /// `exited` carries it or a later one (R takes starts one after another), or R's `dropped` carries it. A later
    /// start R drops does not end an earlier one's run (a `whenever ... until` while R is busy with it).
    pending: BTreeSet<u64>,
    /// C7: the emission time of the newest signal of U that was not sent.
    kept: Option<i64>,
    // C7, for responses without causes:
    /// R runs, as far as its signals read so far tell (in emission order).
    running: bool,
    /// A start was delivered while R was idle: R's next `started` is this statement's run.
    awaiting: bool,
    /// A start was delivered (emitted at this time) while R seemed to run: if R's `exited` turns out to be older,
    /// R was idle and took it.
    sent_while_running: Option<i64>,
    /// The window is open, since R's `started` at this time.
    open_since: Option<i64>,
    /// When R emitted the last of its signals applied here: R's `started` and `exited` come through
    /// different topics and may be read out of order; an older one than what was applied is left alone.
    last_response_signal: i64,
}

/// What a signal read by the table does to an `until` window.
pub(super) enum WindowSignal {
    /// This statement delivered start number `n`, whose source was emitted at `at`.
    StartDelivered { n: u64, at: i64 },
    /// R emitted `started` at `at`.
    Started { at: i64 },
    /// R emitted `exited` at `at`, carrying `from` (the delivery of this statement whose run it ends).
    Exited { at: i64, ours: Option<u64> },
    /// R did not take a start: this statement's delivery, if it was one of ours.
    Dropped { ours: Option<u64> },
    /// U emitted at `at`.
    U { at: i64 },
}

impl UntilWindow {
    /// The window of an `until` whose response keeps causes (or not).
    pub fn new(causes: bool) -> UntilWindow {
        UntilWindow {
            causes,
            last_response_signal: i64::MIN,
            ..UntilWindow::default()
        }
    }

    /// Applies a signal; returns the emission time of a signal of U (the one given, or a kept one) that goes to
    /// R's `interrupt` now.
    pub(super) fn apply(&mut self, s: WindowSignal) -> Option<i64> {
        if self.causes {
            self.apply_by_cause(s)
        } else {
            self.apply_by_stamps(s)
        }
    }

    /// [`UntilWindow::apply`] for a response that keeps causes: its signals say which start they are of.
    fn apply_by_cause(&mut self, s: WindowSignal) -> Option<i64> {
        match s {
            WindowSignal::StartDelivered { n, at } => {
                self.pending.insert(n);
                self.kept.take().filter(|&u| u > at && u - at <= HOLD)
            }
            // the run of our start m has ended, and so have the runs of our earlier starts (R takes starts in
            // order): nothing of them to interrupt
            WindowSignal::Exited { ours: Some(m), .. } => {
                self.pending.retain(|&n| n > m);
                None
            }
            // R did not take our start m: no run of it will be; the run of an earlier start goes on
            WindowSignal::Dropped { ours: Some(m) } => {
                self.pending.remove(&m);
                None
            }
            WindowSignal::Exited { .. }
            | WindowSignal::Dropped { .. }
            | WindowSignal::Started { .. } => None,
            WindowSignal::U { at } => {
                if self.is_open() {
                    Some(at)
                } else {
                    self.kept = Some(self.kept.map_or(at, |k| k.max(at)));
                    None
                }
            }
        }
    }

    /// [`UntilWindow::apply`] for a response that keeps no causes (rclpy): the window is read from the stamps
    /// of R's `started` and `exited`.
    fn apply_by_stamps(&mut self, s: WindowSignal) -> Option<i64> {
        match s {
            WindowSignal::StartDelivered { at, .. } => {
                if self.running {
                    self.sent_while_running = Some(at);
                } else {
                    self.awaiting = true;
                }
                None
            }
            WindowSignal::Started { at } => {
                if at < self.last_response_signal {
                    return None;
                }
                self.last_response_signal = at;
                self.running = true;
                self.sent_while_running = None;
                // a run starts: it is this connection's if it awaited one; any other run closes the window
                // (its `exited` for the run before may still be on its way)
                self.open_since = self.awaiting.then_some(at);
                self.awaiting = false;
                let kept = self.kept.take();
                let since = self.open_since?;
                kept.filter(|&u| u >= since && u - since <= HOLD)
            }
            // (a response that keeps no causes announces no start it dropped)
            WindowSignal::Dropped { .. } => None,
            WindowSignal::Exited { at, .. } => {
                if at < self.last_response_signal {
                    return None;
                }
                self.last_response_signal = at;
                self.running = false;
                self.open_since = None;
                // R had already ended when the start was sent: it was idle, and took it
                if self
                    .sent_while_running
                    .take()
                    .is_some_and(|sent| at <= sent)
                {
                    self.awaiting = true;
                }
                None
            }
            WindowSignal::U { at } => match self.open_since {
                Some(since) if at >= since => Some(at),
                Some(_) => None,
                None => {
                    if self.awaiting || self.sent_while_running.is_some() {
                        self.kept = Some(self.kept.map_or(at, |k| k.max(at)));
                    }
                    None
                }
            },
        }
    }

    /// T2: the receiver's clock stepped back to `now`: remembered stamps later than it are brought back.
    pub(super) fn step_back(&mut self, now: i64) {
        for t in [
            &mut self.kept,
            &mut self.sent_while_running,
            &mut self.open_since,
        ]
        .into_iter()
        .flatten()
        {
            *t = (*t).min(now);
        }
        self.last_response_signal = self.last_response_signal.min(now);
    }

    /// R left the graph: its run (if any) ended without an `exited`, and a new R of that name did not take
    /// this connection's start.
    pub(super) fn response_lost(&mut self) -> bool {
        let was = self.is_open() || self.awaiting || self.running;
        *self = UntilWindow::new(self.causes);
        was
    }

    /// Whether no run of this statement may be going or still to come, as far as R's signals tell: C6, R's
    /// `exited` carried the latest start delivery; C7, R's `exited` closed the window that start opened, or
    /// showed that R was busy when the start came and dropped it.
    pub(super) fn settled(&self) -> bool {
        !self.is_open() && !self.awaiting && self.sent_while_running.is_none()
    }

    /// Whether U's signals reach R's `interrupt` now (C6: while a run of this statement may be going).
    pub fn is_open(&self) -> bool {
        if self.causes {
            !self.pending.is_empty()
        } else {
            self.open_since.is_some()
        }
    }
}
