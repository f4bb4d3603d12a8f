//! `test_msgs/action/Fibonacci`, the ROS 2 tutorials' action, for examples and tests.

use serde::{Deserialize, Serialize};

use super::Action;

/// `test_msgs/action/Fibonacci_Goal`: the goal of the ROS 2 tutorial action (`int32 order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciGoal {
    /// How many numbers of the sequence to compute.
    pub order: i32,
}
crate::ros_message!(FibonacciGoal, "test_msgs", action "Fibonacci_Goal", hash Some(
    "RIHS01_e58ef5a8f4f039ab522a740823547c460b1d5aed8031c8b7825d33d345d90df8"
));

/// `test_msgs/action/Fibonacci_Result` (`int32[] sequence`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciResult {
    /// The sequence computed.
    pub sequence: Vec<i32>,
}
crate::ros_message!(FibonacciResult, "test_msgs", action "Fibonacci_Result", hash Some(
    "RIHS01_0774b095467813c6904d475498b5486b7ebd4cda6a4569f97e8de8c862689049"
));

/// `test_msgs/action/Fibonacci_Feedback` (`int32[] sequence`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciFeedback {
    /// The sequence so far.
    pub sequence: Vec<i32>,
}
crate::ros_message!(FibonacciFeedback, "test_msgs", action "Fibonacci_Feedback", hash Some(
    "RIHS01_7d1110f2efa019ad5ad8ad2244db98d862f39dc9fae8c976814b0065fa2f32d5"
));

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
    // as rosidl wrote them into `share/test_msgs/action/Fibonacci.json` (checked against it by
    // radar_ros/tools/tests/interfaces.rs)
    const TYPE_HASHES: Option<super::ActionTypeHashes> = Some(super::ActionTypeHashes {
        send_goal: "RIHS01_d807633803e38e164276573cd97e9fbd71e109c290bbf4cc312a0a1c9da7bbd9",
        get_result: "RIHS01_5d30fdeb21d20e117aa5f36c7b4f0b6874f1a8cf7a9c038d58f1156c5737b209",
        feedback_message: "RIHS01_37487bae8cea358366b97003c1ef1ca7ce7c08df36f9e8cca496624226aee64e",
    });
}
