//! Causes and source times on the wire (response rules R11-R13, connection rule C6).
//!
//! A slot signal says when the signal that caused it was emitted and which statement sent it, so a response
//! can order its `start`, `interrupt` and `exit` topics by cause rather than by arrival. On DDS both ride in
//! standard fields every vendor passes along: the time is the sample's **source timestamp** (a relay writes
//! the original signal's time, not its own), and the statement is the sample's **related sample identity**
//! (inline QoS, as ROS 2 services use it; topic subscribers that do not look at it, rclpy's among them, are not
//! affected). Over Zenoh both ride in the sample's attachment: the time in rmw_zenoh's source-timestamp field, the
//! statement's identity after its three fields (ros2-client patch 19; rmw_zenoh's readers do not look past them).
//! In this process the same two travel beside the message ([`crate::wire::local`]).
//!
//! A statement's identity is 16 bytes: 8 from its manager's participant ([`statement_base`]), 7 from the
//! connection's number (statements are numbered below 2^56), and a last byte that marks it as a RADAR
//! statement, so that a related identity some other program sets for its own reasons is never taken for one.

use radar_semantics::response::{Cause, Sent};
use ros2_client::{
    dds::rustdds::{
        SampleIdentity, SequenceNumber, Timestamp, WriteOptions, WriteOptionsBuilder, GUID,
    },
    MessageInfo, ROSTime,
};

/// The last byte of a statement's identity.
const MARK: u8 = 0x7a;

/// The high 64 bits of this participant's statement ids: its GUID prefix folded (FNV-1a), unique on a graph
/// in practice.
pub(crate) fn statement_base(participant: GUID) -> u64 {
    participant.to_bytes()[..12]
        .iter()
        .fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
            (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
        })
}

/// The related sample identity that carries `cause`.
pub(crate) fn identity(cause: Cause) -> SampleIdentity {
    // base (8 bytes), the connection's number (7 bytes), the mark
    let base = cause.statement & !u128::from(u64::MAX);
    let raw = base | u128::from((cause.statement as u64) << 8);
    let mut bytes = raw.to_be_bytes();
    bytes[15] = MARK;
    SampleIdentity {
        writer_guid: GUID::from_bytes(bytes),
        sequence_number: SequenceNumber::from(cause.delivery as i64),
    }
}

/// The cause a related sample identity carries, if it is one of ours.
pub(crate) fn from_identity(id: SampleIdentity) -> Option<Cause> {
    let mut bytes = id.writer_guid.to_bytes();
    if bytes[15] != MARK {
        return None;
    }
    bytes[15] = 0;
    // the connection's number is in bytes 8..15: shift it back down
    let raw = u128::from_be_bytes(bytes);
    let statement = (raw & !u128::from(u64::MAX)) | ((raw as u64) >> 8) as u128;
    Some(Cause {
        statement,
        delivery: i64::from(id.sequence_number).max(0) as u64,
    })
}

/// What a received sample says of its sending, read at `now` by this host's clock: its source time (`now` if
/// it has none) taken as rule T1 says (never later than `now`, at most `LATE` before it: another host's clock
/// cannot move ours), and its cause.
pub(crate) fn sent(info: &MessageInfo, now: i64) -> Sent {
    Sent {
        at: info
            .source_timestamp()
            .map(|t| t.to_nanos())
            .filter(|t| *t > 0)
            .unwrap_or(now),
        by: info
            .related_request_id()
            .and_then(|r| from_identity(r.into())),
    }
    .received(now)
}

/// The source time a sample written with time `ns` carries, as its readers read it back (DDS times are
/// seconds and 2^-32 fractions: a few nanoseconds are rounded away).
pub(crate) fn on_wire(ns: i64) -> i64 {
    let t: Timestamp = ROSTime::from_nanos(ns).into();
    ROSTime::try_from(t).map_or(ns, |r| r.to_nanos())
}

/// The write options that send a sample as `sent` says.
pub(crate) fn write_options(sent: Sent) -> WriteOptions {
    let at: Timestamp = ROSTime::from_nanos(sent.at).into();
    let b = WriteOptionsBuilder::new().source_timestamp(at);
    match sent.by {
        Some(c) => b.related_sample_identity(identity(c)),
        None => b,
    }
    .build()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cause_survives_the_wire_and_other_identities_are_not_causes() {
        let base = statement_base(GUID::new_participant_guid());
        for id in [1u64, 2, 1 << 40, (1 << 56) - 1] {
            let c = Cause {
                statement: (u128::from(base) << 64) | u128::from(id),
                delivery: 7,
            };
            assert_eq!(from_identity(identity(c)), Some(c), "connection {id}");
        }
        // a service request's identity, say
        let other = SampleIdentity {
            writer_guid: GUID::new_participant_guid(),
            sequence_number: SequenceNumber::from(3_i64),
        };
        assert!(from_identity(other).is_none());
        assert_ne!(
            statement_base(GUID::new_participant_guid()),
            statement_base(GUID::new_participant_guid()),
            "participants have their own statement ids"
        );
    }
}
