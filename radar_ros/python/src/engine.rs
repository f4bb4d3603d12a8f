//! The engine of one `Radar` (its participant, runtime and slot loop) and its Python face, `Engine`: lookups,
//! spawning, connections, waiters, injection and subscriptions.

use std::{future::IntoFuture, sync::Arc, time::Duration};

use pyo3::{exceptions::PyRuntimeError, prelude::*, types::PyBytes};
use radar_ros::{topics::DynMessage, topics::RawMessage, StartPolicy};

use crate::{
    components::{PyEvent, PyResponse},
    handles::{
        deliver_to, Component, Connection, EventRef, ResponseRef, Signal, Slot, Subscription,
        Waiter,
    },
    init_logs,
    runtime::{timeout, to_py, Engine},
    slot_loop::{describe, SlotLoop},
    statement::{Request, Target},
};

/// A connection's properties from Python, for a request of any target kind.
struct Props {
    rearm: bool,
    depth: Option<usize>,
    timeout: Option<Duration>,
}

/// An armed connection, awaited.
type Arming = <radar_ros::ConnectionRequest as std::future::IntoFuture>::IntoFuture;

impl Props {
    /// `req` with these properties, ready to arm.
    fn apply<T>(&self, mut req: radar_ros::statement::ConnectionRequest<T>) -> PyResult<Arming> {
        if self.rearm {
            req = req.rearm();
        }
        if let Some(d) = self.depth {
            let Some(d) = std::num::NonZeroUsize::new(d) else {
                return Err(to_py(radar_ros::Error::InvalidStatement(
                    "a connection's QoS depth must be at least 1 (the default is 10)".into(),
                )));
            };
            req = req.depth(d);
        }
        if let Some(t) = self.timeout {
            req = req.timeout(t);
        }
        Ok(std::future::IntoFuture::into_future(req))
    }
}

/// One process's RADAR participant: a DDS participant, a connection manager, the components it spawns.
#[pyclass(module = "radar_ros._native", name = "Engine")]
pub(crate) struct PyEngine {
    pub(crate) engine: Option<Arc<Engine>>,
}

impl PyEngine {
    pub(crate) fn engine(&self) -> PyResult<&Arc<Engine>> {
        self.engine.as_ref().ok_or_else(|| {
            PyRuntimeError::new_err("this Radar was shut down: make a new one to go on")
        })
    }
}

pub(crate) fn policy(p: &str) -> PyResult<StartPolicy> {
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
        // the threads made from here on (the runtime's, the transport's) never take Ctrl-C or SIGTERM
        let _blocked = SignalsBlocked::here();
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("radar-engine")
            .on_thread_start(|| std::mem::forget(SignalsBlocked::here()))
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

    /// Spawns the response `name` whose slots are `runner`'s coroutine methods (its plain `*_inline` methods,
    /// called in the engine's task, if `inline`); `output_default` is what `exited` carries after a run that
    /// did not complete (the output type's default message).
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
        inline: bool,
    ) -> PyResult<Component> {
        let e = self.engine()?;
        let r = PyResponse {
            inline,
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
            trigger: None,
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

    /// Makes the connection `request` describes (`Statement.once(source).start(response)`, ...).
    #[pyo3(signature = (request, timeout=None, rearm=false, depth=None))]
    fn connect(
        &self,
        py: Python<'_>,
        mut request: PyRefMut<'_, Request>,
        timeout: Option<f64>,
        rearm: bool,
        depth: Option<usize>,
    ) -> PyResult<Connection> {
        let e = self.engine()?;
        let target = request.take()?;
        let source = request.source.rust();
        let st = match request.once {
            true => e.radar.once(source),
            false => e.radar.whenever(source),
        };
        let props = Props {
            rearm,
            depth,
            timeout: self::timeout(timeout)?,
        };
        let armed = match target {
            Target::Start { response, until } => {
                let req = st.start(&response);
                match until {
                    Some(u) => props.apply(req.until(u.rust()))?,
                    None => props.apply(req)?,
                }
            }
            Target::Interrupt(r) => props.apply(st.interrupt(&r))?,
            Target::Exit(r) => props.apply(st.exit(&r))?,
            Target::Slot(s) => props.apply(st.slot(s.rust()))?,
            Target::Call(deliver) => props.apply(st.call(move |m: DynMessage| {
                Python::attach(|py| {
                    if let Err(err) = deliver.bind(py).call1((PyBytes::new(py, m.0.as_bytes()),)) {
                        tracing::error!(error = %describe(py, &err), "anonymous slot: not delivered");
                    }
                })
            }))?,
        };
        let guard = e.wait(py, armed)?;
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
                forward_states::<EventState>(e, py, topic, deliver)?
            }
            (true, t) if t == ResponseState::ros_type_name() => {
                forward_states::<ResponseState>(e, py, topic, deliver)?
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

/// A task that hands every state message on `topic` (a component's latched state, typed `M`) to `deliver` as
/// its CDR bytes.
fn forward_states<M: radar_ros::msg::RosMessage>(
    e: &Engine,
    py: Python<'_>,
    topic: &str,
    deliver: Py<PyAny>,
) -> PyResult<tokio::task::JoinHandle<()>> {
    let sub = py
        .detach(|| e.radar.state_subscription::<M>(topic))
        .map_err(to_py)?;
    let t = sub.topic().to_owned();
    Ok(e.rt().spawn(async move {
        while let Ok(m) = sub.recv().await {
            if let Ok(raw) = RawMessage::encode(&m) {
                deliver_to(&deliver, raw.as_bytes(), &t);
            }
        }
    }))
}

/// SIGINT and SIGTERM blocked in the calling thread until this is dropped (the thread's mask before is put
/// back). A thread inherits its maker's mask, so threads made meanwhile never take these signals: the kernel
/// hands them to a thread that does not block them, and Python acts on them only in its main thread. Taken
/// by another thread (the engine's, the transport's), Python notes the signal but a main thread asleep in
/// `time.sleep` is not woken, and Ctrl-C seems to do nothing until the sleep ends.
struct SignalsBlocked(libc::sigset_t);

impl SignalsBlocked {
    fn here() -> SignalsBlocked {
        // SAFETY: sigset_t is plain data, initialised by sigemptyset; pthread_sigmask changes only this
        // thread's mask
        unsafe {
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            libc::sigaddset(&mut set, libc::SIGINT);
            libc::sigaddset(&mut set, libc::SIGTERM);
            let mut before: libc::sigset_t = std::mem::zeroed();
            libc::pthread_sigmask(libc::SIG_BLOCK, &set, &mut before);
            SignalsBlocked(before)
        }
    }
}

impl Drop for SignalsBlocked {
    fn drop(&mut self) {
        // SAFETY: puts back the mask pthread_sigmask gave, in the thread that took it
        unsafe {
            libc::pthread_sigmask(libc::SIG_SETMASK, &self.0, std::ptr::null_mut());
        }
    }
}
