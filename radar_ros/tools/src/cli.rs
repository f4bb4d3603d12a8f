//! The command line: its arguments (clap) and which verb each runs.

use std::time::Duration;

use clap::{Parser, Subcommand};
use radar_ros::Radar;

use crate::{
    common::{secs, Fallible, Out},
    verbs::{self, act::ActSlot, connect::ConKind},
};

/// The arguments of `radar`.
#[derive(Parser)]
#[command(
    name = "radar",
    version,
    about = "RADAR on ROS 2 from the shell: see events, responses and connections, and drive them",
    after_help = "The ROS 2 domain is ROS_DOMAIN_ID's (default 0). Payloads are YAML, as `ros2 topic pub` takes them."
)]
pub struct Cli {
    /// Print JSON, one document per line, for scripts.
    #[arg(long, global = true)]
    json: bool,
    /// Seconds to let discovery run before answering.
    #[arg(long, global = true, default_value_t = 1.5, value_name = "SECONDS")]
    discovery: f64,
    /// Also look for message definitions in DIR (`DIR/<pkg>/msg/<Name>.msg`, `srv/`, `action/`), before
    /// AMENT_PREFIX_PATH: interface packages that are not installed. May be given more than once.
    #[arg(long, global = true, value_name = "DIR")]
    interfaces: Vec<std::path::PathBuf>,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// DDS Security keystores and enclaves, as `ros2 security` makes them (needs the `security` feature).
    Security {
        #[command(subcommand)]
        verb: SecurityVerb,
    },
    /// Run a Zenoh router as rmw_zenoh runs one (`rmw_zenohd`: ZENOH_ROUTER_CONFIG_URI, else listening on
    /// tcp/[::]:7447), for programs on Zenoh, until SIGINT or SIGTERM (needs the `zenoh` feature).
    Router {
        /// Listen on ENDPOINT instead (e.g. tcp/0.0.0.0:7447). May be given more than once.
        #[arg(long, value_name = "ENDPOINT")]
        listen: Vec<String>,
    },
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
        /// The start payload as YAML (default: the type's default), e.g. "{data: kitchen}"; `-` reads it from
        /// standard input (for payloads too long for a command line).
        payload: Option<String>,
        /// Seconds to wait for the response and for the signal.
        #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
        timeout: f64,
    },
    /// Publish a payload into a slot topic, once its subscriber is matched (like rtinject).
    Inject {
        /// The topic, e.g. /count_up/start.
        topic: String,
        /// The payload as YAML (default: the type's default), e.g. "{data: kitchen}"; `-` reads it from
        /// standard input (for payloads too long for a command line).
        payload: Option<String>,
        /// Seconds to wait for a subscriber.
        #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
        timeout: f64,
    },
    /// A live timeline of the signals and state changes of every component, or those named (like rtprint).
    ///
    /// Times are relative to when watching began. Events' triggered signals are only observed: every trigger is
    /// shown, but watching does not make an event check (its reader announces that it only observes);
    /// --activate listens as a subscriber does, and so activates them.
    Watch {
        /// Components to watch (default: all, including ones that appear later).
        names: Vec<String>,
        /// Listen to events' triggered signals as a listener (this activates them) rather than only observe.
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
    /// ros2 bag tooling open it. Events' triggered signals are recorded by a reader that only observes: every
    /// trigger is in the file, and recording does not make an event check; --activate listens as a subscriber
    /// does (and so activates them). Any type whose definition is found (AMENT_PREFIX_PATH, --interfaces, the
    /// shipped ones) is recorded with its schema; others are skipped, said once.
    Record {
        /// The MCAP file to write.
        #[arg(short = 'o', long = "output", value_name = "FILE.mcap")]
        output: std::path::PathBuf,
        /// Components to record (default: all, including ones that appear later).
        names: Vec<String>,
        /// Listen to events' triggered signals as a listener (this activates them) rather than only observe.
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
    /// Judge a recording (from `radar record`) by RADAR's rules: name every rule the run broke.
    ///
    /// Reads what the recording saw on the topics (each signal with its stamp, cause and writer, the slot
    /// signals that crossed processes, states, connection lists) and checks it against radar_spec's rules:
    /// prints each rule broken (rule, time, components, the signals involved), or "no violation in N signals,
    /// M statements", and which rules a recording cannot show (what a component read and when, which slot ran).
    /// Exits with 1 if a rule was broken.
    Verify {
        /// The MCAP file `radar record` wrote (or its trace's lines, FILE.jsonl, as --trace prints them).
        input: std::path::PathBuf,
        /// Print what the recording saw, one JSON object a line in the order sent, and judge nothing.
        #[arg(long)]
        trace: bool,
        /// What happened in the last SECONDS of the recording is not judged by the rules that wait for
        /// something (every started run exits, a spent statement ends).
        #[arg(long, default_value_t = 5.0, value_name = "SECONDS")]
        grace: f64,
    },
    /// A running RADAR system in a browser, live: components, connections, states, signals.
    ///
    /// Serves a page (everything it needs is in this binary; nothing is loaded from the internet) that draws
    /// every program, event, response and connection of the domain as `radar graph` does, with each component's
    /// state, a timeline of signals with their payloads, parameters and a namespace filter, pushed over a
    /// WebSocket: a snapshot, then the changes, at most --rate messages a second. Events' triggered signals are
    /// only observed (viewing makes no event check). Listens on 127.0.0.1 unless --bind says otherwise.
    View(crate::view::Options),
    /// Remove a connection made through a manager's services (like rtdis).
    Dis {
        /// The connection's id, as `radar con` or `radar cat` showed it.
        id: u64,
        /// The manager node (default: the only one on the graph).
        #[arg(long, value_name = "NODE")]
        manager: Option<String>,
    },
}

/// `radar security ...`: the verbs of `ros2 security` this build offers.
#[derive(Subcommand)]
#[allow(clippy::enum_variant_names)] // named as `ros2 security` names them
enum SecurityVerb {
    /// Make a keystore: one CA for identities and permissions, and the signed governance (no
    /// unauthenticated participants; discovery and data encrypted).
    #[command(name = "create_keystore")]
    CreateKeystore {
        /// The keystore's directory (made if missing).
        keystore: std::path::PathBuf,
    },
    /// Make an enclave in a keystore: a key and certificate for it, permissions that allow it everything
    /// (as `ros2 security create_enclave` does), signed by the keystore's CA.
    #[command(name = "create_enclave")]
    CreateEnclave {
        /// The keystore's directory.
        keystore: std::path::PathBuf,
        /// The enclave's name, absolute, e.g. /robot/planner (a program uses it with --ros-args --enclave).
        enclave: String,
    },
    /// Make an enclave's permissions again from a policy file in sros2's format (what it may publish,
    /// subscribe, request, reply, call, execute; ALLOW and DENY), signed by the keystore's CA, as
    /// `ros2 security create_permission` does. The format: docs/security.md.
    #[command(name = "create_permission")]
    CreatePermission {
        /// The keystore's directory.
        keystore: std::path::PathBuf,
        /// The enclave (made before with create_enclave).
        enclave: String,
        /// The policy file (XML, `<policy version="0.2.0">`).
        policy: std::path::PathBuf,
    },
    /// Write the policy of the nodes running on the ROS graph (every ROS 2 program's, rclpy's too): one
    /// profile per node under its enclave, what it publishes, subscribes, serves and calls, as `ros2 security
    /// generate_policy` does. An existing file is added to, not replaced. Run the system plain, generate,
    /// then `create_permission` from it.
    #[command(name = "generate_policy")]
    GeneratePolicy {
        /// The policy file to write (or add to).
        policy: std::path::PathBuf,
    },
}

fn security(verb: SecurityVerb, out: &Out) -> Fallible<()> {
    #[cfg(feature = "security")]
    {
        use radar_ros::security::keystore;
        match verb {
            SecurityVerb::CreateKeystore { keystore: dir } => {
                keystore::create_keystore(&dir)?;
                match out.json {
                    true => println!("{}", serde_json::json!({ "keystore": dir })),
                    false => println!("keystore made in {}", dir.display()),
                }
            }
            SecurityVerb::CreateEnclave {
                keystore: dir,
                enclave,
            } => {
                let made = keystore::create_enclave(&dir, &enclave, &keystore::Grant::all())?;
                match out.json {
                    true => println!("{}", serde_json::json!({ "enclave": enclave, "dir": made })),
                    false => println!("enclave {enclave} made in {}", made.display()),
                }
            }
            SecurityVerb::CreatePermission {
                keystore: dir,
                enclave,
                policy,
            } => {
                let made = radar_ros::security::policy::create_permission(&dir, &enclave, &policy)?;
                match out.json {
                    true => {
                        println!(
                            "{}",
                            serde_json::json!({ "enclave": enclave, "permissions": made })
                        )
                    }
                    false => println!("permissions of {enclave} made in {}", made.display()),
                }
            }
            SecurityVerb::GeneratePolicy { .. } => unreachable!("run on the graph, by run()"),
        }
        Ok(())
    }
    #[cfg(not(feature = "security"))]
    {
        let _ = (verb, out);
        Err("this radar was built without DDS Security: build it with `cargo build -p radar_tools --features \
             security` (needs OpenSSL, libssl-dev)"
            .into())
    }
}

/// `radar security generate_policy POLICY`: the nodes on the graph (discovery settled, at most `discovery`
/// and at least 2 s), written as a policy into `policy` (added to it if it exists).
async fn generate_policy(
    radar: &Radar,
    out: &Out,
    discovery: Duration,
    policy: &std::path::Path,
) -> Fallible<()> {
    #[cfg(feature = "security")]
    {
        let nodes = radar
            .introspect()
            .nodes()
            .timeout(discovery.max(Duration::from_secs(2)))
            .await?;
        let shown: Vec<_> = nodes.iter().filter(|n| !n.name.starts_with('_')).collect();
        if shown.is_empty() {
            return Err(
                "no nodes on the ROS graph (ROS_DOMAIN_ID the same as theirs? running plain, or this command \
                 secured in their keystore?); no policy written"
                    .into(),
            );
        }
        let existing = match std::fs::read_to_string(policy) {
            Ok(text) => Some(text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(crate::Error::io(format!("read {}", policy.display()), e)),
        };
        let xml = radar_ros::security::policy::generate(
            existing.as_deref().map(|t| (t, policy)),
            &nodes,
        )?;
        std::fs::write(policy, xml)
            .map_err(|e| crate::Error::io(format!("write {}", policy.display()), e))?;
        match out.json {
            true => println!(
                "{}",
                serde_json::json!({
                    "policy": policy,
                    "nodes": shown.iter().map(|n| serde_json::json!({
                        "node": n.fully_qualified(), "enclave": n.enclave,
                    })).collect::<Vec<_>>(),
                })
            ),
            false => {
                for n in &shown {
                    println!("{} (enclave {})", n.fully_qualified(), n.enclave);
                }
                println!(
                    "policy of {} node(s) written to {}",
                    shown.len(),
                    policy.display()
                );
            }
        }
        Ok(())
    }
    #[cfg(not(feature = "security"))]
    {
        let _ = (radar, out, discovery, policy);
        Err("this radar was built without DDS Security: build it with `cargo build -p radar_tools --features \
             security` (needs OpenSSL, libssl-dev)"
            .into())
    }
}

/// Runs the verb `cli` names, on a program node of its own (several `radar` commands may run at once).
pub async fn run(cli: Cli) -> Result<(), crate::Error> {
    let out = Out { json: cli.json };
    for dir in cli.interfaces.iter().rev() {
        if !dir.is_dir() {
            return Err(format!(
                "--interfaces {}: no such directory (give one that holds <pkg>/msg/<Name>.msg)",
                dir.display()
            )
            .into());
        }
        radar_ros::codec::add_interfaces_dir(dir.clone());
    }
    let cmd = match cli.cmd {
        Cmd::Security {
            verb: SecurityVerb::GeneratePolicy { policy },
        } => Cmd::Security {
            verb: SecurityVerb::GeneratePolicy { policy },
        },
        Cmd::Security { verb } => return security(verb, &out),
        Cmd::Router { listen } => return verbs::router::router(listen, &out).await,
        Cmd::Verify {
            input,
            grace,
            trace,
        } => return verbs::verify::verify(&input, grace, trace, &out),
        other => other,
    };
    // the command line handles Ctrl-C itself (a watch prints its summary, a recording closes its file)
    let mut builder = Radar::builder()
        .program(&format!("radar_cli_{}", std::process::id()))
        .handle_signals(false);
    // the view runs in an enclave of its own when secured
    if let Cmd::View(v) = &cmd {
        if let Some(secured) = v.security()? {
            builder = builder.security(Some(secured));
        }
    }
    let radar = builder.build()?;
    let discovery = Duration::from_secs_f64(cli.discovery.max(0.0));
    dispatch(&radar, &out, discovery, cmd).await
}

/// Runs the verb `cmd` on `radar`.
async fn dispatch(radar: &Radar, out: &Out, discovery: Duration, cmd: Cmd) -> Fallible<()> {
    let manager = |named| verbs::connect::Manager { named, discovery };
    match cmd {
        Cmd::Security {
            verb: SecurityVerb::GeneratePolicy { policy },
        } => generate_policy(radar, out, discovery, &policy).await,
        Cmd::Security { .. } | Cmd::Router { .. } | Cmd::Verify { .. } => {
            unreachable!("handled above")
        }
        Cmd::Ls { namespace, long } => verbs::ls::ls(radar, out, discovery, namespace, long).await,
        Cmd::Cat { name } => verbs::cat::cat(radar, out, discovery, &name).await,
        Cmd::Act {
            slot,
            name,
            payload,
            timeout,
        } => {
            let timeout = secs(timeout)?;
            let payload = payload_arg(payload)?;
            verbs::act::act(radar, out, slot, &name, payload.as_deref(), timeout).await
        }
        Cmd::Inject {
            topic,
            payload,
            timeout,
        } => {
            let timeout = secs(timeout)?;
            let payload = payload_arg(payload)?;
            verbs::inject::inject(radar, out, &topic, payload.as_deref(), timeout).await
        }
        Cmd::Watch {
            names,
            activate,
            duration,
        } => verbs::watch::watch(radar, out, names, activate, duration).await,
        Cmd::Con {
            kind,
            source,
            slot,
            until,
            manager: named,
            detach,
            duration,
        } => {
            let statement = verbs::connect::Statement {
                kind,
                source,
                slot,
                until,
            };
            let lifetime = match detach {
                true => verbs::connect::Lifetime::Detached,
                false => verbs::connect::Lifetime::WhileRunning(duration),
            };
            verbs::connect::con(radar, out, manager(named), statement, lifetime).await
        }
        Cmd::Graph {
            output,
            watch,
            duration,
        } => verbs::graph::draw(radar, out, discovery, output, watch, duration).await,
        Cmd::Record {
            output,
            names,
            activate,
            duration,
        } => verbs::record::record(radar, out, output, names, activate, duration).await,
        Cmd::Replay { input, rate, wait } => {
            verbs::replay::replay(radar, out, input, rate, secs(wait)?).await
        }
        Cmd::View(options) => crate::view::view(radar, out, options).await,
        Cmd::Dis { id, manager: named } => {
            verbs::connect::dis(radar, out, manager(named), id).await
        }
    }
}

/// A payload argument: `-` is standard input, read to its end.
fn payload_arg(payload: Option<String>) -> crate::common::Fallible<Option<String>> {
    match payload.as_deref() {
        Some("-") => {
            let mut text = String::new();
            std::io::Read::read_to_string(&mut std::io::stdin(), &mut text)
                .map_err(|e| crate::Error::io("read the payload from standard input", e))?;
            Ok(Some(text))
        }
        _ => Ok(payload),
    }
}
