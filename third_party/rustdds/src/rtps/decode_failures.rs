//! How secured traffic that does not decode is reported (RADAR patch 48).
//!
//! A participant that takes the ports of one that just ended (a program restarted at once, or a tool run
//! twice in a row) is sent, for a while, what its peers still mean for its predecessor: until they hear the
//! predecessor's goodbye or its lease runs out, they encrypt for keys the newcomer does not have, and every
//! such message fails to decode (`ring`'s "Unspecified"). Each was an ERROR line, several a second for up to a
//! lease. Forged or damaged traffic looks the same, so it is still reported: once per source participant
//! every [`REPORT_EVERY`] as a warning, with how many more failed since; the rest at debug level.

use std::{
  collections::BTreeMap,
  time::{Duration, Instant},
};

use crate::structure::guid::GuidPrefix;

/// How often decode failures from one source are reported as a warning.
pub(crate) const REPORT_EVERY: Duration = Duration::from_secs(10);

/// Sources whose failures are counted at most.
const SOURCES_KEPT: usize = 256;

/// Decode failures per source participant, and when each was last reported.
#[derive(Default)]
pub(crate) struct DecodeFailures {
  by_source: BTreeMap<GuidPrefix, (Instant, u64)>,
}

impl DecodeFailures {
  /// One more failure from `source` at `now`: `Some(n)` if it is to be reported as a warning now (`n`: the
  /// failures from that source not reported since the last warning), `None` if only at debug level.
  pub(crate) fn note(&mut self, source: GuidPrefix, now: Instant) -> Option<u64> {
    if let Some((reported, since)) = self.by_source.get_mut(&source) {
      if now.duration_since(*reported) < REPORT_EVERY {
        *since += 1;
        return None;
      }
      let n = *since;
      *reported = now;
      *since = 0;
      return Some(n);
    }
    if self.by_source.len() >= SOURCES_KEPT {
      // many sources failing (an attack, or a crowd restarting): forget those reported longest ago
      self
        .by_source
        .retain(|_, (reported, _)| now.duration_since(*reported) < REPORT_EVERY);
      if self.by_source.len() >= SOURCES_KEPT {
        return None;
      }
    }
    self.by_source.insert(source, (now, 0));
    Some(0)
  }
}

/// Reports a secured message or submessage from `source` that did not decode (`what`, `error`).
pub(crate) fn report(
  failures: &mut DecodeFailures,
  source: GuidPrefix,
  what: &str,
  error: &dyn std::fmt::Debug,
) {
  match failures.note(source, Instant::now()) {
    Some(more) => log::warn!(
      "{what} from {source:?} did not decode: {error:?} ({more} more from it since the last report; traffic \
       meant for a participant that had this address before does not decode until its peers know it left)"
    ),
    None => log::debug!("{what} from {source:?} did not decode: {error:?}"),
  }
}

#[cfg(test)]
mod tests {
  use super::*;

  #[test]
  fn a_source_is_reported_once_per_period_with_how_many_were_not() {
    let mut f = DecodeFailures::default();
    let (a, b) = (GuidPrefix::new(&[1; 12]), GuidPrefix::new(&[2; 12]));
    let t0 = Instant::now();
    assert_eq!(f.note(a, t0), Some(0), "the first one is reported");
    for i in 1..=50 {
      assert_eq!(f.note(a, t0 + Duration::from_millis(100 * i)), None);
    }
    assert_eq!(f.note(b, t0), Some(0), "another source has its own period");
    assert_eq!(
      f.note(a, t0 + REPORT_EVERY),
      Some(50),
      "a period later: reported, with the ones in between counted"
    );
    assert_eq!(f.note(a, t0 + REPORT_EVERY + Duration::from_millis(1)), None);
  }

  #[test]
  fn many_sources_are_bounded() {
    let mut f = DecodeFailures::default();
    let t0 = Instant::now();
    let p = |i: usize| {
      let mut b = [0u8; 12];
      b[..8].copy_from_slice(&(i as u64).to_le_bytes());
      GuidPrefix::new(&b)
    };
    for i in 0..SOURCES_KEPT {
      assert_eq!(f.note(p(i), t0), Some(0));
    }
    assert_eq!(f.note(p(SOURCES_KEPT), t0), None, "full: not kept, at debug level");
    assert_eq!(f.by_source.len(), SOURCES_KEPT);
    // a period later the old ones are forgotten and a new source is reported again
    assert_eq!(f.note(p(SOURCES_KEPT), t0 + REPORT_EVERY), Some(0));
    assert_eq!(f.by_source.len(), 1);
  }
}
