//! One slot of a response running: what it returns, and what it says before it ends (rules R9, R10).

use std::{future::Future, panic::AssertUnwindSafe, pin::Pin, sync::Arc};

use futures::FutureExt;
use tokio::sync::Mutex;

use radar_semantics::response::{ExitAction, ExitReason, Input, StartEnd};

use super::Response;
use crate::{error::Result, node::endpoints::panic_message};

pub(super) enum SlotDone<O> {
    Start(StartEnd<O>),
    Interrupt(Option<String>),
    Exit(Result<ExitAction, String>),
}

impl<O> SlotDone<O> {
    pub(super) fn into_input<P>(self) -> Input<P, O> {
        match self {
            SlotDone::Start(e) => Input::StartEnded(e),
            SlotDone::Interrupt(p) => Input::InterruptEnded(p),
            SlotDone::Exit(r) => Input::ExitEnded(r),
        }
    }
}

pub(super) type Slot<O> = Pin<Box<dyn Future<Output = SlotDone<O>> + Send>>;

/// What a running slot tells the response's driver before it ends (rules R9 and R10).
pub(super) enum SlotNote {
    /// The start behaviour has really begun: say `started` now (responses that announce on acceptance).
    Accepted,
    /// The run's output, handed over early (a `Box<R::Output>`).
    Output(Box<dyn std::any::Any + Send>),
}

tokio::task_local! {
    static SLOT_NOTES: tokio::sync::mpsc::UnboundedSender<SlotNote>;
}

/// Called from a start behaviour of a response spawned with `Announce::WhenAccepted`: `started` goes out now.
/// Does nothing outside a slot.
pub(crate) fn accepted() {
    let _ = SLOT_NOTES.try_with(|tx| tx.send(SlotNote::Accepted));
}

/// Called from any slot: `exited` will carry `output` unless the start behaviour returns another one.
/// `O` must be the response's output type (anything else is dropped). Does nothing outside a slot.
pub(crate) fn hand_over<O: Send + 'static>(output: O) {
    let _ = SLOT_NOTES.try_with(|tx| tx.send(SlotNote::Output(Box::new(output))));
}

/// Feeds a slot's note to the machine.
pub(super) fn note_input<P, O: 'static>(note: SlotNote) -> Option<Input<P, O>> {
    match note {
        SlotNote::Accepted => Some(Input::Accepted),
        SlotNote::Output(b) => match b.downcast::<O>() {
            Ok(o) => Some(Input::Output(*o)),
            Err(_) => {
                tracing::warn!("a slot handed over an output of another type; dropped");
                None
            }
        },
    }
}

/// Where a running slot's notes go.
pub(super) type NotesTx = tokio::sync::mpsc::UnboundedSender<SlotNote>;

/// The start slot running with `p`. It is called inside the unwind guard: a closure that panics before it
/// returns its future is a panicking start behaviour too (R7).
pub(super) fn start_slot<R: Response>(
    r: Arc<Mutex<R>>,
    p: R::Start,
    notes: &NotesTx,
) -> Slot<R::Output> {
    Box::pin(SLOT_NOTES.scope(notes.clone(), async move {
        let mut guard = r.lock_owned().await;
        let end = match AssertUnwindSafe(async { guard.start(p).await })
            .catch_unwind()
            .await
        {
            Ok(Ok(o)) => StartEnd::Returned(o),
            Ok(Err(e)) => StartEnd::Failed(e.into_message()),
            Err(panic) => StartEnd::Panicked(panic_message(panic)),
        };
        SlotDone::Start(end)
    }))
}

/// The interrupt slot running.
pub(super) fn interrupt_slot<R: Response>(r: Arc<Mutex<R>>, notes: &NotesTx) -> Slot<R::Output> {
    Box::pin(SLOT_NOTES.scope(notes.clone(), async move {
        let mut guard = r.lock_owned().await;
        let panic = AssertUnwindSafe(async { guard.interrupt().await })
            .catch_unwind()
            .await
            .err();
        SlotDone::Interrupt(panic.map(panic_message))
    }))
}

/// The exit slot running for `reason`.
pub(super) fn exit_slot<R: Response>(
    r: Arc<Mutex<R>>,
    reason: ExitReason,
    notes: &NotesTx,
) -> Slot<R::Output> {
    Box::pin(SLOT_NOTES.scope(notes.clone(), async move {
        let mut guard = r.lock_owned().await;
        let res = AssertUnwindSafe(async { guard.exit(reason).await })
            .catch_unwind()
            .await;
        SlotDone::Exit(res.map_err(panic_message))
    }))
}
