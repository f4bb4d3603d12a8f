//! `radar inject`: publish a payload into a slot topic once its subscriber is matched (like rtinject).

use std::time::Duration;

use radar_ros::Radar;
use serde_json::json;

use crate::{
    codec,
    common::{with_status, Fallible, Out},
};

pub(crate) async fn inject(
    radar: &Radar,
    out: &Out,
    topic: &str,
    payload: Option<&str>,
    timeout: Duration,
) -> Fallible<()> {
    let topic = radar.resolve(topic)?.fully_qualified();
    let ty = with_status(
        "looking for a subscriber",
        radar.introspect().subscriber_type(&topic).timeout(timeout),
    )
    .await?;
    let raw = codec::encode(&ty, payload.unwrap_or(""))?;
    let publisher = radar.raw_publisher(&topic, &ty)?;
    with_status(
        "waiting for the match",
        publisher.wait_for_subscribers(1).timeout(timeout),
    )
    .await?;
    publisher.publish(raw.clone())?;
    let shown = codec::decode(&ty, &raw);
    if out.json {
        println!(
            "{}",
            json!({ "topic": topic, "type": ty, "payload": shown })
        );
    } else {
        println!("published {ty} on {topic} {}", codec::inline(&shown));
    }
    // the sample is written; stay a moment so reliable delivery can repair a loss before we leave
    tokio::time::sleep(Duration::from_millis(100)).await;
    Ok(())
}
