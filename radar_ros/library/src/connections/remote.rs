//! Another program's connection manager, through its services: what `radar con` / `radar dis` use, and what
//! a Rust program uses to leave connections in a standalone manager (`radar_manager`).
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
//! use radar_ros::manager::RemoteStatement;
//! let m = radar.remote_manager("/radar_manager").await?;
//! let whenever = RemoteStatement::whenever("/bumper/triggered").to("/dock/start");
//! let id = m.connect(whenever.detach()).await?; // stays after this program ends
//! m.disconnect(id).await?;
//! # Ok(()) }
//! ```
//!
//! Each call waits for the manager's answer, 30 s at most unless `.timeout(d)`. Dropping the wait (a
//! `select!` branch that lost) does not take back a request already sent: a connection may still be made,
//! and is listed by [`RemoteManager::list`].

use crate::node::transport::{Client, RosNode as Node};

use crate::{
    error::{Error, Result},
    wait::Wait,
    wire::msg::{
        ConnectRequest, ConnectResponse, Connection, DisconnectRequest, DisconnectResponse,
        ListRequest, ListResponse,
    },
};

/// How long an owner waits for the manager to read its beats before its first connection there.
const OWNER_MATCH: std::time::Duration = std::time::Duration::from_secs(3);

/// How long a call to another manager waits for its answer unless `.timeout(d)`.
const CALL_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(30);

/// A statement made through another program's manager: `once` or `whenever` a source signal, to a slot,
/// optionally `until` a signal; the typed form of the manager's `connect` request
/// (`radar_msgs/srv/Connect`). Names resolve in the manager's namespace.
///
/// ```
/// use radar_ros::manager::RemoteStatement;
/// let s = RemoteStatement::once("/go/triggered").to("/arm/start").until("/stop/triggered").depth(20);
/// let req = s.request();
/// assert_eq!((req.kind, req.target.as_str(), req.depth), (radar_ros::msg::Connection::ONCE, "/arm/start", 20));
/// ```
#[derive(Clone, Debug, PartialEq)]
#[must_use]
pub struct RemoteStatement {
    once: bool,
    source: String,
    target: String,
    until: Option<String>,
    timeout: Option<std::time::Duration>,
    depth: Option<u32>,
    detach: bool,
}

impl RemoteStatement {
    /// `once source`: delivers the first signal after it is armed, then ends.
    pub fn once(source: &str) -> Self {
        Self::new(true, source)
    }

    /// `whenever source`: delivers every signal until removed.
    pub fn whenever(source: &str) -> Self {
        Self::new(false, source)
    }

    fn new(once: bool, source: &str) -> Self {
        RemoteStatement {
            once,
            source: source.to_owned(),
            target: String::new(),
            until: None,
            timeout: None,
            depth: None,
            detach: false,
        }
    }

    /// The slot topic the signals go to (`/dock/start`, `/dock/interrupt`, ...).
    pub fn to(mut self, slot: &str) -> Self {
        self.target = slot.to_owned();
        self
    }

    /// `until signal`: interrupts the run the statement started (only with a start slot).
    pub fn until(mut self, signal: &str) -> Self {
        self.until = Some(signal.to_owned());
        self
    }

    /// How long the manager waits for the components to appear (default 5 s).
    pub fn arm_within(mut self, d: std::time::Duration) -> Self {
        self.timeout = Some(d);
        self
    }

    /// History depth of the manager's relay: signals queued while the target lags (default 10).
    pub fn depth(mut self, n: u32) -> Self {
        self.depth = Some(n);
        self
    }

    /// Leaves the connection under the manager after this program ends (until `disconnect`).
    pub fn detach(mut self) -> Self {
        self.detach = true;
        self
    }

    /// The manager's `connect` request for it.
    pub fn request(&self) -> ConnectRequest {
        ConnectRequest {
            kind: if self.once {
                Connection::ONCE
            } else {
                Connection::WHENEVER
            },
            source: self.source.clone(),
            target: self.target.clone(),
            until: self.until.clone().unwrap_or_default(),
            timeout: self.timeout.map(|d| d.as_secs_f64()).unwrap_or_default(),
            depth: self.depth.unwrap_or_default(),
            detach: self.detach,
        }
    }
}

/// Clients of one manager node's `connect`, `disconnect` and `list` services, matched both ways.
pub struct RemoteManager {
    pub(crate) name: String,
    /// This program's participant: it says it is alive to the manager while it owns connections there.
    pub(crate) owner: std::sync::Arc<crate::node::participant::Participant>,
    pub(crate) connect: Client<ConnectRequest, ConnectResponse>,
    pub(crate) disconnect: Client<DisconnectRequest, DisconnectResponse>,
    pub(crate) list: Client<ListRequest, ListResponse>,
    pub(crate) _node: Node,
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

    /// Makes the connection `statement` asks for; its id. Unless detached, it belongs to this program and
    /// ends when this program leaves the graph.
    pub fn connect(&self, statement: RemoteStatement) -> Wait<'_, u64> {
        let req = statement.request();
        self.calling(move |limit| async move {
            // an owned connection needs its owner alive (the manager suspends it within a second of the last
            // beat: a dead program's `whenever bumper start motion` must not go on for its lease)
            if !req.detach {
                self.owner
                    .keep_owner_alive(&self.name, limit.min(OWNER_MATCH))
                    .await?;
            }
            let r = self.call(&self.connect, req, "connect", limit).await?;
            match r.ok {
                true => Ok(r.id),
                false => Err(self.refused(r.error)),
            }
        })
    }

    /// Removes connection `id` (made through these services).
    pub fn disconnect(&self, id: u64) -> Wait<'_, ()> {
        self.calling(move |limit| async move {
            let req = DisconnectRequest { id };
            let r = self
                .call(&self.disconnect, req, "disconnect", limit)
                .await?;
            match r.ok {
                true => Ok(()),
                false => Err(self.refused(r.error)),
            }
        })
    }

    /// Every live connection of the manager.
    pub fn list(&self) -> Wait<'_, Vec<Connection>> {
        self.calling(move |limit| async move {
            let r = self
                .call(&self.list, ListRequest::default(), "list", limit)
                .await?;
            Ok(r.connections)
        })
    }

    /// A call, waiting for the answer [`CALL_TIMEOUT`] unless `.timeout(d)`.
    fn calling<'a, T: 'a, Fut>(
        &'a self,
        f: impl FnOnce(std::time::Duration) -> Fut + Send + 'a,
    ) -> Wait<'a, T>
    where
        Fut: std::future::Future<Output = Result<T>> + Send + 'a,
    {
        Wait::new(Some(CALL_TIMEOUT), move |limit| {
            f(limit.unwrap_or(CALL_TIMEOUT))
        })
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
        limit: std::time::Duration,
    ) -> Result<Resp>
    where
        Req: ros2_client::Message + 'static,
        Resp: ros2_client::Message + 'static,
    {
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
