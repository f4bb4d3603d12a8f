//! Helpers shared by the examples: a timeline printer and log setup.

use std::time::Instant;

pub mod listing1;

/// Prints timestamped lines, `[  2.003 s] what`, relative to when it was created.
#[derive(Clone, Copy, Debug)]
pub struct Timeline {
    t0: Instant,
}

impl Timeline {
    /// A timeline starting now.
    pub fn start() -> Timeline {
        Timeline { t0: Instant::now() }
    }

    /// Seconds since the start.
    pub fn now(&self) -> f64 {
        self.t0.elapsed().as_secs_f64()
    }

    /// Prints one line; `listing` is when the paper's listing says it should happen.
    pub fn mark(&self, what: &str, listing: Option<f64>) {
        match listing {
            Some(l) => println!("[{:7.3} s] {what:<34} (listing: {l:.1} s)", self.now()),
            None => println!("[{:7.3} s] {what}", self.now()),
        }
    }
}

/// Logs warnings and errors to stderr (`RUST_LOG` for more).
pub fn init_logs() {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "warn,rustdds=error,ros2_client::distributions=error,ros2_client::service::wrappers=error".into()),
        )
        .with_writer(std::io::stderr)
        .try_init();
}
