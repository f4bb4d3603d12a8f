//! `radar`: RADAR on a ROS 2 graph from the shell, with no ROS installation (like OpenRTM's rtshell).
//!
//! ```text
//! radar ls [NS] [-l]                       events and responses, their types and state     (rtls)
//! radar cat NAME                           one component: topics, state, connections        (rtcat)
//! radar act start|interrupt|exit NAME [P]  drive a response, show the signal that follows   (rtact)
//! radar inject TOPIC [PAYLOAD]             publish into a slot                              (rtinject)
//! radar watch [NAMES]                      a live timeline of signals and state changes     (rtprint)
//! radar con once|whenever SOURCE SLOT      connect through a manager's services             (rtcon)
//! radar dis ID                             remove a detached connection                     (rtdis)
//! radar graph [-o FILE.svg|FILE.dot]       components and live connections as a picture     (rtstodot)
//! radar record -o FILE.mcap [NAMES]        signals and state changes to MCAP (ros2msg/cdr)  (rtlog)
//! radar replay FILE.mcap [--rate R]        publish the recorded signals with their timing   (rtlog)
//! ```
//!
//! Every verb honours `ROS_DOMAIN_ID`, takes `--json` (one JSON document per line) and exits non-zero with a
//! message that says what to do when something is wrong.

#[path = "../cli/codec.rs"]
mod codec;
#[path = "../cli/graph.rs"]
mod graph;
#[path = "../cli/schemas.rs"]
mod schemas;

use std::{collections::BTreeMap, io::IsTerminal, time::Duration};

use clap::{Parser, Subcommand, ValueEnum};
use radar_ros::{
    msg::{ConnectionList, EventState, ResponseState},
    Component, Radar,
};
use serde_json::{json, Value};

#[derive(Parser)]
#[command(
    name = "radar",
    version,
    about = "RADAR on ROS 2 from the shell: see events, responses and connections, and drive them",
    after_help = "The ROS 2 domain is ROS_DOMAIN_ID's (default 0). Payloads are YAML, as `ros2 topic pub` takes them."
)]
struct Cli {
    /// Print JSON, one document per line, for scripts.
    #[arg(long, global = true)]
    json: bool,
    /// Seconds to let discovery run before answering.
    #[arg(long, global = true, default_value_t = 1.5, value_name = "SECONDS")]
    discovery: f64,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// List the events and responses on the graph, by namespace (like rtls).
    Ls {
        /// Only names in this namespace (e.g. /robot).
        namespace: Option<String>,
        /// Also each one's current state (from its state topic).
        #[arg(short = 'l', long)]
        long: bool,
    },
    /// Show one component: topics, types, state, and every program's connections touching it (like rtcat).
    Cat {
        /// The event or response, e.g. /count_up.
        name: String,
    },
    /// Send start, interrupt or exit to a response and show the signal that follows (like rtact).
    Act {
        /// Which slot.
        slot: ActSlot,
        /// The response, e.g. /count_up.
        name: String,
        /// The start payload as YAML (default: the type's default), e.g. "{data: kitchen}".
        payload: Option<String>,
        /// Seconds to wait for the response and for the signal.
        #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
        timeout: f64,
    },
    /// Publish a payload into a slot topic, once its subscriber is matched (like rtinject).
    Inject {
        /// The topic, e.g. /count_up/start.
        topic: String,
        /// The payload as YAML (default: the type's default).
        payload: Option<String>,
        /// Seconds to wait for a subscriber.
        #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
        timeout: f64,
    },
    /// A live timeline of the signals and state changes of every component, or those named (like rtprint).
    ///
    /// Times are relative to when watching began. Events are watched through their state topics, so watching does
    /// not make them check; --activate listens to their triggered signal instead (and so activates them).
    Watch {
        /// Components to watch (default: all, including ones that appear later).
        names: Vec<String>,
        /// Listen to events' triggered signals (this activates them) instead of their state topics.
        #[arg(long)]
        activate: bool,
        /// Stop after this many seconds (default: until Ctrl-C).
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
    },
    /// Connect a signal to a slot through a manager's services (like rtcon).
    ///
    /// The connection lives while this command runs (Ctrl-C ends it), or with --detach under the manager until `radar dis`.
    Con {
        /// once or whenever.
        kind: ConKind,
        /// The source signal topic, e.g. /bumper/triggered.
        source: String,
        /// The target slot topic, e.g. /dock/start.
        slot: String,
        /// Interrupt the started run when this signal comes (only with a start slot).
        #[arg(long, value_name = "SIGNAL")]
        until: Option<String>,
        /// The manager node (default: the only one on the graph).
        #[arg(long, value_name = "NODE")]
        manager: Option<String>,
        /// Leave the connection under the manager and exit at once.
        #[arg(long)]
        detach: bool,
        /// Without --detach: end after this many seconds (default: until Ctrl-C).
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
    },
    /// The components and the live connections of every program as a picture (like rtstodot, but live).
    ///
    /// SVG drawn here (no Graphviz needed) or Graphviz DOT; whenever solid, once dashed, until dotted red,
    /// active events and running responses filled. Without -o: DOT on stdout (JSON with --json).
    Graph {
        /// Write here; .svg or .dot.
        #[arg(short = 'o', long = "output", value_name = "FILE")]
        output: Option<std::path::PathBuf>,
        /// Redraw every second until Ctrl-C (or --duration).
        #[arg(long)]
        watch: bool,
        /// With --watch: stop after this many seconds.
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
    },
    /// Record signals, their payloads and state changes to an MCAP file (like rtlog).
    ///
    /// With ROS 2 message schemas (ros2msg schemas, cdr messages, as rosbag2 writes them), so Foxglove and
    /// ros2 bag tooling open it. Events are recorded through their state topics unless --activate (which records triggered, and
    /// activates them). Types radar has schemas for: std_msgs basics, geometry_msgs Point, Quaternion, Pose,
    /// PoseStamped, builtin_interfaces Time, radar_msgs, test_msgs Fibonacci; others are skipped, said once.
    Record {
        /// The MCAP file to write.
        #[arg(short = 'o', long = "output", value_name = "FILE.mcap")]
        output: std::path::PathBuf,
        /// Components to record (default: all, including ones that appear later).
        names: Vec<String>,
        /// Record events' triggered signals (this activates them).
        #[arg(long)]
        activate: bool,
        /// Stop after this many seconds (default: until Ctrl-C).
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
    },
    /// Publish the signals recorded in an MCAP file again, with their timing (like rtlog).
    ///
    /// The states are not published, only the signals.
    Replay {
        /// The MCAP file.
        input: std::path::PathBuf,
        /// Speed: 2 plays twice as fast.
        #[arg(long, default_value_t = 1.0)]
        rate: f64,
        /// Seconds to wait for each topic's subscribers before playing.
        #[arg(long, default_value_t = 3.0, value_name = "SECONDS")]
        wait: f64,
    },
    /// Remove a connection made through a manager's services (like rtdis).
    Dis {
        /// The connection's id, as `radar con` or `radar cat` showed it.
        id: u64,
        /// The manager node (default: the only one on the graph).
        #[arg(long, value_name = "NODE")]
        manager: Option<String>,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum ConKind {
    Once,
    Whenever,
}

#[derive(Clone, Copy, ValueEnum)]
enum ActSlot {
    Start,
    Interrupt,
    Exit,
}

impl ActSlot {
    fn topic(self) -> &'static str {
        match self {
            ActSlot::Start => "start",
            ActSlot::Interrupt => "interrupt",
            ActSlot::Exit => "exit",
        }
    }
    /// The signal that shows the slot took effect.
    fn answer(self) -> &'static str {
        match self {
            ActSlot::Start => "started",
            ActSlot::Interrupt => "interrupted",
            ActSlot::Exit => "exited",
        }
    }
}

type Fallible<T> = Result<T, String>;

#[tokio::main]
async fn main() {
    let cli = Cli::parse();
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                "warn,rustdds=error,ros2_client::distributions=error,ros2_client::service::wrappers=error"
                    .into()
            }),
        )
        .with_writer(std::io::stderr)
        .try_init();
    if let Err(e) = run(cli).await {
        eprintln!("radar: {e}");
        std::process::exit(1);
    }
}

async fn run(cli: Cli) -> Fallible<()> {
    // one program node per invocation: several may run at once (a watch and an act)
    // the command line handles Ctrl-C itself (a watch prints its summary, a recording closes its file)
    let radar = Radar::builder()
        .program(&format!("radar_cli_{}", std::process::id()))
        .handle_signals(false)
        .build()
        .map_err(|e| e.to_string())?;
    let out = Out { json: cli.json };
    let discovery = Duration::from_secs_f64(cli.discovery.max(0.0));
    match cli.cmd {
        Cmd::Ls { namespace, long } => ls(&radar, &out, discovery, namespace, long).await,
        Cmd::Cat { name } => cat(&radar, &out, discovery, &name).await,
        Cmd::Act {
            slot,
            name,
            payload,
            timeout,
        } => {
            act(
                &radar,
                &out,
                slot,
                &name,
                payload.as_deref(),
                secs(timeout)?,
            )
            .await
        }
        Cmd::Inject {
            topic,
            payload,
            timeout,
        } => inject(&radar, &out, &topic, payload.as_deref(), secs(timeout)?).await,
        Cmd::Watch {
            names,
            activate,
            duration,
        } => watch(&radar, &out, names, activate, duration).await,
        Cmd::Con {
            kind,
            source,
            slot,
            until,
            manager,
            detach,
            duration,
        } => {
            let m = manager_of(&radar, discovery, manager).await?;
            let req = radar_ros::msg::ConnectRequest {
                kind: match kind {
                    ConKind::Once => radar_ros::msg::Connection::ONCE,
                    ConKind::Whenever => radar_ros::msg::Connection::WHENEVER,
                },
                source,
                target: slot,
                until: until.unwrap_or_default(),
                detach,
                ..Default::default()
            };
            let id = with_status("connecting", m.connect(req))
                .await
                .map_err(|e| e.to_string())?;
            if out.json {
                println!(
                    "{}",
                    json!({ "id": id, "manager": m.name(), "detached": detach })
                );
            } else if detach {
                println!(
                    "connection {id} under {} (`radar dis {id}` removes it)",
                    m.name()
                );
            } else {
                println!(
                    "connection {id} under {}, while this runs (Ctrl-C ends it)",
                    m.name()
                );
            }
            if !detach {
                match duration {
                    Some(d) => tokio::time::sleep(secs(d)?).await,
                    None => {
                        let _ = tokio::signal::ctrl_c().await;
                    }
                }
                // it would go when this process leaves the graph; say so at once
                m.disconnect(id).await.map_err(|e| e.to_string())?;
            }
            Ok(())
        }
        Cmd::Graph {
            output,
            watch,
            duration,
        } => draw(&radar, &out, discovery, output, watch, duration).await,
        Cmd::Record {
            output,
            names,
            activate,
            duration,
        } => record(&radar, &out, output, names, activate, duration).await,
        Cmd::Replay { input, rate, wait } => replay(&radar, &out, input, rate, secs(wait)?).await,
        Cmd::Dis { id, manager } => {
            let m = manager_of(&radar, discovery, manager).await?;
            m.disconnect(id).await.map_err(|e| e.to_string())?;
            if out.json {
                println!("{}", json!({ "removed": id, "manager": m.name() }));
            } else {
                println!("connection {id} removed from {}", m.name());
            }
            Ok(())
        }
    }
}

/// Every component with its state, and every program's connections.
async fn picture(radar: &Radar) -> graph::Picture {
    let components = radar.components();
    let states = futures::future::join_all(
        components
            .iter()
            .map(|c| state_of(radar, c, Duration::from_secs(3))),
    )
    .await;
    let mut p = graph::Picture::default();
    for (c, s) in components.iter().zip(states) {
        p.nodes.push(graph::Node {
            name: c.name().fully_qualified(),
            kind: c.kind().into(),
            active: s.as_ref().and_then(|s| s["active"].as_bool()),
            state: s
                .as_ref()
                .and_then(|s| s["state_label"].as_str().map(str::to_owned)),
        });
    }
    let lists =
        futures::future::join_all(radar.connection_topics().into_iter().map(|t| async move {
            latest::<ConnectionList>(radar, &t, Duration::from_secs(3)).await
        }))
        .await;
    for list in lists.into_iter().flatten() {
        for k in list.connections {
            let (source, signal) = graph::split(&k.source);
            let (target, slot) = graph::split(&k.target);
            p.edges.push(graph::Edge {
                id: k.id,
                program: list.manager.clone(),
                kind: k.kind_label.clone(),
                source,
                signal,
                target,
                slot,
                until: (!k.until.is_empty()).then(|| graph::split(&k.until).0),
                state: k.state_label.clone(),
            });
        }
    }
    // a manager node and its program node show the same connections: keep one of each
    p.edges.sort_by(|a, b| {
        (a.id, &a.source, &a.target, &a.program).cmp(&(b.id, &b.source, &b.target, &b.program))
    });
    p.edges.dedup_by(|a, b| {
        (a.id, &a.source, &a.target, &a.kind) == (b.id, &b.source, &b.target, &b.kind)
    });
    p.complete();
    p
}

async fn draw(
    radar: &Radar,
    out: &Out,
    discovery: Duration,
    output: Option<std::path::PathBuf>,
    watch: bool,
    duration: Option<f64>,
) -> Fallible<()> {
    let svg = match output
        .as_ref()
        .and_then(|p| p.extension())
        .and_then(|e| e.to_str())
    {
        Some("svg") => true,
        Some("dot") | Some("gv") => false,
        None if output.is_none() => false,
        _ => return Err("the output file ends in .svg or .dot".into()),
    };
    with_status("discovering", discover(radar, discovery)).await;
    let end = tokio::time::Instant::now()
        + duration
            .map(Duration::from_secs_f64)
            .unwrap_or(Duration::from_secs(u64::MAX / 4));
    loop {
        let p = picture(radar).await;
        let text = if svg { p.svg() } else { p.dot() };
        match &output {
            Some(path) => std::fs::write(path, &text)
                .map_err(|e| format!("could not write {}: {e}", path.display()))?,
            None if !out.json => print!("{text}"),
            None => {}
        }
        if out.json {
            println!("{}", serde_json::to_string(&p).map_err(|e| e.to_string())?);
        } else if let Some(path) = &output {
            if !watch {
                println!(
                    "{}: {} components, {} connections",
                    path.display(),
                    p.nodes.len(),
                    p.edges.len()
                );
            }
        }
        if !watch || tokio::time::Instant::now() >= end {
            return Ok(());
        }
        tokio::select! {
            _ = tokio::time::sleep_until(end.min(tokio::time::Instant::now() + Duration::from_secs(1))) => {}
            _ = tokio::signal::ctrl_c() => return Ok(()),
        }
    }
}

/// The manager named, or the only one on the graph; its services matched.
async fn manager_of(
    radar: &Radar,
    discovery: Duration,
    named: Option<String>,
) -> Fallible<radar_ros::RemoteManager> {
    let name = match named {
        Some(n) => n,
        None => {
            with_status("discovering", discover(radar, discovery)).await;
            let found = radar.managers();
            match found.len() {
                1 => found.into_iter().next().expect("one"),
                0 => {
                    return Err(
                        "no connection manager on the graph: start one (`radar_manager`, or serve_manager in a \
                         program), or name one with --manager"
                            .into(),
                    )
                }
                _ => {
                    return Err(format!(
                        "several managers on the graph ({}): pick one with --manager",
                        found.join(", ")
                    ))
                }
            }
        }
    };
    with_status("waiting for the manager", radar.remote_manager(&name))
        .await
        .map_err(|e| e.to_string())
}

fn secs(s: f64) -> Fallible<Duration> {
    if s.is_finite() && s > 0.0 {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(format!("{s} is not a number of seconds above 0"))
    }
}

/// Where answers go: text for people, JSON lines for scripts.
struct Out {
    json: bool,
}

impl Out {
    fn colour(&self) -> bool {
        !self.json && std::io::stdout().is_terminal() && std::env::var_os("NO_COLOR").is_none()
    }
    fn bold(&self, s: &str) -> String {
        if self.colour() {
            format!("\x1b[1m{s}\x1b[0m")
        } else {
            s.to_owned()
        }
    }
}

/// Shows a status line on stderr while `f` runs longer than a second (discovery), when stderr is a terminal.
async fn with_status<T>(what: &str, f: impl std::future::IntoFuture<Output = T>) -> T {
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

fn in_namespace(name: &str, ns: &Option<String>) -> bool {
    match ns {
        None => true,
        Some(ns) => {
            let ns = ns.trim_end_matches('/');
            ns.is_empty() || name.starts_with(&format!("{ns}/"))
        }
    }
}

fn types_of(c: &Component) -> Value {
    match c {
        Component::Event(e) => json!({ "triggered": e.triggered().ros_type() }),
        Component::Response(r) => json!({
            "start": r.start_slot().ros_type(),
            "exited": r.exited().ros_type(),
        }),
    }
}

/// Lets discovery run: at least one participant-announcement period (others answer a new participant at
/// their next announcement), then until it has been quiet for 300 ms, at most `discovery` in all.
async fn discover(radar: &Radar, discovery: Duration) {
    let first = discovery.min(Duration::from_millis(800));
    tokio::time::sleep(first).await;
    radar
        .settle(Duration::from_millis(300), discovery.saturating_sub(first))
        .await;
}

/// The newest sample of a transient-local topic (a state, a connection list): subscribes, waits for the
/// publisher's match, then for the sample it keeps; `None` if either takes longer than `within`.
async fn latest<M: radar_ros::msg::RosMessage>(
    radar: &Radar,
    topic: &str,
    within: Duration,
) -> Option<M> {
    let s = radar.state_subscription::<M>(topic).ok()?;
    s.wait_for_publishers(1).timeout(within).await.ok()?;
    s.recv().timeout(within).await.ok()
}

/// The current state of a component, from its transient-local state topic (`None` if none came in `within`).
async fn state_of(radar: &Radar, c: &Component, within: Duration) -> Option<Value> {
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

fn state_summary(c: &Component, s: &Value) -> String {
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

async fn ls(
    radar: &Radar,
    out: &Out,
    discovery: Duration,
    namespace: Option<String>,
    long: bool,
) -> Fallible<()> {
    if let Some(ns) = &namespace {
        if !ns.starts_with('/') {
            return Err(format!("the namespace is absolute, e.g. /{ns}"));
        }
    }
    with_status("discovering", discover(radar, discovery)).await;
    let components: Vec<Component> = radar
        .components()
        .into_iter()
        .filter(|c| in_namespace(&c.name().fully_qualified(), &namespace))
        .collect();
    let states: Vec<Option<Value>> = if long {
        let futs = components
            .iter()
            .map(|c| state_of(radar, c, Duration::from_secs(2)));
        futures::future::join_all(futs).await
    } else {
        vec![None; components.len()]
    };
    if out.json {
        let list: Vec<Value> = components
            .iter()
            .zip(&states)
            .map(|(c, s)| {
                let mut v = json!({
                    "name": c.name().fully_qualified(),
                    "kind": c.kind(),
                    "types": types_of(c),
                });
                if long {
                    v["state"] = s.clone().unwrap_or(Value::Null);
                }
                v
            })
            .collect();
        println!("{}", Value::Array(list));
        return Ok(());
    }
    if components.is_empty() {
        println!(
            "no RADAR components in ROS_DOMAIN_ID {}{}",
            radar.domain_id(),
            namespace.map(|n| format!(" under {n}")).unwrap_or_default()
        );
        return Ok(());
    }
    let mut by_ns: BTreeMap<String, Vec<(&Component, &Option<Value>)>> = BTreeMap::new();
    for (c, s) in components.iter().zip(&states) {
        by_ns
            .entry(c.name().namespace().to_owned())
            .or_default()
            .push((c, s));
    }
    for (ns, cs) in by_ns {
        println!("{}", out.bold(&format!("{ns}:")));
        for (c, s) in cs {
            let types = match c {
                Component::Event(e) => e.triggered().ros_type().to_owned(),
                Component::Response(r) => {
                    format!("{} -> {}", r.start_slot().ros_type(), r.exited().ros_type())
                }
            };
            let mut line = format!("  {:<9} {:<28} {}", c.kind(), c.name().base(), types);
            if long {
                line.push_str(&format!(
                    "  [{}]",
                    s.as_ref()
                        .map(|s| state_summary(c, s))
                        .unwrap_or_else(|| "no state".into())
                ));
            }
            println!("{line}");
        }
    }
    Ok(())
}

/// The component `name`, waiting for discovery.
async fn find(radar: &Radar, discovery: Duration, name: &str) -> Fallible<Component> {
    let fq = radar.resolve(name).map_err(|e| e.to_string())?;
    let deadline = tokio::time::Instant::now() + discovery.max(Duration::from_secs(3));
    loop {
        if let Some(c) = radar.components().into_iter().find(|c| *c.name() == fq) {
            return Ok(c);
        }
        if tokio::time::Instant::now() >= deadline {
            let seen: Vec<String> = radar
                .components()
                .iter()
                .map(|c| c.name().fully_qualified())
                .collect();
            return Err(format!(
                "no event or response named {fq} on the graph (ROS_DOMAIN_ID {}); seen: {}",
                radar.domain_id(),
                if seen.is_empty() {
                    "none".to_owned()
                } else {
                    seen.join(", ")
                }
            ));
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

async fn cat(radar: &Radar, out: &Out, discovery: Duration, name: &str) -> Fallible<()> {
    let c = with_status("discovering", find(radar, discovery, name)).await?;
    with_status("discovering", discover(radar, discovery)).await;
    let state = state_of(radar, &c, Duration::from_secs(2)).await;
    let fq = c.name().fully_qualified();
    let prefix = format!("{fq}/");
    let touches = |t: &str| t.starts_with(&prefix);
    // every program's and manager's connections
    let lists =
        futures::future::join_all(radar.connection_topics().into_iter().map(|t| async move {
            latest::<ConnectionList>(radar, &t, Duration::from_secs(3)).await
        }))
        .await;
    let mut connections = Vec::new();
    for list in lists.into_iter().flatten() {
        for k in list.connections {
            if touches(&k.source) || touches(&k.target) || touches(&k.until) {
                connections.push((list.manager.clone(), k));
            }
        }
    }
    let mut topics: Vec<(String, &str, String)> = Vec::new();
    if let Component::Response(r) = &c {
        for slot in [r.start_slot(), r.interrupt_slot(), r.exit_slot()] {
            topics.push((slot.topic().to_owned(), "slot", slot.ros_type().to_owned()));
        }
    }
    for (topic, ty, _) in signal_topics(&c, true) {
        topics.push((topic, "signal", ty));
    }
    topics.push((c.name().topic("state"), "state", state_type(&c).to_owned()));
    if out.json {
        let v = json!({
            "name": fq,
            "kind": c.kind(),
            "topics": topics.iter().map(|(t, k, ty)| json!({"topic": t, "role": k, "type": ty})).collect::<Vec<_>>(),
            "state": state.clone().unwrap_or(Value::Null),
            "connections": connections.iter().map(|(p, k)| {
                let mut v = serde_json::to_value(k).unwrap_or(Value::Null);
                v["program"] = json!(p);
                v
            }).collect::<Vec<_>>(),
        });
        println!("{v}");
        return Ok(());
    }
    println!("{} ({})", out.bold(&fq), c.kind());
    for (t, k, ty) in &topics {
        println!("  {k:<6} {t:<36} {ty}");
    }
    match &state {
        Some(s) => {
            println!("  state: {}", state_summary(&c, s));
            if let Value::Object(m) = s {
                let counters: Vec<String> = m
                    .iter()
                    .filter(|(_, v)| v.is_u64())
                    .map(|(k, v)| format!("{k} {v}"))
                    .collect();
                println!("  counters: {}", counters.join(", "));
            }
        }
        None => println!("  state: none received"),
    }
    if connections.is_empty() {
        println!("  connections: none");
    }
    for (program, k) in &connections {
        let until = if k.until.is_empty() {
            String::new()
        } else {
            format!(" until {}", k.until)
        };
        println!(
            "  connection {} in {}: {} {} -> {}{} [{}], {} delivered, {} DDS hop(s)",
            k.id,
            program,
            k.kind_label,
            k.source,
            k.target,
            until,
            k.state_label,
            k.delivered,
            k.hops
        );
    }
    Ok(())
}

async fn act(
    radar: &Radar,
    out: &Out,
    slot: ActSlot,
    name: &str,
    payload: Option<&str>,
    timeout: Duration,
) -> Fallible<()> {
    let r = with_status(
        "looking for the response",
        radar.response(name).timeout(timeout),
    )
    .await
    .map_err(|e| e.to_string())?;
    let (slot_ref, answer) = match slot {
        ActSlot::Start => (r.start_slot(), r.started()),
        ActSlot::Interrupt => (r.interrupt_slot(), r.interrupted()),
        ActSlot::Exit => (r.exit_slot(), r.exited()),
    };
    if payload.is_some() && !matches!(slot, ActSlot::Start) {
        return Err(format!(
            "only start takes a payload; {} does not",
            slot.topic()
        ));
    }
    let raw = codec::encode(slot_ref.ros_type(), payload.unwrap_or(""))?;
    let signal = radar
        .raw_subscription(answer.topic(), answer.ros_type())
        .map_err(|e| e.to_string())?;
    let state = radar
        .state_subscription::<ResponseState>(&r.name().topic("state"))
        .map_err(|e| e.to_string())?;
    let publisher = radar
        .raw_publisher(slot_ref.topic(), slot_ref.ros_type())
        .map_err(|e| e.to_string())?;
    let ready = async {
        publisher.wait_for_subscribers(1).timeout(timeout).await?;
        signal.wait_for_publishers(1).timeout(timeout).await
    };
    with_status("waiting for the match", ready)
        .await
        .map_err(|e| e.to_string())?;
    // the state before, to say why if nothing comes (responses in other libraries may have no state topic)
    let has_state = state
        .wait_for_publishers(1)
        .timeout(timeout.min(Duration::from_secs(1)))
        .await
        .is_ok();
    let before = match has_state {
        true => state.recv().timeout(timeout).await.ok(),
        false => None,
    };
    publisher.publish(raw).map_err(|e| e.to_string())?;
    match signal.recv_stamped().timeout(timeout).await {
        Ok((m, _)) => {
            let payload = codec::decode(answer.ros_type(), &m);
            if out.json {
                println!(
                    "{}",
                    json!({ "signal": slot.answer(), "response": r.name().fully_qualified(), "payload": payload })
                );
            } else {
                println!("{} {} {}", r.name(), slot.answer(), codec::inline(&payload));
            }
            Ok(())
        }
        Err(_) => {
            // say why, from the state: a busy response ignores a start, an idle one an interrupt
            let now = state.recv().timeout(Duration::from_millis(500)).await.ok();
            let why = match (before, now) {
                (Some(b), Some(n)) if n.ignored_starts > b.ignored_starts => {
                    format!(
                        "it ignored the start: it was {} (start policy {})",
                        b.state_label, b.start_policy
                    )
                }
                (Some(b), Some(n))
                    if n.ignored_interrupts > b.ignored_interrupts
                        || n.ignored_exits > b.ignored_exits =>
                {
                    format!("it ignored the {}: it was {}", slot.topic(), b.state_label)
                }
                (Some(b), _) => format!("it was {}", b.state_label),
                _ if !has_state => "it publishes no state topic to tell why".into(),
                _ => "its state did not arrive either".into(),
            };
            Err(format!(
                "no {} from {} within {timeout:?}; {why}",
                slot.answer(),
                r.name()
            ))
        }
    }
}

async fn inject(
    radar: &Radar,
    out: &Out,
    topic: &str,
    payload: Option<&str>,
    timeout: Duration,
) -> Fallible<()> {
    let topic = radar
        .resolve(topic)
        .map_err(|e| e.to_string())?
        .fully_qualified();
    let ty = with_status(
        "looking for a subscriber",
        radar.subscriber_type(&topic).timeout(timeout),
    )
    .await
    .map_err(|e| e.to_string())?;
    let raw = codec::encode(&ty, payload.unwrap_or(""))?;
    let publisher = radar
        .raw_publisher(&topic, &ty)
        .map_err(|e| e.to_string())?;
    with_status(
        "waiting for the match",
        publisher.wait_for_subscribers(1).timeout(timeout),
    )
    .await
    .map_err(|e| e.to_string())?;
    publisher.publish(raw.clone()).map_err(|e| e.to_string())?;
    let shown = codec::decode(&ty, &raw);
    if out.json {
        println!(
            "{}",
            json!({ "topic": topic, "type": ty, "payload": shown })
        );
    } else {
        println!("published {ty} on {topic} {}", codec::inline(&shown));
    }
    // the sample is written; stay a moment so reliable delivery can repair a loss before we leave
    tokio::time::sleep(Duration::from_millis(100)).await;
    Ok(())
}

/// The signals that show a component's activity, `(topic, type, label)`: a response's three; an event's
/// `triggered` only if `activate` (listening to it makes the event check).
fn signal_topics(c: &Component, activate: bool) -> Vec<(String, String, &'static str)> {
    let of = |s: radar_ros::Signal, label| (s.topic().to_owned(), s.ros_type().to_owned(), label);
    match c {
        Component::Response(r) => vec![
            of(r.started(), "started"),
            of(r.interrupted(), "interrupted"),
            of(r.exited(), "exited"),
        ],
        Component::Event(e) if activate => vec![of(e.triggered(), "triggered")],
        Component::Event(_) => Vec::new(),
    }
}

/// The type of a component's `state` topic.
fn state_type(c: &Component) -> &'static str {
    match c {
        Component::Response(_) => "radar_msgs/msg/ResponseState",
        Component::Event(_) => "radar_msgs/msg/EventState",
    }
}

/// The components a `watch` or `record` follows: those named (all if none), each once, as they appear.
struct Following {
    wanted: Vec<String>,
    seen: std::collections::BTreeSet<String>,
}

impl Following {
    fn new(radar: &Radar, names: &[String]) -> Fallible<Following> {
        let wanted = names
            .iter()
            .map(|n| {
                radar
                    .resolve(n)
                    .map(|c| c.fully_qualified())
                    .map_err(|e| e.to_string())
            })
            .collect::<Fallible<_>>()?;
        Ok(Following {
            wanted,
            seen: Default::default(),
        })
    }

    /// Components on the graph now that are wanted and not followed yet.
    fn new_components(&mut self, radar: &Radar) -> Vec<Component> {
        radar
            .components()
            .into_iter()
            .filter(|c| {
                let fq = c.name().fully_qualified();
                (self.wanted.is_empty() || self.wanted.contains(&fq)) && self.seen.insert(fq)
            })
            .collect()
    }
}

/// Resolves after `duration` seconds, or at Ctrl-C if none is given.
async fn until_done(duration: Option<f64>) {
    match duration {
        Some(d) => tokio::time::sleep(Duration::from_secs_f64(d.max(0.0))).await,
        None => {
            let _ = tokio::signal::ctrl_c().await;
        }
    }
}

/// One line of the timeline.
struct Seen {
    component: String,
    what: String,
    payload: Value,
    /// When it was sent: the source timestamp (signals) or the state's stamp, ns since the epoch (0: unknown).
    stamp: i64,
}

/// How long `watch` holds what arrived, so that signals and states that came on different topics print in the
/// order they were sent.
const REORDER: Duration = Duration::from_millis(60);

async fn watch(
    radar: &Radar,
    out: &Out,
    names: Vec<String>,
    activate: bool,
    duration: Option<f64>,
) -> Fallible<()> {
    let mut following = Following::new(radar, &names)?;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Seen>();
    let mut tasks = Vec::new();
    let end = until_done(duration);
    tokio::pin!(end);
    let mut rescan = tokio::time::interval(Duration::from_millis(250));
    let mut flush = tokio::time::interval(REORDER / 3);
    let mut held: Vec<(tokio::time::Instant, Seen)> = Vec::new();
    let start_ns = epoch_ns() as i64;
    if !out.json {
        println!(
            "watching {} in ROS_DOMAIN_ID {} (Ctrl-C to stop)",
            if following.wanted.is_empty() {
                "every component".to_owned()
            } else {
                following.wanted.join(", ")
            },
            radar.domain_id()
        );
    }
    loop {
        tokio::select! {
            _ = &mut end => break,
            _ = rescan.tick() => {
                for c in following.new_components(radar) {
                    tasks.extend(follow(radar, &c, activate, tx.clone())?);
                }
            }
            Some(s) = rx.recv() => held.push((tokio::time::Instant::now(), s)),
            _ = flush.tick() => print_held(out, &mut held, start_ns, false),
        }
    }
    print_held(out, &mut held, start_ns, true);
    for t in tasks {
        t.abort();
    }
    Ok(())
}

/// Prints, in the order they were sent, the held lines that arrived at least [`REORDER`] ago (all, at the end);
/// times are relative to when watching began.
fn print_held(out: &Out, held: &mut Vec<(tokio::time::Instant, Seen)>, start_ns: i64, all: bool) {
    let now = tokio::time::Instant::now();
    let (mut due, keep): (Vec<_>, Vec<_>) = held
        .drain(..)
        .partition(|(arrived, _)| all || now.duration_since(*arrived) >= REORDER);
    *held = keep;
    // when it was sent; for what carries no stamp, when it arrived
    let sent = |(arrived, s): &(tokio::time::Instant, Seen)| match s.stamp {
        0 => epoch_ns() as i64 - arrived.elapsed().as_nanos() as i64,
        t => t,
    };
    due.sort_by_key(sent);
    for x in due {
        let t = (sent(&x) - start_ns) as f64 / 1e9;
        let s = x.1;
        if out.json {
            println!(
                "{}",
                json!({ "t": t, "component": s.component, "event": s.what, "payload": s.payload })
            );
        } else {
            println!(
                "[{t:8.3} s] {} {} {}",
                s.component,
                s.what,
                codec::inline(&s.payload)
            );
        }
    }
}

fn stamp_ns(t: &radar_ros::msg::Time) -> i64 {
    t.sec as i64 * 1_000_000_000 + t.nanosec as i64
}

/// Subscribes to what shows `c`'s activity and forwards each to `tx`: a response's signals and state, an
/// event's state (or, with `activate`, its triggered signal).
fn follow(
    radar: &Radar,
    c: &Component,
    activate: bool,
    tx: tokio::sync::mpsc::UnboundedSender<Seen>,
) -> Fallible<Vec<tokio::task::JoinHandle<()>>> {
    let name = c.name().fully_qualified();
    let mut tasks = Vec::new();
    let signals = signal_topics(c, activate);
    for (topic, ty, what) in signals {
        let sub = radar
            .raw_subscription(&topic, &ty)
            .map_err(|e| e.to_string())?;
        let (tx, name) = (tx.clone(), name.clone());
        tasks.push(tokio::spawn(async move {
            while let Ok((m, stamp)) = sub.recv_stamped().await {
                let payload = codec::decode(&ty, &m);
                let seen = Seen {
                    component: name.clone(),
                    what: what.into(),
                    payload,
                    stamp,
                };
                if tx.send(seen).is_err() {
                    break;
                }
            }
        }));
    }
    let state_topic = c.name().topic("state");
    let tx2 = tx.clone();
    match c {
        Component::Response(_) => {
            let sub = radar
                .state_subscription::<ResponseState>(&state_topic)
                .map_err(|e| e.to_string())?;
            tasks.push(tokio::spawn(async move {
                let mut last = String::new();
                while let Ok(s) = sub.recv().await {
                    if s.state_label != last {
                        last = s.state_label.clone();
                        let seen = Seen {
                            component: s.name.clone(),
                            what: format!("is {}", s.state_label),
                            payload: Value::Object(Default::default()),
                            stamp: stamp_ns(&s.stamp),
                        };
                        if tx2.send(seen).is_err() {
                            break;
                        }
                    }
                }
            }));
        }
        Component::Event(_) => {
            let sub = radar
                .state_subscription::<EventState>(&state_topic)
                .map_err(|e| e.to_string())?;
            tasks.push(tokio::spawn(async move {
                let mut last: Option<EventState> = None;
                while let Ok(s) = sub.recv().await {
                    let mut lines = Vec::new();
                    match &last {
                        None => lines.push(if s.active { "is active" } else { "is inactive" }),
                        Some(l) => {
                            if s.active != l.active {
                                lines.push(if s.active { "activated" } else { "deactivated" });
                            }
                            if !activate && s.triggers > l.triggers {
                                lines.push("triggered");
                            }
                        }
                    }
                    for what in lines {
                        let seen = Seen {
                            component: s.name.clone(),
                            what: what.into(),
                            payload: Value::Object(Default::default()),
                            stamp: stamp_ns(&s.stamp),
                        };
                        if tx2.send(seen).is_err() {
                            return;
                        }
                    }
                    last = Some(s);
                }
            }));
        }
    }
    Ok(tasks)
}

/// One recorded message.
struct Recorded {
    topic: String,
    ros_type: String,
    body: radar_ros::RawMessage,
    /// Source timestamp, nanoseconds since the epoch (0: unknown).
    published: i64,
}

fn epoch_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or_default()
}

/// A CDR message as MCAP stores it: the 4-byte encapsulation header (little-endian CDR), then the body.
fn cdr(body: &radar_ros::RawMessage) -> Vec<u8> {
    let mut v = vec![0, 1, 0, 0];
    v.extend_from_slice(&body.0);
    v
}

async fn record(
    radar: &Radar,
    out: &Out,
    output: std::path::PathBuf,
    names: Vec<String>,
    activate: bool,
    duration: Option<f64>,
) -> Fallible<()> {
    if output.extension().and_then(|e| e.to_str()) != Some("mcap") {
        return Err("the output file ends in .mcap".into());
    }
    let mut following = Following::new(radar, &names)?;
    let file = std::fs::File::create(&output)
        .map_err(|e| format!("could not create {}: {e}", output.display()))?;
    let mut writer = mcap::Writer::new(std::io::BufWriter::new(file)).map_err(|e| e.to_string())?;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Recorded>();
    let mut tasks = Vec::new();
    let mut channels: BTreeMap<String, u16> = BTreeMap::new();
    let mut schemas: BTreeMap<String, u16> = BTreeMap::new();
    let mut counts: BTreeMap<String, u64> = BTreeMap::new();
    let mut unknown = std::collections::BTreeSet::new();
    let end = until_done(duration);
    tokio::pin!(end);
    let mut rescan = tokio::time::interval(Duration::from_millis(250));
    if !out.json {
        println!("recording to {} (Ctrl-C to stop)", output.display());
    }
    loop {
        tokio::select! {
            _ = &mut end => break,
            _ = rescan.tick() => {
                for c in following.new_components(radar) {
                    tasks.extend(tap(radar, &c, activate, tx.clone())?);
                }
            }
            Some(m) = rx.recv() => {
                let Some(def) = schemas::definition(&m.ros_type) else {
                    // a type radar cannot describe (a user's own): said once, not recorded
                    if unknown.insert(m.ros_type.clone()) {
                        eprintln!(
                            "radar: not recording {} ({}): radar has no ROS 2 schema for that type",
                            m.topic, m.ros_type
                        );
                    }
                    continue;
                };
                let schema = match schemas.get(&m.ros_type) {
                    Some(id) => *id,
                    None => {
                        let id = writer.add_schema(&m.ros_type, "ros2msg", def.as_bytes()).map_err(|e| e.to_string())?;
                        schemas.insert(m.ros_type.clone(), id);
                        id
                    }
                };
                let channel = match channels.get(&m.topic) {
                    Some(id) => *id,
                    None => {
                        let id = writer
                            .add_channel(schema, &m.topic, "cdr", &BTreeMap::new())
                            .map_err(|e| e.to_string())?;
                        channels.insert(m.topic.clone(), id);
                        id
                    }
                };
                let n = counts.entry(m.topic.clone()).or_default();
                *n += 1;
                let now = epoch_ns();
                let header = mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: *n as u32,
                    log_time: now,
                    publish_time: if m.published > 0 { m.published as u64 } else { now },
                };
                writer.write_to_known_channel(&header, &cdr(&m.body)).map_err(|e| e.to_string())?;
            }
        }
    }
    for t in tasks {
        t.abort();
    }
    writer.finish().map_err(|e| e.to_string())?;
    let total: u64 = counts.values().sum();
    if out.json {
        println!(
            "{}",
            json!({ "file": output, "messages": total, "topics": counts })
        );
    } else {
        println!(
            "{}: {total} messages on {} topics",
            output.display(),
            counts.len()
        );
    }
    Ok(())
}

/// Subscribes to what `record` keeps of `c`: a response's signals and state, an event's state (and, with
/// `activate`, its triggered signal), each forwarded raw with its type and source time.
fn tap(
    radar: &Radar,
    c: &Component,
    activate: bool,
    tx: tokio::sync::mpsc::UnboundedSender<Recorded>,
) -> Fallible<Vec<tokio::task::JoinHandle<()>>> {
    let signals = signal_topics(c, activate);
    let state_type = state_type(c);
    let mut tasks = Vec::new();
    for (topic, ty, _) in signals {
        let sub = radar
            .raw_subscription(&topic, &ty)
            .map_err(|e| e.to_string())?;
        let tx = tx.clone();
        tasks.push(tokio::spawn(async move {
            while let Ok((body, published)) = sub.recv_stamped().await {
                let m = Recorded {
                    topic: topic.clone(),
                    ros_type: ty.clone(),
                    body,
                    published,
                };
                if tx.send(m).is_err() {
                    break;
                }
            }
        }));
    }
    // the state, from its transient-local topic (the current one first)
    let topic = c.name().topic("state");
    macro_rules! state_task {
        ($t:ty) => {{
            let sub = radar
                .state_subscription::<$t>(&topic)
                .map_err(|e| e.to_string())?;
            let tx = tx.clone();
            tokio::spawn(async move {
                while let Ok((m, published)) = sub.recv_stamped().await {
                    let Ok(body) = radar_ros::RawMessage::encode(&m) else {
                        continue;
                    };
                    let r = Recorded {
                        topic: topic.clone(),
                        ros_type: state_type.into(),
                        body,
                        published,
                    };
                    if tx.send(r).is_err() {
                        break;
                    }
                }
            })
        }};
    }
    tasks.push(match c {
        Component::Response(_) => state_task!(ResponseState),
        Component::Event(_) => state_task!(EventState),
    });
    Ok(tasks)
}

/// Whether a topic is a RADAR signal (what `replay` publishes again), not a state.
fn is_signal(topic: &str) -> bool {
    [
        "/triggered",
        "/started",
        "/interrupted",
        "/exited",
        "/feedback",
    ]
    .iter()
    .any(|s| topic.ends_with(s))
}

async fn replay(
    radar: &Radar,
    out: &Out,
    input: std::path::PathBuf,
    rate: f64,
    wait: Duration,
) -> Fallible<()> {
    if !(rate.is_finite() && rate > 0.0) {
        return Err(format!(
            "--rate {rate}: give a speed above 0 (1 is as recorded)"
        ));
    }
    let bytes =
        std::fs::read(&input).map_err(|e| format!("could not read {}: {e}", input.display()))?;
    let mut plan = Vec::new();
    for m in mcap::MessageStream::new(&bytes)
        .map_err(|e| format!("{} is not an MCAP file: {e}", input.display()))?
    {
        let m = m.map_err(|e| format!("{}: {e}", input.display()))?;
        if !is_signal(&m.channel.topic) {
            continue;
        }
        let Some(schema) = m.channel.schema.as_ref() else {
            continue;
        };
        if m.data.len() < 4 {
            continue;
        }
        plan.push((
            m.log_time,
            m.channel.topic.clone(),
            schema.name.clone(),
            radar_ros::RawMessage(m.data[4..].to_vec()),
        ));
    }
    plan.sort_by_key(|p| p.0);
    let Some(first) = plan.first().map(|p| p.0) else {
        return Err(format!(
            "{} holds no RADAR signals to replay",
            input.display()
        ));
    };
    let mut publishers = BTreeMap::new();
    for (_, topic, ty, _) in &plan {
        if !publishers.contains_key(topic) {
            let p = radar.raw_publisher(topic, ty).map_err(|e| e.to_string())?;
            publishers.insert(topic.clone(), p);
        }
    }
    // whoever listens now should hear all of it
    let ready = futures::future::join_all(
        publishers
            .values()
            .map(|p| async move { p.wait_for_subscribers(1).timeout(wait).await.is_ok() }),
    )
    .await;
    let unheard: Vec<&String> = publishers
        .keys()
        .zip(ready)
        .filter(|(_, ok)| !ok)
        .map(|(t, _)| t)
        .collect();
    let t0 = tokio::time::Instant::now();
    let mut sent = 0u64;
    for (at, topic, _, body) in &plan {
        let offset = Duration::from_nanos(((at - first) as f64 / rate) as u64);
        tokio::time::sleep_until(t0 + offset).await;
        publishers[topic]
            .publish(body.clone())
            .map_err(|e| e.to_string())?;
        sent += 1;
    }
    // let reliable delivery finish before the writers go
    tokio::time::sleep(Duration::from_millis(200)).await;
    if out.json {
        println!(
            "{}",
            json!({ "file": input, "published": sent, "topics": publishers.len(), "without_subscribers": unheard })
        );
    } else {
        println!(
            "replayed {sent} signals on {} topics from {}",
            publishers.len(),
            input.display()
        );
        for t in unheard {
            println!("  nobody listened on {t}");
        }
    }
    Ok(())
}
