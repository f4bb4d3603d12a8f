//! RADAR patch 62: samples an application hands over itself between endpoints of one participant.
//!
//! An application that delivers what some of its writers write to some of its own readers without DDS (a
//! tap in the same process, taking each sample as it is written) still has those readers matched with those
//! writers: the match is what tells the writer it is listened to and the reader that its source is there.
//! Without this module each such sample is also sent to the participant's own socket, received, parsed,
//! cached and handed to the reader, which drops it: a wake-up of the event loop on each side for nothing.
//!
//! A writer marked with [`delivers_locally`] and a reader marked with [`takes_locally`], of the same
//! participant, are matched as before (the writer's `PublicationMatched` and the participant's
//! `RemoteReaderMatched` count the reader), but the writer keeps no reader proxy for it: it sends it no DATA,
//! no HEARTBEAT and no GAP, does not wait for its acknowledgement, and with only such readers matched it writes
//! as a writer with no reader (patch 61). What it writes does not reach that reader through DDS at all: the
//! application must deliver every sample of the writer to the reader from before the reader is created for as
//! long as it lives.
//!
//! Both marks are read when the writer matches the reader: a pair matched before either mark was set is
//! matched as any other pair (its samples go over DDS), which is what a mark set just after an endpoint's
//! creation, racing its discovery, may give; an endpoint made inside [`marking`] is marked before it can match
//! anything. A reader must be marked before a marked writer matches it, or its samples still come
//! over DDS (which the application then skips). Marks are forgotten when their endpoint is deleted, or with
//! their participant.

use std::{
  collections::HashSet,
  sync::{Mutex, OnceLock},
};

use crate::structure::guid::{GuidPrefix, GUID};

#[derive(Default)]
struct Marks {
  writers: HashSet<GUID>,
  readers: HashSet<GUID>,
}

fn marks() -> std::sync::MutexGuard<'static, Marks> {
  static MARKS: OnceLock<Mutex<Marks>> = OnceLock::new();
  MARKS
    .get_or_init(Default::default)
    .lock()
    .unwrap_or_else(|p| p.into_inner())
}

/// The application delivers what `writer` writes to this participant's readers marked with [`takes_locally`].
/// (Marked after the writer is made, it may already have matched some: see [`marking`].)
pub fn delivers_locally(writer: GUID) {
  marks().writers.insert(writer);
}

/// The application delivers to `reader` what this participant's writers marked with [`delivers_locally`]
/// write, for the reader's whole life. (Marked after the reader is made, it may already have matched some.)
pub fn takes_locally(reader: GUID) {
  marks().readers.insert(reader);
}

thread_local! {
  /// Whether endpoints made on this thread now are marked as they are made.
  static MARKING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f`, marking every writer it makes on this thread with [`delivers_locally`] and every reader with
/// [`takes_locally`] as it is made, before anything can match it.
pub fn marking<R>(f: impl FnOnce() -> R) -> R {
  struct Restore(bool);
  impl Drop for Restore {
    fn drop(&mut self) {
      MARKING.with(|m| m.set(self.0));
    }
  }
  let _restore = Restore(MARKING.with(|m| m.replace(true)));
  f()
}

/// An endpoint `guid` (a writer if `writer`) is being made, before it is announced or matched.
pub(crate) fn on_made(guid: GUID, writer: bool) {
  if MARKING.with(std::cell::Cell::get) {
    let mut m = marks();
    if writer {
      m.writers.insert(guid);
    } else {
      m.readers.insert(guid);
    }
  }
}

/// Whether `writer` sends nothing to `reader` (both marked, one participant).
pub(crate) fn skips(writer: GUID, reader: GUID) -> bool {
  if writer.prefix != reader.prefix {
    return false;
  }
  let m = marks();
  m.writers.contains(&writer) && m.readers.contains(&reader)
}

/// Forgets the marks of an endpoint deleted.
pub(crate) fn forget(guid: GUID) {
  let mut m = marks();
  m.writers.remove(&guid);
  m.readers.remove(&guid);
}

/// Forgets the marks of a participant's endpoints (its event loop ended).
pub(crate) fn forget_participant(prefix: GuidPrefix) {
  let mut m = marks();
  m.writers.retain(|g| g.prefix != prefix);
  m.readers.retain(|g| g.prefix != prefix);
}

#[cfg(test)]
mod tests {
  use super::*;
  use crate::structure::guid::{EntityId, EntityKind};

  fn guid(prefix: u8, key: u8, writer: bool) -> GUID {
    let kind = match writer {
      true => EntityKind::WRITER_NO_KEY_USER_DEFINED,
      false => EntityKind::READER_NO_KEY_USER_DEFINED,
    };
    GUID::new(GuidPrefix::new(&[prefix; 12]), EntityId::new([0, 0, key], kind))
  }

  #[test]
  fn endpoints_made_inside_marking_are_marked_on_this_thread_only_and_go_with_their_participant() {
    let (w, r) = (guid(0x51, 1, true), guid(0x51, 2, false));
    on_made(w, true);
    on_made(r, false);
    assert!(!skips(w, r), "made outside `marking`: not marked");
    let inner = marking(|| {
      on_made(w, true);
      // another thread making endpoints meanwhile is not marking
      let (w2, r2) = (guid(0x51, 3, true), guid(0x51, 4, false));
      std::thread::spawn(move || {
        on_made(w2, true);
        on_made(r2, false);
      })
      .join()
      .unwrap();
      assert!(!skips(w2, r2));
      marking(|| on_made(r, false));
      // the nested scope ended: still marking here
      on_made(guid(0x51, 5, false), false);
      7
    });
    assert_eq!(inner, 7);
    assert!(skips(w, r));
    assert!(skips(w, guid(0x51, 5, false)));
    on_made(guid(0x51, 6, false), false);
    assert!(!skips(w, guid(0x51, 6, false)), "the scope ended");
    // only within one participant
    takes_locally(guid(0x52, 2, false));
    assert!(!skips(w, guid(0x52, 2, false)));
    forget(r);
    assert!(!skips(w, r));
    takes_locally(r);
    forget_participant(GuidPrefix::new(&[0x51; 12]));
    assert!(!skips(w, r), "gone with the participant");
    forget_participant(GuidPrefix::new(&[0x52; 12]));
  }
}
