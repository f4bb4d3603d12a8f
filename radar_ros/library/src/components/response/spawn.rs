//! Starting a response: its node, slot readers, signal writers and state writer, and its task.

use crate::wire::msg::TypeName;

/// The ROS types of a response's payloads, as it says them.
pub(crate) struct SlotTypes {
    pub(crate) start: TypeName,
    pub(crate) output: TypeName,
}
