//! The core every part of a [`Radar`](crate::Radar) stands on: one DDS participant with its ROS 2 context,
//! the match graph, the plain node for endpoints that belong to no component, the names components have
//! claimed, the pool of shared endpoints, and the one place endpoints are made.
//!
//! Components, the connection manager and plain publishers all depend on this module; it depends on none of
//! them.

use std::{
    collections::HashSet,
    sync::{Arc, Mutex},
};

use ros2_client::{NodeName, NodeOptions};

use crate::{
    error::{Error, Result},
    graph::Graph,
    node::pool::Pool,
    node::transport::RosNode as Node,
    wire::names::ComponentName,
};

/// Names this process serves (actions, managers): a client here is matched with them locally, which
/// discovery does not show, so it asks here.
#[derive(Clone, Default)]
pub(crate) struct Served(Arc<Mutex<HashSet<String>>>);

impl Served {
    pub(crate) fn contains(&self, name: &str) -> bool {
        self.0.lock().unwrap().contains(name)
    }

    pub(crate) fn names(&self) -> Vec<String> {
        self.0.lock().unwrap().iter().cloned().collect()
    }

    /// Marks `name` served until the returned mark is dropped.
    pub(crate) fn mark(&self, name: String) -> ServedMark {
        self.0.lock().unwrap().insert(name.clone());
        ServedMark(self.clone(), name)
    }
}

/// A served name, unmarked on drop.
pub(crate) struct ServedMark(Served, String);

impl Drop for ServedMark {
    fn drop(&mut self) {
        self.0 .0.lock().unwrap().remove(&self.1);
    }
}

/// The transport a participant is on: a DDS participant (its ros2-client context), or a Zenoh session as
/// rmw_zenoh's (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`, the `zenoh` feature).
pub(crate) enum Ctx {
    /// DDS.
    Dds(ros2_client::dds::Context),
    /// Zenoh, with where its endpoints count samples that do not decode, and how long a departure must last
    /// to be believed (the lease).
    #[cfg(feature = "zenoh")]
    Zenoh(
        ros2_client::zenoh::Context,
        Arc<crate::wire::malformed::Malformed>,
        std::time::Duration,
    ),
}

/// One DDS participant (or Zenoh session) and what hangs off it.
pub(crate) struct Participant {
    ctx: Ctx,
    domain_id: u16,
    namespace: String,
    graph: Graph,
    /// Fully qualified names of the components of this process.
    names: Mutex<HashSet<String>>,
    /// A plain node for endpoints that belong to no component, made on first use.
    client: Mutex<Option<Node>>,
    pool: Arc<Pool>,
    /// Actions this process serves (`Radar::serve_as_action`): a client here is matched with them locally,
    /// which discovery does not show.
    served_actions: Served,
    /// Managers this process serves (`Radar::serve_manager`), matched locally, unseen by discovery.
    served_managers: Served,
    stop_graph: Mutex<Option<tokio::sync::oneshot::Sender<()>>>,
    /// Says when the graph's thread has ended (it let go of the DDS participant).
    graph_ended: Mutex<Option<std::sync::mpsc::Receiver<()>>>,
    /// The program node's name, once made.
    program_node: Mutex<Option<String>>,
    /// The slots of this process's responses, for in-process delivery.
    inlets: Arc<crate::wire::local::Inlets>,
    /// The types whose payloads this process can check (C2).
    readers: crate::wire::readers::Readers,
    /// The signals of this process's components, for in-process delivery.
    taps: crate::wire::local::Taps,
    /// The components of this participant, so that they can all be stopped at once.
    components: crate::node::shutdown::Components,
    /// How long they may take to stop (exit slots included).
    shutdown_timeout: std::time::Duration,
    /// The process's `--ros-args`, and the program node's name that node-specific rules match.
    ros_args: Arc<crate::node::ros_args::RosArgs>,
    rule_node: String,
    /// Simulated time when `use_sim_time` is on (set once the program node exists); the wall clock otherwise.
    clock: std::sync::OnceLock<crate::node::clock::Clock>,
    /// `RADAR_GENERATE_POLICY`: what writes the program's policy when it ends, given the domain and the names
    /// of this participant's nodes (set by the `Radar`, which knows the enclave and the policy's format).
    policy_out: Mutex<Option<PolicyWriter>>,
    /// The nodes made on this participant (fully qualified), whose declarations its policy holds.
    node_names: Mutex<std::collections::BTreeSet<String>>,
    /// Managers told that this program is alive ([`Participant::keep_owner_alive`]).
    owner_of: Mutex<HashSet<String>>,
}

/// How often a program that owns connections in another program's manager says it is alive.
pub(crate) const OWNER_BEAT: std::time::Duration = std::time::Duration::from_millis(200);

impl crate::node::shutdown::Stoppable for Participant {
    fn components(&self) -> &crate::node::shutdown::Components {
        &self.components
    }

    fn shutdown_timeout(&self) -> std::time::Duration {
        self.shutdown_timeout
    }

    fn leave(&self) {
        self.write_policy();
        match &self.ctx {
            Ctx::Dds(ctx) => ctx.domain_participant().close(),
            // over Zenoh each node and endpoint drops its liveliness token as it goes
            #[cfg(feature = "zenoh")]
            Ctx::Zenoh(..) => {}
        }
    }
}

impl Drop for Participant {
    fn drop(&mut self) {
        self.write_policy();
        if let Some(stop) = self.stop_graph.lock().unwrap().take() {
            let _ = stop.send(());
        }
        // the graph's thread holds the DDS participant's discovery until it ends: let it end before this
        // returns, so that the participant's goodbye is sent by the thread that lets go of radar_ros (a process
        // that ends right after must not end before the goodbye)
        if let Some(ended) = self.graph_ended.lock().unwrap().take() {
            let _ = ended.recv_timeout(std::time::Duration::from_secs(2));
        }
    }
}

/// Writes a program's policy from its domain and its nodes' names (see [`Participant::generate_policy`]).
pub(crate) type PolicyWriter = Box<dyn FnOnce(u16, &std::collections::BTreeSet<String>) + Send>;

/// The program nodes of this process (fully qualified), so that each live program's is distinct.
static PROGRAM_NODES: Mutex<std::collections::BTreeSet<String>> =
    Mutex::new(std::collections::BTreeSet::new());

/// A name held in `PROGRAM_NODES` until the last handle to its `Radar` drops it, not until the participant goes
/// (a component's task let go of on a worker thread may hold that a while after the program ended).
pub(crate) struct ProgramName(String);

impl Drop for ProgramName {
    fn drop(&mut self) {
        PROGRAM_NODES.lock().unwrap().remove(&self.0);
    }
}

impl Participant {
    /// Has `write` called with this participant's domain and node names when it ends
    /// (`RADAR_GENERATE_POLICY`).
    pub(crate) fn generate_policy(&self, write: PolicyWriter) {
        *self.policy_out.lock().unwrap() = Some(write);
    }

    /// Notes that the node `fq` (fully qualified) was made on this participant.
    pub(crate) fn note_node(&self, fq: &str) {
        self.node_names.lock().unwrap().insert(fq.to_owned());
    }

    /// The nodes made on this participant (fully qualified), whose declarations its policy holds.
    pub(crate) fn node_names(&self) -> std::collections::BTreeSet<String> {
        self.node_names.lock().unwrap().clone()
    }

    /// Writes what [`Participant::generate_policy`] asked for, once.
    fn write_policy(&self) {
        let write = self.policy_out.lock().unwrap().take();
        if let Some(write) = write {
            write(self.domain_id, &self.node_names());
        }
    }

    /// Wraps `ctx`, starting the graph's discovery task on a thread of its own (so that discovery goes on when
    /// the program's runtime has gone: exit slots that run after `main` returns may look components up) and the
    /// pool's sweeper on `rt`.
    pub(crate) fn start(
        ctx: Ctx,
        domain_id: u16,
        namespace: String,
        (ros_args, rule_node): (Arc<crate::node::ros_args::RosArgs>, String),
        shutdown_timeout: std::time::Duration,
        rt: &tokio::runtime::Handle,
    ) -> Arc<Participant> {
        let graph = Graph::default();
        let (stop, stop_rx) = tokio::sync::oneshot::channel();
        let (ended_tx, ended) = std::sync::mpsc::channel();
        let run: std::pin::Pin<Box<dyn std::future::Future<Output = ()> + Send>> = match &ctx {
            Ctx::Dds(dds) => {
                graph.set_participant(dds.domain_participant());
                Box::pin(graph.clone().run(dds.domain_participant(), stop_rx))
            }
            // over Zenoh the graph is the liveliness tokens' (`graph/tokens.rs`); match counts each endpoint
            // watches itself
            #[cfg(feature = "zenoh")]
            Ctx::Zenoh(z, _, grace) => {
                graph.set_zenoh(z.clone(), *grace);
                Box::pin(graph.clone().run_tokens(stop_rx))
            }
        };
        let on_thread = std::thread::Builder::new()
            .name("radar-graph".into())
            .spawn(move || {
                match tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                {
                    Ok(graph_rt) => graph_rt.block_on(run),
                    Err(e) => tracing::error!("cannot start the ROS graph's task: {e}"),
                }
                let _ = ended_tx.send(());
            });
        if let Err(e) = on_thread {
            tracing::error!("cannot start the ROS graph's thread: {e}");
        }
        Self::with(
            ctx,
            domain_id,
            namespace,
            graph,
            (stop, ended),
            (ros_args, rule_node),
            shutdown_timeout,
            rt,
        )
    }

    /// The participant on `ctx`, its graph started (over DDS).
    #[allow(clippy::too_many_arguments)]
    fn with(
        ctx: Ctx,
        domain_id: u16,
        namespace: String,
        graph: Graph,
        (stop, ended): (
            tokio::sync::oneshot::Sender<()>,
            std::sync::mpsc::Receiver<()>,
        ),
        (ros_args, rule_node): (Arc<crate::node::ros_args::RosArgs>, String),
        shutdown_timeout: std::time::Duration,
        rt: &tokio::runtime::Handle,
    ) -> Arc<Participant> {
        let pool = Arc::new(Pool::default());
        rt.spawn(Pool::sweeper(Arc::downgrade(&pool)));
        Arc::new(Participant {
            ctx,
            domain_id,
            namespace,
            graph,
            names: Mutex::new(HashSet::new()),
            client: Mutex::new(None),
            pool,
            served_actions: Default::default(),
            served_managers: Default::default(),
            stop_graph: Mutex::new(Some(stop)),
            graph_ended: Mutex::new(Some(ended)),
            program_node: Mutex::new(None),
            inlets: Default::default(),
            readers: Default::default(),
            taps: Default::default(),
            components: Default::default(),
            shutdown_timeout,
            ros_args,
            rule_node,
            clock: std::sync::OnceLock::new(),
            policy_out: Mutex::new(None),
            node_names: Mutex::new(std::collections::BTreeSet::new()),
            owner_of: Mutex::new(HashSet::new()),
        })
    }

    /// Tells manager `manager` (fully qualified) that this program, which owns connections there, is alive:
    /// a sample on `<manager>/owners` every [`OWNER_BEAT`] for as long as this participant lives (on the
    /// caller's runtime: a program whose runtime is gone is not alive). The manager suspends the connections of
    /// an owner it has not heard from for `OWNER_SILENT` (see `radar/manager_node.rs`), once it has heard it: so the
    /// first beat goes out once the manager reads them (waiting at most `within`; a manager that does not read
    /// them, an older one, only has the lease), before the first connection is asked for. Once per manager.
    pub(crate) async fn keep_owner_alive(
        self: &Arc<Self>,
        manager: &str,
        within: std::time::Duration,
    ) -> Result<()> {
        if !self.owner_of.lock().unwrap().insert(manager.to_owned()) {
            return Ok(());
        }
        let beat = self.publisher::<crate::wire::msg::Empty>(
            &format!("{manager}/owners"),
            &crate::wire::qos::signal_qos(),
        )?;
        if beat.wait_for_subscribers(1).timeout(within).await.is_ok() {
            let _ = beat.publish(crate::wire::msg::Empty::default());
        }
        // no strong reference: the participant goes when its program lets go of it, and so does the beat
        let alive = Arc::downgrade(self);
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(OWNER_BEAT);
            while alive.strong_count() > 0 {
                tick.tick().await;
                if beat.publish(crate::wire::msg::Empty::default()).is_err() {
                    break; // the participant has left the graph
                }
            }
        });
        Ok(())
    }

    /// The components of this participant.
    pub(crate) fn components(&self) -> &crate::node::shutdown::Components {
        &self.components
    }

    /// How long its components may take to stop.
    pub(crate) fn shutdown_timeout(&self) -> std::time::Duration {
        self.shutdown_timeout
    }

    /// The DDS participant's GUID; over Zenoh the session's id (16 bytes as well).
    pub(crate) fn guid(&self) -> crate::node::transport::EndpointId {
        match &self.ctx {
            Ctx::Dds(ctx) => {
                use ros2_client::dds::rustdds::RTPSEntity;
                ctx.domain_participant().guid()
            }
            #[cfg(feature = "zenoh")]
            Ctx::Zenoh(ctx, ..) => {
                crate::graph::tokens::participant_of_session(&ctx.session().zid().to_string())
            }
        }
    }

    /// The DDS context, over DDS.
    #[allow(irrefutable_let_patterns)] // without the zenoh feature, DDS is the only transport
    pub(crate) fn dds_context(&self) -> Option<&ros2_client::dds::Context> {
        match &self.ctx {
            Ctx::Dds(ctx) => Some(ctx),
            #[cfg(feature = "zenoh")]
            Ctx::Zenoh(..) => None,
        }
    }

    /// The Zenoh session's context, over Zenoh.
    #[cfg(feature = "zenoh")]
    pub(crate) fn zenoh_context(&self) -> Option<ros2_client::zenoh::Context> {
        let Ctx::Zenoh(ctx, ..) = &self.ctx else {
            return None;
        };
        Some(ctx.clone())
    }

    /// Whether this participant is on Zenoh.
    pub(crate) fn over_zenoh(&self) -> bool {
        self.dds_context().is_none()
    }

    pub(crate) fn domain_id(&self) -> u16 {
        self.domain_id
    }

    pub(crate) fn namespace(&self) -> &str {
        &self.namespace
    }

    pub(crate) fn graph(&self) -> &Graph {
        &self.graph
    }

    pub(crate) fn served_actions(&self) -> Served {
        self.served_actions.clone()
    }

    pub(crate) fn served_managers(&self) -> Served {
        self.served_managers.clone()
    }

    /// The slots of this process's responses, reachable without DDS.
    pub(crate) fn inlets(&self) -> &Arc<crate::wire::local::Inlets> {
        &self.inlets
    }

    /// The types whose payloads this process can check (rule C2).
    pub(crate) fn readers(&self) -> &crate::wire::readers::Readers {
        &self.readers
    }

    /// The signals of this process's components, reachable without DDS.
    pub(crate) fn taps(&self) -> &crate::wire::local::Taps {
        &self.taps
    }

    pub(crate) fn pool(&self) -> &Pool {
        &self.pool
    }

    /// Resolves and validates a component name against this participant's namespace, then applies the
    /// process's `-r from:=to` remapping rules (see [`crate::node::ros_args`]).
    pub(crate) fn resolve(&self, name: &str) -> Result<ComponentName> {
        let n = ComponentName::resolve(name, &self.namespace)?;
        match self
            .ros_args
            .remap_name(&n.fully_qualified(), &self.rule_node, &self.namespace)
        {
            Some(to) => ComponentName::resolve(&to, "/"),
            None => Ok(n),
        }
    }

    /// The clock components follow.
    pub(crate) fn clock(&self) -> crate::node::clock::Clock {
        self.clock
            .get()
            .cloned()
            .unwrap_or_else(crate::node::clock::Clock::wall)
    }

    /// Makes components follow `clock` (simulated time), once.
    pub(crate) fn set_clock(&self, clock: crate::node::clock::Clock) {
        let _ = self.clock.set(clock);
    }

    /// The process's ROS arguments.
    pub(crate) fn ros_args(&self) -> &Arc<crate::node::ros_args::RosArgs> {
        &self.ros_args
    }

    /// Resolves a topic like a component name (relative topics in this participant's namespace).
    pub(crate) fn resolve_topic(&self, topic: &str) -> Result<String> {
        Ok(self.resolve(topic)?.fully_qualified())
    }

    /// Creates a plain node: no rosout, no parameter services (a RADAR node's endpoints are its signals and
    /// its state).
    pub(crate) fn new_node(&self, namespace: &str, base: &str) -> Result<Node> {
        let fq = ComponentName::resolve(base, namespace)?.fully_qualified();
        let name = NodeName::new(namespace, base).map_err(|e| Error::InvalidName {
            name: fq.clone(),
            reason: format!("{e}"),
        })?;
        let options = NodeOptions::new()
            .enable_rosout(false)
            .start_parameter_services(false);
        self.note_node(&fq);
        match &self.ctx {
            Ctx::Dds(ctx) => ctx
                .new_node(name, options)
                .map(Node::Dds)
                .map_err(|e| Error::transport(format!("node {fq}"), e)),
            #[cfg(feature = "zenoh")]
            Ctx::Zenoh(ctx, malformed, grace) => ctx
                .new_node(name, options)
                .map(|node| {
                    Node::Zenoh(crate::node::transport::ZenohNode {
                        node,
                        domain_id: self.domain_id,
                        malformed: malformed.clone(),
                        grace: *grace,
                        ctx: ctx.clone(),
                    })
                })
                .map_err(|e| Error::transport(format!("node {fq} over Zenoh"), e)),
        }
    }

    /// Creates this participant's program node: the node of its plain endpoints, which also shows the
    /// program's connections (see `program.rs`). Named `node` in the participant's namespace, and
    /// `<node>_<n>` for the n-th participant of the process with that name, so each is
    /// distinct on the graph and none takes a name a component may want (process-wide: every program of the
    /// process that has not ended is counted). Returns the node's name and the claim that holds it.
    pub(crate) fn start_program_node(
        self: &Arc<Self>,
        node: &str,
    ) -> Result<(ComponentName, ProgramName)> {
        let mut k = 1;
        loop {
            let base = match k {
                1 => node.to_owned(),
                _ => format!("{node}_{k}"),
            };
            // a node's own name is not remapped by `from:=to` rules (only by __node, before this)
            let name = ComponentName::resolve(&base, &self.namespace)?;
            let fq = name.fully_qualified();
            if !self.names.lock().unwrap().contains(&fq)
                && PROGRAM_NODES.lock().unwrap().insert(fq.clone())
            {
                let claim = ProgramName(fq.clone());
                self.names.lock().unwrap().insert(fq.clone());
                *self.program_node.lock().unwrap() = Some(fq);
                *self.client.lock().unwrap() = Some(self.new_node(name.namespace(), name.base())?);
                return Ok((name, claim));
            }
            k += 1;
        }
    }

    /// Runs `f` with this participant's program node (made by [`Participant::start_program_node`]).
    pub(crate) fn with_client_node<T>(&self, f: impl FnOnce(&mut Node) -> Result<T>) -> Result<T> {
        let mut guard = self.client.lock().unwrap();
        let node = guard
            .as_mut()
            .ok_or_else(|| Error::Closed("the program node".into()))?;
        f(node)
    }

    /// Records that the program node may write `topic` (absolute) though it makes no writer for it now: an
    /// outlet that reaches a slot of this process in-process makes one when that response leaves (see
    /// [`crate::node::declared`]), so a policy generated from this run grants it.
    pub(crate) fn declare_writer(&self, topic: &str) {
        if let Some(fq) = self.program_node.lock().unwrap().as_deref() {
            crate::node::declared::record(
                self.domain_id,
                fq,
                crate::node::declared::Access::Publish,
                topic,
            );
        }
    }

    /// Claims a name for a component in this process and creates its node.
    pub(crate) fn claim_node(self: &Arc<Self>, name: &ComponentName) -> Result<ClaimedNode> {
        let fq = name.fully_qualified();
        if !self.names.lock().unwrap().insert(fq.clone()) {
            return Err(Error::DuplicateName(fq));
        }
        let claim = NameClaim {
            participant: self.clone(),
            name: fq,
        };
        let node = self.new_node(name.namespace(), name.base())?;
        Ok(ClaimedNode { node, claim })
    }

    /// Spawns the task of the component whose node is `node` ([`ComponentTask::spawn`]): the node, the claim
    /// on its name and `keep` (what else the component holds while it runs: its parameters, a served mark)
    /// live until the task ends, and go in that order: the node leaves the graph before the name is free
    /// again in this process.
    pub(crate) fn spawn_component<K, F, Fut>(
        &self,
        node: ClaimedNode,
        keep: K,
        f: F,
    ) -> crate::node::shutdown::ComponentTask
    where
        K: Send + 'static,
        F: FnOnce(tokio::sync::oneshot::Receiver<()>) -> Fut,
        Fut: std::future::Future<Output = ()> + Send + 'static,
    {
        let ClaimedNode { node, claim } = node;
        let name = claim.name.clone();
        crate::node::shutdown::ComponentTask::spawn(self.components(), &name, move |stop| {
            // boxed: each async block that holds a future and awaits it keeps room for it twice (as what it
            // captured and as what it awaits), and two such layers made a response's task 87 KiB for a 22 KiB
            // future (heaptrack; an event's 18 KiB for 4 KiB)
            let fut = Box::pin(f(stop));
            async move {
                // dropped in reverse: the node, then `keep`, then the claim
                let _claim = claim;
                let _keep = keep;
                let _node = node;
                fut.await;
            }
        })
    }
}

/// Frees a claimed component name when the component stops.
/// A component's node, with the claim on its name in this process ([`Participant::claim_node`]).
pub(crate) struct ClaimedNode {
    /// The node, to make the component's endpoints on.
    pub(crate) node: Node,
    claim: NameClaim,
}

pub(crate) struct NameClaim {
    participant: Arc<Participant>,
    name: String,
}

impl Drop for NameClaim {
    fn drop(&mut self) {
        self.participant.names.lock().unwrap().remove(&self.name);
    }
}
