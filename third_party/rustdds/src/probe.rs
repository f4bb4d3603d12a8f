//! RADAR patch 21: a latency probe. Stamps the stages one sample goes through, from `DataWriter::write` to
//! the socket and from the socket to the application's take, so a benchmark can say where a hop's time goes.
//!
//! Off unless the process starts with `RUSTDDS_PROBE_TOPIC` set: then every sample of a DDS topic whose name
//! ends with its value is stamped (writer side in the writing process, reader side in the reading one), on
//! `CLOCK_MONOTONIC` in nanoseconds, which all processes of a Linux host share. Stamps are keyed by the
//! writer's sequence number; [`drain`] hands them over. While off, a stamp costs one relaxed atomic load.

use std::{
  cell::Cell,
  sync::{
    atomic::{AtomicU8, Ordering},
    Mutex, OnceLock,
  },
};

/// A stage of one sample's way through RustDDS.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Stage {
  /// Writing process: `DataWriter::write` was called (before serialization).
  Write = 0,
  /// Writing process: the sample is in the writer's buffer and the event loop has been woken.
  Admitted = 1,
  /// Writing process: the event loop's writer begins to send it.
  LoopSend = 2,
  /// Writing process: the datagram carrying it has been handed to the socket.
  SocketSent = 3,
  /// Reading process: the event loop woke for the datagram (its poll returned).
  LoopWoke = 4,
  /// Reading process: the datagram was read from the socket.
  SocketRead = 5,
  /// Reading process: the DATA submessage reached its reader (parsed).
  Parsed = 6,
  /// Reading process: the sample is in the topic cache.
  Cached = 7,
  /// Reading process: the data reader's waker was woken.
  Notified = 8,
  /// Reading process: the application took it from the data reader (deserialized).
  Taken = 9,
}

impl Stage {
  /// Every stage, in the order a sample passes them.
  pub const ALL: [Stage; 10] = [
    Stage::Write,
    Stage::Admitted,
    Stage::LoopSend,
    Stage::SocketSent,
    Stage::LoopWoke,
    Stage::SocketRead,
    Stage::Parsed,
    Stage::Cached,
    Stage::Notified,
    Stage::Taken,
  ];

  /// The stage's name, as benchmarks print it.
  pub fn name(self) -> &'static str {
    match self {
      Stage::Write => "write",
      Stage::Admitted => "admitted",
      Stage::LoopSend => "loop_send",
      Stage::SocketSent => "socket_sent",
      Stage::LoopWoke => "loop_woke",
      Stage::SocketRead => "socket_read",
      Stage::Parsed => "parsed",
      Stage::Cached => "cached",
      Stage::Notified => "notified",
      Stage::Taken => "taken",
    }
  }
}

/// One stamp: a stage of the sample with this writer sequence number, at `t_ns` on `CLOCK_MONOTONIC`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stamp {
  /// The stage.
  pub stage: Stage,
  /// The writer's sequence number of the sample.
  pub sn: i64,
  /// When, in nanoseconds on `CLOCK_MONOTONIC`.
  pub t_ns: u64,
}

/// At most this many stamps are kept until [`drain`] (the oldest are not dropped: new ones are).
const CAPACITY: usize = 1 << 20;

// 0: not looked at yet, 1: off, 2: on
static STATE: AtomicU8 = AtomicU8::new(0);
static TOPIC: OnceLock<Option<String>> = OnceLock::new();
static STAMPS: Mutex<Vec<Stamp>> = Mutex::new(Vec::new());

thread_local! {
  static LOOP_WOKE: Cell<u64> = const { Cell::new(0) };
  static SOCKET_READ: Cell<u64> = const { Cell::new(0) };
}

/// Whether the probe is on in this process (`RUSTDDS_PROBE_TOPIC` set and not empty).
#[inline]
pub fn on() -> bool {
  match STATE.load(Ordering::Relaxed) {
    1 => false,
    2 => true,
    _ => {
      let topic = TOPIC.get_or_init(|| {
        std::env::var("RUSTDDS_PROBE_TOPIC")
          .ok()
          .filter(|t| !t.is_empty())
      });
      let on = topic.is_some();
      STATE.store(if on { 2 } else { 1 }, Ordering::Relaxed);
      on
    }
  }
}

/// Whether samples of the DDS topic `name` are stamped.
#[inline]
pub fn wants(name: &str) -> bool {
  on() && TOPIC.get().and_then(Option::as_deref).is_some_and(|t| name.ends_with(t))
}

/// Nanoseconds on `CLOCK_MONOTONIC` (0 where there is no such clock).
pub fn now_ns() -> u64 {
  #[cfg(unix)]
  {
    let mut ts = libc::timespec {
      tv_sec: 0,
      tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes into the timespec we own; CLOCK_MONOTONIC exists on every unix.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
  }
  #[cfg(not(unix))]
  {
    0
  }
}

/// Stamps `stage` of sample `sn` at `t_ns`.
pub fn stamp_at(stage: Stage, sn: i64, t_ns: u64) {
  let mut s = STAMPS.lock().unwrap_or_else(|e| e.into_inner());
  if s.len() < CAPACITY {
    s.push(Stamp { stage, sn, t_ns });
  }
}

/// Stamps `stage` of sample `sn` now.
pub fn stamp(stage: Stage, sn: i64) {
  stamp_at(stage, sn, now_ns());
}

/// The event loop notes when its poll returned and when it read a datagram; the reader stamps them for the
/// samples the datagram carries (this thread's latest).
pub(crate) fn note_loop_woke() {
  if on() {
    LOOP_WOKE.with(|c| c.set(now_ns()));
  }
}

/// See [`note_loop_woke`].
pub(crate) fn note_socket_read() {
  if on() {
    SOCKET_READ.with(|c| c.set(now_ns()));
  }
}

/// A reader of a probed topic got sample `sn` from the datagram this thread read last.
pub(crate) fn stamp_arrival(sn: i64) {
  let (woke, read) = (LOOP_WOKE.with(Cell::get), SOCKET_READ.with(Cell::get));
  if woke != 0 {
    stamp_at(Stage::LoopWoke, sn, woke);
  }
  if read != 0 {
    stamp_at(Stage::SocketRead, sn, read);
  }
  stamp(Stage::Parsed, sn);
}

/// Takes every stamp recorded so far in this process.
pub fn drain() -> Vec<Stamp> {
  std::mem::take(&mut *STAMPS.lock().unwrap_or_else(|e| e.into_inner()))
}

#[cfg(test)]
mod tests {
  use super::*;

  #[test]
  fn stamps_are_kept_in_order_and_drained_once() {
    let before = now_ns();
    stamp(Stage::Write, 7);
    stamp_at(Stage::Taken, 7, before + 1);
    let got: Vec<Stamp> = drain().into_iter().filter(|s| s.sn == 7).collect();
    assert_eq!(got.len(), 2);
    assert_eq!(got[0].stage, Stage::Write);
    assert!(got[0].t_ns >= before);
    assert_eq!(got[1].t_ns, before + 1);
    assert!(drain().iter().all(|s| s.sn != 7));
  }

  #[test]
  fn stage_names_are_distinct() {
    let names: std::collections::BTreeSet<_> = Stage::ALL.iter().map(|s| s.name()).collect();
    assert_eq!(names.len(), Stage::ALL.len());
  }
}
