//! What every verb uses: errors as messages, where answers go, discovery, the newest state of a component,
//! and when to stop.

use std::{io::IsTerminal, time::Duration};

use radar_ros::{
    graph::Component,
    msg::{EventState, ResponseState},
    Radar,
};
use serde_json::Value;

/// A verb's result: its error is printed after `radar: `, with its causes.
pub(crate) type Fallible<T> = Result<T, crate::Error>;

pub(crate) fn secs(s: f64) -> Fallible<Duration> {
    if s.is_finite() && s > 0.0 {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(format!("{s} is not a number of seconds above 0").into())
    }
}

/// Where answers go: text for people, JSON lines for scripts.
pub(crate) struct Out {
    /// JSON lines instead of text.
    pub(crate) json: bool,
}

impl Out {
    pub(crate) fn colour(&self) -> bool {
        !self.json && std::io::stdout().is_terminal() && std::env::var_os("NO_COLOR").is_none()
    }
    pub(crate) fn bold(&self, s: &str) -> String {
        if self.colour() {
            format!("\x1b[1m{s}\x1b[0m")
        } else {
            s.to_owned()
        }
    }
}

/// Shows a status line on stderr while `f` runs longer than a second (discovery), when stderr is a terminal.
pub(crate) async fn with_status<T>(what: &str, f: impl std::future::IntoFuture<Output = T>) -> T {
    let show = std::io::stderr().is_terminal();
    let f = f.into_future();
    tokio::pin!(f);
    tokio::select! {
        t = &mut f => return t,
        _ = tokio::time::sleep(Duration::from_secs(1)), if show => eprint!("\r{what} ..."),
    }
    let t = f.await;
    eprint!("\r\x1b[2K");
    t
}

/// Lets discovery run: at least one participant-announcement period (others answer a new participant at
/// their next announcement), then until it has been quiet for 300 ms, at most `discovery` in all.
pub(crate) async fn discover(radar: &Radar, discovery: Duration) {
    let first = discovery.min(Duration::from_millis(800));
    tokio::time::sleep(first).await;
    // the limit running out only means the graph is as settled as it got
    let _ = radar
        .introspect()
        .settle(Duration::from_millis(300))
        .timeout(discovery.saturating_sub(first))
        .await;
}

/// The newest sample of a transient-local topic (a state, a connection list): subscribes, waits for the
/// publisher's match, then for the sample it keeps; `None` if either takes longer than `within`.
pub(crate) async fn latest<M: radar_ros::msg::RosMessage>(
    radar: &Radar,
    topic: &str,
    within: Duration,
) -> Option<M> {
    let s = radar.state_subscription::<M>(topic).ok()?;
    s.wait_for_publishers(1).timeout(within).await.ok()?;
    s.recv().timeout(within).await.ok()
}

/// The current state of a component, from its transient-local state topic (`None` if none came in `within`).
pub(crate) async fn state_of(radar: &Radar, c: &Component, within: Duration) -> Option<Value> {
    let topic = c.name().topic("state");
    match c {
        Component::Event(_) => {
            serde_json::to_value(latest::<EventState>(radar, &topic, within).await?).ok()
        }
        Component::Response(_) => {
            serde_json::to_value(latest::<ResponseState>(radar, &topic, within).await?).ok()
        }
    }
}

pub(crate) fn state_summary(c: &Component, s: &Value) -> String {
    match c {
        Component::Event(_) => format!(
            "{}, {} triggers, {} listeners",
            if s["active"] == true {
                "active"
            } else {
                "inactive"
            },
            s["triggers"],
            s["listeners"]
        ),
        Component::Response(_) => format!(
            "{}, {} starts, {} exits ({})",
            s["state_label"].as_str().unwrap_or("?"),
            s["starts"],
            s["exits"],
            s["last_exit_reason"]
                .as_str()
                .filter(|r| !r.is_empty())
                .unwrap_or("-")
        ),
    }
}

pub(crate) fn epoch_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or_default()
}

pub(crate) fn stamp_ns(t: &radar_ros::msg::Time) -> i64 {
    t.sec as i64 * 1_000_000_000 + t.nanosec as i64
}

/// Ctrl-C (SIGINT) and SIGTERM (`timeout`, systemd, docker, a launch file's shutdown), caught from the moment
/// this is made: a verb that runs until told to stop makes one first, so a stop that comes early is not lost.
pub(crate) struct Stop {
    #[cfg(unix)]
    interrupt: tokio::signal::unix::Signal,
    #[cfg(unix)]
    terminate: tokio::signal::unix::Signal,
}

impl Stop {
    /// Catches SIGINT and SIGTERM from now on (they no longer end the process by themselves).
    pub(crate) fn catch() -> Fallible<Stop> {
        #[cfg(unix)]
        {
            use tokio::signal::unix::{signal, SignalKind};
            let err = |e: std::io::Error| crate::Error::io("catch Ctrl-C and SIGTERM", e);
            Ok(Stop {
                interrupt: signal(SignalKind::interrupt()).map_err(err)?,
                terminate: signal(SignalKind::terminate()).map_err(err)?,
            })
        }
        #[cfg(not(unix))]
        Ok(Stop {})
    }

    /// Resolves at the next SIGINT or SIGTERM.
    pub(crate) async fn requested(&mut self) {
        #[cfg(unix)]
        tokio::select! {
            _ = self.interrupt.recv() => {}
            _ = self.terminate.recv() => {}
        }
        #[cfg(not(unix))]
        {
            let _ = tokio::signal::ctrl_c().await;
        }
    }

    /// Resolves after `duration` seconds, or when asked to stop, whichever comes first.
    pub(crate) async fn after(&mut self, duration: Option<f64>) {
        match duration {
            Some(d) => tokio::select! {
                _ = tokio::time::sleep(Duration::from_secs_f64(d.max(0.0))) => {}
                _ = self.requested() => {}
            },
            None => self.requested().await,
        }
    }
}
