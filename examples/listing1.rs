//! The components of the paper's Listing 1 and printers for its timeline, shared by the `count_up` example
//! (all in one process) and `count_up_nodes` (one process per component).

use std::time::Duration;

use radar_ros::{
    msg::{Empty, EventState},
    Event, ExitAction, ExitReason, Radar, Response, SlotError,
};

use crate::Timeline;

/// Lines 1-8: count to 10 at 0.5 s; the interrupt slot does nothing; on exit, restart.
pub struct CountUp {
    /// Where counts are printed.
    pub tl: Timeline,
}

impl Response for CountUp {
    type Start = Empty;
    type Output = Empty;

    async fn start(&mut self, _: Empty) -> Result<Empty, SlotError> {
        let mut i = 0;
        while i < 10 {
            tokio::time::sleep(Duration::from_millis(500)).await;
            i += 1;
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
pub struct SleepThenTrigger(pub Duration);

impl Event for SleepThenTrigger {
    type Payload = Empty;
    async fn check(&mut self) -> Result<Empty, SlotError> {
        tokio::time::sleep(self.0).await;
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
            if st.triggers > triggers {
                triggers = st.triggers;
                let listing = match (name.as_str(), triggers) {
                    ("start_event", 1) => Some(2.0),
                    ("end_event", 1) => Some(4.0),
                    _ => None,
                };
                tl.mark(&format!("{name} triggered"), listing);
            }
            if active != Some(st.active) {
                active = Some(st.active);
                let word = if st.active {
                    "active (checking)"
                } else {
                    "inactive"
                };
                tl.mark(&format!("{name} {word}"), None);
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
                r = started.recv() => {
                    r?;
                    n_started += 1;
                    let listing = match n_started { 1 => Some(2.0), 2 => Some(4.0), 3 => Some(9.0), _ => None };
                    tl.mark("count_up started", listing);
                }
                r = interrupted.recv() => { r?; tl.mark("count_up interrupted", Some(4.0)); }
                r = exited.recv() => { r?; tl.mark("count_up exited", None); }
            }
        }
    })
}
