//! The radar_ros engine as the Python package `radar_ros`: this crate is its native part,
//! `radar_ros._native`; `python/radar_ros/__init__.py` is the API users import.
//!
//! What lives here: the participant and its tokio runtime, lookups, connections, waiters and injection
//! (all the engine's own code, with payloads as CDR bytes), and the Rust side of Python components: a
//! [`Response`](radar_ros::Response) and an [`Event`](radar_ros::Event) whose slots are Python coroutines. The response state machine, the relays
//! and the wire stay in Rust; Python code runs only inside slots.
//!
//! Threads: the engine runs on its own tokio runtime. Python slots run on an asyncio event loop the Python
//! side owns (a thread of its own), handed here when the `Radar` is made: a slot call schedules a coroutine
//! there and awaits its result without holding the GIL; cancelling the slot (an interrupt) cancels the
//! coroutine at its current `await`, as dropping a Rust slot's future does. Blocking calls release the GIL
//! and wake every 100 ms to let Python raise `KeyboardInterrupt`.
//!
//! Modules, each using only those listed after it: `engine` (the `Engine` class: lookups, spawning,
//! connections, waiters, injection, subscriptions), `components` (Python slots as a Rust [`Response`](radar_ros::Response) and
//! [`Event`](radar_ros::Event)), `statement` (a connection described before it is made: `Statement.once(source).start(r, until)`
//! and the other target kinds, each its own method), `handles` (what `Engine` hands out: signals, slots,
//! references, connections, waiters), `runtime` (the engine's participant, runtime and how a call waits on
//! it), `slot_loop`, `errors`, `rosidl`.

mod components;
mod engine;
mod errors;
mod handles;
mod rosidl;
mod runtime;
mod slot_loop;
mod statement;

use pyo3::{exceptions::PyRuntimeError, prelude::*, types::PyBytes};
use radar_ros::topics::RawMessage;

use crate::{
    engine::PyEngine,
    handles::{Component, Connection, EventRef, ResponseRef, Signal, Slot, Subscription, Waiter},
};

pub(crate) fn init_logs() {
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
    let raw = radar_ros::codec::encode(ros_type, json).map_err(payload_error)?;
    Ok(PyBytes::new(py, raw.as_bytes()))
}

/// The package's `PayloadTypeError` saying `e`.
pub(crate) fn payload_error(e: String) -> PyErr {
    Python::attach(|py| {
        py.import("radar_ros._errors")
            .and_then(|m| m.getattr("PayloadTypeError"))
            .and_then(|cls| cls.call1((e.clone(),)))
            .map(PyErr::from_value)
            .unwrap_or_else(|_| PyRuntimeError::new_err(e))
    })
}

/// A message of `ros_type` (CDR bytes) as JSON; None for a type without a dict form here.
#[pyfunction]
fn decode_json(ros_type: &str, body: Vec<u8>) -> Option<String> {
    if !radar_ros::codec::has_dict_form(ros_type) {
        return None;
    }
    let v = radar_ros::codec::decode(ros_type, &RawMessage::from_bytes(body));
    Some(v.to_string())
}

/// Whether `ros_type` converts to and from dicts here: a type radar_ros knows, or one whose definition is found
/// (`AMENT_PREFIX_PATH`, or a directory given with `add_interfaces_dir`).
#[pyfunction]
fn has_dict_form(ros_type: &str) -> bool {
    radar_ros::codec::has_dict_form(ros_type)
}

/// Looks for message definitions in `path` too (`<pkg>/msg/<Name>.msg`, ...), before `AMENT_PREFIX_PATH`.
#[pyfunction]
fn add_interfaces_dir(path: std::path::PathBuf) {
    radar_ros::codec::add_interfaces_dir(path);
}

/// The native part of the `radar_ros` Python package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(dict_types, m)?)?;
    m.add_function(wrap_pyfunction!(encode_json, m)?)?;
    m.add_function(wrap_pyfunction!(decode_json, m)?)?;
    m.add_function(wrap_pyfunction!(has_dict_form, m)?)?;
    m.add_function(wrap_pyfunction!(add_interfaces_dir, m)?)?;
    m.add_function(wrap_pyfunction!(rosidl::rosidl_codec, m)?)?;
    m.add_class::<rosidl::RosidlCodec>()?;
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
    m.add_class::<statement::Statement>()?;
    m.add_class::<statement::Request>()?;
    Ok(())
}
