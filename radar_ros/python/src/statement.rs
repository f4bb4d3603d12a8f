//! A connection described from Python before it is made, in the shape of radar_ros's statements:
//! `Statement.once(source)` or `Statement.whenever(source)`, then one method per target kind (`start`, which
//! alone takes an `until`; `interrupt`, `exit`, `slot`, `call`), giving a `Request` that `Engine.connect`
//! makes. A request cannot name a target kind that does not exist, nor put `until` on anything but a start.

use pyo3::{exceptions::PyRuntimeError, prelude::*};

use crate::handles::{ResponseRef, Signal, Slot};

/// `once` or `whenever`, and the signal it follows.
#[pyclass(module = "radar_ros._native", frozen)]
pub(crate) struct Statement {
    once: bool,
    source: Signal,
}

/// What a request delivers to.
pub(crate) enum Target {
    /// The response's start slot, and the signal that interrupts the run it started.
    Start {
        response: radar_ros::ResponseRef,
        until: Option<Signal>,
    },
    Interrupt(radar_ros::ResponseRef),
    Exit(radar_ros::ResponseRef),
    Slot(Slot),
    /// An anonymous slot: `deliver(bytes)` for each payload, in order (it must return at once).
    Call(Py<PyAny>),
}

/// A statement with its target, made once by `Engine.connect`.
#[pyclass(module = "radar_ros._native")]
pub(crate) struct Request {
    pub(crate) once: bool,
    pub(crate) source: Signal,
    target: Option<Target>,
}

impl Request {
    /// The target, taken: a request is made once.
    pub(crate) fn take(&mut self) -> PyResult<Target> {
        self.target.take().ok_or_else(|| {
            PyRuntimeError::new_err("this request was made already: describe the connection again")
        })
    }
}

impl Statement {
    fn to(&self, target: Target) -> Request {
        Request {
            once: self.once,
            source: self.source.clone(),
            target: Some(target),
        }
    }
}

#[pymethods]
impl Statement {
    /// Delivers the first `source` signal, then ends.
    #[staticmethod]
    fn once(source: Signal) -> Statement {
        Statement { once: true, source }
    }

    /// Delivers every `source` signal until closed.
    #[staticmethod]
    fn whenever(source: Signal) -> Statement {
        Statement {
            once: false,
            source,
        }
    }

    /// Starts `response`; `until` interrupts the run this statement started.
    #[pyo3(signature = (response, until=None))]
    fn start(&self, response: PyRef<'_, ResponseRef>, until: Option<Signal>) -> Request {
        self.to(Target::Start {
            response: response.inner.clone(),
            until,
        })
    }

    /// Interrupts `response`.
    fn interrupt(&self, response: PyRef<'_, ResponseRef>) -> Request {
        self.to(Target::Interrupt(response.inner.clone()))
    }

    /// Exits `response`.
    fn exit(&self, response: PyRef<'_, ResponseRef>) -> Request {
        self.to(Target::Exit(response.inner.clone()))
    }

    /// Delivers into `slot`.
    fn slot(&self, slot: Slot) -> Request {
        self.to(Target::Slot(slot))
    }

    /// Calls `deliver(bytes)` for each payload (an anonymous slot).
    fn call(&self, deliver: Py<PyAny>) -> Request {
        self.to(Target::Call(deliver))
    }
}
