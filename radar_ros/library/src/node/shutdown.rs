//! How components stop, and how a program told to stop stops: the exit slot always runs (rule R7).
//!
//! Every component (event, response, served action or manager, the program node) runs in a task that its
//! handle asks to stop; its participant also knows it ([`Components`]), so that the whole program can be
//! stopped at once. Three ways a program ends, and what each does:
//!
//! - **Told to stop** (SIGINT, SIGTERM: Ctrl-C, `ros2 launch`, systemd, docker). Unless
//!   [`RadarBuilder::handle_signals`](crate::RadarBuilder::handle_signals) says otherwise, the first `Radar` of
//!   the process installs a handler. On the first signal every component of every `Radar` is stopped: a
//!   running response's start behaviour ends as an `exit` signal would end it, its exit slot runs, `exited` and
//!   the final `state` are sent and acknowledged by their subscribers; then the participants leave the graph
//!   (peers see it at once) and the process exits with status 0. This takes at most the shutdown timeout
//!   ([`RadarBuilder::shutdown_timeout`](crate::RadarBuilder::shutdown_timeout), 5 s by default); what has not
//!   finished by then is named in an error line and the process exits with status 1. While it stops, more
//!   SIGINTs change nothing (a terminal's Ctrl-C reaches every process of a `ros2 launch`, and launch then sends
//!   each its own SIGINT: the exit slots must not be cut by that); a SIGTERM exits at once with status 143
//!   (launch sends it after its `sigterm_timeout`, 5 s by default; systemd and docker follow theirs with
//!   SIGKILL), and so does SIGKILL.
//! - **`main` returns** (or panics, or the runtime is dropped): the runtime drops every task. A response whose
//!   run was still going (its handle dropped at the end of `main` asked it to stop a moment before) finishes it
//!   while it is dropped: the exit slot runs on a thread of its own (with a runtime of its own, so it may
//!   await), `exited` and the state are sent, and the drop waits for that, at most the shutdown timeout. An exit
//!   slot that was cut short is run again from its start: it did not reach its end.
//! - **[`Radar::shutdown`](crate::Radar::shutdown)**: what a signal does, without ending the process.

use std::{
    sync::{
        atomic::{AtomicBool, Ordering},
        Arc, Mutex, OnceLock, Weak,
    },
    time::Duration,
};

use tokio::sync::{oneshot, watch};

/// How long a program told to stop waits for its components (exit slots included) unless told otherwise.
pub const DEFAULT_SHUTDOWN_TIMEOUT: Duration = Duration::from_secs(5);

/// One component's task as its participant sees it.
struct Entry {
    name: String,
    stop: Mutex<Option<oneshot::Sender<()>>>,
    done: watch::Receiver<bool>,
}

impl Entry {
    fn request_stop(&self) {
        if let Some(stop) = self.stop.lock().unwrap().take() {
            let _ = stop.send(());
        }
    }
}

/// Says a component's task has ended, when dropped: after the task's future, whichever way it ended.
struct Done(watch::Sender<bool>);

impl Drop for Done {
    fn drop(&mut self) {
        self.0.send_replace(true);
    }
}

/// The task behind a component handle: asks it to stop on drop, or stops it and waits.
pub(crate) struct ComponentTask {
    entry: Arc<Entry>,
    task: Option<tokio::task::JoinHandle<()>>,
}

impl ComponentTask {
    /// Spawns `f(stop)` for the component `name` of `components`, where `stop` resolves when the handle (or
    /// the participant) asks the component to stop, or the handle is dropped.
    pub(crate) fn spawn<F, Fut>(components: &Components, name: &str, f: F) -> ComponentTask
    where
        F: FnOnce(oneshot::Receiver<()>) -> Fut,
        Fut: std::future::Future<Output = ()> + Send + 'static,
    {
        let (stop, rx) = oneshot::channel();
        let (done_tx, done) = watch::channel(false);
        let entry = Arc::new(Entry {
            name: name.to_owned(),
            stop: Mutex::new(Some(stop)),
            done,
        });
        components.register(&entry);
        let done = Done(done_tx);
        let fut = f(rx);
        ComponentTask {
            entry,
            task: Some(tokio::spawn(tracing::Instrument::instrument(
                async move {
                    // `done` is declared before the future, so it is dropped after it, also when the runtime
                    // drops the task
                    let _done = done;
                    fut.await;
                },
                // what the component logs is its node's (crate::node::rosout)
                tracing::info_span!(crate::node::rosout::COMPONENT_SPAN, node = %name),
            ))),
        }
    }

    /// Asks the component to stop and waits until its task has ended.
    pub(crate) async fn stop_and_wait(mut self) {
        self.entry.request_stop();
        if let Some(task) = self.task.take() {
            let _ = task.await;
        }
    }

    /// What a handle's `shutdown` returns: asks the component to stop at once, and waits (unbounded unless
    /// `.timeout(d)`) until it has. Cancel safe: the stop has been asked for; a wait that is dropped or runs
    /// out leaves the component finishing on its own (its exit slot still runs).
    pub(crate) fn shutdown(self) -> crate::wait::Wait<'static, ()> {
        self.entry.request_stop();
        let what = format!("{} to stop", self.entry.name);
        crate::wait::Wait::signal(what, async move {
            self.stop_and_wait().await;
            Ok(())
        })
    }
}

impl Drop for ComponentTask {
    fn drop(&mut self) {
        self.entry.request_stop();
    }
}

/// The components of one participant, so that they can all be stopped at once.
#[derive(Default)]
pub(crate) struct Components {
    entries: Mutex<Registered>,
    /// Set once the participant is stopping: components make sure their last signals are acknowledged.
    stopping: AtomicBool,
}

/// The components registered, with the gone ones pruned when the list has doubled since the last pruning:
/// registering is constant time amortized (pruning on every one made spawning N components O(N^2)).
#[derive(Default)]
struct Registered {
    entries: Vec<Weak<Entry>>,
    prune_at: usize,
}

impl Registered {
    fn push(&mut self, e: Weak<Entry>) {
        if self.entries.len() >= self.prune_at {
            self.entries.retain(|e| e.strong_count() > 0);
            self.prune_at = (2 * self.entries.len()).max(64);
        }
        self.entries.push(e);
    }
}

impl Components {
    fn register(&self, e: &Arc<Entry>) {
        self.entries.lock().unwrap().push(Arc::downgrade(e));
    }

    fn live(&self) -> Vec<Arc<Entry>> {
        self.entries
            .lock()
            .unwrap()
            .entries
            .iter()
            .filter_map(Weak::upgrade)
            .collect()
    }

    /// Asks every component to stop.
    pub(crate) fn stop_all(&self) {
        self.stopping.store(true, Ordering::SeqCst);
        for e in self.live() {
            e.request_stop();
        }
    }

    /// Whether [`Components::stop_all`] was called: the participant is going.
    pub(crate) fn stopping(&self) -> bool {
        self.stopping.load(Ordering::SeqCst)
    }

    /// Waits until every component asked to stop has ended, at most until `deadline`; the names of those
    /// that had not.
    pub(crate) async fn wait_all(&self, deadline: tokio::time::Instant) -> Vec<String> {
        let mut late = Vec::new();
        for e in self.live() {
            let mut done = e.done.clone();
            let ended = tokio::time::timeout_at(deadline, done.wait_for(|d| *d)).await;
            if !matches!(ended, Ok(Ok(_))) {
                late.push(e.name.clone());
            }
        }
        late
    }
}

/// A participant as the process-wide stop sees it (implemented by the participant, which lives above).
pub(crate) trait Stoppable: Send + Sync {
    /// Its components.
    fn components(&self) -> &Components;
    /// How long its components may take to stop.
    fn shutdown_timeout(&self) -> Duration;
    /// Leaves the ROS graph now (the goodbye is sent), though handles to it may live on.
    fn leave(&self);
}

/// The participants of this process that a signal stops.
static PROCESS: Mutex<Vec<Weak<dyn Stoppable>>> = Mutex::new(Vec::new());

/// Whether this process's signal handler is installed.
static HANDLER: OnceLock<()> = OnceLock::new();

/// Makes `p` one of the participants a SIGINT or SIGTERM stops, and installs the handler if this is the first.
pub(crate) fn on_signals(p: Weak<dyn Stoppable>) -> std::io::Result<()> {
    {
        let mut all = PROCESS.lock().unwrap();
        all.retain(|p| p.strong_count() > 0);
        all.push(p);
    }
    if HANDLER.get().is_some() {
        return Ok(());
    }
    let mut result = Ok(());
    HANDLER.get_or_init(|| {
        if let Err(e) = install() {
            result = Err(e);
        }
    });
    result
}

/// The handler: a thread of its own with a small runtime, so that it works whatever the program's runtime is
/// doing (blocked, shutting down) and whichever runtime made the first `Radar`. The signals are registered
/// before this returns: one that comes right after is already handled.
fn install() -> std::io::Result<()> {
    use tokio::signal::unix::{signal, SignalKind};
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .thread_name("radar-signals")
        .build()?;
    let (mut int, mut term) = {
        let _in = rt.enter();
        (
            signal(SignalKind::interrupt())?,
            signal(SignalKind::terminate())?,
        )
    };
    std::thread::Builder::new()
        .name("radar-signals".into())
        .spawn(move || {
            rt.block_on(async move {
                let name = tokio::select! {
                    _ = int.recv() => "SIGINT",
                    _ = term.recv() => "SIGTERM",
                };
                // While stopping: more SIGINTs are the same request again (a terminal's Ctrl-C reaches every
                // process of its group, and `ros2 launch` then sends its own SIGINT to each child): the exit
                // slots go on. A SIGTERM ends the program at once (launch escalates to it after
                // `sigterm_timeout`; systemd and docker follow it with SIGKILL).
                tokio::spawn(async move {
                    let mut told = false;
                    loop {
                        tokio::select! {
                            _ = int.recv() => {
                                if !std::mem::replace(&mut told, true) {
                                    tracing::info!(
                                        "SIGINT again: already stopping, the exit slots go on (SIGTERM or \
                                         SIGKILL ends the program at once)"
                                    );
                                }
                            }
                            _ = term.recv() => break,
                        }
                    }
                    eprintln!("radar_ros: SIGTERM while stopping: exiting at once, exit slots not finished");
                    std::process::exit(143);
                });
                let status = stop_process(name).await;
                std::process::exit(status);
            })
        })?;
    Ok(())
}

/// Stops every participant a signal stops; the exit status.
async fn stop_process(signal: &str) -> i32 {
    let all: Vec<Arc<dyn Stoppable>> = PROCESS
        .lock()
        .unwrap()
        .iter()
        .filter_map(Weak::upgrade)
        .collect();
    let timeout = all
        .iter()
        .map(|p| p.shutdown_timeout())
        .max()
        .unwrap_or(DEFAULT_SHUTDOWN_TIMEOUT);
    tracing::info!(
        signal,
        "told to stop: stopping every component (exit slots run) within {timeout:?}; SIGTERM to exit at once"
    );
    let late = stop(&all, timeout).await;
    for p in &all {
        p.leave();
    }
    if late.is_empty() {
        tracing::info!("stopped");
        0
    } else {
        tracing::error!(
            "gave up after {timeout:?} waiting for {} to stop: their exit slots did not finish; raise \
             RadarBuilder::shutdown_timeout if they need longer",
            late.join(", ")
        );
        1
    }
}

/// Stops the components of `participants` and waits for them, at most `timeout`; those that did not end.
pub(crate) async fn stop(participants: &[Arc<dyn Stoppable>], timeout: Duration) -> Vec<String> {
    for p in participants {
        p.components().stop_all();
    }
    let deadline = tokio::time::Instant::now() + timeout;
    let mut late = Vec::new();
    for p in participants {
        late.extend(p.components().wait_all(deadline).await);
    }
    late
}

/// Runs `f` to completion on a thread of its own with a runtime of its own (the caller's runtime may be going
/// away), waiting at most `timeout`; whether it finished. For what must happen even while the program's runtime
/// drops its tasks: a response's exit slot (R7).
pub(crate) fn run_detached<F>(what: String, timeout: Duration, f: F) -> bool
where
    F: std::future::Future<Output = ()> + Send + 'static,
{
    let (tx, rx) = std::sync::mpsc::channel();
    let spawned = std::thread::Builder::new()
        .name("radar-exit".into())
        .spawn(move || {
            let rt = match tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            {
                Ok(rt) => rt,
                Err(e) => {
                    tracing::error!(error = %crate::error::Report(&e), "no runtime for {what}");
                    return;
                }
            };
            rt.block_on(f);
            // what the slot spawned goes too (it may hold the participant), before the caller goes on
            drop(rt);
            let _ = tx.send(());
        });
    match spawned {
        Ok(_) => rx.recv_timeout(timeout).is_ok(),
        Err(e) => {
            tracing::error!(error = %crate::error::Report(&e), "no thread to finish a response's run on");
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn stopping_all_components_waits_for_each_and_names_the_late_ones() {
        let components = Components::default();
        let quick = ComponentTask::spawn(&components, "/quick", |stop| async move {
            let _ = stop.await;
        });
        let slow = ComponentTask::spawn(&components, "/slow", |stop| async move {
            let _ = stop.await;
            tokio::time::sleep(Duration::from_secs(3600)).await;
        });
        assert!(!components.stopping());
        components.stop_all();
        assert!(components.stopping());
        let late = components
            .wait_all(tokio::time::Instant::now() + Duration::from_millis(200))
            .await;
        assert_eq!(late, ["/slow"]);
        drop((quick, slow));
    }

    #[tokio::test]
    async fn a_task_dropped_with_its_runtime_says_it_is_done() {
        let components = Components::default();
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .unwrap();
        let task = {
            let _in = rt.enter();
            ComponentTask::spawn(&components, "/r", |_stop| std::future::pending())
        };
        let done = components.live()[0].done.clone();
        assert!(!*done.borrow());
        std::thread::spawn(move || drop(rt)).join().unwrap();
        assert!(*done.borrow(), "dropped with the runtime");
        drop(task);
    }

    #[tokio::test]
    async fn the_registry_keeps_every_live_component_and_forgets_the_gone_ones() {
        let components = Components::default();
        let mut kept = Vec::new();
        for i in 0..5_000 {
            let t = ComponentTask::spawn(&components, &format!("/c{i}"), |stop| async move {
                let _ = stop.await;
            });
            // one in ten stays; the rest go at once
            if i % 10 == 0 {
                kept.push(t);
            }
        }
        let mut live: Vec<String> = components.live().iter().map(|e| e.name.clone()).collect();
        live.sort();
        let mut want: Vec<String> = (0..5_000).step_by(10).map(|i| format!("/c{i}")).collect();
        want.sort();
        assert_eq!(live, want, "every live component, and only those");
        // what is held for the gone ones stays within twice the live ones (and the first 64)
        let held = components.entries.lock().unwrap().entries.len();
        assert!(
            held <= 2 * kept.len() + 64,
            "{held} entries held for {} live",
            kept.len()
        );
        drop(kept);
    }

    #[test]
    fn run_detached_runs_async_code_to_the_end_or_gives_up() {
        let (tx, rx) = std::sync::mpsc::channel();
        assert!(run_detached(
            "a test".into(),
            Duration::from_secs(5),
            async move {
                tokio::time::sleep(Duration::from_millis(20)).await;
                tx.send(7).unwrap();
            }
        ));
        assert_eq!(rx.recv().unwrap(), 7);
        assert!(!run_detached(
            "a test".into(),
            Duration::from_millis(50),
            std::future::pending()
        ));
    }
}
