//! Time for components: the wall clock, or a simulator's with `use_sim_time`.
//!
//! With `--ros-args -p use_sim_time:=true` (or `RadarBuilder::use_sim_time(true)`), a `Radar` follows
//! `/clock` (`rosgraph_msgs/msg/Clock`, as Gazebo and `ros2 bag play --clock` publish it): [`Clock::now`] is the
//! newest time heard there (zero before the first), and [`Clock::sleep`] / [`Clock::sleep_until`] wake when
//! simulated time gets there, however fast or slow it runs, and not at all while it is paused. When the time
//! jumps backwards (a simulation reset, a bag looping) a sleep starts over from the new time, as rclcpp's timers
//! do. [`TimerEvent`](crate::TimerEvent) runs on it; components get it from
//! [`EventNode::clock`](crate::nodes::EventNode::clock) and [`ResponseNode::clock`](crate::nodes::ResponseNode::clock).
//!
//! The library's own waits (discovery, acknowledgements, shutdown) stay on the wall clock: they are about the
//! network, not the simulated world.

use std::time::Duration;

use tokio::sync::watch;

use crate::wire::msg::Time;

/// `rosgraph_msgs/msg/Clock`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClockMsg {
    /// The simulated time.
    pub clock: Time,
}
crate::ros_message!(ClockMsg, "rosgraph_msgs", "Clock");

/// Nanoseconds since the epoch.
fn ns(t: Time) -> i64 {
    i64::from(t.sec) * 1_000_000_000 + i64::from(t.nanosec)
}

fn time(ns: i64) -> Time {
    Time {
        sec: ns.div_euclid(1_000_000_000) as i32,
        nanosec: ns.rem_euclid(1_000_000_000) as u32,
    }
}

/// A component's clock: the wall clock, or simulated time from `/clock` (see the [module docs](self)). Cheap to
/// clone.
#[derive(Clone, Debug)]
pub struct Clock {
    /// `None`: the wall clock. Else the newest `/clock` time in ns (0 before the first).
    sim: Option<watch::Receiver<i64>>,
}

/// How a [`Clock::sleep_until`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Woke {
    /// The clock reached the time.
    Reached,
    /// Simulated time jumped backwards before it did.
    JumpedBack,
}

impl Clock {
    /// The wall clock.
    pub fn wall() -> Clock {
        Clock { sim: None }
    }

    /// Whether this clock follows `/clock`.
    pub fn is_simulated(&self) -> bool {
        self.sim.is_some()
    }

    /// The time now.
    pub fn now(&self) -> Time {
        match &self.sim {
            None => Time::now(),
            Some(rx) => time(*rx.borrow()),
        }
    }

    /// Waits until the clock reads `t` or later; in simulated time, returns [`Woke::JumpedBack`] if the time
    /// goes backwards first. Cancel safe.
    pub async fn sleep_until(&self, t: Time) -> Woke {
        match &self.sim {
            None => {
                let now = ns(Time::now());
                let left = ns(t).saturating_sub(now).max(0) as u64;
                tokio::time::sleep(Duration::from_nanos(left)).await;
                Woke::Reached
            }
            Some(rx) => {
                let mut rx = rx.clone();
                let mut last = *rx.borrow_and_update();
                loop {
                    if last >= ns(t) {
                        return Woke::Reached;
                    }
                    if rx.changed().await.is_err() {
                        // the Radar is gone: simulated time stands still
                        std::future::pending::<()>().await;
                    }
                    let now = *rx.borrow_and_update();
                    if now < last {
                        return Woke::JumpedBack;
                    }
                    last = now;
                }
            }
        }
    }

    /// Waits `d` of this clock's time; a backward jump of simulated time starts the wait over from the new
    /// time. Cancel safe.
    pub async fn sleep(&self, d: Duration) {
        if self.sim.is_none() {
            // monotonic: no wall-clock adjustment lengthens or cuts it
            return tokio::time::sleep(d).await;
        }
        loop {
            let until = time(ns(self.now()).saturating_add(d.as_nanos() as i64));
            if self.sleep_until(until).await == Woke::Reached {
                return;
            }
        }
    }

    /// `f`, unless `d` of this clock's time passes first.
    pub async fn timeout<F: std::future::Future>(
        &self,
        d: Duration,
        f: F,
    ) -> Result<F::Output, crate::Error> {
        tokio::select! {
            out = f => Ok(out),
            _ = self.sleep(d) => Err(crate::Error::Timeout {
                what: "a component's wait".into(),
                after: d,
            }),
        }
    }
}

/// Follows `/clock` for a `Radar`: subscribes on its program node and feeds the clock; dropping it stops.
pub(crate) struct SimClock {
    clock: Clock,
    _task: tokio::task::JoinHandle<()>,
}

impl Drop for SimClock {
    fn drop(&mut self) {
        self._task.abort();
    }
}

impl SimClock {
    /// rclcpp's clock QoS: keep-last 1; best effort takes a reliable or a best-effort publisher.
    pub(crate) fn qos() -> ros2_client::QosProfile {
        crate::wire::qos::signal_qos_depth(1).reliability(ros2_client::qos::Reliability::BestEffort)
    }

    /// Follows what `sub` (a subscription to `/clock` with [`SimClock::qos`]) receives.
    pub(crate) fn start(sub: crate::node::topics::SignalSubscription<ClockMsg>) -> SimClock {
        let (tx, rx) = watch::channel(0i64);
        let task = tokio::spawn(async move {
            loop {
                match sub.recv().await {
                    Ok(m) => {
                        let _ = tx.send(ns(m.clock));
                    }
                    Err(crate::Error::Closed(_)) => break,
                    Err(e) => {
                        tracing::warn!(error = %crate::error::Report(&e), "reading /clock");
                        tokio::time::sleep(Duration::from_millis(100)).await;
                    }
                }
            }
        });
        SimClock {
            clock: Clock { sim: Some(rx) },
            _task: task,
        }
    }

    pub(crate) fn clock(&self) -> Clock {
        self.clock.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sim() -> (watch::Sender<i64>, Clock) {
        let (tx, rx) = watch::channel(0);
        (tx, Clock { sim: Some(rx) })
    }

    #[tokio::test]
    async fn simulated_sleeps_follow_the_clock_and_start_over_after_a_jump_back() {
        let (tx, clock) = sim();
        tx.send(100 * 1_000_000_000).unwrap();
        let c = clock.clone();
        let sleeping = tokio::spawn(async move { c.sleep(Duration::from_secs(10)).await });
        tokio::task::yield_now().await;
        tx.send(105 * 1_000_000_000).unwrap();
        tokio::time::sleep(Duration::from_millis(20)).await;
        assert!(!sleeping.is_finished(), "5 s of 10 passed");
        // the simulation is reset: 10 s from 50 s now
        tx.send(50 * 1_000_000_000).unwrap();
        tokio::time::sleep(Duration::from_millis(20)).await;
        tx.send(59 * 1_000_000_000).unwrap();
        tokio::time::sleep(Duration::from_millis(20)).await;
        assert!(!sleeping.is_finished(), "started over at 50 s");
        tx.send(60 * 1_000_000_000).unwrap();
        tokio::time::timeout(Duration::from_secs(1), sleeping)
            .await
            .expect("woke at 60 s")
            .unwrap();
        assert_eq!(
            clock.now(),
            Time {
                sec: 60,
                nanosec: 0
            }
        );
    }

    #[test]
    fn times_convert_both_ways() {
        let t = Time {
            sec: 3,
            nanosec: 250_000_000,
        };
        assert_eq!(time(ns(t)), t);
    }
}
