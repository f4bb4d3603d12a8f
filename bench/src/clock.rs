//! One clock for every process of a run: `CLOCK_MONOTONIC` is system-wide on Linux, so a stamp taken in one
//! process and read in another gives the one-way latency without wall-clock jumps (Python reads the same
//! clock with `time.clock_gettime_ns(time.CLOCK_MONOTONIC)`).

use radar_ros::msg::{Header, Time};

/// Nanoseconds on `CLOCK_MONOTONIC`.
pub fn now_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes into the timespec we own; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// A benchmark payload: `std_msgs/msg/Header` with the send time in `stamp` and the sequence number in
/// `frame_id`, so every client library (rclpy too) carries it unchanged.
pub fn stamped(seq: u64) -> Header {
    let t = now_ns();
    Header {
        stamp: Time {
            sec: (t / 1_000_000_000) as i32,
            nanosec: (t % 1_000_000_000) as u32,
        },
        frame_id: seq.to_string(),
    }
}

/// The sequence number and send time of a payload made by [`stamped`].
pub fn unstamp(h: &Header) -> (u64, u64) {
    let seq = h.frame_id.parse().unwrap_or(u64::MAX);
    let t = h.stamp.sec as u64 * 1_000_000_000 + h.stamp.nanosec as u64;
    (seq, t)
}

/// Nanoseconds since the stamp of `h`, now.
pub fn age_ns(h: &Header) -> u64 {
    now_ns().saturating_sub(unstamp(h).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stamp_round_trips_and_ages() {
        let h = stamped(42);
        let (seq, t) = unstamp(&h);
        assert_eq!(seq, 42);
        assert!(t > 0 && t <= now_ns());
        std::thread::sleep(std::time::Duration::from_millis(2));
        assert!(age_ns(&h) >= 2_000_000);
    }
}
