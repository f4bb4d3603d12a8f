//! The asyncio loop Python slots run on, seen from Rust: scheduling a coroutine there, awaiting it without
//! the GIL, and what its end means in Rust's terms (a value, a `SlotError`, or a panic).

use std::{
    sync::{Arc, Mutex},
    time::Duration,
};

use pyo3::{
    exceptions::PyRuntimeError,
    prelude::*,
    types::{PyCFunction, PyDict, PyTuple},
};
use radar_ros::{topics::DynMessage, topics::RawMessage};

/// The asyncio loop Python slots run on, and the package's `_SlotCall(coro, loop, done)`, which runs `coro` in
/// a task of the loop with `done(outcome)` called as it ends (`outcome.result()`: its value, or what it raised), and has `cancel()`.
#[derive(Clone)]
pub(crate) struct SlotLoop {
    pub(crate) event_loop: Arc<Py<PyAny>>,
    pub(crate) submit: Arc<Py<PyAny>>,
}

impl SlotLoop {
    /// Schedules the coroutine `coro` on the loop; how it ended arrives through the returned call, which
    /// cancels the coroutine if dropped before it finished. `value` reads its return value into Rust in the
    /// loop's thread, as the coroutine ends (that thread holds the GIL then: the engine's side takes no GIL to
    /// read the outcome); a value it refuses ends the slot as failed, with its message.
    pub(crate) fn schedule<T: Send + 'static>(
        &self,
        py: Python<'_>,
        coro: Bound<'_, PyAny>,
        value: impl Fn(&Bound<'_, PyAny>) -> Result<T, String> + Send + Sync + 'static,
    ) -> PyResult<PyCall<T>> {
        self.schedule_acked(py, coro, None, value)
    }

    /// [`schedule`](Self::schedule), also sending on `begun` when the coroutine ends (in case it ended before
    /// it could say it had begun).
    pub(crate) fn schedule_acked<T: Send + 'static>(
        &self,
        py: Python<'_>,
        coro: Bound<'_, PyAny>,
        begun: Option<std::sync::mpsc::SyncSender<()>>,
        value: impl Fn(&Bound<'_, PyAny>) -> Result<T, String> + Send + Sync + 'static,
    ) -> PyResult<PyCall<T>> {
        let (tx, rx) = tokio::sync::oneshot::channel::<Ended<T>>();
        let tx = Mutex::new(Some(tx));
        let done = PyCFunction::new_closure(
            py,
            None,
            None,
            move |args: &Bound<'_, PyTuple>, _kw: Option<&Bound<'_, PyDict>>| -> PyResult<()> {
                let outcome = args.get_item(0)?;
                let ended = match outcome.call_method0("result") {
                    Ok(v) => match value(&v) {
                        Ok(v) => Ended::Value(v),
                        Err(m) => Ended::Failed(m),
                    },
                    Err(e) => ended_by(args.py(), &e),
                };
                if let Some(tx) = tx.lock().unwrap().take() {
                    let _ = tx.send(ended);
                }
                if let Some(b) = &begun {
                    let _ = b.try_send(());
                }
                Ok(())
            },
        )?;
        // the last thing done holding the GIL: the loop's thread, woken by it, does not wait for the GIL
        let fut = self
            .submit
            .bind(py)
            .call1((coro, self.event_loop.bind(py), done))?;
        Ok(PyCall {
            fut: Some(fut.unbind()),
            rx,
        })
    }
}

/// A Python coroutine running on the slot loop, seen from Rust (`fut`: its `_SlotCall`).
pub(crate) struct PyCall<T> {
    pub(crate) fut: Option<Py<PyAny>>,
    pub(crate) rx: tokio::sync::oneshot::Receiver<Ended<T>>,
}

impl<T> PyCall<T> {
    /// How the coroutine ended (read in the loop's thread; no GIL taken here unless the loop stopped).
    pub(crate) async fn result(mut self) -> Ended<T> {
        let r = (&mut self.rx).await;
        // done: nothing to cancel (its reference is dropped when a thread next holds the GIL)
        self.fut = None;
        r.unwrap_or_else(|_| {
            Python::attach(|py| ended_by(py, &PyRuntimeError::new_err("the slot loop stopped")))
        })
    }
}

impl<T> Drop for PyCall<T> {
    fn drop(&mut self) {
        if let Some(fut) = self.fut.take() {
            Python::attach(|py| {
                let _ = fut.bind(py).call_method0("cancel");
            });
        }
    }
}

/// How a slot that raised `e` ended: failed (a `radar_ros.SlotError`) or panicked (any other exception).
pub(crate) fn ended_by<T>(py: Python<'_>, e: &PyErr) -> Ended<T> {
    if is_slot_error(py, e) {
        Ended::Failed(e.value(py).to_string())
    } else {
        Ended::Panicked(describe(py, e))
    }
}

/// The text of a Python exception with its traceback, as a panic message says what panicked and where.
pub(crate) fn describe(py: Python<'_>, e: &PyErr) -> String {
    let tb = e
        .traceback(py)
        .and_then(|tb| tb.format().ok())
        .unwrap_or_default();
    format!(
        "{}{}",
        tb,
        e.value(py)
            .repr()
            .map(|r| r.to_string())
            .unwrap_or_default()
    )
    .trim_end()
    .to_owned()
}

/// Whether `e` is a `radar_ros.SlotError`: a slot's failure, said on purpose (Rust's `Err(SlotError)`).
pub(crate) fn is_slot_error(py: Python<'_>, e: &PyErr) -> bool {
    py.import("radar_ros._errors")
        .and_then(|m| m.getattr("SlotError"))
        .map(|cls| e.matches(py, cls).unwrap_or(false))
        .unwrap_or(false)
}

/// How a Python slot ended, in Rust's terms: a value, a `SlotError` (failed), or any other exception (as a
/// panic of a Rust slot: the run ends as panicked with the exception and its traceback).
pub(crate) enum Ended<T> {
    Value(T),
    Failed(String),
    Panicked(String),
}

/// Runs the coroutine `make` gives on the loop and waits for how it ended, its value read by `value`.
pub(crate) async fn run_slot<T: Send + 'static>(
    loop_: &SlotLoop,
    make: impl FnOnce(Python<'_>) -> PyResult<Bound<'_, PyAny>>,
    value: impl Fn(&Bound<'_, PyAny>) -> Result<T, String> + Send + Sync + 'static,
) -> Ended<T> {
    let call = Python::attach(|py| {
        make(py)
            .and_then(|coro| loop_.schedule(py, coro, value))
            .map_err(|e| ended_by(py, &e))
    });
    match call {
        Ok(call) => call.result().await,
        Err(ended) => ended,
    }
}

/// Waits (at most 1 s: a loop blocked by user code must not hold up the engine for ever) until a Python
/// start behaviour says it has begun. Blocking, as the first poll of a Rust slot runs its code: on the
/// engine's multi-thread runtime the worker hands its other tasks over first.
pub(crate) fn wait_begun(begun: &std::sync::mpsc::Receiver<()>) {
    let wait = || {
        let _ = begun.recv_timeout(Duration::from_secs(1));
    };
    match tokio::runtime::Handle::try_current().map(|h| h.runtime_flavor()) {
        Ok(tokio::runtime::RuntimeFlavor::MultiThread) => tokio::task::block_in_place(wait),
        _ => wait(),
    }
}

/// Ends the Rust slot as a panic does, without the panic hook's printout (the message says it all).
pub(crate) fn panic_with(msg: String) -> ! {
    std::panic::resume_unwind(Box::new(msg))
}

/// The payload's bytes a slot returned (`what` names the slot in the error).
pub(crate) fn body(v: &Bound<'_, PyAny>, what: &str) -> Result<DynMessage, String> {
    v.extract::<Vec<u8>>()
        .map(|b| DynMessage(RawMessage::from_bytes(b)))
        .map_err(|_| {
            format!(
                "{what} returned {}, not the payload's bytes",
                v.repr().map(|r| r.to_string()).unwrap_or_default()
            )
        })
}
