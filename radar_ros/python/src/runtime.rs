//! The engine of one `Radar` (its participant, its runtime, the loop Python slots run on) and how a call from
//! Python waits on it: what `Engine` (engine.rs) and the handles it gives out (handles.rs) both use.

use std::{future::Future, time::Duration};

use pyo3::prelude::*;

use crate::slot_loop::SlotLoop;

/// The engine of one `Radar`: its participant, runtime and the loop Python slots run on.
pub(crate) struct Engine {
    pub(crate) radar: radar_ros::Radar,
    pub(crate) rt: Option<tokio::runtime::Runtime>,
    pub(crate) slots: SlotLoop,
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

pub(crate) use crate::errors::to_py;

impl Engine {
    pub(crate) fn rt(&self) -> &tokio::runtime::Runtime {
        self.rt
            .as_ref()
            .expect("the runtime lives as long as the engine")
    }

    /// Runs `fut` to its end on the runtime with the GIL released, letting Python raise (Ctrl-C) every
    /// 100 ms; a raise drops `fut`. Refused on one of the engine's own threads (an inline slot's): it would
    /// wait there for work that thread has to do.
    pub(crate) fn wait<T: Send>(
        &self,
        py: Python<'_>,
        fut: impl Future<Output = radar_ros::Result<T>> + Send,
    ) -> PyResult<T> {
        if tokio::runtime::Handle::try_current().is_ok() {
            return Err(crate::errors::InvalidArgument::new_err(
                "a blocking call (lookup, connection, waitfor, inject, recv) in an inline slot, on the \
                 engine's own thread, would stall the engine: make it from a plain or async def slot \
                 (Response.inline False), or from the program's own threads",
            ));
        }
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

/// A timeout given from Python in seconds (`None`: the call's default).
pub(crate) fn timeout(t: Option<f64>) -> PyResult<Option<Duration>> {
    t.map(|s| {
        Duration::try_from_secs_f64(s).map_err(|_| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "timeout {s}: give seconds, 0 or more (None: the default)"
            ))
        })
    })
    .transpose()
}
