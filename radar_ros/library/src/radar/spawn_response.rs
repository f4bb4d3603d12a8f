//! [`Radar::spawn_response`]: a response as a ROS 2 node, its endpoints made in order; how it runs is in
//! `components/response/`.

use crate::components::response::spawn::SlotTypes;
use crate::components::response::{
    driver::{drive, state_message, Endpoints, Inboxes, Io, SlotReaders},
    Response, ResponseHandle,
};
use crate::{
    endpoint::Endpoint,
    error::Result,
    node::endpoints::{emit, publisher, subscription, typed_publisher, SignalWriter},
    radar::Radar,
    wire::msg::{Empty, ResponseState, TypeName},
    wire::names::ComponentName,
    wire::qos::{signal_qos, state_qos},
    wire::raw::RawMessage,
    wire::refs::ResponseRef,
};
use radar_semantics::response::{Announce, ResponseMachine};
use std::sync::Arc;
use tokio::sync::{watch, Mutex};

impl Radar {
    /// Starts `response` as the ROS 2 node `name` (relative to this participant's namespace, or absolute).
    ///
    /// Fails before creating anything if the name is not a valid ROS name or is already used in this process.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, StartPolicy, msg::{Empty, StringMsg}};
    /// let say = radar.spawn_response("say", FnResponse::new(|s: StringMsg| async move {
    ///     println!("{}", s.data);
    ///     Ok(Empty::default())
    /// }).start_policy(StartPolicy::QueueOne))?;
    /// # Ok(()) }
    /// ```
    pub fn spawn_response<R: Response>(&self, name: &str, response: R) -> Result<ResponseHandle> {
        self.spawn_response_with(name, Announce::OnStart, |_, _, _| Ok(response))
    }

    /// Starts the response that `make` builds on the response's node (for responses whose behaviour needs
    /// endpoints of their own, such as an action client), announcing `started` as `announce` says.
    pub(crate) fn spawn_response_with<R: Response>(
        &self,
        name: &str,
        announce: Announce,
        make: impl FnOnce(
            &mut crate::node::transport::RosNode,
            &crate::graph::Graph,
            &ComponentName,
        ) -> Result<R>,
    ) -> Result<ResponseHandle> {
        let name = self.resolve(name)?;
        let mut claimed = self.participant().claim_node(&name)?;
        let node = &mut claimed.node;
        let mut response = make(node, self.graph(), &name)?;
        let mut params = crate::node::params::Declared::default();
        response.attach(&mut crate::components::own_node::ComponentNode {
            node,
            participant: self.participant(),
            params: &mut params,
        })?;
        let types = SlotTypes {
            start: crate::wire::raw::component_type(&response.start_type(), "its start type")?
                .with_hash_of::<R::Start>(),
            output: crate::wire::raw::component_type(&response.output_type(), "its output type")?
                .with_hash_of::<R::Output>(),
        };
        // a manager of this process can tell which payloads its start slot reads (C2)
        if <R::Start as crate::wire::msg::RosMessage>::ros_type_name() == types.start.ros {
            self.participant()
                .readers()
                .register(&types.start.ros, crate::wire::msg::reads::<R::Start>);
        }
        let mut endpoints = self.response_endpoints::<R>(node, &name, &types)?;
        endpoints.io.incomplete_output = response.incomplete_output();
        let slot_publishers = [
            endpoints.slots.start.matching().matched.clone(),
            endpoints.slots.interrupt.matching().matched.clone(),
            endpoints.slots.exit.matching().matched.clone(),
        ];
        let signal_subscribers = [
            endpoints.io.started.matching().matched.clone(),
            endpoints.io.interrupted.matching().matched.clone(),
            endpoints.io.exited.matching().matched.clone(),
        ];
        let policy = response.start_policy();
        let machine = ResponseMachine::<R::Start, R::Output>::with_announce(policy, announce);
        let initial = state_message::<R>(&name, &types.start.ros, &machine);
        emit(&endpoints.io.state_pub, "state", initial.clone());
        let (state_tx, state_rx) = watch::channel(initial);
        let endpoints = Endpoints {
            io: Io {
                state_tx,
                ..endpoints.io
            },
            ..endpoints
        };
        let participant = self.participant().clone();
        let task = self
            .participant()
            .spawn_component(claimed, params, move |stop_rx| async move {
                let response = Arc::new(Mutex::new(response));
                drive(response, machine, endpoints, stop_rx, participant).await;
            });
        tracing::info!(response = %name, start_type = %types.start.ros, policy = policy.label(), "response up");
        Ok(ResponseHandle {
            reference: ResponseRef::new(name.clone(), types.start.ros, types.output.ros),
            name,
            state: state_rx,
            slot_publishers,
            signal_subscribers,
            task,
        })
    }

    /// The endpoints of the response `name` on `node`: slot readers, what this process's connections hand its
    /// slots, the state writer (made, so announced, before the signal writers: whoever has discovered those
    /// has discovered it, and knows this response keeps causes, C6), the signal writers.
    fn response_endpoints<R: Response>(
        &self,
        node: &mut crate::node::transport::RosNode,
        name: &ComponentName,
        types: &SlotTypes,
    ) -> Result<Endpoints<R>> {
        let (g, sq) = (self.graph(), signal_qos());
        let (start_t, empty_t) = (types.start.clone(), TypeName::of::<Empty>());
        let output_t = types.output.clone();
        let slots = SlotReaders {
            start: subscription::<RawMessage>(
                g,
                node,
                &name.endpoint(Endpoint::Start),
                &start_t,
                &sq,
            )?,
            interrupt: subscription::<RawMessage>(
                g,
                node,
                &name.endpoint(Endpoint::Interrupt),
                &empty_t,
                &sq,
            )?,
            exit: subscription::<RawMessage>(
                g,
                node,
                &name.endpoint(Endpoint::Exit),
                &empty_t,
                &sq,
            )?,
        };
        let inlets = self.participant().inlets();
        let inboxes = Inboxes {
            start: inlets.open(&name.endpoint(Endpoint::Start), &start_t.ros),
            interrupt: inlets.open(&name.endpoint(Endpoint::Interrupt), &empty_t.ros),
            exit: inlets.open(&name.endpoint(Endpoint::Exit), &empty_t.ros),
        };
        let state_pub = typed_publisher::<ResponseState>(
            g,
            node,
            &name.endpoint(Endpoint::State),
            &state_qos(),
        )?;
        let taps = self.participant().taps();
        let t = |e: Endpoint| name.endpoint(e);
        // the signal writers hand every sample to their taps (`wire/local.rs`)
        let (started, interrupted, exited) = crate::wire::local::marked(|| -> Result<_> {
            Ok((
                publisher::<R::Start>(g, node, &t(Endpoint::Started), &start_t, &sq)?,
                publisher::<Empty>(g, node, &t(Endpoint::Interrupted), &empty_t, &sq)?,
                publisher::<R::Output>(g, node, &t(Endpoint::Exited), &output_t, &sq)?,
            ))
        })?;
        let dropped = self.dropped_writer(node, name)?;
        let io = Io {
            name: name.clone(),
            start_type: start_t.ros.clone(),
            incomplete_output: None,
            started: SignalWriter::new(taps, started, &t(Endpoint::Started), &start_t.ros),
            interrupted: SignalWriter::new(
                taps,
                interrupted,
                &t(Endpoint::Interrupted),
                &empty_t.ros,
            ),
            exited: SignalWriter::new(taps, exited, &t(Endpoint::Exited), &output_t.ros),
            dropped,
            state_pub,
            state_tx: watch::channel(ResponseState::default()).0,
        };
        Ok(Endpoints { slots, inboxes, io })
    }

    /// The writer of `<response>/dropped`, or none when the enclave's permissions do not grant it.
    ///
    /// `dropped` came later than the other signals: an enclave whose permissions were written before it
    /// (docs/security.md's policy until issue 69) still runs the response, without it.
    fn dropped_writer(
        &self,
        node: &mut crate::node::transport::RosNode,
        name: &ComponentName,
    ) -> Result<Option<SignalWriter<Empty>>> {
        let (g, sq, empty_t) = (self.graph(), signal_qos(), TypeName::of::<Empty>());
        let dropped_topic = name.endpoint(Endpoint::Dropped);
        match crate::wire::local::marked(|| {
            publisher::<Empty>(g, node, &dropped_topic, &empty_t, &sq)
        }) {
            Ok(p) => Ok(Some(SignalWriter::new(
                self.participant().taps(),
                p,
                &dropped_topic,
                &empty_t.ros,
            ))),
            Err(e) if e.not_allowed_by_security() => {
                tracing::warn!(
                    response = %name,
                    "{dropped_topic} is not granted by this enclave's permissions: {name} runs without it, so a \
                     start it does not take is not announced, and a `once ... until` whose start it dropped \
                     lasts until its next `exited`; grant publishing ~/dropped in the enclave's policy \
                     (docs/security.md)"
                );
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }
}
