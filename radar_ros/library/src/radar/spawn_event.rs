//! [`Radar::spawn_event`]: an event as a ROS 2 node; how it checks is in `components/event.rs`.

use crate::components::event::{drive_event, Event, EventHandle};
use crate::components::own_node::ComponentNode;
use crate::{
    error::Result,
    node::endpoints::{emit, typed_publisher, SignalWriter},
    radar::Radar,
    wire::msg::{EventState, Time},
    wire::qos::{signal_qos, state_qos},
};
use tokio::sync::watch;

impl Radar {
    /// Starts `event` as the ROS 2 node `name` (relative to this participant's namespace, or absolute).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{TimerEvent, TopicEvent, msg::{Empty, Float64}};
    /// let tick = radar.spawn_event("tick", TimerEvent::new(std::time::Duration::from_secs(1)))?;
    /// let low = radar.spawn_event("low_battery", TopicEvent::new("battery", |b: &Float64| (b.data < 0.2).then(Empty::default)))?;
    /// # Ok(()) }
    /// ```
    pub fn spawn_event<E: Event>(&self, name: &str, mut event: E) -> Result<EventHandle> {
        let name = self.resolve(name)?;
        let payload_t =
            crate::wire::raw::component_type(&event.payload_type(), "its payload type")?
                .with_hash_of::<E::Payload>();
        let mut claimed = self.participant().claim_node(&name)?;
        let node = &mut claimed.node;
        let mut params = crate::node::params::Declared::default();
        event.attach(&mut ComponentNode {
            node,
            participant: self.participant(),
            params: &mut params,
        })?;
        let triggered = SignalWriter::new(
            self.participant().taps(),
            crate::wire::local::marked(|| {
                crate::node::endpoints::publisher::<E::Payload>(
                    self.graph(),
                    node,
                    &name.endpoint(crate::endpoint::Endpoint::Triggered),
                    &payload_t,
                    &signal_qos(),
                )
            })?,
            &name.endpoint(crate::endpoint::Endpoint::Triggered),
            &payload_t.ros,
        );
        let state_pub = typed_publisher::<EventState>(
            self.graph(),
            node,
            &name.endpoint(crate::endpoint::Endpoint::State),
            &state_qos(),
        )?;
        // its listeners: readers of `triggered` that do not only observe (`graph/observers.rs`)
        let listeners = triggered.matching().listeners();
        let st = EventState {
            stamp: Time::now(),
            name: name.fully_qualified(),
            trigger_type: payload_t.ros.clone(),
            ..Default::default()
        };
        emit(&state_pub, "state", st.clone());
        let (state_tx, state_rx) = watch::channel(st.clone());
        let graph = self.graph().clone();
        let guid = triggered.id();
        let task = self
            .participant()
            .spawn_component(claimed, params, move |stop_rx| async move {
                drive_event(
                    event, triggered, state_pub, state_tx, st, listeners, stop_rx,
                )
                .await;
                graph.forget(guid);
            });
        tracing::info!(event = %name, payload = %payload_t.ros, "event up");
        Ok(EventHandle {
            name,
            payload_type: payload_t.ros,
            state: state_rx,
            task,
        })
    }
}
