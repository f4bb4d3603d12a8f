//! The RADAR event activation rule, with no I/O.
//!
//! **E1.** An event checks its condition only while something listens to its `triggered` signal. In ROS 2 terms
//! "something listens" means at least one subscription is matched with the event's `triggered` writer: a
//! connection relay, an rclpy node, `ros2 topic echo`. The count comes from DDS discovery (see
//! the crate docs); this type turns count changes into activate / deactivate transitions.

/// A transition of an event between checking and not checking.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Transition {
    /// The first listener arrived: start checking.
    Activate,
    /// The last listener left: cancel the running check.
    Deactivate,
}

/// Tracks listeners and whether the event is active.
///
/// ```
/// use radar_semantics::event::{Activation, Transition};
/// let mut a = Activation::new();
/// assert_eq!(a.set_listeners(1), Some(Transition::Activate));
/// assert_eq!(a.set_listeners(2), None);
/// assert_eq!(a.set_listeners(0), Some(Transition::Deactivate));
/// assert_eq!(a.activations(), 1);
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Activation {
    listeners: usize,
    activations: u64,
}

impl Activation {
    /// Inactive, with no listeners.
    pub fn new() -> Self {
        Self::default()
    }

    /// True while at least one listener is matched.
    pub fn is_active(&self) -> bool {
        self.listeners > 0
    }

    /// The number of matched listeners.
    pub fn listeners(&self) -> usize {
        self.listeners
    }

    /// How many times the event has become active.
    pub fn activations(&self) -> u64 {
        self.activations
    }

    /// Records a new listener count and says whether the event must change state.
    #[must_use = "a transition is what the binding must carry out (start or stop checking)"]
    pub fn set_listeners(&mut self, n: usize) -> Option<Transition> {
        let was = self.is_active();
        self.listeners = n;
        match (was, self.is_active()) {
            (false, true) => {
                self.activations += 1;
                Some(Transition::Activate)
            }
            (true, false) => Some(Transition::Deactivate),
            _ => None,
        }
    }
}

#[cfg(test)]
// the tests step machines into a state and look at the effects of the steps that matter
#[allow(unused_must_use)]
mod tests {
    use super::*;

    #[test]
    fn active_exactly_while_someone_listens() {
        let mut a = Activation::new();
        assert!(!a.is_active());
        assert_eq!(a.set_listeners(1), Some(Transition::Activate));
        assert_eq!(a.set_listeners(3), None);
        assert_eq!(a.set_listeners(1), None);
        assert!(a.is_active());
        assert_eq!(a.set_listeners(0), Some(Transition::Deactivate));
        assert_eq!(a.set_listeners(0), None);
        assert_eq!(a.set_listeners(2), Some(Transition::Activate));
        assert_eq!(a.activations(), 2);
        assert_eq!(a.listeners(), 2);
    }
}
