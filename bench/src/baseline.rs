//! The raw ros2-client baseline's pieces, shared by the child roles: a node as a user would make one without
//! radar_ros, and its signal endpoints (the same QoS and message as radar_ros's signals).

use std::time::Duration;

use anyhow::{anyhow, Result};
use radar_ros::{
    msg::{Header, RosMessage},
    qos::signal_qos,
};
use ros2_client::{
    dds::{Context, ContextOptions, Node},
    Name, NodeName, NodeOptions,
};

/// How long a child waits for discovery or a peer before it answers with an error.
pub(crate) const WAIT: Duration = Duration::from_secs(20);

/// A plain ros2-client node, as a user would write it without radar_ros: context in `ROS_DOMAIN_ID`, no
/// rosout or parameter services, spinner running.
pub(crate) fn raw_node(name: &str) -> Result<(Context, Node)> {
    let domain = radar_ros::settings::domain_id_from_env()?;
    let ctx = Context::with_options(ContextOptions::new().domain_id(domain))
        .map_err(|e| anyhow!("ros2-client context: {e:?}"))?;
    let mut node = ctx
        .new_node(
            NodeName::new("/bench", name).map_err(|e| anyhow!("{e:?}"))?,
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .map_err(|e| anyhow!("ros2-client node: {e:?}"))?;
    let spinner = node.spinner().map_err(|e| anyhow!("spinner: {e:?}"))?;
    tokio::spawn(spinner.spin());
    Ok((ctx, node))
}

fn raw_topic(node: &mut Node, topic: &str) -> Result<ros2_client::dds::rustdds::Topic> {
    node.create_topic(
        &Name::parse(topic).map_err(|e| anyhow!("{topic}: {e:?}"))?,
        Header::message_type_name(),
        &signal_qos(),
    )
    .map_err(|e| anyhow!("topic {topic}: {e:?}"))
}

pub(crate) fn raw_subscription(
    node: &mut Node,
    topic: &str,
) -> Result<ros2_client::dds::Subscription<Header>> {
    let t = raw_topic(node, topic)?;
    node.create_subscription::<Header>(&t, Some(signal_qos()))
        .map_err(|e| anyhow!("subscription {topic}: {e:?}"))
}

pub(crate) fn raw_publisher(
    node: &mut Node,
    topic: &str,
) -> Result<ros2_client::dds::Publisher<Header>> {
    let t = raw_topic(node, topic)?;
    node.create_publisher::<Header>(&t, Some(signal_qos()))
        .map_err(|e| anyhow!("publisher {topic}: {e:?}"))
}
