//! Parameters of RADAR components, served as rclcpp and rclpy serve a node's: `ros2 param list/get/set/
//! describe/dump` and rclpy's parameter client work on them, and changes are published on `/parameter_events`.
//!
//! A component declares its parameters when it is set up ([`crate::nodes::EventNode::declare`],
//! [`crate::nodes::ResponseNode::declare`]), each with a default value (its type), a description, a range, read-only
//! or not. The values start from the command line when it sets them (`-p name:=value`, `--params-file`, for
//! the component's node name: see [`crate::node::ros_args`]), else from the defaults. A `set` from `ros2 param set` or
//! [`Params::set`] is checked against the declaration (type, range, read-only) and refused with the reason
//! otherwise, as rclcpp does.
//!
//! The component reads them through its [`Params`] handle whenever it wants: **a change applies from the next
//! read**. A check or start behaviour that reads a parameter at its beginning keeps the value it read for that
//! run; one that must react mid-run awaits [`ParamWatch::changed`].
//!
//! ```
//! use radar_ros::{Event, nodes::EventNode, SlotError, msg::Empty, params::{ParamDecl, Params}};
//! /// Triggers every `interval` seconds; `ros2 param set /tick interval 0.5` changes it from the next wait.
//! struct Tick(Option<Params>);
//! impl Event for Tick {
//!     type Payload = Empty;
//!     fn attach(&mut self, node: &mut EventNode<'_>) -> radar_ros::Result<()> {
//!         self.0 = Some(node.declare([ParamDecl::new("interval", 1.0)
//!             .description("seconds between triggers")
//!             .float_range(0.01, 3600.0)])?);
//!         Ok(())
//!     }
//!     async fn check(&mut self) -> Result<Empty, SlotError> {
//!         let secs = self.0.as_ref().and_then(|p| p.f64("interval")).unwrap_or(1.0);
//!         tokio::time::sleep(std::time::Duration::from_secs_f64(secs)).await;
//!         Ok(Empty::default())
//!     }
//! }
//! ```

mod serve;
mod store;

use std::sync::{Arc, Mutex};

pub use ros2_client::ParameterValue;
pub(crate) use serve::{serve, Serving};
pub(crate) use store::Store;
pub use store::{ParamDecl, ParamValue};

use crate::error::{Error, Result};

/// The parameters of one component: read them, set them (checked as `ros2 param set` is), watch them change.
/// Cheap to clone.
#[derive(Clone)]
pub struct Params {
    inner: Arc<Inner>,
}

struct Inner {
    node: String,
    store: Mutex<Store>,
    version: tokio::sync::watch::Sender<u64>,
    /// Publishes a change on `/parameter_events` (set by `serve`).
    events: serve::Events,
}

impl std::fmt::Debug for Params {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Params")
            .field("node", &self.inner.node)
            .finish()
    }
}

impl Params {
    fn new(node: String, store: Store, events: serve::Events) -> Params {
        Params {
            inner: Arc::new(Inner {
                node,
                store: Mutex::new(store),
                version: tokio::sync::watch::channel(0).0,
                events,
            }),
        }
    }

    /// The node they belong to (fully qualified).
    pub fn node(&self) -> &str {
        &self.inner.node
    }

    /// The value of `name`, if declared.
    pub fn get(&self, name: &str) -> Option<ParameterValue> {
        self.inner.store.lock().unwrap().get(name).cloned()
    }

    /// A `double` parameter's value.
    pub fn f64(&self, name: &str) -> Option<f64> {
        match self.get(name)? {
            ParameterValue::Double(x) => Some(x),
            _ => None,
        }
    }

    /// An `integer` parameter's value.
    pub fn i64(&self, name: &str) -> Option<i64> {
        match self.get(name)? {
            ParameterValue::Integer(x) => Some(x),
            _ => None,
        }
    }

    /// A `bool` parameter's value.
    pub fn bool(&self, name: &str) -> Option<bool> {
        match self.get(name)? {
            ParameterValue::Boolean(x) => Some(x),
            _ => None,
        }
    }

    /// A `string` parameter's value.
    pub fn string(&self, name: &str) -> Option<String> {
        match self.get(name)? {
            ParameterValue::String(x) => Some(x),
            _ => None,
        }
    }

    /// Sets `name` as `ros2 param set` would: refused (with the reason) when it is not declared, read-only,
    /// of another type or out of its range. A change is published on `/parameter_events`.
    pub fn set(&self, name: &str, value: impl Into<ParamValue>) -> Result<()> {
        let v = value.into().0;
        let changed = self
            .inner
            .store
            .lock()
            .unwrap()
            .set(name, v.clone())
            .map_err(|reason| Error::Config {
                setting: "parameter",
                value: format!("{}: {name}", self.inner.node),
                reason,
            })?;
        if changed {
            self.changed(vec![(name.to_owned(), v)]);
        }
        Ok(())
    }

    /// Sets several parameters at once, all or none (as `set_parameters_atomically`).
    pub fn set_all(&self, values: Vec<(String, ParameterValue)>) -> Result<()> {
        let changed: Vec<(String, ParameterValue)> = {
            let mut store = self.inner.store.lock().unwrap();
            let changed = values
                .iter()
                .filter(|(n, v)| store.get(n) != Some(v))
                .cloned()
                .collect();
            store.set_all(values).map_err(|reason| Error::Config {
                setting: "parameter",
                value: self.inner.node.clone(),
                reason,
            })?;
            changed
        };
        if !changed.is_empty() {
            self.changed(changed);
        }
        Ok(())
    }

    /// A watch that wakes when any parameter of this component changes.
    pub fn watch(&self) -> ParamWatch {
        ParamWatch(self.inner.version.subscribe())
    }

    /// Every parameter with its value.
    pub fn all(&self) -> Vec<(String, ParameterValue)> {
        self.inner
            .store
            .lock()
            .unwrap()
            .all()
            .map(|(n, v)| (n.clone(), v.clone()))
            .collect()
    }

    fn changed(&self, changes: Vec<(String, ParameterValue)>) {
        self.inner.version.send_modify(|v| *v += 1);
        self.inner
            .events
            .publish(&self.inner.node, Vec::new(), changes);
    }
}

/// Wakes when a component's parameters change ([`Params::watch`]).
#[derive(Debug)]
pub struct ParamWatch(tokio::sync::watch::Receiver<u64>);

impl ParamWatch {
    /// Resolves at the next change after the last one seen (or at once if one came since). Cancel safe.
    pub async fn changed(&mut self) {
        if self.0.changed().await.is_err() {
            // the component is gone: nothing changes any more
            std::future::pending::<()>().await
        }
    }
}

/// What a component's set-up holds of its parameters: the services, once declared (at most once).
#[derive(Default)]
pub(crate) struct Declared(Option<Serving>);

impl Declared {
    /// [`declare`] for the component node `node`, once.
    pub(crate) fn declare(
        &mut self,
        participant: &crate::node::participant::Participant,
        node: &mut crate::node::transport::RosNode,
        decls: impl IntoIterator<Item = ParamDecl>,
    ) -> Result<Params> {
        let fq = node.fully_qualified_name();
        if self.0.is_some() {
            return Err(Error::Config {
                setting: "parameter",
                value: fq,
                reason: "a component declares its parameters once, all in one call".into(),
            });
        }
        let (params, serving) = declare(participant, node, &fq, decls)?;
        self.0 = Some(serving);
        Ok(params)
    }
}

/// Declares `decls` on the component node `node` (`fq`): values from the command line's overrides for it,
/// else the defaults; serves the parameter services and announces the parameters on `/parameter_events`.
/// Returns the handle and the guard that keeps the services up.
pub(crate) fn declare(
    participant: &crate::node::participant::Participant,
    node: &mut crate::node::transport::RosNode,
    fq: &str,
    decls: impl IntoIterator<Item = ParamDecl>,
) -> Result<(Params, serve::Serving)> {
    let mut overrides = participant.ros_args().parameters_for(fq);
    let mut store = Store::default();
    for d in decls {
        let given = overrides.remove(&d.name);
        store.declare(d, given).map_err(|reason| Error::Config {
            setting: "parameter",
            value: fq.to_owned(),
            reason,
        })?;
    }
    let events = serve::Events::create(participant.graph(), node)?;
    let params = Params::new(fq.to_owned(), store, events);
    let declared = params.all();
    params.inner.events.publish(fq, declared, Vec::new());
    let serving = serve(participant, node, &params)?;
    Ok((params, serving))
}
