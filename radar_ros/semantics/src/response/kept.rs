//! The slot signals a response keeps for a run that has not begun (R12, R14): an interrupt or exit that
//! reached it idle, or an `until`'s interrupt whose statement's start is still on its way. What is kept,
//! for how long ([`HOLD`]), and which run takes it.

use std::collections::VecDeque;

use super::{Cause, Sent, HOLD};

/// How many kept signals an idle response remembers (R12).
const KEPT: usize = 8;

/// A slot signal kept for a run that has not begun (R12, R14).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Kept {
    /// An interrupt, counted as ignored until a run takes it.
    Interrupt(Sent),
    /// An exit signal, counted as ignored until a run takes it.
    Exit(Sent),
    /// An `until`'s interrupt that already counted otherwise (it interrupted the run before, or waits with a
    /// queued start: R14).
    Bound(Sent),
}

impl Kept {
    pub(super) fn sent(&self) -> Sent {
        match self {
            Kept::Interrupt(s) | Kept::Exit(s) | Kept::Bound(s) => *s,
        }
    }

    pub(super) fn sent_mut(&mut self) -> &mut Sent {
        match self {
            Kept::Interrupt(s) | Kept::Exit(s) | Kept::Bound(s) => s,
        }
    }
}

/// The signals kept while idle (R12), oldest first, at most [`KEPT`].
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub(super) struct KeptSignals {
    kept: VecDeque<Kept>,
}

impl KeptSignals {
    /// Keeps `k`, dropping what is older than [`HOLD`] at `now` and the oldest when full.
    pub(super) fn keep(&mut self, k: Kept, now: i64) {
        let horizon = now.saturating_sub(HOLD);
        self.kept.retain(|k| k.sent().at >= horizon);
        if self.kept.len() == KEPT {
            self.kept.pop_front();
        }
        self.kept.push_back(k);
    }

    /// Forgets everything kept.
    pub(super) fn clear(&mut self) {
        self.kept.clear();
    }

    /// R12: the kept signal a run takes, begun at `began` by a start sent as `s` (caused by `cause`): the
    /// earliest sent after the start (within [`HOLD`]) that is for that run. Kept signals sent before the
    /// start are of no use any more and go, except an `until`'s interrupt of another statement: its
    /// statement's start may still be on its way (R14).
    pub(super) fn take_for_run(
        &mut self,
        s: Sent,
        cause: Option<Cause>,
        began: i64,
    ) -> Option<Kept> {
        let pos = self.kept.iter().position(|k| {
            let k_at = k.sent().at;
            let for_run = match k {
                // R14: an until's interrupt sent after its statement's start, whenever the run began
                Kept::Interrupt(Sent { by: Some(by), .. })
                | Kept::Bound(Sent { by: Some(by), .. }) => {
                    cause.map(|c| c.statement) == Some(by.statement)
                }
                _ => k_at >= began,
            };
            k_at > s.at && k_at - s.at <= HOLD && for_run
        });
        let taken = pos.and_then(|i| self.kept.remove(i));
        let statement = cause.map(|c| c.statement);
        self.kept.retain(|k| {
            let another = matches!(k, Kept::Interrupt(_) | Kept::Bound(_))
                && k.sent()
                    .by
                    .is_some_and(|by| Some(by.statement) != statement);
            k.sent().at > s.at || another
        });
        taken
    }

    /// R14: the `until`'s interrupt of the statement of the start `s` that is being queued, sent after it
    /// (within [`HOLD`]) and kept while the start was on its way: taken to go with that start.
    pub(super) fn take_until_of(&mut self, s: Sent) -> Option<Kept> {
        let by = s.by?;
        let i = self.kept.iter().position(|k| {
            let k_s = k.sent();
            matches!(k, Kept::Interrupt(_) | Kept::Bound(_))
                && k_s.by.map(|c| c.statement) == Some(by.statement)
                && k_s.at > s.at
                && k_s.at - s.at <= HOLD
        })?;
        self.kept.remove(i)
    }

    /// T2: the clock stepped back to `now`: kept times later than `now` come back to it.
    pub(super) fn step_back(&mut self, now: i64) {
        for k in self.kept.iter_mut() {
            let s = k.sent_mut();
            s.at = s.at.min(now);
        }
    }
}
