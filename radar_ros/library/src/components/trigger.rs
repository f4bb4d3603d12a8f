//! A check's own writer of its event's `triggered` ([`Trigger`]): the value of a check written from the thread
//! that saw the condition, without first waking the event's task.

use std::sync::{
    atomic::{AtomicBool, Ordering},
    Arc, Mutex, PoisonError,
};

use crate::{node::endpoints::SignalWriter, wire::msg::RosMessage};

/// Where one check's own trigger stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Nothing emitted yet as the check's own value; the check runs.
    Open,
    /// Emitted, with this source time (nanoseconds since the epoch), not yet counted by the event.
    Emitted(i64),
    /// The check ended: nothing more goes out through this trigger.
    Closed,
}

/// One check's trigger: its own phase, and what [`Trigger::emit_and_continue`] emitted that the event has not
/// counted yet.
#[derive(Debug)]
struct Stand {
    phase: Phase,
    /// Triggers emitted by `emit_and_continue` and not yet counted, and the last one's source time.
    continued: u64,
    last: i64,
}

/// Wakes an event's task to count the triggers of [`Trigger::emit_and_continue`]: once, then not again until
/// the task has published what it counted (its `state` is throttled anyway), so a fast emitter does not wake
/// the task per trigger.
#[derive(Debug)]
pub(crate) struct Nudge {
    notify: tokio::sync::Notify,
    armed: AtomicBool,
}

impl Nudge {
    /// A nudge for one event, armed.
    pub(crate) fn new() -> Arc<Nudge> {
        Arc::new(Nudge {
            notify: tokio::sync::Notify::new(),
            armed: AtomicBool::new(true),
        })
    }

    fn poke(&self) {
        if self.armed.swap(false, Ordering::AcqRel) {
            self.notify.notify_one();
        }
    }

    /// Resolves when a trigger was emitted and continued since the nudge was last armed.
    pub(crate) async fn poked(&self) {
        self.notify.notified().await
    }

    /// Arms the nudge again; call it before counting, so that a trigger counted late still pokes.
    pub(crate) fn rearm(&self) {
        self.armed.store(true, Ordering::Release);
    }
}

/// What a check's trigger had emitted when the check ended ([`CheckTrigger::close`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Emitted {
    /// The check's own value, emitted through the trigger, with its source time.
    pub(crate) own: Option<i64>,
    /// Triggers emitted and continued that were not counted yet, and the last one's source time.
    pub(crate) continued: Option<(u64, i64)>,
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
    nudge: Arc<Nudge>,
}

impl<P: RosMessage> Trigger<P> {
    /// Emits `payload` on `triggered` now, from this thread, as the value of the running check. `Err` hands the
    /// payload back, unsent, when this check's trigger already went out or the check ended (the event
    /// deactivated or stopped): an event's listeners never get a trigger of a check that was dropped.
    pub fn emit(&self, payload: P) -> Result<(), P> {
        let mut stand = self.stand.lock().unwrap_or_else(PoisonError::into_inner);
        if stand.phase != Phase::Open {
            return Err(payload);
        }
        // under the lock: the event closing the check waits for a trigger being written to be out
        let at = self.writer.emit("triggered", payload, None);
        stand.phase = Phase::Emitted(at);
        Ok(())
    }

    /// Emits `payload` on `triggered` now, from this thread, as the value of the running check, and begins the
    /// next check at once, here: the check's future keeps running as the next one's, and this trigger stays
    /// open for it. For an event whose condition is seen on a thread of its own again and again (a driver's
    /// callback, a pacing loop): the event's task is not woken per trigger, only to count them in `state`
    /// (published at most every 100 ms for triggers anyway). `Err` hands the payload back, unsent, once the
    /// check ended (the event deactivated or stopped, or the check resolved) or took its value through
    /// [`emit`](Self::emit): then the next check's trigger comes through [`Event::before_check`](crate::Event::before_check).
    ///
    /// ```
    /// use radar_ros::{Event, SlotError, Trigger, msg::Int32};
    /// /// Triggers with every reading a sensor thread reports above 100, emitted from that thread.
    /// struct Sensor { triggers: std::sync::mpsc::Sender<Trigger<Int32>> }
    /// impl Event for Sensor {
    ///     type Payload = Int32;
    ///     fn before_check(&mut self, trigger: Trigger<Int32>) {
    ///         // the thread keeps this trigger and calls `trigger.emit_and_continue(Int32 { data })` for each
    ///         // reading; on `Err` it waits for the next trigger (the event was deactivated meanwhile)
    ///         let _ = self.triggers.send(trigger);
    ///     }
    ///     async fn check(&mut self) -> Result<Int32, SlotError> {
    ///         // the thread emits; this check never resolves by itself
    ///         std::future::pending().await
    ///     }
    /// }
    /// ```
    pub fn emit_and_continue(&self, payload: P) -> Result<(), P> {
        let mut stand = self.stand.lock().unwrap_or_else(PoisonError::into_inner);
        if stand.phase != Phase::Open {
            return Err(payload);
        }
        let at = self.writer.emit("triggered", payload, None);
        stand.continued += 1;
        stand.last = at;
        drop(stand);
        self.nudge.poke();
        Ok(())
    }

    /// Whether [`emit`](Self::emit) would send now (the check runs and nothing went out through it yet).
    pub fn is_open(&self) -> bool {
        self.stand
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .phase
            == Phase::Open
    }
}

impl<P: RosMessage> Clone for Trigger<P> {
    fn clone(&self) -> Self {
        Trigger {
            writer: Arc::clone(&self.writer),
            stand: Arc::clone(&self.stand),
            nudge: Arc::clone(&self.nudge),
        }
    }
}

impl<P: RosMessage> std::fmt::Debug for Trigger<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Trigger")
            .field(
                "stand",
                &self
                    .stand
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .phase,
            )
            .finish_non_exhaustive()
    }
}

/// The event's side of one check's [`Trigger`]: made with it, closed when the check ends.
pub(crate) struct CheckTrigger {
    stand: Arc<Mutex<Stand>>,
}

impl CheckTrigger {
    /// A trigger for a new check, writing through `writer` and poking `nudge` when it continues, and the
    /// event's side of it.
    pub(crate) fn open<P: RosMessage>(
        writer: &Arc<SignalWriter<P>>,
        nudge: &Arc<Nudge>,
    ) -> (Trigger<P>, CheckTrigger) {
        let stand = Arc::new(Mutex::new(Stand {
            phase: Phase::Open,
            continued: 0,
            last: 0,
        }));
        let trigger = Trigger {
            writer: Arc::clone(writer),
            stand: Arc::clone(&stand),
            nudge: Arc::clone(nudge),
        };
        (trigger, CheckTrigger { stand })
    }

    /// Ends the check's trigger: nothing goes out through it after this returns (a trigger being written is out
    /// first). What it emitted and the event has not counted.
    pub(crate) fn close(&self) -> Emitted {
        let mut stand = self.stand.lock().unwrap_or_else(PoisonError::into_inner);
        let own = match std::mem::replace(&mut stand.phase, Phase::Closed) {
            Phase::Emitted(at) => Some(at),
            Phase::Open | Phase::Closed => None,
        };
        Emitted {
            own,
            continued: take_continued(&mut stand),
        }
    }

    /// The triggers emitted and continued since the last call (how many, and the last one's source time).
    pub(crate) fn take_continued(&self) -> Option<(u64, i64)> {
        take_continued(&mut self.stand.lock().unwrap_or_else(PoisonError::into_inner))
    }
}

fn take_continued(stand: &mut Stand) -> Option<(u64, i64)> {
    let n = std::mem::take(&mut stand.continued);
    (n > 0).then_some((n, stand.last))
}
