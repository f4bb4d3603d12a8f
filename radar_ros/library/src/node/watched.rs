//! An endpoint with its live match count, whichever transport it is on ([`Watched`], [`Matching`]): what
//! every wait for peers, departure and type filter above reads.

use futures::{Stream, StreamExt};
use ros2_client::{MessageInfo, Name};

use crate::{
    error::{Error, Result},
    graph::Graph,
    node::transport::Subscription,
};

/// A ROS endpoint with its live match count (peers of the same type only): from the participant's [`Graph`]
/// over DDS, from the liveliness tokens over Zenoh. Dropping it removes it from the graph.
pub(crate) struct Watched<T> {
    // before `inner`: fields drop in order, and the graph forgets the endpoint before the endpoint goes (as
    // before the matching had a type of its own), so its own departure is not taken for a peer's
    matching: Matching,
    inner: T,
}

/// What an endpoint is matched with, whichever transport it is on: the live count and where it comes from.
pub(crate) struct Matching {
    source: Source,
    /// Matched peers now and as they change.
    pub(crate) matched: tokio::sync::watch::Receiver<usize>,
}

enum Source {
    /// The endpoint's GUID in the participant's graph (RustDDS's match events).
    Dds {
        guid: ros2_client::dds::rustdds::GUID,
        graph: Graph,
    },
    /// Over Zenoh the count comes from the liveliness tokens (ros2-client's `watch_matched`, bridged by a task
    /// that ends with the endpoint); samples that do not decode are counted here.
    #[cfg(feature = "zenoh")]
    Zenoh {
        malformed: std::sync::Arc<crate::wire::malformed::Malformed>,
        bridge: tokio::task::AbortHandle,
    },
}

impl Matching {
    /// Waits until at least `n` peers of the same type are matched, and over DDS those in this participant
    /// have matched this endpoint back (see `Graph::reciprocated`), so that nothing sent from now on is lost.
    /// (Over Zenoh a subscription's interest is declared before its token, on the same link: a sample sent
    /// once the token is counted arrives, `tests/zenoh_matched.rs`.)
    #[allow(irrefutable_let_patterns)] // without the zenoh feature, DDS is the only source
    pub(crate) async fn wait_matched(
        &self,
        n: usize,
        timeout: std::time::Duration,
        what: impl Fn() -> String,
    ) -> Result<()> {
        let deadline = tokio::time::Instant::now() + timeout;
        let mut rx = self.matched.clone();
        match tokio::time::timeout_at(deadline, rx.wait_for(|c| *c >= n)).await {
            Ok(Ok(_)) => {}
            Ok(Err(_)) => return Err(Error::Closed(what())),
            Err(_) => {
                return Err(Error::Timeout {
                    what: what(),
                    after: timeout,
                })
            }
        }
        if let Source::Dds { guid, graph } = &self.source {
            while !graph.reciprocated(*guid) {
                if tokio::time::Instant::now() >= deadline {
                    return Err(Error::Timeout {
                        what: format!("{} (matched on this side only)", what()),
                        after: timeout,
                    });
                }
                tokio::time::sleep(std::time::Duration::from_millis(1)).await;
            }
        }
        Ok(())
    }

    /// Why the last peer that went went, if one did (over Zenoh a token's deletion does not say: none).
    pub(crate) fn last_loss(&self) -> Option<crate::departure::LossCause> {
        match &self.source {
            Source::Dds { guid, graph } => graph.last_loss(*guid),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { .. } => None,
        }
    }

    /// Who an event's `triggered` (this endpoint, a publisher) has as listeners: over DDS its matched readers
    /// that do not only observe (`graph/observers.rs`), over Zenoh every matched subscription (an observer there
    /// declares no token, so it is not matched).
    pub(crate) fn listeners(&self) -> tokio::sync::watch::Receiver<usize> {
        match &self.source {
            Source::Dds { guid, graph } => graph.watch_listeners(*guid),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { .. } => self.matched.clone(),
        }
    }

    /// The number of peers matched now.
    pub(crate) fn matched_now(&self) -> usize {
        *self.matched.borrow()
    }

    /// Whether a sample from this writer should be used (false for peers of another type). Over Zenoh a
    /// subscription hears its type only (the key carries the type and, when known, its hash: ros2-client
    /// patch 16): every sample is used.
    pub(crate) fn accepts(&self, info: &MessageInfo) -> bool {
        match &self.source {
            Source::Dds { guid, graph } => graph.accepts(*guid, info.publisher_gid()),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { .. } => true,
        }
    }

    /// The first sample `take` gives (one taken from the subscription's queue without waiting, each call)
    /// that comes from a peer of the subscription's type; `None` once the queue is empty or the transport fails.
    pub(crate) fn first_accepted<M>(
        &self,
        mut take: impl FnMut() -> ros2_client::ReadResult<Option<(M, MessageInfo)>>,
    ) -> Option<M> {
        loop {
            match take() {
                Ok(Some((m, info))) if self.accepts(&info) => return Some(m),
                Ok(Some(_)) => continue,
                Err(_) | Ok(None) => return None,
            }
        }
    }

    /// Where samples that do not decode are counted.
    fn malformed(&self) -> &crate::wire::malformed::Malformed {
        match &self.source {
            Source::Dds { graph, .. } => graph.malformed(),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { malformed, .. } => malformed,
        }
    }

    /// The samples of `stream` (a stream of this endpoint's subscription) that come from peers of the
    /// subscription's type, in arrival order. RustDDS matches endpoints whatever their types, so samples of a
    /// peer of another type are dropped here (the graph warned when it matched); samples that do not decode
    /// are dropped and counted (a warning names the expected type, once per topic). Nothing stops the stream
    /// but the subscription ending.
    pub(crate) fn accepted<'a, T: 'a>(
        &'a self,
        stream: impl Stream<Item = ros2_client::ReadResult<(T, MessageInfo)>> + 'a,
        topic: &'a str,
        expected: &'a str,
    ) -> impl Stream<Item = (T, MessageInfo)> + 'a {
        stream.filter_map(move |r| async move {
            match r {
                Ok((m, info)) if self.accepts(&info) => Some((m, info)),
                Ok(_) => None,
                Err(e) => {
                    // the transport does not say who sent it
                    self.malformed().note(topic, expected, None, &e);
                    None
                }
            }
        })
    }
}

impl<T> Watched<T> {
    /// Its matching: the live count, waiting on it, why the last peer left.
    pub(crate) fn matching(&self) -> &Matching {
        &self.matching
    }
}

impl<M: 'static + serde::de::DeserializeOwned> Watched<Subscription<M>> {
    /// A sample that has already arrived from a peer of the right type, without waiting.
    pub(crate) fn take_accepted(&self) -> Option<M> {
        self.matching.first_accepted(|| self.take())
    }
}

impl Watched<Subscription<crate::wire::raw::RawMessage>> {
    /// The samples of peers of the subscription's type, decoded as `M`, in arrival order: `Some` message, or
    /// `None` for one that did not decode. Those are dropped, counted per publisher and logged once per
    /// publisher (the participant's [`Malformed`](crate::wire::malformed::Malformed) registry).
    pub(crate) fn decoded<'a, M: crate::wire::msg::RosMessage>(
        &'a self,
        topic: &'a str,
        expected: &'a str,
    ) -> impl Stream<Item = Option<(M, MessageInfo)>> + 'a {
        self.matching
            .accepted(self.bodies(), topic, expected)
            .map(move |(raw, info)| match raw.decode::<M>() {
                Ok(m) => Some((m, info)),
                Err(e) => {
                    let who = format!("{:?}", info.publisher_gid());
                    self.matching
                        .malformed()
                        .note(topic, expected, Some(&who), &e);
                    None
                }
            })
    }
}

impl<T> std::ops::Deref for Watched<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.inner
    }
}

impl Drop for Matching {
    fn drop(&mut self) {
        match &self.source {
            Source::Dds { guid, graph } => graph.forget(*guid),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { bridge, .. } => bridge.abort(),
        }
    }
}

/// `inner`, an endpoint over Zenoh, with its matched count from `counts` (its `watch_matched`: the count at once,
/// then each change), kept current by a task on the caller's tokio runtime that ends with the endpoint. A rise
/// is said at once; a fall only once it has lasted `grace` (the lease): a router restart makes every peer's
/// tokens vanish and come back within a second, and a peer is not taken for gone for that (as over DDS a
/// peer silent for less than its lease is not).
#[cfg(feature = "zenoh")]
pub(crate) fn over_zenoh<T>(
    inner: T,
    counts: async_channel::Receiver<usize>,
    malformed: std::sync::Arc<crate::wire::malformed::Malformed>,
    grace: std::time::Duration,
) -> Result<Watched<T>> {
    let runtime = tokio::runtime::Handle::try_current().map_err(|_| Error::Config {
        setting: "tokio runtime",
        value: "none".into(),
        reason: "make Zenoh endpoints inside a tokio runtime (#[tokio::main], or Runtime::enter): each keeps \
                 its matched count current from a task"
            .into(),
    })?;
    let (tx, matched) = tokio::sync::watch::channel(counts.try_recv().unwrap_or(0));
    let bridge = runtime.spawn(held_falls(counts, tx, grace)).abort_handle();
    Ok(Watched {
        inner,
        matching: Matching {
            source: Source::Zenoh { malformed, bridge },
            matched,
        },
    })
}

/// Sends each count of `counts` on `tx`: a rise at once, a fall once it has lasted `grace` (a fall undone within
/// it is never sent). Ends when either side closes.
#[cfg(feature = "zenoh")]
async fn held_falls(
    counts: async_channel::Receiver<usize>,
    tx: tokio::sync::watch::Sender<usize>,
    grace: std::time::Duration,
) {
    let mut shown = *tx.borrow();
    // a fall not said yet: the count now, and when it is said
    let mut held: Option<(usize, tokio::time::Instant)> = None;
    loop {
        let next = match held {
            Some((_, due)) => match tokio::time::timeout_at(due, counts.recv()).await {
                Ok(next) => next.ok(),
                Err(_) => {
                    let (n, _) = held.take().expect("held");
                    shown = n;
                    if tx.send(n).is_err() {
                        return;
                    }
                    continue;
                }
            },
            None => counts.recv().await.ok(),
        };
        let Some(n) = next else { return };
        if n >= shown {
            held = None;
            if n != shown {
                shown = n;
                if tx.send(n).is_err() {
                    return;
                }
            }
        } else {
            let due = held.map_or_else(|| tokio::time::Instant::now() + grace, |(_, due)| due);
            held = Some((n, due));
        }
    }
}

/// `inner`, an endpoint over DDS whose GUID is `guid` in `graph`, with its matched count `matched` from the
/// graph (`Graph::watch_writer` or `watch_reader`).
pub(crate) fn over_dds<T>(
    inner: T,
    guid: ros2_client::dds::rustdds::GUID,
    graph: &Graph,
    matched: tokio::sync::watch::Receiver<usize>,
) -> Watched<T> {
    Watched {
        inner,
        matching: Matching {
            source: Source::Dds {
                guid,
                graph: graph.clone(),
            },
            matched,
        },
    }
}

/// `topic` as a ROS name, or an error saying why it is not one.
pub(crate) fn topic_name(topic: &str) -> Result<Name> {
    Name::parse(topic).map_err(|e| Error::InvalidName {
        name: topic.to_owned(),
        reason: format!("{e}"),
    })
}

#[cfg(all(test, feature = "zenoh"))]
mod tests {
    use super::*;
    use std::time::Duration;

    #[tokio::test(start_paused = true)]
    async fn a_fall_is_said_once_it_has_lasted_the_grace_and_a_rise_at_once() {
        let grace = Duration::from_secs(3);
        let (counts_tx, counts) = async_channel::unbounded();
        let (tx, mut rx) = tokio::sync::watch::channel(1);
        tokio::spawn(held_falls(counts, tx, grace));
        // a fall undone within the grace (a router restart) is never said
        counts_tx.send(0).await.unwrap();
        tokio::time::sleep(Duration::from_secs(2)).await;
        counts_tx.send(1).await.unwrap();
        tokio::time::sleep(Duration::from_secs(5)).await;
        assert!(!rx.has_changed().unwrap(), "nothing said: {}", *rx.borrow());
        // a rise at once
        counts_tx.send(2).await.unwrap();
        rx.changed().await.unwrap();
        assert_eq!(*rx.borrow_and_update(), 2);
        // a fall that lasts: said after the grace, counted from its first step
        let t0 = tokio::time::Instant::now();
        counts_tx.send(1).await.unwrap();
        tokio::time::sleep(Duration::from_secs(1)).await;
        counts_tx.send(0).await.unwrap();
        rx.changed().await.unwrap();
        assert_eq!((*rx.borrow_and_update(), t0.elapsed()), (0, grace));
    }
}
