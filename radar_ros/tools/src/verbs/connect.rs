//! `radar con` and `radar dis`: connections made and removed through a manager's services (like rtcon, rtdis).

use std::time::Duration;

use clap::ValueEnum;
use radar_ros::{manager::RemoteStatement, Radar};
use serde_json::json;

use crate::common::{discover, with_status, Fallible, Out, Stop};

/// The statement kind `radar con` makes.
#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum ConKind {
    Once,
    Whenever,
}

/// The statement `radar con` asks for: `KIND SOURCE SLOT [until UNTIL]`.
pub(crate) struct Statement {
    /// once or whenever.
    pub(crate) kind: ConKind,
    /// The source signal topic.
    pub(crate) source: String,
    /// The target slot topic.
    pub(crate) slot: String,
    /// The signal that interrupts the started run.
    pub(crate) until: Option<String>,
}

/// Which manager: the one named, or the only one found within `discovery`.
pub(crate) struct Manager {
    /// `--manager`.
    pub(crate) named: Option<String>,
    /// How long discovery may take.
    pub(crate) discovery: Duration,
}

/// How long a connection made by `radar con` lives.
pub(crate) enum Lifetime {
    /// Under the manager until `radar dis` (`--detach`).
    Detached,
    /// While this command runs: the seconds given, or until Ctrl-C or SIGTERM.
    WhileRunning(Option<f64>),
}

/// `radar con`: makes the statement through the manager's `connect` service.
pub(crate) async fn con(
    radar: &Radar,
    out: &Out,
    manager: Manager,
    statement: Statement,
    lifetime: Lifetime,
) -> Fallible<()> {
    // caught before anything waits, so an early Ctrl-C still removes the connection
    let mut stop = match lifetime {
        Lifetime::WhileRunning(_) => Some(Stop::catch()?),
        Lifetime::Detached => None,
    };
    let m = manager_of(radar, manager).await?;
    let detach = matches!(lifetime, Lifetime::Detached);
    let mut s = match statement.kind {
        ConKind::Once => RemoteStatement::once(&statement.source),
        ConKind::Whenever => RemoteStatement::whenever(&statement.source),
    }
    .to(&statement.slot);
    if let Some(u) = &statement.until {
        s = s.until(u);
    }
    if detach {
        s = s.detach();
    }
    let id = with_status("connecting", m.connect(s)).await?;
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
    if let (Lifetime::WhileRunning(duration), Some(stop)) = (lifetime, stop.as_mut()) {
        stop.after(duration).await;
        // it would go when this process leaves the graph; say so at once
        m.disconnect(id).await?;
    }
    Ok(())
}

/// `radar dis`: removes connection `id` through the manager's `disconnect` service.
pub(crate) async fn dis(radar: &Radar, out: &Out, manager: Manager, id: u64) -> Fallible<()> {
    let m = manager_of(radar, manager).await?;
    m.disconnect(id).await?;
    if out.json {
        println!("{}", json!({ "removed": id, "manager": m.name() }));
    } else {
        println!("connection {id} removed from {}", m.name());
    }
    Ok(())
}

/// The manager named, or the only one on the graph; its services matched.
async fn manager_of(
    radar: &Radar,
    manager: Manager,
) -> Fallible<radar_ros::manager::RemoteManager> {
    let Manager { named, discovery } = manager;
    let name = match named {
        Some(n) => n,
        None => {
            with_status("discovering", discover(radar, discovery)).await;
            let found = radar.introspect().managers();
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
                    ).into())
                }
            }
        }
    };
    with_status("waiting for the manager", radar.remote_manager(&name))
        .await
        .map_err(crate::Error::from)
}
