//! The Rust side of Python components: a [`Response`] and an [`Event`] whose slots are Python coroutines
//! run on the slot loop ([`crate::slot_loop`]).

use std::sync::Arc;

use pyo3::{
    prelude::*,
    types::{PyBytes, PyCFunction, PyDict, PyTuple},
};
use radar_ros::{
    topics::DynMessage, Event, ExitAction, ExitReason, Response, SlotError, StartPolicy, Trigger,
};

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
    /// `Response.inline`: the slots are the runner's plain `start_inline`, `interrupt_inline` and
    /// `exit_inline`, called here, in the engine's task (as rclpy calls a callback on the thread that took the
    /// message), instead of coroutines handed to the slot loop.
    pub(crate) inline: bool,
}

impl PyResponse {
    /// Calls the runner's plain method `method` with `args` in this thread, holding the GIL; its value read by
    /// `value`.
    fn call_inline<T>(
        &self,
        method: &str,
        args: impl for<'py> FnOnce(Python<'py>) -> PyResult<Bound<'py, PyTuple>>,
        value: impl FnOnce(&Bound<'_, PyAny>) -> Result<T, String>,
    ) -> Ended<T> {
        Python::attach(|py| {
            match args(py).and_then(|a| self.runner.bind(py).call_method1(method, a)) {
                Ok(v) => match value(&v) {
                    Ok(v) => Ended::Value(v),
                    Err(m) => Ended::Failed(m),
                },
                Err(e) => ended_by(py, &e),
            }
        })
    }
}

impl Response for PyResponse {
    type Start = DynMessage;
    type Output = DynMessage;

    async fn start(&mut self, payload: DynMessage) -> Result<DynMessage, SlotError> {
        if self.inline {
            // run to its end in this first poll: `started` is on the wire already (R1), and nothing can
            // interrupt it before it returns (an rclpy callback's contract)
            let ended = self.call_inline(
                "start_inline",
                |py| PyTuple::new(py, [PyBytes::new(py, payload.0.as_bytes())]),
                |v| body(v, "start"),
            );
            return match ended {
                Ended::Value(v) => Ok(v),
                Ended::Failed(m) => Err(SlotError::msg(m)),
                Ended::Panicked(m) => panic_with(m),
            };
        }
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
        let ended = if self.inline {
            self.call_inline("interrupt_inline", |py| Ok(PyTuple::empty(py)), |_| Ok(()))
        } else {
            let runner = self.runner.clone();
            run_slot(
                &self.slots,
                move |py| runner.bind(py).call_method0("interrupt"),
                |_| Ok(()),
            )
            .await
        };
        if let Ended::Failed(m) | Ended::Panicked(m) = ended {
            panic_with(m)
        }
    }

    async fn exit(&mut self, reason: ExitReason) -> ExitAction {
        let why = reason.describe();
        let restart = |v: &Bound<'_, PyAny>| Ok(v.is_truthy().unwrap_or(false));
        let ended = if self.inline {
            self.call_inline("exit_inline", |py| PyTuple::new(py, [why]), restart)
        } else {
            let runner = self.runner.clone();
            run_slot(
                &self.slots,
                move |py| runner.bind(py).call_method1("exit", (why,)),
                restart,
            )
            .await
        };
        match ended {
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
    /// The running check's writer of `triggered`: its value is emitted from the loop's thread as the coroutine
    /// ends, not after a wake-up of the engine's task.
    pub(crate) trigger: Option<Trigger<DynMessage>>,
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

    fn before_check(&mut self, trigger: Trigger<DynMessage>) {
        self.trigger = Some(trigger);
    }

    async fn check(&mut self) -> Result<DynMessage, SlotError> {
        let runner = self.runner.clone();
        let trigger = self.trigger.take();
        match run_slot(
            &self.slots,
            move |py| runner.bind(py).call_method0("check"),
            move |v| {
                let payload = body(v, "check")?;
                // out now, in the loop's thread; the engine's task only counts it. Refused only once the
                // check was dropped (the event deactivated or stopped): then nothing reads the value
                match &trigger {
                    Some(t) => Ok(t.emit(payload).err().unwrap_or_default()),
                    None => Ok(payload),
                }
            },
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
