//! `test_msgs/action/Fibonacci`, the ROS 2 tutorials' action, for examples and tests.

use serde::{Deserialize, Serialize};

use super::Action;

/// `test_msgs/action/Fibonacci_Goal`: the goal of the ROS 2 tutorial action (`int32 order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciGoal {
    /// How many numbers of the sequence to compute.
    pub order: i32,
}
crate::ros_message!(FibonacciGoal, "test_msgs", action "Fibonacci_Goal");

/// `test_msgs/action/Fibonacci_Result` (`int32[] sequence`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciResult {
    /// The sequence computed.
    pub sequence: Vec<i32>,
}
crate::ros_message!(FibonacciResult, "test_msgs", action "Fibonacci_Result");

/// `test_msgs/action/Fibonacci_Feedback` (`int32[] sequence`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciFeedback {
    /// The sequence so far.
    pub sequence: Vec<i32>,
}
crate::ros_message!(FibonacciFeedback, "test_msgs", action "Fibonacci_Feedback");

/// `test_msgs/action/Fibonacci`: the action of the ROS 2 tutorials, as the `ros-jazzy-test-msgs` package
/// defines it, for examples and tests (`ros2 action send_goal /fibonacci test_msgs/action/Fibonacci
/// "{order: 5}"`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Fibonacci;

impl Action for Fibonacci {
    const PACKAGE: &'static str = "test_msgs";
    const NAME: &'static str = "Fibonacci";
    type Goal = FibonacciGoal;
    type Result = FibonacciResult;
    type Feedback = FibonacciFeedback;
}
