//! The RADAR endpoints below a component's name, by role rather than by string.

/// A RADAR endpoint below a component's name: an event's `triggered` and `state`; a response's `start`,
/// `interrupt` and `exit` slots, its `started`, `interrupted` and `exited` signals, its `dropped` notice, its
/// `state`, and (an action response's) `feedback`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Endpoint {
    /// An event's signal.
    Triggered,
    /// A response's start slot.
    Start,
    /// A response's interrupt slot.
    Interrupt,
    /// A response's exit slot.
    Exit,
    /// A response's signal that a run started.
    Started,
    /// A response's signal that a run was interrupted.
    Interrupted,
    /// A response's signal that a run ended.
    Exited,
    /// A response's notice that it did not take a start a statement sent (busy, replaced in its queue,
    /// stopping), carrying that statement's cause (rule R6): the statement's `until` ends (C3).
    Dropped,
    /// An action response's feedback signal.
    Feedback,
    /// A component's state (transient-local).
    State,
}

impl Endpoint {
    /// Every RADAR endpoint.
    pub const ALL: [Endpoint; 10] = [
        Endpoint::Triggered,
        Endpoint::Start,
        Endpoint::Interrupt,
        Endpoint::Exit,
        Endpoint::Started,
        Endpoint::Interrupted,
        Endpoint::Exited,
        Endpoint::Dropped,
        Endpoint::Feedback,
        Endpoint::State,
    ];

    /// Its name, the last segment of its topic (`triggered`, `start`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Endpoint::Triggered => "triggered",
            Endpoint::Start => "start",
            Endpoint::Interrupt => "interrupt",
            Endpoint::Exit => "exit",
            Endpoint::Started => "started",
            Endpoint::Interrupted => "interrupted",
            Endpoint::Exited => "exited",
            Endpoint::Dropped => "dropped",
            Endpoint::Feedback => "feedback",
            Endpoint::State => "state",
        }
    }

    /// The endpoint a topic's last segment names, if it is one.
    ///
    /// ```
    /// use radar_ros::graph::Endpoint;
    /// assert_eq!(Endpoint::of_topic("/fib/feedback"), Some(("/fib", Endpoint::Feedback)));
    /// assert_eq!(Endpoint::of_topic("/chatter"), None);
    /// ```
    pub fn of_topic(topic: &str) -> Option<(&str, Endpoint)> {
        let (parent, last) = topic.rsplit_once('/')?;
        let e = Endpoint::ALL.into_iter().find(|e| e.name() == last)?;
        (!parent.is_empty()).then_some((parent, e))
    }

    /// A signal (published by the component: `triggered`, `started`, `interrupted`, `exited`, `dropped`,
    /// `feedback`).
    pub fn is_signal(self) -> bool {
        matches!(
            self,
            Endpoint::Triggered
                | Endpoint::Started
                | Endpoint::Interrupted
                | Endpoint::Exited
                | Endpoint::Dropped
                | Endpoint::Feedback
        )
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
