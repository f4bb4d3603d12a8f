//! Every program is visible: each [`Radar`](crate::Radar) has a program node, named after the program, that
//! shows the connections its statements made.
//!
//! | endpoint | type |
//! |---|---|
//! | `<node>/connections` (topic, transient-local) | `radar_msgs/msg/ConnectionList`, republished on change (at most every 100 ms) |
//! | `<node>/list` (service) | `radar_msgs/srv/List` |
//!
//! | `/diagnostics` (topic) | `diagnostic_msgs/msg/DiagnosticArray`: its connections' health and the messages this process dropped as malformed, on change and every second ([`diagnostics`](super::diagnostics)) |
//!
//! The node is named after the program: the executable's name and the process id (`count_up` -> node
//! `/count_up_4242`: several processes of one executable, as a launch of components often is, stay apart), or
//! exactly what [`RadarBuilder::program`](crate::RadarBuilder::program) says; a second program of that
//! name alive in one process gets `_2`, and so on (a name comes back when the last handle to its `Radar` is
//! dropped). The node is also the one plain publishers and subscriptions of the program live on. Unlike [`Radar::serve_manager`](crate::Radar::serve_manager) it takes no connect requests from
//! others; it only shows. `ros2 topic echo /count_up_4242/connections` (with transient-local durability)
//! prints them; the `radar` command line reads them from every program.

use std::{
    sync::{Arc, Weak},
    time::Duration,
};

use crate::{
    connections::diagnostics::{self, Shown},
    connections::manager::Manager,
    error::Result,
    node::endpoints::{malformed, reply, typed_publisher, Throttle},
    node::participant::Participant,
    node::services::service_server,
    node::shutdown::ComponentTask,
    wire::msg::{ConnectionList, ListRequest, ListResponse},
    wire::names::ComponentName,
    wire::qos::state_qos,
};
use futures::StreamExt;

/// The program name from the executable: its file name, made a valid ROS name (`my-tool` -> `my_tool`).
pub(crate) fn default_program_name() -> String {
    let exe = std::env::current_exe().ok();
    let stem = exe
        .as_deref()
        .and_then(|p| p.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    ros_base_name(&stem)
}

/// `text` as a valid ROS base name: other characters become `_`, no `__`, no leading digit, never empty.
pub(crate) fn ros_base_name(text: &str) -> String {
    let mut out = String::new();
    for c in text.chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '_' };
        if c == '_' && (out.is_empty() || out.ends_with('_')) {
            continue;
        }
        out.push(c);
    }
    let out = out.trim_end_matches('_').to_owned();
    match out.chars().next() {
        None => "radar".to_owned(),
        Some(c) if c.is_ascii_digit() => format!("p_{out}"),
        Some(_) => out,
    }
}

/// The connections this program's own code made (`once`, `whenever`, ... statements), not those a manager node
/// of this process made for its callers (that node lists them): each connection is shown once.
fn made_here(mut list: Vec<crate::wire::msg::Connection>) -> Vec<crate::wire::msg::Connection> {
    let own = crate::connections::statement::program_owner();
    list.retain(|c| c.owner == own);
    list
}

/// Starts showing the connections of `manager` on the program node `name` (its node is the participant's
/// client node). The task holds the manager weakly: it ends when the handle does.
pub(crate) fn serve_program(
    participant: &Arc<Participant>,
    manager: &Arc<Manager>,
    name: &ComponentName,
) -> Result<ComponentTask> {
    let fq = name.fully_qualified();
    let graph = participant.graph().clone();
    let (list_srv, shown) = participant.with_client_node(|node| {
        let srv = service_server::<ListRequest, ListResponse>(node, &fq, "list", "List")?;
        let list = typed_publisher::<ConnectionList>(
            &graph,
            node,
            &name.topic("connections"),
            &state_qos(),
        )?;
        let health = diagnostics::health_publisher(&graph, node, &fq)?;
        let malformed = Some(graph.clone());
        let node = fq.clone();
        Ok((
            Arc::new(srv),
            Shown {
                node,
                list,
                health,
                malformed,
            },
        ))
    })?;
    let weak: Weak<Manager> = Arc::downgrade(manager);
    let (mut changes, mut counts) = (manager.changes(), manager.count_changes());
    let first = made_here(manager.listing());
    Ok(ComponentTask::spawn(
        participant.components(),
        &name.fully_qualified(),
        move |mut stop| async move {
            let publish = |list| shown.publish(list);
            publish(first);
            let mut throttle = Throttle::new(Duration::from_millis(100));
            // health once a second as well, as diagnostic_updater does (a monitor marks a silent node stale)
            let mut beat = tokio::time::interval(Duration::from_secs(1));
            let mut lists = Box::pin(list_srv.receive_request_stream());
            loop {
                let Some(manager) = weak.upgrade() else { break };
                tokio::select! {
                    _ = &mut stop => break,
                    Some(r) = lists.next() => match r {
                        Ok((id, _)) => {
                            let resp = ListResponse { connections: made_here(manager.list()) };
                            reply(&list_srv, &graph, &fq, "list", id, resp);
                        }
                        Err(e) => malformed(&graph, &fq, "list", &e),
                    },
                    changed = changed_or_counted(&mut changes, &mut counts) => {
                        if changed.is_err() {
                            break;
                        }
                        if throttle.changed() {
                            publish(made_here(manager.listing()));
                        }
                    }
                    _ = throttle.due() => {
                        publish(made_here(manager.listing()));
                        throttle.published();
                    }
                    _ = beat.tick() => shown.health(&made_here(manager.listing())),
                }
            }
        },
    ))
}

/// The next change of a manager's table or of its counts (`Manager::changes`, `Manager::count_changes`): what
/// a task that publishes its list waits for.
pub(crate) async fn changed_or_counted(
    changes: &mut tokio::sync::watch::Receiver<u64>,
    counts: &mut tokio::sync::watch::Receiver<u64>,
) -> Result<(), tokio::sync::watch::error::RecvError> {
    tokio::select! {
        r = changes.changed() => r,
        r = counts.changed() => r,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn executable_names_become_valid_ros_names() {
        assert_eq!(ros_base_name("count_up"), "count_up");
        assert_eq!(ros_base_name("actions-fd4bd0c1"), "actions_fd4bd0c1");
        assert_eq!(ros_base_name("my--tool."), "my_tool");
        assert_eq!(ros_base_name("3d_mapper"), "p_3d_mapper");
        assert_eq!(ros_base_name("__"), "radar");
        for n in [
            "count_up",
            "actions-fd4bd0c1",
            "my--tool.",
            "3d_mapper",
            "",
            "x y",
        ] {
            let b = ros_base_name(n);
            assert!(
                crate::wire::names::ComponentName::resolve(&b, "/").is_ok(),
                "{n:?} -> {b:?}"
            );
        }
    }
}
