//! Another program's connection manager, through its services: what `radar con` / `radar dis` use, and what
//! a Rust program uses to leave connections in a standalone manager (`radar_manager`).
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
//! use radar_ros::msg::{ConnectRequest, Connection};
//! let m = radar.remote_manager("/radar_manager").await?;
//! let id = m.connect(ConnectRequest {
//!     kind: Connection::WHENEVER,
//!     source: "/bumper/triggered".into(),
//!     target: "/dock/start".into(),
//!     detach: true, // stays after this program ends
//!     ..Default::default()
//! }).await?;
//! m.disconnect(id).await?;
//! # Ok(()) }
//! ```

use std::collections::BTreeSet;

use ros2_client::{Client, Name, Node, NodeName, NodeOptions, ServiceMapping, ServiceTypeName};

use crate::{
    error::{Error, Result},
    msg::{
        ConnectRequest, ConnectResponse, Connection, DisconnectRequest, DisconnectResponse,
        ListRequest, ListResponse,
    },
    qos::signal_qos,
    radar::Radar,
    wait::Wait,
};

/// The DDS type name of a `Connect` request, as a manager's `connect` server announces it.
const CONNECT_REQUEST: &str = "radar_msgs::srv::dds_::Connect_Request_";

/// Clients of one manager node's `connect`, `disconnect` and `list` services, matched both ways.
pub struct RemoteManager {
    name: String,
    connect: Client<ConnectRequest, ConnectResponse>,
    disconnect: Client<DisconnectRequest, DisconnectResponse>,
    list: Client<ListRequest, ListResponse>,
    _node: Node,
}

impl std::fmt::Debug for RemoteManager {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemoteManager")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

impl RemoteManager {
    /// The manager node's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Makes a connection; its id. Unless `req.detach`, it belongs to this program and ends when this
    /// program leaves the graph.
    pub async fn connect(&self, req: ConnectRequest) -> Result<u64> {
        let r = self.call(&self.connect, req, "connect").await?;
        match r.ok {
            true => Ok(r.id),
            false => Err(self.refused(r.error)),
        }
    }

    /// Removes connection `id` (made through these services).
    pub async fn disconnect(&self, id: u64) -> Result<()> {
        let r = self
            .call(&self.disconnect, DisconnectRequest { id }, "disconnect")
            .await?;
        match r.ok {
            true => Ok(()),
            false => Err(self.refused(r.error)),
        }
    }

    /// Every live connection of the manager.
    pub async fn list(&self) -> Result<Vec<Connection>> {
        Ok(self
            .call(&self.list, ListRequest::default(), "list")
            .await?
            .connections)
    }

    fn refused(&self, reason: String) -> Error {
        Error::Refused {
            manager: self.name.clone(),
            reason,
        }
    }

    async fn call<Req, Resp>(
        &self,
        client: &Client<Req, Resp>,
        req: Req,
        service: &str,
    ) -> Result<Resp>
    where
        Req: ros2_client::Message + 'static,
        Resp: ros2_client::Message + 'static,
    {
        let limit = crate::DEFAULT_TIMEOUT * 6;
        let call = client.async_call_service(req);
        match tokio::time::timeout(limit, call).await {
            Ok(Ok(r)) => Ok(r),
            Ok(Err(e)) => Err(Error::transport(
                format!("call {}/{service}", self.name),
                crate::error::Text(format!("{e:?}")),
            )),
            Err(_) => Err(Error::Timeout {
                what: format!("an answer from {}/{service}", self.name),
                after: limit,
            }),
        }
    }
}

/// The DDS topics of a manager's services, as `Graph::participants_matched_on` takes them.
fn service_topics(manager: &str) -> Vec<(bool, String)> {
    ["connect", "disconnect", "list"]
        .iter()
        .flat_map(|s| {
            let service = format!("{manager}/{s}");
            [
                (true, crate::wire_names::request(&service)),
                (false, crate::wire_names::reply(&service)),
            ]
        })
        .collect()
}

impl Radar {
    /// The manager nodes on the graph that take connect requests (`serve_manager`, `radar_manager`),
    /// by name; this process's own included.
    pub fn managers(&self) -> Vec<String> {
        let mut names: BTreeSet<String> = self
            .graph()
            .discovered_reader_topics(CONNECT_REQUEST)
            .into_iter()
            .filter_map(|t| {
                crate::wire_names::service_of_request(&t)
                    .and_then(|s| s.strip_suffix("/connect"))
                    .map(str::to_owned)
            })
            .collect();
        names.extend(self.participant().served_managers().names());
        names.into_iter().collect()
    }

    /// Clients of the manager node `name`'s services, once they are matched both ways (default limit
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change), so that no request is lost.
    pub fn remote_manager(&self, name: &str) -> Wait<'static, RemoteManager> {
        let radar = self.clone();
        let name = self.resolve(name).map(|n| n.fully_qualified());
        Wait::discovery(move |timeout| async move {
            let name = name?;
            let svc = |s: &str| {
                Name::new(&name, s).map_err(|e| Error::InvalidName {
                    name: format!("{name}/{s}"),
                    reason: format!("{e}"),
                })
            };
            static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
            let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let base = format!("{}_client_{k}", radar.program_node().base());
            let mut node = radar
                .context()
                .new_node(
                    NodeName::new(radar.namespace(), &base).map_err(|e| Error::InvalidName {
                        name: base.clone(),
                        reason: format!("{e}"),
                    })?,
                    NodeOptions::new()
                        .enable_rosout(false)
                        .start_parameter_services(false),
                )
                .map_err(|e| Error::transport(format!("node {base}"), e))?;
            let q = signal_qos();
            macro_rules! client {
                ($s:literal, $t:literal) => {
                    node.create_client(
                        ServiceMapping::Enhanced,
                        &svc($s)?,
                        &ServiceTypeName::new("radar_msgs", $t),
                        q.clone(),
                        q.clone(),
                    )
                    .map_err(|e| Error::transport(format!("a client of {name}/{}", $s), e))?
                };
            }
            let m = RemoteManager {
                connect: client!("connect", "Connect"),
                disconnect: client!("disconnect", "Disconnect"),
                list: client!("list", "List"),
                _node: node,
                name: name.clone(),
            };
            let local = radar.participant().served_managers();
            let wanted = service_topics(&name);
            let mut changes = radar.graph().changes();
            let deadline = tokio::time::Instant::now() + timeout;
            loop {
                if local.contains(&name)
                    || !radar.graph().participants_matched_on(&wanted).is_empty()
                {
                    return Ok(m);
                }
                let next = deadline
                    .min(tokio::time::Instant::now() + std::time::Duration::from_millis(50));
                if tokio::time::Instant::now() >= deadline {
                    return Err(Error::Timeout {
                        what: format!(
                            "the manager {name}'s services (managers seen: {})",
                            match radar.managers() {
                                m if m.is_empty() => "none".to_owned(),
                                m => m.join(", "),
                            }
                        ),
                        after: timeout,
                    });
                }
                let _ = tokio::time::timeout_at(next, changes.changed()).await;
            }
        })
    }
}
