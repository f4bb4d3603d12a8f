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

    /// Whether this endpoint was left without peers when an endpoint of process `participant` went (lately):
    /// its count has told that departure. Over Zenoh a token's deletion does not say whose it was: false.
    pub(crate) fn emptied_by(&self, participant: ros2_client::dds::rustdds::GUID) -> bool {
        match &self.source {
            Source::Dds { guid, graph } => graph.emptied_by(*guid, participant),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { .. } => false,
        }
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

/// What the tokens show of the peers of a Zenoh endpoint, now: the endpoints of the other kind on its topic
/// (session id, node id, entity id) and every session that has a token. What tells a peer that undeclared one
/// endpoint (its session still there: believed at once, as DDS believes an unmatch) from a session that
/// vanished (a crash, a lost link, a router restart: held for the lease).
#[cfg(feature = "zenoh")]
pub(crate) type Peers =
    std::sync::Arc<dyn Fn() -> (PeerSet, std::collections::BTreeSet<String>) + Send + Sync>;

/// Endpoints by (session id, node id, entity id).
#[cfg(feature = "zenoh")]
pub(crate) type PeerSet = std::collections::BTreeSet<(String, u64, u64)>;

/// [`Peers`] of an endpoint of `ctx` on `topic` whose peers are of kind `other`.
#[cfg(feature = "zenoh")]
pub(crate) fn peers_of(
    ctx: ros2_client::zenoh::Context,
    topic: &str,
    other: ros2_client::graph::EntityKind,
) -> Peers {
    let topic = topic.to_owned();
    std::sync::Arc::new(move || {
        let all = ctx.graph_entities();
        let on_topic = all
            .iter()
            .filter(|(_, e)| e.kind == other && e.topic_name.as_deref() == Some(topic.as_str()))
            .map(|(_, e)| (e.zid.clone(), e.node_id, e.entity_id))
            .collect();
        let sessions = all.into_iter().map(|(_, e)| e.zid).collect();
        (on_topic, sessions)
    })
}

/// How long after a fall the tokens are looked at to tell why (a session's tokens go in one burst).
#[cfg(feature = "zenoh")]
const SETTLE: std::time::Duration = std::time::Duration::from_millis(100);

/// `inner`, an endpoint over Zenoh, with its matched count from `counts` (its `watch_matched`: the count at once,
/// then each change), kept current by a task on the caller's tokio runtime that ends with the endpoint. A rise
/// is said at once. A fall is said at once when each peer that went undeclared its endpoint while its session
/// stays (an `until` let go, a connection dropped: as over DDS, and what lets an event stop checking as soon
/// as its last listener leaves, E1); otherwise once it has lasted `grace` (the lease): a router restart makes
/// every peer's tokens vanish and come back within a second, and a peer is not taken for gone for that (as
/// over DDS a peer silent for less than its lease is not).
#[cfg(feature = "zenoh")]
pub(crate) fn over_zenoh<T>(
    inner: T,
    counts: async_channel::Receiver<usize>,
    malformed: std::sync::Arc<crate::wire::malformed::Malformed>,
    grace: std::time::Duration,
    peers: Peers,
) -> Result<Watched<T>> {
    let runtime = tokio::runtime::Handle::try_current().map_err(|_| Error::Config {
        setting: "tokio runtime",
        value: "none".into(),
        reason: "make Zenoh endpoints inside a tokio runtime (#[tokio::main], or Runtime::enter): each keeps \
                 its matched count current from a task"
            .into(),
    })?;
    let (tx, matched) = tokio::sync::watch::channel(counts.try_recv().unwrap_or(0));
    let bridge = runtime
        .spawn(held_falls(counts, tx, grace, Some(peers)))
        .abort_handle();
    Ok(Watched {
        inner,
        matching: Matching {
            source: Source::Zenoh { malformed, bridge },
            matched,
        },
    })
}

/// Sends each count of `counts` on `tx`: a rise at once; a fall at once when `peers` shows, [`SETTLE`] after
/// it, that every peer gone undeclared its endpoint while its session stayed, else once it has lasted `grace`
/// (a fall undone within it is never sent). Ends when either side closes.
#[cfg(feature = "zenoh")]
async fn held_falls(
    counts: async_channel::Receiver<usize>,
    tx: tokio::sync::watch::Sender<usize>,
    grace: std::time::Duration,
    peers: Option<Peers>,
) {
    let mut shown = *tx.borrow();
    // the peers when the count was last said
    let mut known = peers.as_ref().map(|p| p().0).unwrap_or_default();
    // a fall not said yet: the count now, when it is said, and when the tokens are looked at
    let mut held: Option<(usize, tokio::time::Instant)> = None;
    let mut look: Option<tokio::time::Instant> = None;
    loop {
        let wake = match (held, look) {
            (Some((_, due)), Some(l)) => Some(due.min(l)),
            (Some((_, due)), None) => Some(due),
            (None, _) => None,
        };
        let next = match wake {
            Some(at) => match tokio::time::timeout_at(at, counts.recv()).await {
                Ok(next) => next.ok(),
                Err(_) => {
                    let (n, due) = held.expect("held");
                    let now = tokio::time::Instant::now();
                    let said = if now >= due {
                        true
                    } else {
                        // the look: who went, and whether their sessions are still there
                        look = None;
                        let (on_topic, sessions) = peers.as_ref().map(|p| p()).unwrap_or_default();
                        let mut gone = known.difference(&on_topic).peekable();
                        gone.peek().is_some() && gone.all(|(zid, _, _)| sessions.contains(zid))
                    };
                    if said {
                        held = None;
                        look = None;
                        shown = n;
                        known = peers.as_ref().map(|p| p().0).unwrap_or_default();
                        if tx.send(n).is_err() {
                            return;
                        }
                    }
                    continue;
                }
            },
            None => counts.recv().await.ok(),
        };
        let Some(n) = next else { return };
        if n >= shown {
            held = None;
            look = None;
            known = peers.as_ref().map(|p| p().0).unwrap_or_default();
            if n != shown {
                shown = n;
                if tx.send(n).is_err() {
                    return;
                }
            }
        } else {
            let now = tokio::time::Instant::now();
            let due = held.map_or(now + grace, |(_, due)| due);
            held = Some((n, due));
            if peers.is_some() {
                look = Some(now + SETTLE);
            }
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

    /// A peer that undeclares its endpoint while its session stays is believed at once (E1: an event stops
    /// checking when its last listener lets go); a session that vanishes is believed after the grace, and one
    /// back within it (a router restart) never.
    #[tokio::test(start_paused = true)]
    async fn a_fall_is_said_at_once_when_the_peers_session_stays_and_after_the_grace_when_it_went()
    {
        use std::sync::{Arc, Mutex};
        let grace = Duration::from_secs(3);
        type Shown = (PeerSet, std::collections::BTreeSet<String>);
        let tokens: Arc<Mutex<Shown>> = Arc::default();
        let set = |t: &Arc<Mutex<Shown>>, eps: &[(&str, u64)], sessions: &[&str]| {
            *t.lock().unwrap() = (
                eps.iter().map(|(z, e)| (z.to_string(), 0, *e)).collect(),
                sessions.iter().map(|z| z.to_string()).collect(),
            );
        };
        set(&tokens, &[("a", 1)], &["a", "me"]);
        let seen = tokens.clone();
        let peers: Peers = Arc::new(move || seen.lock().unwrap().clone());
        let (counts_tx, counts) = async_channel::unbounded();
        let (tx, mut rx) = tokio::sync::watch::channel(1);
        tokio::spawn(held_falls(counts, tx, grace, Some(peers)));
        tokio::task::yield_now().await;
        // a's endpoint undeclared, a's session still there: said at the look
        let t0 = tokio::time::Instant::now();
        set(&tokens, &[], &["a", "me"]);
        counts_tx.send(0).await.unwrap();
        rx.changed().await.unwrap();
        assert_eq!((*rx.borrow_and_update(), t0.elapsed()), (0, SETTLE));
        // b comes; then b's whole session goes (a crash, a lost link): said after the grace
        set(&tokens, &[("b", 7)], &["a", "b", "me"]);
        counts_tx.send(1).await.unwrap();
        rx.changed().await.unwrap();
        assert_eq!(*rx.borrow_and_update(), 1);
        let t0 = tokio::time::Instant::now();
        set(&tokens, &[], &["a", "me"]);
        counts_tx.send(0).await.unwrap();
        rx.changed().await.unwrap();
        assert_eq!((*rx.borrow_and_update(), t0.elapsed()), (0, grace));
        // c comes; every session's tokens vanish and come back within the grace (a router restart): not said
        set(&tokens, &[("c", 2)], &["a", "c", "me"]);
        counts_tx.send(1).await.unwrap();
        rx.changed().await.unwrap();
        assert_eq!(*rx.borrow_and_update(), 1);
        set(&tokens, &[], &["me"]);
        counts_tx.send(0).await.unwrap();
        tokio::time::sleep(Duration::from_secs(1)).await;
        set(&tokens, &[("c", 2)], &["a", "c", "me"]);
        counts_tx.send(1).await.unwrap();
        tokio::time::sleep(Duration::from_secs(5)).await;
        assert!(!rx.has_changed().unwrap(), "nothing said: {}", *rx.borrow());
    }

    #[tokio::test(start_paused = true)]
    async fn a_fall_is_said_once_it_has_lasted_the_grace_and_a_rise_at_once() {
        let grace = Duration::from_secs(3);
        let (counts_tx, counts) = async_channel::unbounded();
        let (tx, mut rx) = tokio::sync::watch::channel(1);
        tokio::spawn(held_falls(counts, tx, grace, None));
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
