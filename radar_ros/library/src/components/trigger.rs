//! A check's own writer of its event's `triggered` ([`Trigger`]): the value of a check written from the thread
//! that saw the condition, without first waking the event's task.

use std::sync::{Arc, Mutex, PoisonError};

use crate::{node::endpoints::SignalWriter, wire::msg::RosMessage};

/// Where one check's trigger stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stand {
    /// Nothing emitted yet; the check runs.
    Open,
    /// Emitted, with this source time (nanoseconds since the epoch), not yet counted by the event.
    Emitted(i64),
    /// The check ended: nothing more goes out through this trigger.
    Closed,
}

/// The writer of an event's `triggered` for one check, handed to [`Event::before_check`](crate::Event::before_check).
///
/// An event whose condition is seen on a thread of its own (a driver's callback, an interpreter's loop) emits
/// through it from there, once, instead of resolving its check and waiting for the event's task to wake and
/// emit: the signal leaves one thread wake-up sooner. It is the same writer the event uses (the same source
/// time, this process's connections first, then the wire). A trigger goes out at most once per check, and never
/// after the check ended: after the event deactivated (its last listener left), stopped, or took the check's
/// own value.
///
/// ```
/// use radar_ros::{Event, SlotError, Trigger, msg::Int32};
/// /// Triggers with the number a sensor thread reports, sent from that thread.
/// struct Sensor { triggers: std::sync::mpsc::Sender<Trigger<Int32>>, done: tokio::sync::watch::Receiver<u64> }
/// impl Event for Sensor {
///     type Payload = Int32;
///     fn before_check(&mut self, trigger: Trigger<Int32>) {
///         // the sensor thread calls `trigger.emit(Int32 { data })` when the reading comes
///         let _ = self.triggers.send(trigger);
///     }
///     async fn check(&mut self) -> Result<Int32, SlotError> {
///         // ends once the thread emitted; the value is not emitted again
///         self.done.changed().await.map_err(|_| SlotError::msg("sensor gone"))?;
///         Ok(Int32::default())
///     }
/// }
/// ```
pub struct Trigger<P: RosMessage> {
    writer: Arc<SignalWriter<P>>,
    stand: Arc<Mutex<Stand>>,
}

impl<P: RosMessage> Trigger<P> {
    /// Emits `payload` on `triggered` now, from this thread, as the value of the running check. `Err` hands the
    /// payload back, unsent, when this check's trigger already went out or the check ended (the event
    /// deactivated or stopped): an event's listeners never get a trigger of a check that was dropped.
    pub fn emit(&self, payload: P) -> Result<(), P> {
        let mut stand = self.stand.lock().unwrap_or_else(PoisonError::into_inner);
        if *stand != Stand::Open {
            return Err(payload);
        }
        // under the lock: the event closing the check waits for a trigger being written to be out
        let at = self.writer.emit("triggered", payload, None);
        *stand = Stand::Emitted(at);
        Ok(())
    }

    /// Whether [`emit`](Self::emit) would send now (the check runs and nothing went out through it yet).
    pub fn is_open(&self) -> bool {
        *self.stand.lock().unwrap_or_else(PoisonError::into_inner) == Stand::Open
    }
}

impl<P: RosMessage> Clone for Trigger<P> {
    fn clone(&self) -> Self {
        Trigger {
            writer: Arc::clone(&self.writer),
            stand: Arc::clone(&self.stand),
        }
    }
}

impl<P: RosMessage> std::fmt::Debug for Trigger<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Trigger")
            .field(
                "stand",
                &*self.stand.lock().unwrap_or_else(PoisonError::into_inner),
            )
            .finish_non_exhaustive()
    }
}

/// The event's side of one check's [`Trigger`]: made with it, closed when the check ends.
pub(crate) struct CheckTrigger {
    stand: Arc<Mutex<Stand>>,
}

impl CheckTrigger {
    /// A trigger for a new check, writing through `writer`, and the event's side of it.
    pub(crate) fn open<P: RosMessage>(writer: &Arc<SignalWriter<P>>) -> (Trigger<P>, CheckTrigger) {
        let stand = Arc::new(Mutex::new(Stand::Open));
        let trigger = Trigger {
            writer: Arc::clone(writer),
            stand: Arc::clone(&stand),
        };
        (trigger, CheckTrigger { stand })
    }

    /// Ends the check's trigger: nothing goes out through it after this returns (a trigger being written is out
    /// first). The source time of what it emitted, if it did.
    pub(crate) fn close(&self) -> Option<i64> {
        let mut stand = self.stand.lock().unwrap_or_else(PoisonError::into_inner);
        match std::mem::replace(&mut *stand, Stand::Closed) {
            Stand::Emitted(at) => Some(at),
            Stand::Open | Stand::Closed => None,
        }
    }
}
