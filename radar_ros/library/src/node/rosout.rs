//! Logs on `/rosout`, as rclcpp and rclpy nodes send theirs, so `ros2 topic echo /rosout` and `rqt_console`
//! show what radar_ros components say.
//!
//! radar_ros logs through [`tracing`]; a program adds [`layer`] to its subscriber (beside the one that prints
//! to stderr), and every `Radar` of the process publishes what the layer takes on `/rosout`
//! (`rcl_interfaces/msg/Log`, rcl's QoS: reliable, transient-local, keep-last 1000, 10 s lifespan) from its
//! program node:
//!
//! ```no_run
//! use tracing_subscriber::prelude::*;
//! tracing_subscriber::registry()
//!     .with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr))
//!     .with(radar_ros::rosout::layer())
//!     .init();
//! ```
//!
//! - **Which node a line belongs to** (the message's `name`, rcl's logger name: `robot1.count_up` for
//!   `/robot1/count_up`): the component whose slot, check or task logged it (its task runs in a
//!   `radar_component` span), or the component a library line names (`response = ...`, `event = ...`), else the
//!   program node.
//! - **Level**: info and above, or what `--ros-args --log-level` says (`debug`, `warn`, ...). Lines of the
//!   transport (`rustdds`, `ros2_client` targets) are not sent: publishing them would log again.
//! - Before any `Radar` exists, and after the last one is gone, lines are not sent (stderr still has them). With
//!   several `Radar`s in a process, the oldest one still alive publishes.

use std::sync::Mutex;

use ros2_client::log::Log;
use tracing::{field::Visit, Subscriber};
use tracing_subscriber::{layer::Context, registry::LookupSpan, Layer};

use crate::{
    error::Result,
    node::endpoints::{publisher, Watched},
};

/// The span every component's task runs in; its `node` field names the component's node.
pub(crate) const COMPONENT_SPAN: &str = "radar_component";

/// What a `Radar` publishes, and the program node lines without a component go to.
struct Sink {
    id: u64,
    tx: tokio::sync::mpsc::UnboundedSender<Log>,
    program: String,
}

static SINKS: Mutex<Vec<Sink>> = Mutex::new(Vec::new());

/// The `tracing` layer that sends log lines to `/rosout` (see the [module docs](self)), at info and above or
/// the process's `--log-level`.
pub fn layer<S>() -> impl Layer<S> + Send + Sync + 'static
where
    S: Subscriber + for<'a> LookupSpan<'a>,
{
    let level = crate::node::ros_args::RosArgs::from_env()
        .ok()
        .and_then(|a| a.log_level())
        .unwrap_or(crate::node::ros_args::LogLevel::Info);
    layer_at(level)
}

/// [`layer`] sending `level` and above.
pub fn layer_at<S>(level: crate::node::ros_args::LogLevel) -> impl Layer<S> + Send + Sync + 'static
where
    S: Subscriber + for<'a> LookupSpan<'a>,
{
    let min = severity_of_level(level);
    // a filter of this layer only: what it leaves out is still there for the program's other layers, and
    // what no layer wants (the transport's debug lines) is never even formatted
    RosoutLayer.with_filter(tracing_subscriber::filter::filter_fn(move |meta| {
        if meta.is_span() {
            meta.name() == COMPONENT_SPAN
        } else {
            severity(meta.level()) >= min
                && !meta.target().starts_with("rustdds")
                && !meta.target().starts_with("ros2_client")
        }
    }))
}

/// The layer behind [`layer`]; its filter (in [`layer_at`]) picks the lines.
#[derive(Clone, Debug)]
struct RosoutLayer;

fn severity_of_level(l: crate::node::ros_args::LogLevel) -> u8 {
    use crate::node::ros_args::LogLevel as L;
    match l {
        L::Debug => Log::DEBUG,
        L::Unset | L::Info => Log::INFO,
        L::Warn => Log::WARN,
        L::Error => Log::ERROR,
        L::Fatal => Log::FATAL,
    }
}

fn severity(l: &tracing::Level) -> u8 {
    match *l {
        tracing::Level::TRACE | tracing::Level::DEBUG => Log::DEBUG,
        tracing::Level::INFO => Log::INFO,
        tracing::Level::WARN => Log::WARN,
        tracing::Level::ERROR => Log::ERROR,
    }
}

/// rcl's logger name of the node `fq`: `/robot1/count_up` -> `robot1.count_up`.
fn logger_name(fq: &str) -> String {
    fq.trim_start_matches('/').replace('/', ".")
}

/// The component node a span names.
struct NodeOf(String);

/// The fields of a line: its message, the other fields as ` k=v`, and a component it names.
#[derive(Default)]
struct Fields {
    message: String,
    rest: String,
    node: Option<String>,
}

impl Visit for Fields {
    fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
        self.record_str(field, &format!("{value:?}"));
    }

    fn record_str(&mut self, field: &tracing::field::Field, value: &str) {
        match field.name() {
            "message" => self.message = value.to_owned(),
            name => {
                if matches!(name, "response" | "event" | "node" | "component")
                    && self.node.is_none()
                {
                    self.node = Some(value.to_owned());
                }
                self.rest.push_str(&format!(" {name}={value}"));
            }
        }
    }
}

impl<S> Layer<S> for RosoutLayer
where
    S: Subscriber + for<'a> LookupSpan<'a>,
{
    fn on_new_span(
        &self,
        attrs: &tracing::span::Attributes<'_>,
        id: &tracing::span::Id,
        ctx: Context<'_, S>,
    ) {
        if attrs.metadata().name() != COMPONENT_SPAN {
            return;
        }
        let mut f = Fields::default();
        attrs.record(&mut f);
        if let (Some(node), Some(span)) = (f.node, ctx.span(id)) {
            span.extensions_mut().insert(NodeOf(node));
        }
    }

    fn on_event(&self, event: &tracing::Event<'_>, ctx: Context<'_, S>) {
        let meta = event.metadata();
        let mut f = Fields::default();
        event.record(&mut f);
        let node = f.node.clone().or_else(|| {
            ctx.event_scope(event)?
                .find_map(|span| span.extensions().get::<NodeOf>().map(|n| n.0.clone()))
        });
        let sinks = SINKS.lock().unwrap();
        let Some(sink) = sinks.first() else {
            return;
        };
        let name = logger_name(node.as_deref().unwrap_or(&sink.program));
        let _ = sink.tx.send(Log {
            stamp: ros2_client::builtin_interfaces::Time::now(),
            level: severity(meta.level()),
            name,
            msg: format!("{}{}", f.message, f.rest),
            file: meta.file().unwrap_or_default().to_owned(),
            function: meta.module_path().unwrap_or_default().to_owned(),
            line: meta.line().unwrap_or_default(),
        });
    }
}

/// A `Radar`'s `/rosout` writer and the task that feeds it; dropping it stops both.
pub(crate) struct Publishing {
    id: u64,
    task: tokio::task::JoinHandle<()>,
}

impl Drop for Publishing {
    fn drop(&mut self) {
        SINKS.lock().unwrap().retain(|s| s.id != self.id);
        self.task.abort();
    }
}

/// The `/rosout` writer of the program node `node`.
pub(crate) fn writer(
    graph: &crate::graph::Graph,
    node: &mut crate::node::transport::RosNode,
) -> Result<Watched<crate::node::transport::Publisher<Log>>> {
    let ty = crate::wire::raw::parse_type_name("rcl_interfaces/msg/Log")?;
    publisher(graph, node, "/rosout", &ty, &crate::wire::qos::rosout_qos())
}

/// Starts publishing the layer's lines with `writer` ([`writer`]) of the program node `program` (fully
/// qualified).
pub(crate) fn start(
    writer: Watched<crate::node::transport::Publisher<Log>>,
    program: &str,
) -> Publishing {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Log>();
    let id = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    SINKS.lock().unwrap().push(Sink {
        id,
        tx,
        program: program.to_owned(),
    });
    let task = tokio::spawn(async move {
        while let Some(line) = rx.recv().await {
            // no logging here: it would come back through the layer
            let _ = writer.publish(line);
        }
    });
    Publishing { id, task }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logger_names_are_rcls() {
        assert_eq!(logger_name("/robot1/count_up"), "robot1.count_up");
        assert_eq!(logger_name("/count_up"), "count_up");
    }
}
