//! The components of the paper's Listing 1 and printers for its timeline, shared by the `count_up` example
//! (all in one process) and `count_up_nodes` (one process per component).

use std::time::Duration;

use radar_ros::{
    msg::{Empty, EventState},
    nodes::EventNode,
    nodes::ResponseNode,
    params::{ParamDecl, Params},
    Event, ExitAction, ExitReason, Radar, Response, SlotError,
};

use crate::Timeline;

/// Lines 1-8: count to 10 at 0.5 s; the interrupt slot does nothing; on exit, restart.
///
/// Its parameters (`ros2 param list /count_up`): `limit` (10) and `period` (0.5 s), read when a run begins, so a
/// change applies from the next run; `-p count_up:limit:=5` (or a params file) sets them at start.
pub struct CountUp {
    tl: Timeline,
    params: Option<Params>,
}

impl CountUp {
    /// A CountUp printing its counts on `tl`.
    pub fn new(tl: Timeline) -> CountUp {
        CountUp { tl, params: None }
    }
}

impl Response for CountUp {
    type Start = Empty;
    type Output = Empty;

    fn attach(&mut self, node: &mut ResponseNode<'_>) -> radar_ros::Result<()> {
        self.params = Some(
            node.declare([
                ParamDecl::new("limit", 10)
                    .description("how far a run counts")
                    .integer_range(1, 1_000_000, 1),
                ParamDecl::new("period", 0.5)
                    .description("seconds between counts")
                    .float_range(0.001, 3600.0),
            ])?,
        );
        Ok(())
    }

    async fn start(&mut self, _: Empty) -> Result<Empty, SlotError> {
        let p = self.params.as_ref();
        let limit = p.and_then(|p| p.i64("limit")).unwrap_or(10);
        let period = Duration::from_secs_f64(p.and_then(|p| p.f64("period")).unwrap_or(0.5));
        // The listing's `sleep(0.5 s)` per count, kept on a grid from the run's start: a loaded machine's late
        // wake-ups (2 ms each seen in CI) do not add up over ten counts.
        let begun = tokio::time::Instant::now();
        let mut i = 0;
        while i < limit {
            i += 1;
            tokio::time::sleep_until(begun + period * i as u32).await;
            self.tl.mark(&format!("count_up counts {i}"), None);
        }
        Ok(Empty::default())
    }

    async fn interrupt(&mut self) {}

    async fn exit(&mut self, why: ExitReason) -> ExitAction {
        self.tl
            .mark(&format!("count_up exit slot ({})", why.describe()), None);
        ExitAction::Restart
    }
}

/// Lines 10-12 (`StartEvent`, 2 s) and 14-16 (`EndEvent`, 4 s): sleep, then trigger.
///
/// Its parameter `delay` (seconds) is read when a check begins.
pub struct SleepThenTrigger {
    delay: Duration,
    params: Option<Params>,
}

impl SleepThenTrigger {
    /// Sleeps `delay` (the parameter's default), then triggers.
    pub fn new(delay: Duration) -> SleepThenTrigger {
        SleepThenTrigger {
            delay,
            params: None,
        }
    }
}

impl Event for SleepThenTrigger {
    type Payload = Empty;
    fn attach(&mut self, node: &mut EventNode<'_>) -> radar_ros::Result<()> {
        self.params = Some(
            node.declare([ParamDecl::new("delay", self.delay.as_secs_f64())
                .description("seconds from the check's start to the trigger")
                .float_range(0.0, 86_400.0)])?,
        );
        Ok(())
    }
    async fn check(&mut self) -> Result<Empty, SlotError> {
        let delay = self
            .params
            .as_ref()
            .and_then(|p| p.f64("delay"))
            .map_or(self.delay, Duration::from_secs_f64);
        tokio::time::sleep(delay).await;
        Ok(Empty::default())
    }
}

/// Prints an event's activation changes and triggers, from its `state` topic (so it works wherever the
/// event runs). Returns once subscribed; the future prints until an error.
pub fn watch_event(
    radar: &Radar,
    tl: Timeline,
    name: &str,
) -> radar_ros::Result<impl std::future::Future<Output = radar_ros::Result<()>>> {
    let state = radar.state_subscription::<EventState>(&format!("{name}/state"))?;
    let name = name.to_owned();
    Ok(async move {
        let (mut active, mut triggers) = (None, 0);
        loop {
            let st = state.recv().await?;
            // the state's stamp is when it was entered: when the event triggered, or (de)activated
            let at = st.stamp.to_nanos();
            if st.triggers > triggers {
                triggers = st.triggers;
                let listing = match (name.as_str(), triggers) {
                    ("start_event", 1) => Some(2.0),
                    ("end_event", 1) => Some(4.0),
                    _ => None,
                };
                tl.mark_at(&format!("{name} triggered"), listing, at);
            }
            if active != Some(st.active) {
                active = Some(st.active);
                let word = if st.active {
                    "active (checking)"
                } else {
                    "inactive"
                };
                tl.mark_at(&format!("{name} {word}"), None, at);
            }
        }
    })
}

/// Prints every signal of `count_up`, wherever it runs. Returns once subscribed (matching takes place in the
/// background); the returned future prints until an error.
pub fn watch_count_up(
    radar: &Radar,
    tl: Timeline,
) -> radar_ros::Result<impl std::future::Future<Output = radar_ros::Result<()>>> {
    let started = radar.signal_subscription::<Empty>("count_up/started")?;
    let interrupted = radar.signal_subscription::<Empty>("count_up/interrupted")?;
    let exited = radar.signal_subscription::<Empty>("count_up/exited")?;
    Ok(async move {
        let mut n_started = 0;
        loop {
            tokio::select! {
                // each at the time the response emitted it (its source timestamp): printed in that order
                r = started.recv_stamped() => {
                    let (_, at) = r?;
                    n_started += 1;
                    let listing = match n_started { 1 => Some(2.0), 2 => Some(4.0), 3 => Some(9.0), _ => None };
                    tl.mark_at("count_up started", listing, at);
                }
                r = interrupted.recv_stamped() => { let (_, at) = r?; tl.mark_at("count_up interrupted", Some(4.0), at); }
                r = exited.recv_stamped() => { let (_, at) = r?; tl.mark_at("count_up exited", None, at); }
            }
        }
    })
}
