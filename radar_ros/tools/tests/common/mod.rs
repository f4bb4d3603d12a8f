//! What the `radar` command line's tests over DDS (`radar_cli.rs`) and over Zenoh (`zenoh_verbs.rs`) share.

use radar_ros::{msg::Empty, nodes::EventNode, params::ParamDecl, Event, SlotError};

/// An event whose check never ends: it stays armed and never triggers; it has two parameters for `radar cat`
/// to show (`gain` 1.5, `mode` "fast").
pub struct Never;

impl Event for Never {
    type Payload = Empty;
    fn attach(&mut self, node: &mut EventNode<'_>) -> radar_ros::Result<()> {
        node.declare([ParamDecl::new("gain", 1.5), ParamDecl::new("mode", "fast")])?;
        Ok(())
    }
    async fn check(&mut self) -> Result<Empty, SlotError> {
        std::future::pending().await
    }
}
