//! RADAR's statements: `once E ...` and `whenever E ...`, with a target (`start R`, `interrupt R`, `exit R`, a
//! slot, or an anonymous slot), optionally `until U`, and connection properties.
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar, start_event: radar_ros::EventHandle,
//! #            end_event: radar_ros::EventHandle, count_up: radar_ros::ResponseHandle) -> radar_ros::Result<()> {
//! // once start_event start count_up until end_event
//! let _c = radar.once(&start_event).start(&count_up).until(&end_event).await?;
//! // the connection lives until `_c` is dropped (end of scope, `?`, panic)
//! # Ok(()) }
//! ```
//!
//! **`until U` interrupts only runs this statement started.** `once E start R until U` delivers one `E` to R's
//! `start`; then U's signals interrupt R only in the run that start began, and only if they were emitted after
//! it began (whichever topic's sample is read first: the start carries the statement's cause and E's time, the
//! interrupt names the statement). A run R starts by itself (its exit slot asking for a restart) or that another
//! statement started is not interrupted by this one. The rules, each tested: C3, C6, C7 in
//! [`radar_semantics::connection`], R11-R13 in [`radar_semantics::response`].

use std::{
    future::{Future, IntoFuture},
    num::NonZeroUsize,
    pin::Pin,
    sync::Arc,
    time::Duration,
};

use radar_semantics::connection::Kind;

use crate::{
    connections::manager::{ConnectionGuard, Manager, Spec, TargetSpec, UntilSpec},
    error::{Error, Result},
    wait::DEFAULT_TIMEOUT,
    wire::msg::{Empty, RosMessage},
    wire::qos::SIGNAL_DEPTH,
    wire::raw::RawMessage,
    wire::refs::{AsResponse, AsSignal, ResponseRef, Signal, Slot},
};

/// `once E` / `whenever E`: give it a target with [`start`](Statement::start),
/// [`interrupt`](Statement::interrupt), [`exit`](Statement::exit), [`slot`](Statement::slot) or
/// [`call`](Statement::call).
#[must_use = "a statement does nothing until given a target and awaited"]
pub struct Statement {
    pub(crate) manager: Arc<Manager>,
    pub(crate) kind: Kind,
    pub(crate) source: Signal,
}

/// A statement with its target: `.await` it to arm the connection, after setting properties if wanted.
///
/// Arming waits for discovery ([`DEFAULT_TIMEOUT`], `.timeout(d)` to change): the relay's readers must have
/// matched the sources' writers and its writers the slots' readers. The connection then delivers the signals
/// emitted after it was armed, for as long as the returned [`ConnectionGuard`] lives.
///
/// The target's kind is in the type: only a `start R` target ([`StartTarget`]) has
/// [`until`](ConnectionRequest::until), so a statement the paper does not allow does not compile:
///
/// ```compile_fail,E0599
/// # async fn f(radar: radar_ros::Radar, bumper: radar_ros::EventRef, stop: radar_ros::EventRef,
/// #            nav: radar_ros::ResponseRef) -> radar_ros::Result<()> {
/// // `until` after `interrupt`: no such method (until U interrupts the runs a `start` began)
/// let _c = radar.whenever(&bumper).interrupt(&nav).until(&stop).await?;
/// # Ok(()) }
/// ```
///
/// ```compile_fail,E0599
/// # async fn f(radar: radar_ros::Radar, done: radar_ros::EventRef, stop: radar_ros::EventRef,
/// #            nav: radar_ros::ResponseRef) -> radar_ros::Result<()> {
/// // nor after `exit`
/// let _c = radar.once(&done).exit(&nav).until(&stop).await?;
/// # Ok(()) }
/// ```
///
/// A depth of 0 does not compile either ([`depth`](ConnectionRequest::depth) takes a [`NonZeroUsize`]):
///
/// ```compile_fail,E0308
/// # async fn f(radar: radar_ros::Radar, scan: radar_ros::EventRef) -> radar_ros::Result<()> {
/// use radar_ros::msg::Empty;
/// let _c = radar.whenever(&scan).call(|_: Empty| {}).depth(0).await?;
/// # Ok(()) }
/// ```
///
/// and a statement's source is a signal, never a slot or a response:
///
/// ```compile_fail,E0277
/// # async fn f(radar: radar_ros::Radar, nav: radar_ros::ResponseRef) -> radar_ros::Result<()> {
/// use radar_ros::Slot;
/// let _c = radar.once(Slot::new("/beeper/beep", "std_msgs/msg/Empty")).start(&nav).await?;
/// # Ok(()) }
/// ```
///
/// ```compile_fail,E0277
/// # async fn f(radar: radar_ros::Radar, nav: radar_ros::ResponseRef, dock: radar_ros::ResponseRef)
/// #     -> radar_ros::Result<()> {
/// let _c = radar.once(&nav).start(&dock).await?; // a response is no signal: `nav.exited()` is
/// # Ok(()) }
/// ```
#[must_use = "a connection is made only when this is awaited"]
pub struct ConnectionRequest<T = StartTarget> {
    manager: Arc<Manager>,
    spec: Spec,
    target: T,
    /// A mistake found while building the statement (a payload type that does not fit), reported when it is
    /// awaited.
    error: Option<Error>,
}

/// The target kind of a [`ConnectionRequest`] made by [`Statement::start`]: it may take
/// [`until`](ConnectionRequest::until).
pub struct StartTarget(ResponseRef);

/// The target kind of a [`ConnectionRequest`] made by [`Statement::interrupt`], [`Statement::exit`],
/// [`Statement::slot`] or [`Statement::call`]: no `until`.
pub struct OtherTarget;

/// The owner a connection made by this program's own code names (`process <pid>`); one made through a manager
/// node's services names its caller instead. A program node lists the first kind, a manager node the second.
pub(crate) fn program_owner() -> String {
    format!("process {}", std::process::id())
}

impl Statement {
    fn to<T>(self, target: TargetSpec, starts: bool, kind: T) -> ConnectionRequest<T> {
        ConnectionRequest {
            error: None,
            manager: self.manager,
            spec: Spec {
                owner: program_owner(),
                filter: None,
                map: None,
                mapped_type: None,
                kind: self.kind,
                source: self.source,
                target,
                starts,
                until: None,
                timeout: DEFAULT_TIMEOUT,
                depth: SIGNAL_DEPTH,
                rearm: false,
            },
            target: kind,
        }
    }

    /// `... start R`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, ev: radar_ros::EventHandle, r: radar_ros::ResponseHandle)
    /// #     -> radar_ros::Result<()> {
    /// let _c = radar.whenever(&ev).start(&r).await?;
    /// # Ok(()) }
    /// ```
    pub fn start(self, r: &impl AsResponse) -> ConnectionRequest<StartTarget> {
        let r = r.response_ref();
        self.to(TargetSpec::Slot(r.start_slot()), true, StartTarget(r))
    }

    /// `... interrupt R`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, bumper: radar_ros::EventRef, nav: radar_ros::ResponseRef)
    /// #     -> radar_ros::Result<()> {
    /// let _c = radar.whenever(&bumper).interrupt(&nav).await?;
    /// # Ok(()) }
    /// ```
    pub fn interrupt(self, r: &impl AsResponse) -> ConnectionRequest<OtherTarget> {
        let r = r.response_ref();
        self.to(TargetSpec::Slot(r.interrupt_slot()), false, OtherTarget)
    }

    /// `... exit R`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, done: radar_ros::EventRef, nav: radar_ros::ResponseRef)
    /// #     -> radar_ros::Result<()> {
    /// let _c = radar.once(&done).exit(&nav).await?;
    /// # Ok(()) }
    /// ```
    pub fn exit(self, r: &impl AsResponse) -> ConnectionRequest<OtherTarget> {
        let r = r.response_ref();
        self.to(TargetSpec::Slot(r.exit_slot()), false, OtherTarget)
    }

    /// `... slot`: any slot topic with its type (a component that is not a RADAR response, say).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, ev: radar_ros::EventRef) -> radar_ros::Result<()> {
    /// use radar_ros::Slot;
    /// let _c = radar.whenever(&ev).slot(Slot::new("/beeper/beep", "std_msgs/msg/Empty")).await?;
    /// # Ok(()) }
    /// ```
    pub fn slot(self, slot: Slot) -> ConnectionRequest<OtherTarget> {
        self.to(TargetSpec::Slot(slot), false, OtherTarget)
    }

    /// An anonymous slot: `f` runs with each delivered payload, decoded as `M` (the source's type, or
    /// `std_msgs/msg/Empty` to ignore the payload), in its own task, one call after the other.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, ev: radar_ros::EventRef) -> radar_ros::Result<()> {
    /// use radar_ros::msg::Empty;
    /// let _c = radar.whenever(&ev).call(|_: Empty| println!("bumped")).await?;
    /// # Ok(()) }
    /// ```
    pub fn call<M: RosMessage>(
        self,
        mut f: impl FnMut(M) + Send + 'static,
    ) -> ConnectionRequest<OtherTarget> {
        let topic = self.source.topic().to_owned();
        let ty = M::ros_type_name();
        let error = (!crate::wire::raw::carries::<M>(self.source.ros_type())
            && ty != Empty::ros_type_name())
        .then(|| Error::PayloadType {
            what: "an anonymous slot",
            topic: self.source.topic().to_owned(),
            expected: self.source.ros_type().to_owned(),
            given: ty.clone(),
        });
        let empty = ty == Empty::ros_type_name();
        let graph = self.manager.graph().clone();
        let mut c = self.to(
            TargetSpec::Anon(Box::new(move |raw: RawMessage| {
                let decoded = if empty {
                    Ok(M::default())
                } else {
                    raw.decode::<M>()
                };
                // checked before delivery (below): a payload that reaches here decodes
                if let Ok(m) = decoded {
                    f(m)
                }
            })),
            false,
            OtherTarget,
        );
        if !empty {
            // C2: a payload that does not decode as `M` is not a delivery (it does not use up a `once`, nor end
            // a waiter); it is reported like every malformed message (counted per publisher, logged once)
            let graph = graph.clone();
            let expected = ty.clone();
            c.spec.filter = Some(Arc::new(move |raw: &RawMessage| match raw.decode::<M>() {
                Ok(_) => true,
                Err(e) => {
                    graph.malformed().note(&topic, &expected, None, &e);
                    false
                }
            }));
        }
        c.error = error;
        c
    }
}

impl ConnectionRequest<StartTarget> {
    /// `... until U`: U's signals interrupt R while a run this statement started is in progress (see
    /// [until windows](crate#connections), rules C3, C6, C7). Only `start` targets have it.
    ///
    /// U need not have a publisher when the statement is armed: U is often an operator's one-shot
    /// `ros2 topic pub --once` or a fresh process per stop. Arming waits to be matched with the publishers of U
    /// that are on the graph then (so none of their signals is missed), and with none if there are none.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, go: radar_ros::EventRef, stop: radar_ros::EventRef,
    /// #            count_up: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// let _c = radar.once(&go).start(&count_up).until(&stop).await?;
    /// # Ok(()) }
    /// ```
    pub fn until(mut self, u: impl AsSignal) -> ConnectionRequest<StartTarget> {
        let r = &self.target.0;
        self.spec.until = Some(UntilSpec {
            source: u.signal(),
            started: r.started(),
            exited: r.exited(),
            dropped: r.dropped(),
            interrupt: r.interrupt_slot(),
            state: r.name().endpoint(crate::endpoint::Endpoint::State),
        });
        self
    }
}

impl<T> ConnectionRequest<T> {
    /// Records who asked for the connection (shown in the manager's `connections` list).
    pub(crate) fn owner(mut self, owner: String) -> ConnectionRequest<T> {
        self.spec.owner = owner;
        self
    }

    /// Connection property: deliver only the signals whose payload (decoded as the source's type `M`)
    /// satisfies `f`. A refused signal does not use up a `once`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, level: radar_ros::EventRef, dock: radar_ros::ResponseRef)
    /// #     -> radar_ros::Result<()> {
    /// use radar_ros::msg::Int32;
    /// let _c = radar.once(&level).start(&dock).filter(|b: &Int32| b.data < 20).await?;
    /// # Ok(()) }
    /// ```
    pub fn filter<M: RosMessage>(
        mut self,
        f: impl Fn(&M) -> bool + Send + Sync + 'static,
    ) -> ConnectionRequest<T> {
        if let Some(e) = self.source_type_error::<M>("a filter") {
            self.error.get_or_insert(e);
            return self;
        }
        let topic = self.spec.source.topic().to_owned();
        let graph = self.manager.graph().clone();
        // after the check an anonymous slot makes, if any
        let before = self.spec.filter.take();
        self.spec.filter = Some(Arc::new(move |raw: &RawMessage| {
            if before.as_ref().is_some_and(|b| !b(raw)) {
                return false;
            }
            match raw.decode::<M>() {
                Ok(m) => f(&m),
                Err(e) => {
                    // not delivered
                    graph
                        .malformed()
                        .note(&topic, &M::ros_type_name(), None, &e);
                    false
                }
            }
        }));
        self
    }

    /// Connection property: deliver `f(payload)` instead of the payload; the slot must take `N`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, seen: radar_ros::EventRef, say: radar_ros::ResponseRef)
    /// #     -> radar_ros::Result<()> {
    /// use radar_ros::msg::{Int32, StringMsg};
    /// let _c = radar
    ///     .whenever(&seen)
    ///     .start(&say)
    ///     .map(|n: Int32| StringMsg::from(format!("{} people", n.data).as_str()))
    ///     .await?;
    /// # Ok(()) }
    /// ```
    pub fn map<M: RosMessage, N: RosMessage>(
        self,
        f: impl Fn(M) -> N + Send + Sync + 'static,
    ) -> ConnectionRequest<T> {
        let mapped = N::ros_type_name();
        self.map_as(&mapped, f)
    }

    /// [`map`](Self::map) to a payload whose type is known only at run time: `f` returns a
    /// [`DynMessage`](crate::topics::DynMessage) holding a `ros_type` (`pkg/msg/Name`).
    pub fn map_dyn<M: RosMessage>(
        self,
        ros_type: &str,
        f: impl Fn(M) -> crate::wire::raw::DynMessage + Send + Sync + 'static,
    ) -> ConnectionRequest<T> {
        self.map_as(ros_type, f)
    }

    fn map_as<M: RosMessage, N: RosMessage>(
        mut self,
        mapped: &str,
        f: impl Fn(M) -> N + Send + Sync + 'static,
    ) -> ConnectionRequest<T> {
        if let Some(e) = self.source_type_error::<M>("a map") {
            self.error.get_or_insert(e);
            return self;
        }
        match crate::wire::raw::component_type(mapped, "a map's result type") {
            Ok(t) => self.spec.mapped_type = Some(t.ros),
            Err(e) => {
                self.error.get_or_insert(e);
                return self;
            }
        }
        let topic = self.spec.source.topic().to_owned();
        let graph = self.manager.graph().clone();
        self.spec.map = Some(Arc::new(move |raw: &RawMessage| {
            let m = raw
                .decode::<M>()
                .map_err(|e| {
                    graph
                        .malformed()
                        .note(&topic, &M::ros_type_name(), None, &e)
                })
                .ok()?;
            RawMessage::encode(&f(m))
                .map_err(|e| tracing::warn!(%topic, error = %crate::error::Report(&e), "map: result does not encode; not delivered"))
                .ok()
        }));
        self
    }

    fn source_type_error<M: RosMessage>(&self, what: &'static str) -> Option<Error> {
        (!crate::wire::raw::carries::<M>(self.spec.source.ros_type())).then(|| Error::PayloadType {
            what,
            topic: self.spec.source.topic().to_owned(),
            expected: self.spec.source.ros_type().to_owned(),
            given: M::ros_type_name(),
        })
    }

    /// Connection property: the history depth of the relay (default 10, as rclpy's): how many signals
    /// the relay's reader queues while the manager has not taken them, and its writer keeps for
    /// retransmission to a slow or lossy target; for an anonymous slot, how many payloads wait for the
    /// closure (the oldest are dropped, with a warning). Connections asking for a depth other than the
    /// default get a reader and writer of their own (shared with connections asking for the same depth). At
    /// least 1: a [`NonZeroUsize`].
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, scan: radar_ros::EventRef) -> radar_ros::Result<()> {
    /// use radar_ros::msg::Empty;
    /// use std::num::NonZeroUsize;
    /// let _c = radar.whenever(&scan).call(|_: Empty| {}).depth(NonZeroUsize::new(100).unwrap()).await?;
    /// # Ok(()) }
    /// ```
    pub fn depth(mut self, depth: NonZeroUsize) -> ConnectionRequest<T> {
        self.spec.depth = depth.get();
        self
    }

    /// Connection property: when the target leaves the ROS graph (its process exits, crashes or is cut off),
    /// wait for a target of that name to come back and deliver to it, instead of delivering nothing more (the
    /// default: see [components that leave](crate#when-components-leave)). Signals emitted while there was no
    /// target are not delivered.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, bumper: radar_ros::EventRef, stop: radar_ros::ResponseRef)
    /// #     -> radar_ros::Result<()> {
    /// // the motor driver may be restarted by its launch file: keep stopping it on a bump
    /// let _c = radar.whenever(&bumper).start(&stop).rearm().await?;
    /// # Ok(()) }
    /// ```
    pub fn rearm(mut self) -> ConnectionRequest<T> {
        self.spec.rearm = true;
        self
    }

    /// How long arming may wait for discovery (default [`DEFAULT_TIMEOUT`], 5 s).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, go: radar_ros::EventRef, r: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// let _c = radar.whenever(&go).start(&r).timeout(std::time::Duration::from_secs(30)).await?;
    /// # Ok(()) }
    /// ```
    pub fn timeout(mut self, d: Duration) -> ConnectionRequest<T> {
        self.spec.timeout = d;
        self
    }
}

impl<T> IntoFuture for ConnectionRequest<T> {
    type Output = Result<ConnectionGuard>;
    type IntoFuture = Pin<Box<dyn Future<Output = Result<ConnectionGuard>> + Send>>;
    fn into_future(self) -> Self::IntoFuture {
        let ConnectionRequest {
            manager,
            spec,
            error,
            ..
        } = self;
        Box::pin(async move {
            if let Some(e) = error {
                return Err(e);
            }
            manager.arm(spec).await
        })
    }
}
