//! What the table tells the binding: what to deliver and by which way, each connection's link and listing.

use super::{ConnId, Kind};
use crate::response::Sent;

/// Whether a connection can deliver now (rule 5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Link {
    /// Source and target are there: signals are delivered.
    #[default]
    Armed,
    /// Every publisher of the source left; what a source of that name emits when one comes back is delivered.
    WaitingForSource,
    /// The target left and the connection re-arms: it delivers again when a target of that name comes back.
    WaitingForTarget,
    /// The target left: nothing more is delivered through this connection.
    TargetLost,
}

impl Link {
    /// A short lower-case label: `armed`, `waiting for source`, `waiting for target`, `target lost`.
    pub fn label(self) -> &'static str {
        match self {
            Link::Armed => "armed",
            Link::WaitingForSource => "waiting for source",
            Link::WaitingForTarget => "waiting for target",
            Link::TargetLost => "target lost",
        }
    }
}

/// What the runtime must deliver.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Delivery<T> {
    /// Through which connection.
    pub id: ConnId,
    /// To which slot.
    pub target: T,
    /// What it is: the connection's signal, or its `until`'s interrupt.
    pub via: Via,
}

/// What a [`Delivery`] carries, for the runtime to tag it (C6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Via {
    /// The connection's source signal, its delivery number `n` (from 1): a start slot gets the cause
    /// `(statement, n)`.
    Signal {
        /// The delivery's number.
        n: u64,
    },
    /// A signal of the connection's `until`, emitted at `at`, to R's `interrupt`: it names the statement and
    /// carries that time (a kept signal of U is sent later than it was read: C7).
    Until {
        /// When the signal of U was emitted.
        at: i64,
    },
}

/// One live connection, as listed by [`ConnectionTable::list`](super::ConnectionTable::list).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ConnInfo<S, T> {
    /// Its id.
    pub id: ConnId,
    /// Source signal.
    pub source: S,
    /// Target slot.
    pub target: T,
    /// Once or whenever.
    pub kind: Kind,
    /// Signals delivered so far through the main source.
    pub delivered: u64,
    /// The until source, if any.
    pub until: Option<S>,
    /// Whether it can deliver now.
    pub link: Link,
    /// The signals it delivers are those emitted from this time on (C1).
    pub armed_at: i64,
}

/// A slot signal the runtime must send (or a payload to hand to an anonymous slot), tagged as it goes on the
/// wire.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Send<T> {
    /// Through which connection.
    pub id: ConnId,
    /// To which slot.
    pub target: T,
    /// The stamp and cause it carries (C6).
    pub sent: Sent,
    /// What it is: the connection's signal, or its `until`'s interrupt.
    pub via: Via,
}

/// Everything one signal read by the table comes to (see
/// [`ConnectionTable::signal`](super::ConnectionTable::signal)).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Outcome<S, T> {
    /// What to send, in connection order.
    pub sends: Vec<Send<T>>,
    /// The connections this signal ended (a `once` that fired, or whose run ended: C2, C3).
    pub ended: Vec<ConnId>,
    /// The sources and targets no connection needs any more: the readers and writers to let go.
    pub released: (Vec<S>, Vec<T>),
}
