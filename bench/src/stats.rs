//! Percentiles and summaries of latency samples.

use serde::Serialize;

/// The distribution of one latency scenario, in microseconds.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Summary {
    /// Samples.
    pub n: usize,
    /// Median.
    pub p50_us: f64,
    /// 90th percentile.
    pub p90_us: f64,
    /// 99th percentile.
    pub p99_us: f64,
    /// Largest sample.
    pub max_us: f64,
    /// Mean.
    pub mean_us: f64,
}

/// The value below which `q` (0..=1) of the sorted samples lie (nearest rank).
pub fn percentile(sorted: &[u64], q: f64) -> u64 {
    assert!(!sorted.is_empty(), "percentile of no samples");
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Summarises nanosecond samples; `None` when there are none.
pub fn summarize(samples_ns: &[u64]) -> Option<Summary> {
    if samples_ns.is_empty() {
        return None;
    }
    let mut s = samples_ns.to_vec();
    s.sort_unstable();
    let us = |ns: u64| ns as f64 / 1000.0;
    Some(Summary {
        n: s.len(),
        p50_us: us(percentile(&s, 0.50)),
        p90_us: us(percentile(&s, 0.90)),
        p99_us: us(percentile(&s, 0.99)),
        max_us: us(*s.last().unwrap()),
        mean_us: s.iter().map(|&x| x as f64).sum::<f64>() / s.len() as f64 / 1000.0,
    })
}

/// Points of the empirical CDF (value in microseconds, fraction at or below), thinned to at most `max` points
/// but always keeping the tail.
pub fn cdf(samples_ns: &[u64], max: usize) -> Vec<(f64, f64)> {
    let mut s = samples_ns.to_vec();
    s.sort_unstable();
    let n = s.len();
    let step = n.div_ceil(max.max(1)).max(1);
    let mut out: Vec<(f64, f64)> = (0..n)
        .step_by(step)
        .map(|i| (s[i] as f64 / 1000.0, (i + 1) as f64 / n as f64))
        .collect();
    if n > 0 && !(n - 1).is_multiple_of(step) {
        out.push((s[n - 1] as f64 / 1000.0, 1.0));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_use_the_nearest_rank() {
        let s: Vec<u64> = (1..=100).collect();
        assert_eq!(percentile(&s, 0.5), 50);
        assert_eq!(percentile(&s, 0.9), 90);
        assert_eq!(percentile(&s, 0.99), 99);
        assert_eq!(percentile(&s, 1.0), 100);
        assert_eq!(percentile(&[7], 0.99), 7);
    }

    #[test]
    fn a_summary_is_in_microseconds_and_order_free() {
        let s = summarize(&[3000, 1000, 2000]).unwrap();
        assert_eq!(s.n, 3);
        assert_eq!(s.p50_us, 2.0);
        assert_eq!(s.max_us, 3.0);
        assert_eq!(s.mean_us, 2.0);
        assert!(summarize(&[]).is_none());
    }

    #[test]
    fn a_cdf_is_thinned_but_ends_at_the_maximum() {
        let s: Vec<u64> = (1..=1001).map(|x| x * 1000).collect();
        let c = cdf(&s, 100);
        assert!(c.len() <= 102);
        assert_eq!(c.first().unwrap(), &(1.0, 1.0 / 1001.0));
        assert_eq!(c.last().unwrap(), &(1001.0, 1.0));
        assert!(c.windows(2).all(|w| w[0].0 <= w[1].0 && w[0].1 < w[1].1));
    }
}
