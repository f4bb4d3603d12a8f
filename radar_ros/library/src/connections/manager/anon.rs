//! The queue behind an anonymous slot: the payloads delivered to a closure that runs in its own task.

use std::sync::{
    atomic::{AtomicBool, Ordering},
    Mutex,
};

use crate::wire::raw::RawMessage;

thread_local! {
    /// This thread runs an anonymous slot's call now.
    static IN_CALL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// The payloads waiting for one anonymous slot: keep-last `depth`, like a ROS subscription's queue, so a
/// slow closure under a fast source costs bounded memory and sees the newest signals.
pub(crate) struct AnonQueue {
    source: String,
    depth: usize,
    queue: Mutex<std::collections::VecDeque<RawMessage>>,
    ready: tokio::sync::Notify,
    /// No more pushes: the consumer ends once the queue is empty.
    closed: AtomicBool,
    /// The guard dropped: the consumer ends before the next call.
    cancelled: AtomicBool,
    /// Held from the consumer's last look at `cancelled` to the end of the call it begins: a cancel waits for
    /// it, so that once the guard's drop has returned no call begins (C4).
    calling: Mutex<()>,
    dropped: std::sync::atomic::AtomicU64,
}

impl AnonQueue {
    pub(crate) fn new(source: String, depth: usize) -> AnonQueue {
        AnonQueue {
            source,
            depth,
            queue: Mutex::new(Default::default()),
            ready: tokio::sync::Notify::new(),
            closed: AtomicBool::new(false),
            cancelled: AtomicBool::new(false),
            calling: Mutex::new(()),
            dropped: Default::default(),
        }
    }

    pub(crate) fn push(&self, m: RawMessage) {
        let mut q = self.queue.lock().unwrap();
        if q.len() >= self.depth {
            q.pop_front();
            if self.dropped.fetch_add(1, Ordering::Relaxed) == 0 {
                tracing::warn!(
                    source = %self.source, depth = self.depth,
                    "an anonymous slot is slower than its source: the oldest queued signal was dropped \
                     (keep-last {}); give the connection a larger .depth(n) to keep more", self.depth
                );
            }
        }
        q.push_back(m);
        drop(q);
        self.ready.notify_one();
    }

    pub(crate) fn close(&self) {
        self.closed.store(true, Ordering::SeqCst);
        self.ready.notify_one();
    }

    /// No call begins after this returns: one that is going on (begun before) is waited for, unless this is
    /// called from within that call (a slot that drops its own statement's guard).
    pub(crate) fn cancel(&self) {
        self.cancelled.store(true, Ordering::SeqCst);
        self.close();
        if !IN_CALL.with(|c| c.get()) {
            drop(self.calling.lock().unwrap_or_else(|p| p.into_inner()));
        }
    }

    /// Calls `f` with `m` unless the queue was cancelled: whether it did.
    pub(crate) fn call(&self, m: RawMessage, f: impl FnOnce(RawMessage)) -> bool {
        let _calling = self.calling.lock().unwrap_or_else(|p| p.into_inner());
        if self.cancelled.load(Ordering::SeqCst) {
            return false;
        }
        IN_CALL.with(|c| c.set(true));
        f(m);
        IN_CALL.with(|c| c.set(false));
        true
    }

    /// The next payload to call the slot with; `None` when closed and drained, or cancelled.
    pub(crate) async fn next(&self) -> Option<RawMessage> {
        self.next_with(|| {}).await
    }

    /// [`AnonQueue::next`], calling `between` after each look at the queue that found it empty (a test puts a
    /// push and a close there).
    async fn next_with(&self, mut between: impl FnMut()) -> Option<RawMessage> {
        loop {
            if self.cancelled.load(Ordering::SeqCst) {
                return None;
            }
            // read `closed` before looking at the queue: every push comes before the close, so a queue seen
            // empty after a close was seen is drained. (Looked at the other way round, a push and a close
            // between the two looks lost the push: a fired `once` whose call never came, seen once in CI.)
            let closed = self.closed.load(Ordering::SeqCst);
            if let Some(m) = self.queue.lock().unwrap().pop_front() {
                return Some(m);
            }
            between();
            if closed {
                return None;
            }
            // a push between the check and here left a permit, so this returns at once
            self.ready.notified().await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(b: u8) -> RawMessage {
        RawMessage::from_bytes(vec![b])
    }

    #[tokio::test]
    async fn a_slow_slot_sees_the_newest_depth_payloads_then_the_queue_ends_when_closed() {
        let q = AnonQueue::new("/src".into(), 2);
        for b in 0..5 {
            q.push(m(b));
        }
        q.close();
        assert_eq!(q.next().await, Some(m(3)));
        assert_eq!(q.next().await, Some(m(4)));
        assert_eq!(q.next().await, None, "closed and drained");
    }

    /// A push and the close right after it (a `once` that fired) landing between the consumer's look at the
    /// queue and its look at `closed`: the payload is still given, not lost.
    #[tokio::test]
    async fn a_push_and_close_between_the_consumers_looks_is_not_lost() {
        let q = AnonQueue::new("/src".into(), 10);
        let mut once = true;
        let got = q
            .next_with(|| {
                if std::mem::take(&mut once) {
                    q.push(m(7));
                    q.close();
                }
            })
            .await;
        assert_eq!(
            got,
            Some(m(7)),
            "the payload pushed before the close was lost"
        );
        assert_eq!(q.next().await, None, "then closed and drained");
    }

    #[tokio::test]
    async fn a_cancelled_queue_begins_no_further_call() {
        let q = AnonQueue::new("/src".into(), 10);
        q.push(m(1));
        q.cancel();
        assert_eq!(q.next().await, None);
    }
}
