//! Which payloads a slot of a given type can read (rule C2: a payload its target cannot read is no delivery).
//!
//! A connection manager moves serialized bodies and knows its slots by ROS type name only. Before it counts a
//! signal as delivered to a response's `start`, it asks here whether the bytes are a whole message of the slot's
//! type: for the interfaces radar_ros ships (`radar_ros::interfaces::READERS`) and for the start types of this
//! process's responses. A type known to neither is delivered as it is (the response drops what it cannot read,
//! counting it as malformed).

use std::{collections::HashMap, sync::Mutex};

/// Whether some bytes are a whole message of one type.
pub(crate) type Reads = fn(&[u8]) -> bool;

/// The types whose payloads this process can check, by ROS name.
#[derive(Default)]
pub(crate) struct Readers {
    local: Mutex<HashMap<String, Reads>>,
}

impl Readers {
    /// Adds a type (a response's start type, whose Rust type this process has).
    pub(crate) fn register(&self, ros_type: &str, reads: Reads) {
        self.local
            .lock()
            .unwrap()
            .insert(ros_type.to_owned(), reads);
    }

    /// How to check a payload of `ros_type`, if this process knows.
    pub(crate) fn get(&self, ros_type: &str) -> Option<Reads> {
        if let Some(r) = self.local.lock().unwrap().get(ros_type) {
            return Some(*r);
        }
        let table = crate::interfaces::READERS;
        table
            .binary_search_by(|(t, _)| (*t).cmp(ros_type))
            .ok()
            .map(|i| table[i].1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::msg::{reads, Int32, RosMessage};
    use crate::wire::raw::RawMessage;

    #[test]
    fn c2_a_shipped_type_and_a_registered_one_are_checked_and_others_are_not_known() {
        let r = Readers::default();
        let point = r.get("geometry_msgs/msg/Point").expect("a shipped type");
        assert!(point(&[0; 24]));
        assert!(!point(&[7, 0, 0, 0]), "one uint32 is no Point");
        assert!(r.get("my_robot/msg/Dock").is_none());
        r.register("my_robot/msg/Dock", reads::<Int32>);
        let dock = r.get("my_robot/msg/Dock").unwrap();
        assert!(dock(
            RawMessage::encode(&Int32 { data: 1 }).unwrap().as_bytes()
        ));
        assert!(r.get(&Int32::ros_type_name()).is_some());
    }
}
