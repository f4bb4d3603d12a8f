//! The Rust side of Python components: a [`Response`] and an [`Event`] whose slots are Python coroutines
//! run on the slot loop ([`crate::slot_loop`]).

use std::sync::Arc;

use pyo3::{
    prelude::*,
    types::{PyBytes, PyCFunction, PyDict, PyTuple},
};
use radar_ros::{DynMessage, Event, ExitAction, ExitReason, Response, SlotError, StartPolicy};

use crate::slot_loop::{
    body, describe, ended_by, panic_with, run_slot, wait_begun, Ended, SlotLoop,
};

/// A response whose slots are the Python object `runner`'s coroutine methods `start(body: bytes) -> bytes`,
/// `interrupt() -> None` and `exit(reason: str) -> bool` (restart), as `radar_ros.Response` makes them.
pub(crate) struct PyResponse {
    pub(crate) runner: Arc<Py<PyAny>>,
    pub(crate) slots: SlotLoop,
    pub(crate) start_type: String,
    pub(crate) output_type: String,
    pub(crate) output_default: DynMessage,
    pub(crate) policy: StartPolicy,
}

impl Response for PyResponse {
    type Start = DynMessage;
    type Output = DynMessage;

    async fn start(&mut self, payload: DynMessage) -> Result<DynMessage, SlotError> {
        // R12 and "started never announces a behaviour that did not run": this first poll ends only once the
        // Python behaviour has begun (run up to its first await, or its thread started), as a Rust slot's
        // first poll runs it up to its first await; an interrupt right after cannot cancel it unrun
        let (begun_tx, begun) = std::sync::mpsc::sync_channel::<()>(2);
        let runner = self.runner.clone();
        let slots = self.slots.clone();
        let call = Python::attach(|py| {
            let tx = begun_tx.clone();
            let ack = PyCFunction::new_closure(
                py,
                None,
                None,
                move |_: &Bound<'_, PyTuple>, _: Option<&Bound<'_, PyDict>>| -> PyResult<()> {
                    let _ = tx.try_send(());
                    Ok(())
                },
            )?;
            let coro = runner
                .bind(py)
                .call_method1("start", (PyBytes::new(py, payload.0.as_bytes()), ack))?;
            slots.schedule_acked(py, coro, Some(begun_tx), |v| body(v, "start"))
        });
        if call.is_ok() {
            wait_begun(&begun);
        }
        let ended = match call {
            Ok(call) => call.result().await,
            Err(e) => Python::attach(|py| ended_by(py, &e)),
        };
        match ended {
            Ended::Value(v) => Ok(v),
            Ended::Failed(m) => Err(SlotError::msg(m)),
            Ended::Panicked(m) => panic_with(m),
        }
    }

    async fn interrupt(&mut self) {
        let runner = self.runner.clone();
        if let Ended::Failed(m) | Ended::Panicked(m) = run_slot(
            &self.slots,
            move |py| runner.bind(py).call_method0("interrupt"),
            |_| Ok(()),
        )
        .await
        {
            panic_with(m)
        }
    }

    async fn exit(&mut self, reason: ExitReason) -> ExitAction {
        let runner = self.runner.clone();
        let why = reason.describe();
        match run_slot(
            &self.slots,
            move |py| runner.bind(py).call_method1("exit", (why,)),
            |v| Ok(v.is_truthy().unwrap_or(false)),
        )
        .await
        {
            Ended::Value(true) => ExitAction::Restart,
            Ended::Value(false) => ExitAction::Done,
            Ended::Failed(m) | Ended::Panicked(m) => panic_with(m),
        }
    }

    fn start_type(&self) -> String {
        self.start_type.clone()
    }

    fn output_type(&self) -> String {
        self.output_type.clone()
    }

    fn start_policy(&self) -> StartPolicy {
        self.policy
    }

    fn incomplete_output(&self) -> Option<DynMessage> {
        Some(self.output_default.clone())
    }
}

/// An event whose check is the Python object `runner`'s coroutine method `check() -> bytes`, with
/// `activate()`/`deactivate()` called as the event becomes active and inactive.
pub(crate) struct PyEvent {
    pub(crate) runner: Arc<Py<PyAny>>,
    pub(crate) slots: SlotLoop,
    pub(crate) payload_type: String,
}

impl PyEvent {
    /// Calls a plain method on the slot loop, in order with the checks, without waiting.
    fn notify(&self, method: &'static str) {
        Python::attach(|py| {
            let cb = self.runner.bind(py).getattr(method);
            let r = cb.and_then(|cb| {
                self.slots
                    .event_loop
                    .bind(py)
                    .call_method1("call_soon_threadsafe", (cb,))
            });
            if let Err(e) = r {
                tracing::warn!(error = %describe(py, &e), "{method}: not called");
            }
        });
    }
}

impl Event for PyEvent {
    type Payload = DynMessage;

    async fn check(&mut self) -> Result<DynMessage, SlotError> {
        let runner = self.runner.clone();
        match run_slot(
            &self.slots,
            move |py| runner.bind(py).call_method0("check"),
            |v| body(v, "check"),
        )
        .await
        {
            Ended::Value(v) => Ok(v),
            Ended::Failed(m) => Err(SlotError::msg(m)),
            Ended::Panicked(m) => panic_with(m),
        }
    }

    fn on_activate(&mut self) {
        self.notify("activate");
    }

    fn on_deactivate(&mut self) {
        self.notify("deactivate");
    }

    fn payload_type(&self) -> String {
        self.payload_type.clone()
    }
}
