//! The connection manager as a ROS 2 node, so other programs (rclpy, the command line, other Rust programs)
//! can make connections through it.
//!
//! `radar.serve_manager("radar_manager")` (or the `radar_manager` binary) makes a node with
//!
//! | endpoint | type |
//! |---|---|
//! | `<name>/connect` (service) | `radar_msgs/srv/Connect` |
//! | `<name>/disconnect` (service) | `radar_msgs/srv/Disconnect` |
//! | `<name>/list` (service) | `radar_msgs/srv/List` |
//! | `<name>/connections` (topic, transient-local) | `radar_msgs/msg/ConnectionList` of the connections made through this node (the program's own statements are on its program node), republished on change (at most every 100 ms) |
//! | `<name>/owners` (topic, read) | `std_msgs/msg/Empty`: owners saying they are alive |
//!
//! It serves the same manager as the program's own statements, so the list shows both. A connection made
//! through the service belongs to the caller's DDS participant (its process) and is removed when that
//! participant leaves the ROS graph: at once when it exits cleanly, at its DDS lease expiry when killed (3-3.6 s
//! for a radar_ros program, see [`crate::settings::DEFAULT_LEASE`]; ~20 s for an rclpy one).
//!
//! An owner may also say it is alive, on `<name>/owners` (a radar_ros program does, every 200 ms, from its
//! first owned connection on: [`RemoteManager::connect`](crate::manager::RemoteManager::connect)). The manager then
//! holds it to that: once it has not heard from an owner for [`OWNER_SILENT`] (a killed, hung or stopped
//! program), the owner's connections deliver nothing (the list says why, in `departure`) until it is heard
//! again; they go when its participant leaves the graph, as above. So a dead program's `whenever bumper start
//! motion` stops within a second, not its lease. An owner that never says it is alive (rclpy calling the
//! service) keeps the lease as its only bound.
//! Errors come back as `ok = false` with a message saying what to do.

use crate::node::transport::{EndpointId, RosNode, Server};
use std::{
    collections::{HashMap, HashSet},
    sync::Arc,
    time::{Duration, Instant},
};

use futures::StreamExt;

use crate::{
    connections::diagnostics::{self, Shown},
    connections::manager::ConnectionGuard,
    error::{Error, Result},
    node::endpoints::{malformed, reply, typed_publisher, Throttle},
    node::services::service_server,
    node::shutdown::ComponentTask,
    radar::Radar,
    wait::DEFAULT_TIMEOUT,
    wire::msg::{
        ConnectRequest, ConnectResponse, Connection as ConnectionMsg, ConnectionList,
        DisconnectRequest, DisconnectResponse, ListRequest, ListResponse,
    },
    wire::names::ComponentName,
    wire::qos::state_qos,
    wire::refs::{Signal, Slot},
};

/// How long an owner that says it is alive may go unheard before its connections deliver nothing (five of its
/// beats: a loaded machine may delay one or two).
pub const OWNER_SILENT: Duration = Duration::from_millis(900);

/// A running manager node; dropping it removes the node and the connections made through its services.
#[must_use = "the manager node serves only while its handle lives; bind it (`let _m = radar.serve_manager(..)?`)"]
pub struct ManagerHandle {
    name: ComponentName,
    task: ComponentTask,
}

impl ManagerHandle {
    /// The node's name.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let manager = radar.serve_manager("radar_manager")?;
    /// assert_eq!(manager.name().fully_qualified(), "/radar_manager");
    /// manager.shutdown().await?; // its service connections go with it
    /// # Ok(()) }
    /// ```
    pub fn name(&self) -> &ComponentName {
        &self.name
    }

    /// Stops serving and waits until the node is gone (unbounded unless `.timeout(d)`).
    ///
    /// # Cancel safety
    ///
    /// The stop is asked for when this is called; dropping the returned wait (or its timeout running out)
    /// leaves the component finishing on its own, its exit slot included.
    pub fn shutdown(self) -> crate::Wait<'static, ()> {
        self.task.shutdown()
    }
}

impl std::fmt::Debug for ManagerHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ManagerHandle")
            .field("name", &self.name.fully_qualified())
            .finish()
    }
}

async fn connect(radar: &Radar, req: &ConnectRequest, owner: String) -> Result<ConnectionGuard> {
    let timeout = if req.timeout > 0.0 {
        Duration::from_secs_f64(req.timeout)
    } else {
        DEFAULT_TIMEOUT
    };
    let source_topic = radar.resolve(&req.source)?.fully_qualified();
    let target_topic = radar.resolve(&req.target)?.fully_qualified();
    let source = Signal::new(
        &source_topic,
        radar.topic_type(&source_topic, true, timeout).await?,
    );
    let statement = match req.kind {
        ConnectionMsg::ONCE => radar.once(source),
        ConnectionMsg::WHENEVER => radar.whenever(source),
        k => {
            return Err(Error::InvalidStatement(format!(
                "kind {k} is neither ONCE (0) nor WHENEVER (1)"
            )))
        }
    };
    if req.until.is_empty() {
        let slot = Slot::new(
            &target_topic,
            radar.topic_type(&target_topic, false, timeout).await?,
        );
        armed(statement.slot(slot), req, owner, timeout).await
    } else {
        let Some((response, crate::endpoint::Endpoint::Start)) =
            crate::endpoint::Endpoint::of_topic(&target_topic)
        else {
            return Err(Error::InvalidStatement(format!(
                "`until` goes with a start slot (…/start), not {target_topic}"
            )));
        };
        let r = radar.response(response).timeout(timeout).await?;
        let u_topic = radar.resolve(&req.until)?.fully_qualified();
        let u = Signal::new(&u_topic, radar.topic_type(&u_topic, true, timeout).await?);
        armed(statement.start(&r).until(u), req, owner, timeout).await
    }
}

/// Arms `c` with the request's properties (a depth of 0 means the default).
async fn armed<T>(
    c: crate::connections::statement::ConnectionRequest<T>,
    req: &ConnectRequest,
    owner: String,
    timeout: Duration,
) -> Result<ConnectionGuard> {
    let c = match std::num::NonZeroUsize::new(req.depth as usize) {
        Some(depth) => c.depth(depth),
        None => c,
    };
    c.owner(owner).timeout(timeout).await
}

impl Radar {
    /// Serves this participant's connection manager as the ROS node `name` (see the module docs).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let manager = radar.serve_manager("radar_manager")?;
    /// // `ros2 service call /radar_manager/list radar_msgs/srv/List` now answers
    /// # Ok(()) }
    /// ```
    pub fn serve_manager(&self, name: &str) -> Result<ManagerHandle> {
        let name = self.resolve(name)?;
        let mut claimed = self.participant().claim_node(&name)?;
        let fq = name.fully_qualified();
        let services = Services::create(&mut claimed.node, &fq)?;
        let shown = Shown {
            node: fq.clone(),
            list: typed_publisher::<ConnectionList>(
                self.graph(),
                &mut claimed.node,
                &name.topic("connections"),
                &state_qos(),
            )?,
            health: diagnostics::health_publisher(self.graph(), &mut claimed.node, &fq)?,
            malformed: None,
        };
        let served = self.participant().served_managers().mark(fq.clone());
        let owners = self.signal_subscription::<crate::wire::msg::Empty>(&name.topic("owners"))?;
        let serving = Serving {
            radar: self.clone(),
            fq,
            owned: HashMap::new(),
            heard: HashMap::new(),
            silent: HashSet::new(),
        };
        let lost = self.graph().participants_lost();
        let task = self
            .participant()
            .spawn_component(claimed, served, move |stop| async move {
                serving.run(services, shown, lost, owners, stop).await;
            });
        tracing::info!(manager = %name, "connection manager serving");
        Ok(ManagerHandle { name, task })
    }
}

/// A manager node's three service servers.
struct Services {
    connect: Arc<Server<ConnectRequest, ConnectResponse>>,
    disconnect: Arc<Server<DisconnectRequest, DisconnectResponse>>,
    list: Arc<Server<ListRequest, ListResponse>>,
}

impl Services {
    fn create(node: &mut RosNode, fq: &str) -> Result<Services> {
        Ok(Services {
            connect: Arc::new(service_server(node, fq, "connect", "Connect")?),
            disconnect: Arc::new(service_server(node, fq, "disconnect", "Disconnect")?),
            list: Arc::new(service_server(node, fq, "list", "List")?),
        })
    }
}

/// A connection made through the service, with its owner's participant (none: detached).
type Owned = (ConnectionGuard, Option<EndpointId>);

/// What a connect request ended with: its request id, its owner, the connection or why not.
type Done = (
    ros2_client::RmwRequestId,
    Option<EndpointId>,
    Result<ConnectionGuard>,
);

/// An owner's participant, as the first 12 bytes of its GUIDs (the prefix).
type OwnerKey = [u8; 12];

fn owner_key(guid: EndpointId) -> OwnerKey {
    let mut k = [0; 12];
    k.copy_from_slice(&guid.to_bytes()[..12]);
    k
}

/// Owners' beats, read in a task of their own (a read is not to be cut by the manager loop's other branches):
/// the task, and each beat's owner.
fn read_beats(
    graph: crate::graph::Graph,
    owners: crate::node::topics::SignalSubscription<crate::wire::msg::Empty>,
) -> (
    tokio::task::JoinHandle<()>,
    tokio::sync::mpsc::UnboundedReceiver<OwnerKey>,
) {
    let (beat_tx, beats) = tokio::sync::mpsc::unbounded_channel::<OwnerKey>();
    let reader = tokio::spawn(async move {
        while let Ok((_, gid)) = owners.recv_from().await {
            // over Zenoh a GID is a hash of its token: the graph tells its process
            if beat_tx.send(owner_key(graph.process_of_gid(gid))).is_err() {
                break;
            }
        }
    });
    (reader, beats)
}

/// A manager node at work: the connections made through its services, by id.
struct Serving {
    radar: Radar,
    fq: String,
    owned: HashMap<u64, Owned>,
    /// Owners that say they are alive, and when each was last heard.
    heard: HashMap<OwnerKey, Instant>,
    /// Those of them unheard for longer than [`OWNER_SILENT`]: their connections are suspended.
    silent: HashSet<OwnerKey>,
}

impl Serving {
    async fn run(
        mut self,
        services: Services,
        shown: Shown,
        mut lost: tokio::sync::broadcast::Receiver<EndpointId>,
        owners: crate::node::topics::SignalSubscription<crate::wire::msg::Empty>,
        mut stop: tokio::sync::oneshot::Receiver<()>,
    ) {
        let (reader, mut beats) = read_beats(self.radar.graph().clone(), owners);
        let mut check = tokio::time::interval(Duration::from_millis(100));
        let (mut changes, mut counts) = (
            self.radar.manager().changes(),
            self.radar.manager().count_changes(),
        );
        let (graph, fq) = (self.radar.graph().clone(), self.fq.clone());
        // the list and its health (once a second too, as diagnostic_updater publishes)
        let (publish, mut beat) = (
            |l| shown.publish(l),
            tokio::time::interval(Duration::from_secs(1)),
        );
        publish(self.made_through());
        // the list changes with every delivered signal (counts): publish at most every 100 ms, and the last
        // change always
        let mut throttle = Throttle::new(Duration::from_millis(100));
        let (done_tx, mut done_rx) = tokio::sync::mpsc::unbounded_channel::<Done>();
        let mut connects = Box::pin(services.connect.receive_request_stream());
        let mut disconnects = Box::pin(services.disconnect.receive_request_stream());
        let mut lists = Box::pin(services.list.receive_request_stream());
        loop {
            tokio::select! {
                _ = &mut stop => break,
                Some(r) = connects.next() => match r {
                    Ok((id, req)) => self.connect(id, req, done_tx.clone()),
                    Err(e) => malformed(&graph, &fq, "connect", &e),
                },
                Some(done) = done_rx.recv() => {
                    if let Some((id, resp)) = self.connected(done) {
                        reply(&services.connect, &graph, &fq, "connect", id, resp);
                    }
                    // a connection made is this node's only now: shown from here on
                    publish(self.made_through());
                }
                Some(r) = disconnects.next() => match r {
                    Ok((id, req)) => {
                        let resp = self.disconnect(req.id);
                        reply(&services.disconnect, &graph, &fq, "disconnect", id, resp);
                    }
                    Err(e) => malformed(&graph, &fq, "disconnect", &e),
                },
                Some(r) = lists.next() => match r {
                    Ok((id, _)) => {
                        let resp = ListResponse { connections: self.made_through() };
                        reply(&services.list, &graph, &fq, "list", id, resp);
                    }
                    Err(e) => malformed(&graph, &fq, "list", &e),
                },
                gone = lost.recv() => {
                    if !self.owner_left(gone) {
                        break;
                    }
                }
                Some(owner) = beats.recv() => self.owner_heard(owner),
                _ = check.tick() => self.owners_silent(),
                Ok(()) = crate::connections::program::changed_or_counted(&mut changes, &mut counts) => {
                    if throttle.changed() {
                        publish(self.made_through());
                    }
                }
                _ = throttle.due() => {
                    publish(self.made_through());
                    throttle.published();
                }
                _ = beat.tick() => shown.health(&self.made_through()),
            }
        }
        reader.abort();
    }

    /// The connections made through this node's services (its program node lists the code's own).
    fn made_through(&self) -> Vec<ConnectionMsg> {
        let mut list = self.radar.manager().listing();
        list.retain(|c| self.owned.contains_key(&c.id));
        list
    }

    /// Arms the requested connection in a task of its own; `done` gets the outcome.
    fn connect(
        &self,
        id: ros2_client::RmwRequestId,
        req: ConnectRequest,
        done: tokio::sync::mpsc::UnboundedSender<Done>,
    ) {
        let radar = self.radar.clone();
        let caller: EndpointId = radar.graph().process_of_gid(id.writer_gid);
        tokio::spawn(async move {
            let owner = match req.detach {
                true => format!("detached, by service caller {:?}", caller.prefix),
                false => format!("service caller {:?}", caller.prefix),
            };
            let r = connect(&radar, &req, owner).await;
            let _ = done.send((id, (!req.detach).then_some(caller), r));
        });
    }

    /// A connect request's outcome: the answer to send, if any (none when the caller has left).
    fn connected(
        &mut self,
        (id, caller, r): Done,
    ) -> Option<(ros2_client::RmwRequestId, ConnectResponse)> {
        let resp = match r {
            // B7: the caller left while the connection armed: it is not kept for nobody
            Ok(c) if caller.is_some_and(|c| self.radar.graph().has_left(c)) => {
                tracing::info!(
                    connection = c.id(),
                    "the caller left while its connection armed; it is gone"
                );
                return None;
            }
            Ok(c) => {
                let cid = c.id();
                self.owned.insert(cid, (c, caller));
                ConnectResponse {
                    ok: true,
                    error: String::new(),
                    id: cid,
                }
            }
            Err(e) => ConnectResponse {
                ok: false,
                error: e.to_string(),
                id: 0,
            },
        };
        Some((id, resp))
    }

    /// Removes connection `id`, if it was made through the service.
    fn disconnect(&mut self, id: u64) -> DisconnectResponse {
        match self.owned.remove(&id) {
            Some(_) => DisconnectResponse {
                ok: true,
                error: String::new(),
            },
            None => DisconnectResponse {
                ok: false,
                error: format!(
                    "no connection {id} made through this service; the list service shows the live ones"
                ),
            },
        }
    }

    /// An owner said it is alive: its connections deliver again if they were suspended.
    fn owner_heard(&mut self, owner: OwnerKey) {
        self.heard.insert(owner, Instant::now());
        if self.silent.remove(&owner) {
            let n = self.suspend(owner, None);
            tracing::info!(
                connections = n,
                "a silent owner is heard again; its connections deliver again"
            );
        }
    }

    /// Owners unheard for longer than [`OWNER_SILENT`]: their connections deliver nothing until they are heard.
    fn owners_silent(&mut self) {
        let newly: Vec<(OwnerKey, Duration)> = self
            .heard
            .iter()
            .filter(|(k, t)| t.elapsed() > OWNER_SILENT && !self.silent.contains(*k))
            .map(|(k, t)| (*k, t.elapsed()))
            .collect();
        for (owner, quiet) in newly {
            self.silent.insert(owner);
            let why = format!(
                "its owner has not said it is alive for {:.1} s (killed, hung or stopped?): it delivers \
                 nothing until the owner is heard again, and goes when the owner leaves the graph",
                quiet.as_secs_f64()
            );
            let n = self.suspend(owner, Some(why));
            tracing::warn!(
                connections = n,
                silent_ms = quiet.as_millis() as u64,
                "an owner went silent; its connections deliver nothing until it is heard again"
            );
        }
    }

    /// Suspends (`why`) or resumes the connections of `owner`; how many it has.
    fn suspend(&self, owner: OwnerKey, why: Option<String>) -> usize {
        let mine: Vec<&ConnectionGuard> = self
            .owned
            .values()
            .filter(|(_, caller)| caller.is_some_and(|c| owner_key(c) == owner))
            .map(|(c, _)| c)
            .collect();
        for c in &mine {
            c.suspend(why.clone());
        }
        mine.len()
    }

    /// A participant left the graph: its connections go. False once departures can no longer be heard.
    fn owner_left(
        &mut self,
        gone: std::result::Result<EndpointId, tokio::sync::broadcast::error::RecvError>,
    ) -> bool {
        use tokio::sync::broadcast::error::RecvError;
        let before = self.owned.len();
        match gone {
            Ok(gone) => {
                self.heard.remove(&owner_key(gone));
                self.silent.remove(&owner_key(gone));
                self.owned
                    .retain(|_, (_, caller)| caller.is_none_or(|c| c.prefix != gone.prefix))
            }
            // B7: departures were missed: ask the graph about every owner
            Err(RecvError::Lagged(_)) => {
                let graph = self.radar.graph();
                self.owned
                    .retain(|_, (_, caller)| caller.is_none_or(|c| !graph.has_left(c)))
            }
            Err(RecvError::Closed) => return false,
        }
        if self.owned.len() != before {
            let removed = before - self.owned.len();
            tracing::info!(removed, "an owner left the graph; its connections are gone");
        }
        true
    }
}
