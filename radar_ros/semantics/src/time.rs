//! Times from other clocks: what a receiver makes of a signal's source stamp (rule T1).
//!
//! The response rules R11-R13 and the connection rules C1, C3, C6 and C7 compare when signals were emitted, and
//! a signal says when it was emitted by its sender's clock (the DDS source timestamp). Hosts' clocks differ
//! (no NTP, a robot that booted in 1970, a laptop an hour ahead) and a host's own clock can step (an NTP
//! correction). Those comparisons are meant to put signals sent a few milliseconds apart in the order they were
//! sent; they must never let one host's clock decide for longer than that what another host's response does.
//!
//! - **T1.** A stamp is taken as it is while it lies within [`LATE`] before the receiver's clock and not after
//!   it; outside, it is taken as the nearest edge: a stamp from the future is read as *now* (it cannot have
//!   been sent later than it arrived), one older than `LATE` as `now - LATE`. A manager's relay first brings
//!   a sender's stamps back by that sender's [`Lead`] (how far ahead its recent stamps were), so that the
//!   signals of a sender whose clock is ahead keep their order and age, not all read as *now*. So a stamp never moves a
//!   machine past its own clock, and a peer whose clock is off by any amount can change a decision only about
//!   signals read within [`LATE`] of each other: a peer whose clock is *ahead* changes nothing (its signals
//!   are read as sent when they arrive); one whose clock is *behind* by more than `LATE` has its signals read
//!   as `LATE` old, so for `LATE` after a statement is armed (C1) or a run begins (R11) its signals are taken
//!   as sent before that. Peers within `LATE` of each other (NTP or PTP on a robot: far less) are ordered by
//!   their stamps, as the rules say.
//! - **T2.** When the receiver's own clock steps back, the times a machine remembers (when a run began or
//!   ended, when a connection was armed, the stamps in an `until` window) are moved back to the new clock, so
//!   that signals stamped by the stepped clock are not all taken as older than them.
//!
//! ```
//! use radar_semantics::time::{received, LATE};
//! let now = 1_000 * LATE;
//! assert_eq!(received(now - 5, now), now - 5); // a few ns ago: as sent
//! assert_eq!(received(now + 3_600_000_000_000, now), now); // an hour ahead: now
//! assert_eq!(received(now - 3_600_000_000_000, now), now - LATE); // an hour behind: LATE old
//! ```

/// How long an `interrupt` or `exit` that reached an idle response is kept for a start sent before it that
/// is still on its way (R12, `crate::response`), in ns: far above a DDS hop (well under a millisecond on a
/// host, a few on a network), below anything a person or a robot would call "at the same time".
pub const HOLD: i64 = 1_000_000_000;

/// How old a stamp may be, by the receiver's clock, and still be taken as it is (T1), in ns: twice
/// [`HOLD`], far above a DDS hop on a loaded host or a network (a few milliseconds),
/// well below what a person would notice of a robot.
pub const LATE: i64 = 2 * HOLD;

/// The time a signal stamped `stamp` by its sender is taken as sent, by a receiver whose clock reads `now`
/// (T1).
pub fn received(stamp: i64, now: i64) -> i64 {
    stamp.clamp(now.saturating_sub(LATE), now)
}

/// How far one sender's clock runs ahead of the receiver's, as its recent stamps show (rule T1): a stamp
/// from a sender that is ahead is brought back by that much before it is taken, so that its signals keep the
/// order and the age they had when sent. The lead is the largest amount by which one of the sender's last
/// [`Lead::KEPT`] stamps was ahead of the receiver's clock as it read it (the stamp of a signal that took
/// long to come is less ahead, and says nothing more); never below zero (a clock behind is T1's other case).
///
/// Without it a stamp from the future is read as *now*, so a signal a sender whose clock is ahead emitted
/// before a statement was armed, and that was read after, was taken as emitted after it (C1). The first
/// signal a receiver reads from such a sender still cannot be dated: it is read as sent when it arrives.
///
/// ```
/// use radar_semantics::time::{Lead, LATE};
/// let hour = 3_600_000_000_000;
/// let mut lead = Lead::default();
/// let now = 1_000 * LATE;
/// // a sender an hour ahead: its first signal, 1 us in transit, is read as sent now
/// assert_eq!(lead.date(now - 1_000 + hour, now), now);
/// // one it sent 5 ms before, read later, is dated 5 ms before that one, not now
/// assert_eq!(lead.date(now - 5_001_000 + hour, now + 10), now - 5_000_000);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Lead {
    recent: [i64; Lead::KEPT],
    seen: usize,
}

impl Lead {
    /// How many of a sender's latest stamps its lead is taken from.
    pub const KEPT: usize = 8;

    /// The sender's lead now: how much to take from its stamps.
    pub fn get(&self) -> i64 {
        self.recent[..self.seen.min(Self::KEPT)]
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .max(0)
    }

    /// A stamp of the sender, read at `now`: when the signal is taken as sent (T1), with this stamp counted in
    /// the lead.
    pub fn date(&mut self, stamp: i64, now: i64) -> i64 {
        self.recent[self.seen % Self::KEPT] = stamp.saturating_sub(now);
        self.seen += 1;
        received(stamp.saturating_sub(self.get()), now)
    }
}

/// A receiver's clock as the machines see it: it never runs ahead of the clock it is given, and when that
/// clock steps back it reports by how much, so remembered times can follow it (T2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Clock {
    now: i64,
}

impl Default for Clock {
    fn default() -> Self {
        Clock { now: i64::MIN }
    }
}

impl Clock {
    /// The latest time set.
    pub fn now(&self) -> i64 {
        self.now
    }

    /// Sets the clock to `now`. `Some(now)` when that is a step back (the remembered times later than `now`
    /// must be brought back to it, T2), `None` otherwise.
    pub fn set(&mut self, now: i64) -> Option<i64> {
        let back = now < self.now;
        self.now = now;
        back.then_some(now)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t1_stamps_within_late_are_kept_and_others_are_taken_as_the_nearest_edge() {
        let now = 10 * LATE;
        assert_eq!(received(now, now), now);
        assert_eq!(received(now - LATE, now), now - LATE);
        assert_eq!(received(now - LATE - 1, now), now - LATE);
        assert_eq!(received(now + 1, now), now);
        assert_eq!(received(i64::MAX, now), now);
        assert_eq!(received(i64::MIN, now), now - LATE);
        // a clock that has never been read does not overflow
        assert_eq!(received(5, i64::MIN), i64::MIN);
    }

    #[test]
    fn t1_a_senders_lead_dates_its_later_signals_by_when_they_were_sent() {
        let now = 10 * LATE;
        let ahead = 3_600_000_000_000;
        let mut l = Lead::default();
        assert_eq!(l.date(now + ahead, now), now, "the first: read as now");
        // a signal sent 1 ms before the next read, and one read 5 ms late: both dated by when they were sent
        assert_eq!(
            l.date(now + 9_000_000 + ahead, now + 10_000_000),
            now + 9_000_000
        );
        assert_eq!(
            l.date(now + 20_000_000 + ahead, now + 25_000_000),
            now + 20_000_000
        );
        // a sender in step (or behind) has no lead: its stamps are taken as T1 takes them
        let mut l = Lead::default();
        assert_eq!(l.date(now - 5, now), now - 5);
        assert_eq!(l.get(), 0);
        // only the latest few count: a sender whose clock was set back is soon read by its new lead
        let mut l = Lead::default();
        l.date(now + ahead, now);
        for i in 1..=Lead::KEPT as i64 {
            l.date(now + i, now + i);
        }
        assert_eq!(l.get(), 0);
    }

    #[test]
    fn t2_a_clock_reports_its_steps_back_only() {
        let mut c = Clock::default();
        assert_eq!(c.set(100), None);
        assert_eq!(c.set(150), None);
        assert_eq!(c.set(150), None);
        assert_eq!(c.set(90), Some(90));
        assert_eq!(c.now(), 90);
    }
}
