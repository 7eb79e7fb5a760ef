//! Percentiles by sorting: enough for the sample counts a benchmark run takes.

use super::Latency;

/// The nearest-rank `p`-th percentile (`p` in 0..=100) of `sorted` (ascending): the smallest
/// value with at least `p` % of the samples at or below it. `None` if there are no samples or
/// `p` is not a number in range.
pub(crate) fn percentile(sorted: &[u64], p: f64) -> Option<u64> {
    if sorted.is_empty() || !(0.0..=100.0).contains(&p) {
        return None;
    }
    let n = sorted.len();
    let rank = ((p / 100.0) * n as f64).ceil() as usize;
    sorted.get(rank.clamp(1, n) - 1).copied()
}

/// p50, p99, max and mean of `samples` (nanoseconds); all zero with `n = 0` if empty.
pub(crate) fn summarize(mut samples: Vec<u64>) -> Latency {
    samples.sort_unstable();
    let n = samples.len();
    let at = |p: f64| percentile(&samples, p).unwrap_or(0) as f64;
    let mean = if n == 0 { 0.0 } else { samples.iter().map(|&s| s as f64).sum::<f64>() / n as f64 };
    Latency { n, p50_ns: at(50.0), p99_ns: at(99.0), max_ns: at(100.0), mean_ns: mean }
}

/// `a / b`, or `None` when it means nothing (`b` zero or either not finite).
pub(crate) fn ratio(a: f64, b: f64) -> Option<f64> {
    (a.is_finite() && b.is_finite() && b > 0.0).then(|| a / b)
}

/// The middle value (the upper one of an even count), or `None` for none.
pub(crate) fn median(mut values: Vec<f64>) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles_of_one_to_a_hundred() {
        let v: Vec<u64> = (1..=100).collect();
        assert_eq!(percentile(&v, 50.0), Some(50));
        assert_eq!(percentile(&v, 99.0), Some(99));
        assert_eq!(percentile(&v, 99.5), Some(100));
        assert_eq!(percentile(&v, 100.0), Some(100));
        assert_eq!(percentile(&v, 0.0), Some(1));
        assert_eq!(percentile(&v, 1.0), Some(1));
    }

    #[test]
    fn percentiles_of_few_samples_and_bad_input() {
        assert_eq!(percentile(&[], 50.0), None);
        assert_eq!(percentile(&[7], 99.0), Some(7));
        assert_eq!(percentile(&[1, 2], 50.0), Some(1));
        assert_eq!(percentile(&[1, 2], 51.0), Some(2));
        assert_eq!(percentile(&[1, 2, 3], f64::NAN), None);
        assert_eq!(percentile(&[1, 2, 3], -1.0), None);
        assert_eq!(percentile(&[1, 2, 3], 100.1), None);
    }

    #[test]
    fn summary_sorts_and_handles_empty() {
        let s = summarize(vec![30, 10, 20, 1000]);
        assert_eq!((s.n, s.p50_ns, s.p99_ns, s.max_ns), (4, 20.0, 1000.0, 1000.0));
        assert_eq!(s.mean_ns, 265.0);
        let e = summarize(Vec::new());
        assert_eq!((e.n, e.p50_ns, e.max_ns, e.mean_ns), (0, 0.0, 0.0, 0.0));
    }

    #[test]
    fn ratio_refuses_nonsense() {
        assert_eq!(ratio(3.0, 2.0), Some(1.5));
        assert_eq!(ratio(3.0, 0.0), None);
        assert_eq!(ratio(f64::NAN, 2.0), None);
    }

    #[test]
    fn median_takes_the_middle_of_unsorted_values() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), Some(3.0));
        assert_eq!(median(vec![7.5]), Some(7.5));
        assert_eq!(median(Vec::new()), None);
    }
}
