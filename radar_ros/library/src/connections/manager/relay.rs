//! How the table's sources are reached: a relay per source (its reader's task feeds the table through
//! `Manager::dispatch`; with local delivery it also takes this process's emitters from their tap), and the watch
//! on its writers (rule C5). The slots the table writes are reached through outlets (`outlet.rs`).

use std::sync::Arc;

use futures::StreamExt;
use radar_semantics::response::Sent;

use super::{presence::Presence, End, Manager};
use crate::{
    node::pool::Key,
    node::topics::RawSubscription,
    wire::local::{Buffered, Emitted, Listener},
    wire::raw::RawMessage,
};

/// A source the table reads: the task that feeds its reader's signals to the table (stopped on drop), and
/// its listening to this process's emitters of the source (ends on drop).
pub(super) struct Relay {
    /// Its reader (also held by the task): whose departure its count has told (`instances.rs`).
    pub(super) sub: Arc<RawSubscription>,
    _stop: tokio::sync::oneshot::Sender<()>,
    _tap: Option<crate::wire::local::TapListener>,
}

impl Manager {
    /// A relay for `k`, whose reader `sub` is held once more for it; its task feeds the table, and tells it
    /// when the source's publishers have all gone (and when one is back). With local delivery it takes what
    /// this process's components emit on `k` from their tap, and skips their samples on DDS (those writers
    /// send its reader nothing, RustDDS patch 62, unless matched before they were marked); `kept` is what the
    /// tap gave the statement that makes the relay while it armed, from before the reader was made: returned
    /// with the relay, what of it the relay will not get itself, for the table once the statement is in it.
    pub(super) fn relay(
        self: &Arc<Self>,
        k: &Key,
        sub: Arc<RawSubscription>,
        kept: Option<Buffered>,
    ) -> (Relay, Vec<Emitted>) {
        let (stop, mut stop_rx) = tokio::sync::oneshot::channel();
        let me = Arc::downgrade(self);
        let source = k.clone();
        let end = End::Source(k.clone());
        let mut presence = Presence::new(vec![sub.matched_watch()]);
        let tap = self
            .local
            .then(|| self.participant.taps().get(&k.topic, &k.ros_type));
        let to_table: Listener = {
            let (me, source) = (me.clone(), source.clone());
            let here = self.participant.guid();
            Arc::new(move |raw: &RawMessage, at, by| {
                if let Some(m) = me.upgrade() {
                    m.dispatch(&source, raw.clone(), Sent { at, by }, here, 0);
                }
            })
        };
        let token = tap.as_ref().map(|t| t.listen(to_table.clone()));
        // this process's signals from `kept`'s start come by the tap, up to the relay's own start through `kept`
        let since = match (&kept, &token) {
            (Some(b), Some(_)) => Some(b.since()),
            (_, t) => t.as_ref().map(|t| t.since()),
        };
        let replay = match (kept, &token) {
            (Some(b), Some(t)) => b.before(t.since(), to_table),
            _ => Vec::new(),
        };
        let held = sub.clone();
        tokio::spawn(async move {
            let mut samples = std::pin::pin!(sub.stream_from());
            loop {
                tokio::select! {
                    biased;
                    _ = &mut stop_rx => break,
                    r = samples.next() => match (r, me.upgrade()) {
                        // already taken from the tap (unless emitted before the relay listened to it)
                        (Some((_, _, gid, stamp)), Some(_))
                            if since.is_some_and(|s| stamp >= s)
                                && tap.as_ref().is_some_and(|t| t.is_local(gid)) => {}
                        (Some((raw, sent, gid, stamp)), Some(m)) => m.dispatch(
                            &source,
                            raw,
                            sent,
                            crate::node::transport::EndpointId::from(gid),
                            stamp,
                        ),
                        _ => break,
                    },
                    change = presence.next() => match (change, me.upgrade()) {
                        (Some(c), Some(m)) => m.peers_changed(&end, c, || sub.departure()),
                        _ => break,
                    },
                }
            }
        });
        (
            Relay {
                sub: held,
                _stop: stop,
                _tap: token,
            },
            replay,
        )
    }
}
