//! One pool of the raw endpoints a participant shares between connections and injections, with one rule for
//! when they go: when nothing holds them any more, a reader at once (so an event whose last listener left stops
//! checking), a writer after [`WRITER_LINGER`] (so what it just wrote is not lost). A writer asked for again
//! while it lingers is reused, without new discovery. Other objects whose last write must not be lost (a
//! response's signal writers at shutdown) are [`Pool::retire`]d under the same rule.
//!
//! The bookkeeping ([`Book`]) has no I/O and is unit-tested on its own; [`Pool`] keeps the endpoints it
//! decides about.

use std::{
    any::Any,
    collections::HashMap,
    hash::Hash,
    sync::{Arc, Mutex},
    time::{Duration, Instant},
};

use crate::{
    error::Result,
    node::topics::{RawPublisher, RawSubscription},
};

/// How long a writer whose last sample was just written is kept before it is deleted.
///
/// A RustDDS write only queues the sample for the participant's event loop; deleting the writer right after
/// (a `once` that just fired, an injection, a response's final `exited` at shutdown) can lose the sample
/// before it is sent, and a lost reliable sample is repaired only by the writer's next heartbeat (100 ms to
/// 1 s). Three seconds cover several repair rounds.
pub(crate) const WRITER_LINGER: Duration = Duration::from_secs(3);

/// What a pooled endpoint is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum Dir {
    /// Reads a topic (a relay's source).
    Reader,
    /// Writes a topic (a relay's target slot, an injection).
    Writer,
}

/// A pooled endpoint: one per topic, type, history depth and direction.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct Key {
    pub(crate) topic: String,
    pub(crate) ros_type: String,
    pub(crate) depth: usize,
    pub(crate) dir: Dir,
}

/// What [`Book::acquire`] found.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Acquired {
    /// Nothing held or lingering: create the endpoint.
    Create,
    /// Held already, or lingering and now held again: reuse it.
    Reuse,
}

/// What [`Book::release`] decided.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Released {
    /// Others still hold it.
    Held,
    /// Nobody holds it: keep it until this instant, then delete it.
    Lingering(Instant),
    /// Nobody holds it: delete it now.
    Gone,
}

/// Reference counts and linger deadlines of keys, with no I/O.
#[derive(Debug)]
pub(crate) struct Book<K> {
    holds: HashMap<K, usize>,
    lingering: HashMap<K, Instant>,
}

impl<K> Default for Book<K> {
    fn default() -> Self {
        Book {
            holds: HashMap::new(),
            lingering: HashMap::new(),
        }
    }
}

impl<K: Hash + Eq + Clone> Book<K> {
    /// One more holder of `k`.
    pub(crate) fn acquire(&mut self, k: &K) -> Acquired {
        let n = self.holds.entry(k.clone()).or_default();
        *n += 1;
        if *n > 1 || self.lingering.remove(k).is_some() {
            Acquired::Reuse
        } else {
            Acquired::Create
        }
    }

    /// One holder of `k` less; the last one leaves it lingering for `linger` from `now` (or gone, if zero).
    /// Releasing a key nobody holds is a no-op ([`Released::Held`] is not returned for it).
    pub(crate) fn release(&mut self, k: &K, now: Instant, linger: Duration) -> Released {
        match self.holds.get_mut(k) {
            Some(n) if *n > 1 => {
                *n -= 1;
                Released::Held
            }
            Some(_) => {
                self.holds.remove(k);
                if linger.is_zero() {
                    Released::Gone
                } else {
                    let until = now + linger;
                    self.lingering.insert(k.clone(), until);
                    Released::Lingering(until)
                }
            }
            None => Released::Gone,
        }
    }

    /// The lingering keys whose time is up at `now`, forgotten.
    pub(crate) fn expired(&mut self, now: Instant) -> Vec<K> {
        let done: Vec<K> = self
            .lingering
            .iter()
            .filter(|(_, until)| **until <= now)
            .map(|(k, _)| k.clone())
            .collect();
        for k in &done {
            self.lingering.remove(k);
        }
        done
    }

    /// When the next lingering key expires.
    pub(crate) fn next_expiry(&self) -> Option<Instant> {
        self.lingering.values().min().copied()
    }

    /// Holders of `k` now.
    #[cfg(test)]
    pub(crate) fn holders(&self, k: &K) -> usize {
        self.holds.get(k).copied().unwrap_or(0)
    }

    /// Keys held or lingering (what the pool keeps).
    #[cfg(test)]
    pub(crate) fn kept(&self) -> usize {
        self.holds.len() + self.lingering.len()
    }
}

/// A pooled endpoint.
#[derive(Clone)]
pub(crate) enum Endpoint {
    /// A raw reader.
    Reader(Arc<RawSubscription>),
    /// A raw writer.
    Writer(Arc<RawPublisher>),
}

/// Now, on tokio's clock (which tests can pause and advance) where there is one.
fn now() -> Instant {
    tokio::time::Instant::now().into_std()
}

#[derive(Default)]
struct Inner {
    book: Book<Key>,
    endpoints: HashMap<Key, Endpoint>,
    /// Objects kept until an instant, then dropped (see [`Pool::retire`]).
    retired: Vec<(Instant, Box<dyn Any + Send>)>,
}

/// The endpoints of one participant that connections and injections share.
#[derive(Default)]
pub(crate) struct Pool {
    inner: Mutex<Inner>,
    /// Wakes the sweeper when something starts lingering.
    wake: Arc<tokio::sync::Notify>,
}

impl Pool {
    /// Holds the endpoint for `key`, made with `create` if the pool has none.
    pub(crate) fn acquire(
        &self,
        key: &Key,
        create: impl FnOnce() -> Result<Endpoint>,
    ) -> Result<Endpoint> {
        let mut inner = self.inner.lock().unwrap();
        if inner.book.acquire(key) == Acquired::Reuse {
            if let Some(e) = inner.endpoints.get(key) {
                return Ok(e.clone());
            }
        }
        match create() {
            Ok(e) => {
                inner.endpoints.insert(key.clone(), e.clone());
                Ok(e)
            }
            Err(err) => {
                inner.book.release(key, now(), Duration::ZERO);
                Err(err)
            }
        }
    }

    /// A writer of `topic` for `key`, held (see [`Pool::acquire`]).
    pub(crate) fn writer(
        &self,
        key: &Key,
        create: impl FnOnce() -> Result<RawPublisher>,
    ) -> Result<Arc<RawPublisher>> {
        match self.acquire(key, || Ok(Endpoint::Writer(Arc::new(create()?))))? {
            Endpoint::Writer(w) => Ok(w),
            Endpoint::Reader(_) => unreachable!("a writer key maps to a writer"),
        }
    }

    /// A reader for `key`, held (see [`Pool::acquire`]).
    pub(crate) fn reader(
        &self,
        key: &Key,
        create: impl FnOnce() -> Result<RawSubscription>,
    ) -> Result<Arc<RawSubscription>> {
        match self.acquire(key, || Ok(Endpoint::Reader(Arc::new(create()?))))? {
            Endpoint::Reader(r) => Ok(r),
            Endpoint::Writer(_) => unreachable!("a reader key maps to a reader"),
        }
    }

    /// Gives up one hold on `key`. Returns whether the endpoint is gone (a reader with no holder left).
    pub(crate) fn release(&self, key: &Key) -> bool {
        let linger = match key.dir {
            Dir::Reader => Duration::ZERO,
            Dir::Writer => WRITER_LINGER,
        };
        let mut inner = self.inner.lock().unwrap();
        match inner.book.release(key, now(), linger) {
            Released::Held => false,
            Released::Lingering(_) => {
                drop(inner);
                self.wake.notify_one();
                false
            }
            Released::Gone => {
                let gone = inner.endpoints.remove(key);
                drop(inner);
                drop(gone); // outside the lock: deleting a DDS endpoint talks to its event loop
                true
            }
        }
    }

    /// Keeps `object` for [`WRITER_LINGER`], then drops it: for writers whose last sample must not be lost.
    pub(crate) fn retire(&self, object: Box<dyn Any + Send>) {
        let until = now() + WRITER_LINGER;
        self.inner.lock().unwrap().retired.push((until, object));
        self.wake.notify_one();
    }

    /// Drops what has lingered long enough; when to look again.
    fn sweep(&self) -> Option<Instant> {
        let now = now();
        let mut inner = self.inner.lock().unwrap();
        let expired = inner.book.expired(now);
        let mut dropped: Vec<Box<dyn Any + Send>> = Vec::new();
        for k in expired {
            if let Some(e) = inner.endpoints.remove(&k) {
                dropped.push(Box::new(e));
            }
        }
        let (due, keep): (Vec<_>, Vec<_>) = std::mem::take(&mut inner.retired)
            .into_iter()
            .partition(|(until, _)| *until <= now);
        inner.retired = keep;
        dropped.extend(due.into_iter().map(|(_, o)| o));
        let next = [
            inner.book.next_expiry(),
            inner.retired.iter().map(|(t, _)| *t).min(),
        ]
        .into_iter()
        .flatten()
        .min();
        drop(inner);
        drop(dropped); // outside the lock
        next
    }

    /// Runs until the pool is gone: deletes lingering endpoints and retired objects when their time is up.
    pub(crate) async fn sweeper(pool: std::sync::Weak<Pool>) {
        loop {
            let Some(p) = pool.upgrade() else { return };
            let wake = p.wake.clone();
            let woken = wake.notified();
            tokio::pin!(woken);
            // registered before sweeping: a linger that starts during the sweep wakes us
            woken.as_mut().enable();
            let next = p.sweep();
            drop(p);
            match next {
                Some(t) => {
                    tokio::select! {
                        _ = tokio::time::sleep_until(tokio::time::Instant::from_std(t)) => {}
                        _ = &mut woken => {}
                    }
                }
                None => {
                    // nothing lingers: wait to be told, but look again now and then (the pool may be gone)
                    let _ = tokio::time::timeout(Duration::from_secs(5), &mut woken).await;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const L: Duration = Duration::from_secs(3);

    #[test]
    fn the_first_holder_creates_the_others_reuse() {
        let mut b = Book::default();
        assert_eq!(b.acquire(&"w"), Acquired::Create);
        assert_eq!(b.acquire(&"w"), Acquired::Reuse);
        assert_eq!(b.holders(&"w"), 2);
        let t = Instant::now();
        assert_eq!(b.release(&"w", t, L), Released::Held);
        assert_eq!(b.release(&"w", t, L), Released::Lingering(t + L));
        assert_eq!(b.holders(&"w"), 0);
    }

    #[test]
    fn a_lingering_key_is_reused_if_asked_for_again_and_expires_otherwise() {
        let mut b = Book::default();
        let t = Instant::now();
        b.acquire(&"a");
        b.acquire(&"b");
        b.release(&"a", t, L);
        b.release(&"b", t, L);
        assert_eq!(b.next_expiry(), Some(t + L));
        assert_eq!(b.acquire(&"a"), Acquired::Reuse, "revived, no new endpoint");
        assert!(b.expired(t + L - Duration::from_millis(1)).is_empty());
        assert_eq!(b.expired(t + L), vec!["b"], "only b: a is held again");
        assert_eq!(b.kept(), 1);
        assert_eq!(b.next_expiry(), None);
    }

    #[test]
    fn without_linger_the_last_release_deletes_at_once() {
        let mut b = Book::default();
        b.acquire(&"r");
        assert_eq!(
            b.release(&"r", Instant::now(), Duration::ZERO),
            Released::Gone
        );
        assert_eq!(b.kept(), 0, "nothing is kept forever");
        assert_eq!(b.acquire(&"r"), Acquired::Create);
    }

    #[test]
    fn releasing_what_nobody_holds_changes_nothing() {
        let mut b = Book::<&str>::default();
        assert_eq!(b.release(&"x", Instant::now(), L), Released::Gone);
        assert_eq!(b.kept(), 0);
    }

    #[tokio::test(start_paused = true)]
    async fn retired_objects_are_dropped_after_the_linger_and_not_before() {
        let pool = Arc::new(Pool::default());
        tokio::spawn(Pool::sweeper(Arc::downgrade(&pool)));
        let flag = Arc::new(());
        pool.retire(Box::new(flag.clone()));
        tokio::time::sleep(WRITER_LINGER - Duration::from_millis(100)).await;
        assert_eq!(Arc::strong_count(&flag), 2, "still kept");
        tokio::time::sleep(Duration::from_millis(200)).await;
        tokio::task::yield_now().await;
        assert_eq!(Arc::strong_count(&flag), 1, "dropped after the linger");
    }
}
