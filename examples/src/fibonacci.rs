//! The ROS 2 tutorial's Fibonacci action behaviour as a RADAR response, shared by the action examples, tests
//! and benchmarks.

use std::{sync::Arc, time::Duration};

use radar_ros::{
    action::{FibonacciFeedback, FibonacciGoal, FibonacciResult},
    FnResponse, Radar, ResponseHandle, Result,
};

/// Spawns the response `name`: for a goal of order `n` it computes the sequence one number every `period`,
/// publishing the sequence so far on `<name>/feedback` (what [`Radar::serve_as_action`] forwards as the
/// action's feedback), and exits with the whole sequence.
pub fn fibonacci_response(radar: &Radar, name: &str, period: Duration) -> Result<ResponseHandle> {
    let response = radar.resolve(name)?;
    let feedback =
        Arc::new(radar.signal_publisher::<FibonacciFeedback>(&response.topic("feedback"))?);
    radar.spawn_response(
        name,
        FnResponse::new(move |goal: FibonacciGoal| {
            let feedback = feedback.clone();
            async move {
                let mut sequence = vec![0, 1];
                for i in 1..goal.order.max(0) as usize {
                    sequence.push(sequence[i] + sequence[i - 1]);
                    // a lost feedback message is not worth ending the run for
                    let _ = feedback.publish(FibonacciFeedback {
                        sequence: sequence.clone(),
                    });
                    tokio::time::sleep(period).await;
                }
                Ok(FibonacciResult { sequence })
            }
        }),
    )
}
