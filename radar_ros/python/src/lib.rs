//! The radar_ros engine as the Python package `radar_ros`: this crate is its native part,
//! `radar_ros._native`; `python/radar_ros/__init__.py` is the API users import.
//!
//! What lives here: the participant and its tokio runtime, lookups, connections, waiters and injection
//! (all the engine's own code, with payloads as CDR bytes), and the Rust side of Python components: a
//! [`Response`] and an [`Event`] whose slots are Python coroutines. The response state machine, the relays
//! and the wire stay in Rust; Python code runs only inside slots.
//!
//! Threads: the engine runs on its own tokio runtime. Python slots run on an asyncio event loop the Python
//! side owns (a thread of its own), handed here when the `Radar` is made: a slot call schedules a coroutine
//! there and awaits its result without holding the GIL; cancelling the slot (an interrupt) cancels the
//! coroutine at its current `await`, as dropping a Rust slot's future does. Blocking calls release the GIL
//! and wake every 100 ms to let Python raise `KeyboardInterrupt`.

use std::{
    future::{Future, IntoFuture},
    sync::{Arc, Mutex},
    time::Duration,
};

use pyo3::{
    exceptions::PyRuntimeError,
    prelude::*,
    types::{PyBytes, PyCFunction, PyDict, PyTuple},
};
use radar_ros::{
    ConnectionGuard, DynMessage, Event, ExitAction, ExitReason, RawMessage, Response, SlotError,
    StartPolicy,
};

/// The engine of one `Radar`: its participant, runtime and the loop Python slots run on.
struct Engine {
    radar: radar_ros::Radar,
    rt: Option<tokio::runtime::Runtime>,
    slots: SlotLoop,
}

impl Drop for Engine {
    /// The runtime goes without waiting for its tasks: this may run in a thread that holds the GIL, which a
    /// task may be waiting for.
    fn drop(&mut self) {
        if let Some(rt) = self.rt.take() {
            rt.shutdown_background();
        }
    }
}

/// The asyncio loop Python slots run on, and `asyncio.run_coroutine_threadsafe`.
#[derive(Clone)]
struct SlotLoop {
    event_loop: Arc<Py<PyAny>>,
    submit: Arc<Py<PyAny>>,
}

impl SlotLoop {
    /// Schedules the coroutine `coro` on the loop; its result (or exception) arrives through the returned
    /// call, which cancels the coroutine if dropped before it finished.
    fn schedule(&self, py: Python<'_>, coro: Bound<'_, PyAny>) -> PyResult<PyCall> {
        self.schedule_acked(py, coro, None)
    }

    /// [`schedule`](Self::schedule), also sending on `begun` when the coroutine ends (in case it ended before
    /// it could say it had begun).
    fn schedule_acked(
        &self,
        py: Python<'_>,
        coro: Bound<'_, PyAny>,
        begun: Option<std::sync::mpsc::SyncSender<()>>,
    ) -> PyResult<PyCall> {
        let fut = self
            .submit
            .bind(py)
            .call1((coro, self.event_loop.bind(py)))?;
        let (tx, rx) = tokio::sync::oneshot::channel::<PyResult<Py<PyAny>>>();
        let tx = Mutex::new(Some(tx));
        let done = PyCFunction::new_closure(
            py,
            None,
            None,
            move |args: &Bound<'_, PyTuple>, _kw: Option<&Bound<'_, PyDict>>| -> PyResult<()> {
                let fut = args.get_item(0)?;
                let res = fut.call_method0("result").map(Bound::unbind);
                if let Some(tx) = tx.lock().unwrap().take() {
                    let _ = tx.send(res);
                }
                if let Some(b) = &begun {
                    let _ = b.try_send(());
                }
                Ok(())
            },
        )?;
        fut.call_method1("add_done_callback", (done,))?;
        Ok(PyCall {
            fut: Some(fut.unbind()),
            rx,
        })
    }
}

/// A Python coroutine running on the slot loop, seen from Rust.
struct PyCall {
    fut: Option<Py<PyAny>>,
    rx: tokio::sync::oneshot::Receiver<PyResult<Py<PyAny>>>,
}

impl PyCall {
    async fn result(mut self) -> PyResult<Py<PyAny>> {
        let r = (&mut self.rx).await;
        self.fut = None;
        r.unwrap_or_else(|_| Err(PyRuntimeError::new_err("the slot loop stopped")))
    }
}

impl Drop for PyCall {
    fn drop(&mut self) {
        if let Some(fut) = self.fut.take() {
            Python::attach(|py| {
                let _ = fut.bind(py).call_method0("cancel");
            });
        }
    }
}

/// The text of a Python exception with its traceback, as a panic message says what panicked and where.
fn describe(py: Python<'_>, e: &PyErr) -> String {
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
fn is_slot_error(py: Python<'_>, e: &PyErr) -> bool {
    py.import("radar_ros._errors")
        .and_then(|m| m.getattr("SlotError"))
        .map(|cls| e.matches(py, cls).unwrap_or(false))
        .unwrap_or(false)
}

/// How a Python slot ended, in Rust's terms: a value, a `SlotError` (failed), or any other exception (as a
/// panic of a Rust slot: the run ends as panicked with the exception and its traceback).
enum Ended {
    Value(Py<PyAny>),
    Failed(String),
    Panicked(String),
}

async fn run_slot(
    loop_: &SlotLoop,
    make: impl FnOnce(Python<'_>) -> PyResult<Bound<'_, PyAny>>,
) -> Ended {
    let call = Python::attach(|py| make(py).and_then(|coro| loop_.schedule(py, coro)));
    let res = match call {
        Ok(call) => call.result().await,
        Err(e) => Err(e),
    };
    Python::attach(|py| match res {
        Ok(v) => Ended::Value(v),
        Err(e) if is_slot_error(py, &e) => Ended::Failed(e.value(py).to_string()),
        Err(e) => Ended::Panicked(describe(py, &e)),
    })
}

/// Waits (at most 1 s: a loop blocked by user code must not hold up the engine for ever) until a Python
/// start behaviour says it has begun. Blocking, as the first poll of a Rust slot runs its code: on the
/// engine's multi-thread runtime the worker hands its other tasks over first.
fn wait_begun(begun: &std::sync::mpsc::Receiver<()>) {
    let wait = || {
        let _ = begun.recv_timeout(Duration::from_secs(1));
    };
    match tokio::runtime::Handle::try_current().map(|h| h.runtime_flavor()) {
        Ok(tokio::runtime::RuntimeFlavor::MultiThread) => tokio::task::block_in_place(wait),
        _ => wait(),
    }
}

/// Ends the Rust slot as a panic does, without the panic hook's printout (the message says it all).
fn panic_with(msg: String) -> ! {
    std::panic::resume_unwind(Box::new(msg))
}

fn body(py: Python<'_>, v: &Py<PyAny>, what: &str) -> Result<DynMessage, String> {
    v.bind(py)
        .extract::<Vec<u8>>()
        .map(|b| DynMessage(RawMessage::from_bytes(b)))
        .map_err(|_| {
            format!(
                "{what} returned {}, not the payload's bytes",
                v.bind(py).repr().map(|r| r.to_string()).unwrap_or_default()
            )
        })
}

/// A response whose slots are the Python object `runner`'s coroutine methods `start(body: bytes) -> bytes`,
/// `interrupt() -> None` and `exit(reason: str) -> bool` (restart), as `radar_ros.Response` makes them.
struct PyResponse {
    runner: Arc<Py<PyAny>>,
    slots: SlotLoop,
    start_type: String,
    output_type: String,
    output_default: DynMessage,
    policy: StartPolicy,
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
            slots.schedule_acked(py, coro, Some(begun_tx))
        });
        if call.is_ok() {
            wait_begun(&begun);
        }
        let res = match call {
            Ok(call) => call.result().await,
            Err(e) => Err(e),
        };
        let ended = Python::attach(|py| match res {
            Ok(v) => Ended::Value(v),
            Err(e) if is_slot_error(py, &e) => Ended::Failed(e.value(py).to_string()),
            Err(e) => Ended::Panicked(describe(py, &e)),
        });
        match ended {
            Ended::Value(v) => Python::attach(|py| body(py, &v, "start")).map_err(SlotError::msg),
            Ended::Failed(m) => Err(SlotError::msg(m)),
            Ended::Panicked(m) => panic_with(m),
        }
    }

    async fn interrupt(&mut self) {
        let runner = self.runner.clone();
        if let Ended::Failed(m) | Ended::Panicked(m) = run_slot(&self.slots, move |py| {
            runner.bind(py).call_method0("interrupt")
        })
        .await
        {
            panic_with(m)
        }
    }

    async fn exit(&mut self, reason: ExitReason) -> ExitAction {
        let runner = self.runner.clone();
        let why = reason.describe();
        match run_slot(&self.slots, move |py| {
            runner.bind(py).call_method1("exit", (why,))
        })
        .await
        {
            Ended::Value(v) => match Python::attach(|py| v.bind(py).is_truthy().unwrap_or(false)) {
                true => ExitAction::Restart,
                false => ExitAction::Done,
            },
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
struct PyEvent {
    runner: Arc<Py<PyAny>>,
    slots: SlotLoop,
    payload_type: String,
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
        match run_slot(&self.slots, move |py| runner.bind(py).call_method0("check")).await {
            Ended::Value(v) => Python::attach(|py| body(py, &v, "check")).map_err(SlotError::msg),
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

/// Raises the `radar_ros` exception for `e`: the class says its kind, the message what to do next.
fn to_py(e: radar_ros::Error) -> PyErr {
    use radar_ros::Error as E;
    let class = match &e {
        E::Timeout { .. } => "RadarTimeout",
        E::NotFound { .. } => "NotFound",
        E::WrongKind { .. } | E::Ambiguous { .. } => "NotFound",
        E::TypeMismatch { .. } | E::PayloadType { .. } => "PayloadTypeError",
        E::InvalidName { .. } | E::DuplicateName(_) | E::InvalidStatement(_) | E::Config { .. } => {
            "InvalidArgument"
        }
        E::ComponentLost { .. } | E::Closed(_) => "ComponentLost",
        _ => "RadarError",
    };
    let msg = e.to_string();
    Python::attach(|py| {
        match py
            .import("radar_ros._errors")
            .and_then(|m| m.getattr(class))
            .and_then(|cls| cls.call1((msg.clone(),)))
        {
            Ok(exc) => PyErr::from_value(exc),
            Err(_) => PyRuntimeError::new_err(msg),
        }
    })
}

impl Engine {
    fn rt(&self) -> &tokio::runtime::Runtime {
        self.rt
            .as_ref()
            .expect("the runtime lives as long as the engine")
    }

    /// Runs `fut` to its end on the runtime with the GIL released, letting Python raise (Ctrl-C) every
    /// 100 ms; a raise drops `fut`.
    fn wait<T: Send>(
        &self,
        py: Python<'_>,
        fut: impl Future<Output = radar_ros::Result<T>> + Send,
    ) -> PyResult<T> {
        let mut fut = Box::pin(fut);
        loop {
            let step = py.detach(|| {
                self.rt().block_on(async {
                    tokio::time::timeout(Duration::from_millis(100), &mut fut)
                        .await
                        .ok()
                })
            });
            match step {
                Some(r) => return r.map_err(to_py),
                None => {
                    if let Err(e) = py.check_signals() {
                        py.detach(|| {
                            let _g = self.rt().enter();
                            drop(fut);
                        });
                        return Err(e);
                    }
                }
            }
        }
    }
}

fn timeout(t: Option<f64>) -> PyResult<Option<Duration>> {
    t.map(|s| {
        Duration::try_from_secs_f64(s).map_err(|_| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "timeout {s}: give seconds, 0 or more (None: the default)"
            ))
        })
    })
    .transpose()
}

/// A signal: a topic a component publishes, with its type.
#[pyclass(module = "radar_ros._native", frozen, eq, hash, from_py_object)]
#[derive(Clone, PartialEq, Eq, Hash)]
struct Signal {
    #[pyo3(get)]
    topic: String,
    #[pyo3(get)]
    ros_type: String,
}

#[pymethods]
impl Signal {
    #[new]
    fn new(topic: String, ros_type: String) -> Self {
        Signal { topic, ros_type }
    }

    fn __repr__(&self) -> String {
        format!("Signal({:?}, {:?})", self.topic, self.ros_type)
    }
}

impl Signal {
    fn of(s: radar_ros::Signal) -> Signal {
        Signal {
            topic: s.topic().to_owned(),
            ros_type: s.ros_type().to_owned(),
        }
    }

    fn rust(&self) -> radar_ros::Signal {
        radar_ros::Signal::new(self.topic.clone(), self.ros_type.clone())
    }
}

/// A slot: a topic a component subscribes to, with its type.
#[pyclass(module = "radar_ros._native", frozen, eq, hash, from_py_object)]
#[derive(Clone, PartialEq, Eq, Hash)]
struct Slot {
    #[pyo3(get)]
    topic: String,
    #[pyo3(get)]
    ros_type: String,
}

#[pymethods]
impl Slot {
    #[new]
    fn new(topic: String, ros_type: String) -> Self {
        Slot { topic, ros_type }
    }

    fn __repr__(&self) -> String {
        format!("Slot({:?}, {:?})", self.topic, self.ros_type)
    }
}

impl Slot {
    fn of(s: radar_ros::Slot) -> Slot {
        Slot {
            topic: s.topic().to_owned(),
            ros_type: s.ros_type().to_owned(),
        }
    }

    fn rust(&self) -> radar_ros::Slot {
        radar_ros::Slot::new(self.topic.clone(), self.ros_type.clone())
    }
}

/// A response on the graph (found by name, or spawned here): its signals and slots.
#[pyclass(module = "radar_ros._native", frozen)]
#[derive(Clone)]
struct ResponseRef {
    inner: radar_ros::ResponseRef,
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
struct EventRef {
    inner: radar_ros::EventRef,
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
struct Component {
    engine: Arc<Engine>,
    response: Option<radar_ros::ResponseHandle>,
    event: Option<radar_ros::EventHandle>,
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
struct Connection {
    engine: Arc<Engine>,
    guard: Option<ConnectionGuard>,
    id: u64,
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
struct Waiter {
    engine: Arc<Engine>,
    inner: Option<radar_ros::Waiter<DynMessage>>,
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
struct Subscription {
    task: Option<tokio::task::JoinHandle<()>>,
    #[pyo3(get)]
    topic: String,
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
fn deliver_to(deliver: &Py<PyAny>, body: &[u8], topic: &str) {
    Python::attach(|py| {
        if let Err(e) = deliver.bind(py).call1((PyBytes::new(py, body),)) {
            tracing::error!(%topic, error = %describe(py, &e), "subscription callback raised");
        }
    })
}

/// One process's RADAR participant: a DDS participant, a connection manager, the components it spawns.
#[pyclass(module = "radar_ros._native", name = "Engine")]
struct PyEngine {
    engine: Option<Arc<Engine>>,
}

impl PyEngine {
    fn engine(&self) -> PyResult<&Arc<Engine>> {
        self.engine.as_ref().ok_or_else(|| {
            PyRuntimeError::new_err("this Radar was shut down: make a new one to go on")
        })
    }
}

fn policy(p: &str) -> PyResult<StartPolicy> {
    match p {
        "ignore" => Ok(StartPolicy::Ignore),
        "restart" => Ok(StartPolicy::Restart),
        "queue_one" => Ok(StartPolicy::QueueOne),
        other => Err(pyo3::exceptions::PyValueError::new_err(format!(
            "start policy {other:?}: use \"ignore\", \"restart\" or \"queue_one\""
        ))),
    }
}

#[pymethods]
impl PyEngine {
    /// Makes the participant. `event_loop` is the asyncio loop Python slots run on (running in a thread of
    /// its own); `args` the command line (`--ros-args` read from it).
    #[new]
    #[pyo3(signature = (event_loop, submit, args, domain_id=None, namespace=None, program=None, shutdown_timeout=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        event_loop: Py<PyAny>,
        submit: Py<PyAny>,
        args: Vec<String>,
        domain_id: Option<u16>,
        namespace: Option<String>,
        program: Option<String>,
        shutdown_timeout: Option<f64>,
    ) -> PyResult<Self> {
        init_logs();
        let st = timeout(shutdown_timeout)?;
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("radar-engine")
            .enable_all()
            .build()
            .map_err(|e| {
                PyRuntimeError::new_err(format!("cannot start the engine's runtime: {e}"))
            })?;
        let ros_args = radar_ros::ros_args::RosArgs::parse(args).map_err(to_py)?;
        let radar = py
            .detach(|| {
                let _e = rt.enter();
                let mut b = radar_ros::Radar::builder()
                    .handle_signals(false)
                    .ros_args(ros_args);
                if let Some(d) = domain_id {
                    b = b.domain_id(d);
                }
                if let Some(ns) = &namespace {
                    b = b.namespace(ns);
                }
                if let Some(p) = &program {
                    b = b.program(p);
                }
                if let Some(t) = st {
                    b = b.shutdown_timeout(t);
                }
                b.build()
            })
            .map_err(to_py)?;
        Ok(PyEngine {
            engine: Some(Arc::new(Engine {
                radar,
                rt: Some(rt),
                slots: SlotLoop {
                    event_loop: Arc::new(event_loop),
                    submit: Arc::new(submit),
                },
            })),
        })
    }

    /// The ROS domain id in use.
    #[getter]
    fn domain_id(&self) -> PyResult<u16> {
        Ok(self.engine()?.radar.domain_id())
    }

    /// The namespace components are spawned in.
    #[getter]
    fn namespace(&self) -> PyResult<String> {
        Ok(self.engine()?.radar.namespace().to_owned())
    }

    /// Finds the event `name` on the graph.
    #[pyo3(signature = (name, timeout=None))]
    fn event(&self, py: Python<'_>, name: &str, timeout: Option<f64>) -> PyResult<EventRef> {
        let e = self.engine()?;
        let mut w = e.radar.event(name);
        if let Some(t) = self::timeout(timeout)? {
            w = w.timeout(t);
        }
        Ok(EventRef {
            inner: e.wait(py, w.into_future())?,
        })
    }

    /// Finds the response `name` on the graph.
    #[pyo3(signature = (name, timeout=None))]
    fn response(&self, py: Python<'_>, name: &str, timeout: Option<f64>) -> PyResult<ResponseRef> {
        let e = self.engine()?;
        let mut w = e.radar.response(name);
        if let Some(t) = self::timeout(timeout)? {
            w = w.timeout(t);
        }
        Ok(ResponseRef {
            inner: e.wait(py, w.into_future())?,
        })
    }

    /// Spawns the response `name` whose slots are `runner`'s coroutine methods; `output_default` is what
    /// `exited` carries after a run that did not complete (the output type's default message).
    #[allow(clippy::too_many_arguments)]
    fn spawn_response(
        &self,
        py: Python<'_>,
        name: &str,
        runner: Py<PyAny>,
        start_type: String,
        output_type: String,
        output_default: Vec<u8>,
        start_policy: &str,
    ) -> PyResult<Component> {
        let e = self.engine()?;
        let r = PyResponse {
            runner: Arc::new(runner),
            slots: e.slots.clone(),
            start_type,
            output_type,
            output_default: DynMessage(RawMessage::from_bytes(output_default)),
            policy: policy(start_policy)?,
        };
        let h = py
            .detach(|| {
                let _g = e.rt().enter();
                e.radar.spawn_response(name, r)
            })
            .map_err(to_py)?;
        Ok(Component {
            engine: e.clone(),
            response: Some(h),
            event: None,
        })
    }

    /// Spawns the event `name` whose check is `runner.check()`.
    fn spawn_event(
        &self,
        py: Python<'_>,
        name: &str,
        runner: Py<PyAny>,
        payload_type: String,
    ) -> PyResult<Component> {
        let e = self.engine()?;
        let ev = PyEvent {
            runner: Arc::new(runner),
            slots: e.slots.clone(),
            payload_type,
        };
        let h = py
            .detach(|| {
                let _g = e.rt().enter();
                e.radar.spawn_event(name, ev)
            })
            .map_err(to_py)?;
        Ok(Component {
            engine: e.clone(),
            response: None,
            event: Some(h),
        })
    }

    /// Makes a connection: `once` (or `whenever`) `source` to `target`, one of `("start"|"interrupt"|"exit",
    /// ResponseRef)`, `("slot", Slot)` or `("call", deliver)` (an anonymous slot: `deliver(bytes)` is called
    /// for each payload, in order, and must return at once), with `until` if given.
    #[pyo3(signature = (once, source, kind, target, until=None, timeout=None, rearm=false, depth=None))]
    #[allow(clippy::too_many_arguments)]
    fn connect(
        &self,
        py: Python<'_>,
        once: bool,
        source: Signal,
        kind: &str,
        target: Bound<'_, PyAny>,
        until: Option<Signal>,
        timeout: Option<f64>,
        rearm: bool,
        depth: Option<usize>,
    ) -> PyResult<Connection> {
        let e = self.engine()?;
        let st = match once {
            true => e.radar.once(source.rust()),
            false => e.radar.whenever(source.rust()),
        };
        let mut req = match kind {
            "start" | "interrupt" | "exit" => {
                let r = target.extract::<PyRef<'_, ResponseRef>>()?.inner.clone();
                match kind {
                    "start" => st.start(&r),
                    "interrupt" => st.interrupt(&r),
                    _ => st.exit(&r),
                }
            }
            "slot" => st.slot(target.extract::<PyRef<'_, Slot>>()?.rust()),
            "call" => {
                let deliver = target.unbind();
                st.call(move |m: DynMessage| {
                    Python::attach(|py| {
                        if let Err(err) = deliver.bind(py).call1((PyBytes::new(py, m.0.as_bytes()),)) {
                            tracing::error!(error = %describe(py, &err), "anonymous slot: not delivered");
                        }
                    })
                })
            }
            other => {
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "connection target kind {other:?}: use start, interrupt, exit, slot or call"
                )))
            }
        };
        if let Some(u) = until {
            req = req.until(u.rust());
        }
        if rearm {
            req = req.rearm();
        }
        if let Some(d) = depth {
            req = req.depth(d);
        }
        if let Some(t) = self::timeout(timeout)? {
            req = req.timeout(t);
        }
        let guard = e.wait(py, req.into_future())?;
        Ok(Connection {
            engine: e.clone(),
            id: guard.id(),
            guard: Some(guard),
        })
    }

    /// Arms a waiter on `source` (returns once armed: a signal after this is not missed).
    #[pyo3(signature = (source, timeout=None))]
    fn waiter(&self, py: Python<'_>, source: Signal, timeout: Option<f64>) -> PyResult<Waiter> {
        let e = self.engine()?;
        let mut w = e.radar.waiter::<DynMessage>(source.rust());
        if let Some(t) = self::timeout(timeout)? {
            w = w.timeout(t);
        }
        let w = e.wait(py, w.into_future())?;
        Ok(Waiter {
            engine: e.clone(),
            inner: Some(w),
        })
    }

    /// Sends `body` (CDR bytes of the slot's type) into `slot` once its subscriber is there.
    #[pyo3(signature = (slot, body, timeout=None))]
    fn inject(
        &self,
        py: Python<'_>,
        slot: Slot,
        body: Vec<u8>,
        timeout: Option<f64>,
    ) -> PyResult<()> {
        let e = self.engine()?;
        let mut w = e
            .radar
            .inject(slot.rust(), DynMessage(RawMessage::from_bytes(body)));
        if let Some(t) = self::timeout(timeout)? {
            w = w.timeout(t);
        }
        e.wait(py, w.into_future())
    }

    /// Subscribes to `topic` of `ros_type` (signal QoS; with `state`, a component's transient-local state:
    /// `radar_msgs/msg/EventState` or `ResponseState`) and calls `deliver(body)` for each message, in order,
    /// from the engine's runtime (`deliver` must return at once).
    #[pyo3(signature = (topic, ros_type, deliver, state=false))]
    fn subscribe(
        &self,
        py: Python<'_>,
        topic: &str,
        ros_type: &str,
        deliver: Py<PyAny>,
        state: bool,
    ) -> PyResult<Subscription> {
        use radar_ros::msg::{EventState, ResponseState, RosMessage};
        let e = self.engine()?;
        let _g = e.rt().enter();
        let task = match (state, ros_type) {
            (false, _) => {
                let sub = py.detach(|| e.radar.raw_subscription(topic, ros_type)).map_err(to_py)?;
                let t = sub.topic().to_owned();
                e.rt().spawn(async move {
                    while let Ok((m, _)) = sub.recv_stamped().await {
                        deliver_to(&deliver, m.as_bytes(), &t);
                    }
                })
            }
            (true, t) if t == EventState::ros_type_name() => {
                let sub = py
                    .detach(|| e.radar.state_subscription::<EventState>(topic))
                    .map_err(to_py)?;
                let t = sub.topic().to_owned();
                e.rt().spawn(async move {
                    while let Ok(m) = sub.recv().await {
                        if let Ok(raw) = RawMessage::encode(&m) {
                            deliver_to(&deliver, raw.as_bytes(), &t);
                        }
                    }
                })
            }
            (true, t) if t == ResponseState::ros_type_name() => {
                let sub = py
                    .detach(|| e.radar.state_subscription::<ResponseState>(topic))
                    .map_err(to_py)?;
                let t = sub.topic().to_owned();
                e.rt().spawn(async move {
                    while let Ok(m) = sub.recv().await {
                        if let Ok(raw) = RawMessage::encode(&m) {
                            deliver_to(&deliver, raw.as_bytes(), &t);
                        }
                    }
                })
            }
            (true, other) => {
                return Err(to_py(radar_ros::Error::InvalidName {
                    name: other.to_owned(),
                    reason: "a state subscription is to radar_msgs/msg/EventState or radar_msgs/msg/ResponseState"
                        .into(),
                }))
            }
        };
        Ok(Subscription {
            task: Some(task),
            topic: topic.to_owned(),
        })
    }

    /// Stops every component (their exit slots run, `exited` is sent) and leaves the graph. Idempotent.
    #[pyo3(signature = (timeout=None))]
    fn shutdown(&mut self, py: Python<'_>, timeout: Option<f64>) -> PyResult<()> {
        let Some(e) = self.engine.take() else {
            return Ok(());
        };
        let mut w = e.radar.shutdown();
        if let Some(t) = self::timeout(timeout)? {
            w = w.timeout(t);
        }
        let r = e.wait(py, w.into_future());
        // the runtime goes when the last handle (components, connections) does
        drop(e);
        r
    }
}

fn init_logs() {
    let filter = std::env::var("RADAR_LOG")
        .or_else(|_| std::env::var("RUST_LOG"))
        .unwrap_or_else(|_| {
            "info,rustdds=error,ros2_client=error,ros2_client::distributions=error".to_owned()
        });
    let _ = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::new(filter))
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_writer(std::io::stderr)
        .try_init();
}

/// The ROS types whose messages convert to and from dicts without a Python message package.
#[pyfunction]
fn dict_types() -> Vec<String> {
    radar_ros::codec::known()
}

/// A message of `ros_type` from its fields as JSON (missing fields: their defaults), as CDR bytes.
#[pyfunction]
fn encode_json<'py>(py: Python<'py>, ros_type: &str, json: &str) -> PyResult<Bound<'py, PyBytes>> {
    let raw = radar_ros::codec::encode(ros_type, json).map_err(|e| {
        Python::attach(|py| {
            py.import("radar_ros._errors")
                .and_then(|m| m.getattr("PayloadTypeError"))
                .and_then(|cls| cls.call1((e.clone(),)))
                .map(PyErr::from_value)
                .unwrap_or_else(|_| PyRuntimeError::new_err(e))
        })
    })?;
    Ok(PyBytes::new(py, raw.as_bytes()))
}

/// A message of `ros_type` (CDR bytes) as JSON; None for a type without a dict form here.
#[pyfunction]
fn decode_json(ros_type: &str, body: Vec<u8>) -> Option<String> {
    if !radar_ros::codec::known().iter().any(|t| t == ros_type) {
        return None;
    }
    let v = radar_ros::codec::decode(ros_type, &RawMessage::from_bytes(body));
    Some(v.to_string())
}

/// The native part of the `radar_ros` Python package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(dict_types, m)?)?;
    m.add_function(wrap_pyfunction!(encode_json, m)?)?;
    m.add_function(wrap_pyfunction!(decode_json, m)?)?;
    m.add(
        "BUILD",
        if cfg!(debug_assertions) {
            "dev"
        } else {
            "release"
        },
    )?;
    m.add_class::<PyEngine>()?;
    m.add_class::<Signal>()?;
    m.add_class::<Slot>()?;
    m.add_class::<ResponseRef>()?;
    m.add_class::<EventRef>()?;
    m.add_class::<Component>()?;
    m.add_class::<Connection>()?;
    m.add_class::<Waiter>()?;
    m.add_class::<Subscription>()?;
    Ok(())
}
