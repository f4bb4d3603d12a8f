//! `radar act`: send start, interrupt or exit to a response and show the signal that follows (like rtact).

use std::time::Duration;

use clap::ValueEnum;
use radar_ros::{msg::ResponseState, Radar};
use serde_json::json;

use crate::{
    codec,
    common::{with_status, Fallible, Out},
};

/// The slot `radar act` sends to.
#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum ActSlot {
    Start,
    Interrupt,
    Exit,
}

impl ActSlot {
    pub(crate) fn topic(self) -> &'static str {
        match self {
            ActSlot::Start => "start",
            ActSlot::Interrupt => "interrupt",
            ActSlot::Exit => "exit",
        }
    }
    /// The signal that shows the slot took effect.
    pub(crate) fn answer(self) -> &'static str {
        match self {
            ActSlot::Start => "started",
            ActSlot::Interrupt => "interrupted",
            ActSlot::Exit => "exited",
        }
    }
}

pub(crate) async fn act(
    radar: &Radar,
    out: &Out,
    slot: ActSlot,
    name: &str,
    payload: Option<&str>,
    timeout: Duration,
) -> Fallible<()> {
    let r = with_status(
        "looking for the response",
        radar.response(name).timeout(timeout),
    )
    .await?;
    let (slot_ref, answer) = match slot {
        ActSlot::Start => (r.start_slot(), r.started()),
        ActSlot::Interrupt => (r.interrupt_slot(), r.interrupted()),
        ActSlot::Exit => (r.exit_slot(), r.exited()),
    };
    if payload.is_some() && !matches!(slot, ActSlot::Start) {
        return Err(format!("only start takes a payload; {} does not", slot.topic()).into());
    }
    let raw = codec::encode(slot_ref.ros_type(), payload.unwrap_or(""))?;
    let signal = radar.raw_subscription(answer.topic(), answer.ros_type())?;
    let state = radar.state_subscription::<ResponseState>(&r.name().topic("state"))?;
    let publisher = radar.raw_publisher(slot_ref.topic(), slot_ref.ros_type())?;
    let ready = async {
        publisher.wait_for_subscribers(1).timeout(timeout).await?;
        signal.wait_for_publishers(1).timeout(timeout).await
    };
    with_status("waiting for the match", ready).await?;
    // the state before, to say why if nothing comes (responses in other libraries may have no state topic)
    let has_state = state
        .wait_for_publishers(1)
        .timeout(timeout.min(Duration::from_secs(1)))
        .await
        .is_ok();
    let before = match has_state {
        true => state.recv().timeout(timeout).await.ok(),
        false => None,
    };
    publisher.publish(raw)?;
    match signal.recv_stamped().timeout(timeout).await {
        Ok((m, _)) => {
            let payload = codec::decode(answer.ros_type(), &m);
            if out.json {
                println!(
                    "{}",
                    json!({ "signal": slot.answer(), "response": r.name().fully_qualified(), "payload": payload })
                );
            } else {
                println!("{} {} {}", r.name(), slot.answer(), codec::inline(&payload));
            }
            Ok(())
        }
        Err(_) => {
            // say why, from the state: a busy response ignores a start, an idle one an interrupt
            let now = state.recv().timeout(Duration::from_millis(500)).await.ok();
            let why = why_no_answer(slot, has_state, before, now);
            Err(format!(
                "no {} from {} within {timeout:?}; {why}",
                slot.answer(),
                r.name()
            )
            .into())
        }
    }
}

/// Why a response did not answer `slot`, from its state before (`before`) and after (`now`).
fn why_no_answer(
    slot: ActSlot,
    has_state: bool,
    before: Option<ResponseState>,
    now: Option<ResponseState>,
) -> String {
    match (before, now) {
        (Some(b), Some(n)) if n.ignored_starts > b.ignored_starts => {
            format!(
                "it ignored the start: it was {} (start policy {})",
                b.state_label, b.start_policy
            )
        }
        (Some(b), Some(n))
            if n.ignored_interrupts > b.ignored_interrupts || n.ignored_exits > b.ignored_exits =>
        {
            format!("it ignored the {}: it was {}", slot.topic(), b.state_label)
        }
        (Some(b), _) => format!("it was {}", b.state_label),
        _ if !has_state => "it publishes no state topic to tell why".into(),
        _ => "its state did not arrive either".into(),
    }
}
