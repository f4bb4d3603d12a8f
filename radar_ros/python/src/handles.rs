//! What `Engine` hands to Python: signals and slots, references to components on the graph, spawned
//! components, connections, waiters and subscriptions.

use std::{future::IntoFuture, sync::Arc};

use pyo3::{
    exceptions::PyRuntimeError,
    prelude::*,
    types::{PyBytes, PyDict},
};
use radar_ros::{topics::DynMessage, ConnectionGuard};

use crate::{
    runtime::{timeout, Engine},
    slot_loop::describe,
};

/// A Python class for one end of a connection (`radar_ros::Signal` or `radar_ros::Slot`): a topic and its
/// ROS type, frozen, comparable and hashable, converting to and from the Rust type.
macro_rules! topic_end {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[pyclass(module = "radar_ros._native", frozen, eq, hash, from_py_object)]
        #[derive(Clone, PartialEq, Eq, Hash)]
        pub(crate) struct $name {
            #[pyo3(get)]
            topic: String,
            #[pyo3(get)]
            ros_type: String,
        }

        #[pymethods]
        impl $name {
            #[new]
            fn new(topic: String, ros_type: String) -> Self {
                $name { topic, ros_type }
            }

            fn __repr__(&self) -> String {
                format!(concat!(stringify!($name), "({:?}, {:?})"), self.topic, self.ros_type)
            }
        }

        impl $name {
            pub(crate) fn of(s: radar_ros::$name) -> $name {
                $name {
                    topic: s.topic().to_owned(),
                    ros_type: s.ros_type().to_owned(),
                }
            }

            pub(crate) fn rust(&self) -> radar_ros::$name {
                radar_ros::$name::new(self.topic.clone(), self.ros_type.clone())
            }
        }
    };
}

topic_end!(
    /// A signal: a topic a component publishes, with its type.
    Signal
);
topic_end!(
    /// A slot: a topic a component subscribes to, with its type.
    Slot
);

/// A response on the graph (found by name, or spawned here): its signals and slots.
#[pyclass(module = "radar_ros._native", frozen)]
#[derive(Clone)]
pub(crate) struct ResponseRef {
    pub(crate) inner: radar_ros::ResponseRef,
}

#[pymethods]
impl ResponseRef {
    /// Its fully qualified name.
    #[getter]
    fn name(&self) -> String {
        self.inner.name().fully_qualified()
    }
    #[getter]
    fn started(&self) -> Signal {
        Signal::of(self.inner.started())
    }
    #[getter]
    fn interrupted(&self) -> Signal {
        Signal::of(self.inner.interrupted())
    }
    #[getter]
    fn exited(&self) -> Signal {
        Signal::of(self.inner.exited())
    }
    #[getter]
    fn start_slot(&self) -> Slot {
        Slot::of(self.inner.start_slot())
    }
    #[getter]
    fn interrupt_slot(&self) -> Slot {
        Slot::of(self.inner.interrupt_slot())
    }
    #[getter]
    fn exit_slot(&self) -> Slot {
        Slot::of(self.inner.exit_slot())
    }
    fn __repr__(&self) -> String {
        format!(
            "ResponseRef({:?}, start={:?}, output={:?})",
            self.name(),
            self.inner.start_slot().ros_type(),
            self.inner.exited().ros_type()
        )
    }
}

/// An event on the graph: its name and its `triggered` signal.
#[pyclass(module = "radar_ros._native", frozen)]
#[derive(Clone)]
pub(crate) struct EventRef {
    pub(crate) inner: radar_ros::EventRef,
}

#[pymethods]
impl EventRef {
    #[getter]
    fn name(&self) -> String {
        self.inner.name().fully_qualified()
    }
    #[getter]
    fn triggered(&self) -> Signal {
        use radar_ros::AsSignal;
        Signal::of(self.inner.signal())
    }
    fn __repr__(&self) -> String {
        use radar_ros::AsSignal;
        format!(
            "EventRef({:?}, payload={:?})",
            self.name(),
            self.inner.signal().ros_type()
        )
    }
}

/// A component spawned by this `Radar`: lives until `shutdown()` or the `Radar`'s end.
#[pyclass(module = "radar_ros._native")]
pub(crate) struct Component {
    pub(crate) engine: Arc<Engine>,
    pub(crate) response: Option<radar_ros::ResponseHandle>,
    pub(crate) event: Option<radar_ros::EventHandle>,
}

#[pymethods]
impl Component {
    /// The response's reference (None for an event).
    fn response_ref(&self) -> Option<ResponseRef> {
        self.response.as_ref().map(|h| ResponseRef {
            inner: h.reference().clone(),
        })
    }

    /// The event's reference (None for a response).
    fn event_ref(&self) -> Option<EventRef> {
        self.event.as_ref().map(|h| EventRef {
            inner: radar_ros::EventRef::new(h.name().clone(), h.triggered().ros_type()),
        })
    }

    /// The state the component publishes, as a dict of its fields.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        if let Some(h) = &self.response {
            let s = h.state();
            d.set_item("name", s.name)?;
            d.set_item("state", s.state_label)?;
            d.set_item("start_type", s.start_type)?;
            d.set_item("start_policy", s.start_policy)?;
            d.set_item("last_exit_reason", s.last_exit_reason)?;
            d.set_item("starts", s.starts)?;
            d.set_item("exits", s.exits)?;
            d.set_item("interrupts", s.interrupts)?;
            d.set_item("exit_signals", s.exit_signals)?;
            d.set_item("completed", s.completed)?;
            d.set_item("failures", s.failures)?;
            d.set_item("panics", s.panics)?;
            d.set_item("restarts", s.restarts)?;
            d.set_item("ignored_starts", s.ignored_starts)?;
            d.set_item("ignored_interrupts", s.ignored_interrupts)?;
            d.set_item("ignored_exits", s.ignored_exits)?;
            d.set_item("malformed", s.malformed)?;
        }
        if let Some(h) = &self.event {
            let s = h.state();
            d.set_item("name", s.name)?;
            d.set_item("active", s.active)?;
            d.set_item("trigger_type", s.trigger_type)?;
            d.set_item("triggers", s.triggers)?;
            d.set_item("listeners", s.listeners)?;
            d.set_item("activations", s.activations)?;
            d.set_item("check_errors", s.check_errors)?;
            d.set_item("last_error", s.last_error)?;
        }
        Ok(d)
    }

    /// Stops it: a running response is ended as by an exit signal (its exit slot runs), then its node leaves.
    #[pyo3(signature = (timeout=None))]
    fn shutdown(&mut self, py: Python<'_>, timeout: Option<f64>) -> PyResult<()> {
        let t = self::timeout(timeout)?;
        let engine = self.engine.clone();
        if let Some(h) = self.response.take() {
            let w = h.shutdown();
            let w = match t {
                Some(t) => w.timeout(t),
                None => w,
            };
            engine.wait(py, w.into_future())?;
        }
        if let Some(h) = self.event.take() {
            let w = h.shutdown();
            let w = match t {
                Some(t) => w.timeout(t),
                None => w,
            };
            engine.wait(py, w.into_future())?;
        }
        Ok(())
    }
}

/// A connection made by `once` or `whenever`: delivers until closed (a fired `once` closes itself).
#[pyclass(module = "radar_ros._native")]
pub(crate) struct Connection {
    pub(crate) engine: Arc<Engine>,
    pub(crate) guard: Option<ConnectionGuard>,
    pub(crate) id: u64,
}

#[pymethods]
impl Connection {
    /// Its id in the manager's list.
    #[getter]
    fn id(&self) -> u64 {
        self.id
    }

    /// Whether it still delivers.
    #[getter]
    fn live(&self) -> bool {
        self.guard.as_ref().is_some_and(|g| g.is_live())
    }

    /// Signals delivered so far.
    #[getter]
    fn delivered(&self) -> u64 {
        self.guard.as_ref().map_or(0, |g| g.delivered())
    }

    /// Ends it (a relay in flight delivers nothing more). Idempotent.
    fn close(&mut self, py: Python<'_>) {
        if let Some(g) = self.guard.take() {
            let engine = self.engine.clone();
            py.detach(move || {
                let _e = engine.rt().enter();
                drop(g);
            });
        }
    }

    /// Waits until it no longer delivers (a `once` that fired); `timeout` in seconds, None: unbounded.
    #[pyo3(signature = (timeout=None))]
    fn wait_closed(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<()> {
        let t = self::timeout(timeout)?;
        let Some(g) = &self.guard else {
            return Ok(());
        };
        let w = g.closed();
        let w = match t {
            Some(t) => w.timeout(t),
            None => w,
        };
        self.engine.wait(py, w.into_future())
    }
}

impl Drop for Connection {
    fn drop(&mut self) {
        if let Some(g) = self.guard.take() {
            let _e = self.engine.rt().enter();
            drop(g);
        }
    }
}

/// A waiter: armed on a signal, holds its first payload.
#[pyclass(module = "radar_ros._native")]
pub(crate) struct Waiter {
    pub(crate) engine: Arc<Engine>,
    pub(crate) inner: Option<radar_ros::statement::Waiter<DynMessage>>,
}

#[pymethods]
impl Waiter {
    /// The first payload's bytes; `timeout` in seconds (None: unbounded).
    #[pyo3(signature = (timeout=None))]
    fn recv<'py>(
        &mut self,
        py: Python<'py>,
        timeout: Option<f64>,
    ) -> PyResult<Bound<'py, PyBytes>> {
        let t = self::timeout(timeout)?;
        let engine = self.engine.clone();
        let w = self
            .inner
            .as_mut()
            .ok_or_else(|| PyRuntimeError::new_err("this waiter was closed"))?;
        let r = w.recv();
        let r = match t {
            Some(t) => r.timeout(t),
            None => r,
        };
        let m = engine.wait(py, r.into_future())?;
        Ok(PyBytes::new(py, m.0.as_bytes()))
    }

    /// Disarms it.
    fn close(&mut self, py: Python<'_>) {
        if let Some(w) = self.inner.take() {
            let engine = self.engine.clone();
            py.detach(move || {
                let _e = engine.rt().enter();
                drop(w);
            });
        }
    }
}

impl Drop for Waiter {
    fn drop(&mut self) {
        if let Some(w) = self.inner.take() {
            let _e = self.engine.rt().enter();
            drop(w);
        }
    }
}

/// A subscription made by `Engine.subscribe`: delivers until closed.
#[pyclass(module = "radar_ros._native")]
pub(crate) struct Subscription {
    pub(crate) task: Option<tokio::task::JoinHandle<()>>,
    #[pyo3(get)]
    pub(crate) topic: String,
}

#[pymethods]
impl Subscription {
    /// Stops delivering. Idempotent.
    fn close(&mut self) {
        if let Some(t) = self.task.take() {
            t.abort();
        }
    }
}

impl Drop for Subscription {
    fn drop(&mut self) {
        self.close();
    }
}

/// Calls `deliver(body)` from a runtime task; an exception is printed with its traceback.
pub(crate) fn deliver_to(deliver: &Py<PyAny>, body: &[u8], topic: &str) {
    Python::attach(|py| {
        if let Err(e) = deliver.bind(py).call1((PyBytes::new(py, body),)) {
            tracing::error!(%topic, error = %describe(py, &e), "subscription callback raised");
        }
    })
}
