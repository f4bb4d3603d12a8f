//! A connection's own code that panics: its filter, its map, its anonymous slot's call.
//!
//! Connection properties and anonymous slots are user code, like slots, and are treated like them (rule R7
//! treats a panicking slot as a slot that finished): the panic is caught where the closure runs, the signal it
//! was called for is not delivered (a filter or a map: C2, it does not use up a `once`) or its call is over (an
//! anonymous slot: the next signal gets the next call), and the connection stays as it was. The panic is
//! reported on the connection: the first one in an error line naming the statement, every one in its count
//! and the last one's message, which its entry in the manager's `connections` list shows
//! (`radar_msgs/msg/Connection` `panics`, `panic`) and [`ConnectionGuard::panics`](super::ConnectionGuard::panics)
//! reads. Nothing the manager holds is left half-changed by it: the manager's lock is never held poisoned.

use std::{
    panic::{catch_unwind, AssertUnwindSafe},
    sync::{
        atomic::{AtomicU64, Ordering},
        Mutex,
    },
};

use crate::node::endpoints::panic_message;

/// The panics caught in one connection's own code.
pub(crate) struct Faults {
    /// The statement, as a person reads it: `whenever /tick/triggered start /drive/start`.
    statement: String,
    count: AtomicU64,
    last: Mutex<String>,
}

impl Faults {
    pub(crate) fn new(statement: String) -> Faults {
        Faults {
            statement,
            count: AtomicU64::new(0),
            last: Mutex::new(String::new()),
        }
    }

    /// Runs `f`, the connection's `what` (`filter`, `map`, `call`); `None` if it panicked (caught, reported).
    pub(crate) fn run<R>(&self, what: &str, f: impl FnOnce() -> R) -> Option<R> {
        match catch_unwind(AssertUnwindSafe(f)) {
            Ok(r) => Some(r),
            Err(p) => {
                self.caught(what, &panic_message(p));
                None
            }
        }
    }

    fn caught(&self, what: &str, message: &str) {
        let n = self.count.fetch_add(1, Ordering::SeqCst) + 1;
        *self.last.lock().unwrap_or_else(|p| p.into_inner()) = format!("{what}: {message}");
        let outcome = if what == "call" {
            "that call is over, the next signal gets the next call"
        } else {
            "that signal is not delivered (a once is not used up)"
        };
        if n == 1 {
            tracing::error!(
                statement = %self.statement,
                "the connection's {what} panicked: {message}; {outcome}, and the connection stays armed \
                 (its panics are counted on its entry in the connections list)"
            );
        } else {
            tracing::debug!(statement = %self.statement, panics = n, "the connection's {what} panicked again: {message}");
        }
    }

    /// Panics caught so far.
    pub(crate) fn count(&self) -> u64 {
        self.count.load(Ordering::SeqCst)
    }

    /// The last one: which closure, and its message; empty if none.
    pub(crate) fn last(&self) -> String {
        self.last.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_is_caught_counted_and_its_message_kept() {
        let f = Faults::new("whenever /a start /b/start".into());
        assert_eq!(f.run("filter", || 3), Some(3));
        assert_eq!(f.count(), 0);
        assert_eq!(f.run("filter", || -> i32 { panic!("boom {}", 1) }), None);
        assert_eq!(f.run("map", || -> i32 { panic!("bang") }), None);
        assert_eq!((f.count(), f.last()), (2, "map: bang".to_owned()));
    }
}
