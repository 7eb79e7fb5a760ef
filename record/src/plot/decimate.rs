//! Fewer points, same picture: an hour at 10 Hz is 36 000 samples, far more than a figure's
//! pixels. Trajectories drop points closer than a step to the last kept one; time series keep,
//! per pixel column, the first, lowest, highest and last sample (the "M4" reduction), which
//! draws exactly the same envelope as the full series.

use super::TrajectorySample;

/// A stretch of trajectory driven by one behaviour.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Run<'a> {
    /// The behaviour driving, `None` while no behaviour was wired.
    pub(crate) behaviour: Option<&'a str>,
    /// Positions `[x, y]` in metres.
    pub(crate) points: Vec<[f64; 2]>,
}

/// Splits `samples` into runs of one behaviour each, keeping only points at least `min_step_m`
/// from the previous kept point (and each run's last point). A run starts where the previous
/// one ended, so the drawn path has no holes. Non-finite positions are skipped.
pub(crate) fn trajectory(samples: &[TrajectorySample], min_step_m: f64) -> Vec<Run<'_>> {
    let mut runs: Vec<Run<'_>> = Vec::new();
    let min_sq = min_step_m * min_step_m;
    let finite = samples.iter().filter(|s| s.x_m.is_finite() && s.y_m.is_finite());
    let mut pending: Option<[f64; 2]> = None; // the last sample, when it was not kept
    for s in finite {
        let p = [s.x_m, s.y_m];
        let behaviour = s.behaviour.as_deref();
        match runs.last_mut() {
            Some(run) if run.behaviour == behaviour => {
                let last = run.points.last().copied().unwrap_or(p);
                if (p[0] - last[0]).powi(2) + (p[1] - last[1]).powi(2) >= min_sq {
                    run.points.push(p);
                    pending = None;
                } else {
                    pending = Some(p);
                }
            }
            previous => {
                let mut points = Vec::new();
                if let Some(run) = previous {
                    if let Some(tail) = pending.take() {
                        run.points.push(tail);
                    }
                    points.extend(run.points.last().copied());
                }
                points.push(p);
                runs.push(Run { behaviour, points });
            }
        }
    }
    if let (Some(run), Some(tail)) = (runs.last_mut(), pending) {
        run.points.push(tail);
    }
    runs
}

/// Reduces a time series `(t, v)` (sorted by t) to at most four points per column of
/// `columns` columns spanning `t0..t1`, split into separate polylines wherever consecutive
/// samples are more than `max_gap` apart (the behaviour was not running). Non-finite samples
/// are skipped.
pub(crate) fn series(
    points: &[(f64, f64)],
    t0: f64,
    t1: f64,
    columns: usize,
    max_gap: f64,
) -> Vec<Vec<(f64, f64)>> {
    let span = (t1 - t0).max(f64::MIN_POSITIVE);
    let column_of = |t: f64| ((t - t0) / span * columns as f64).floor() as i64;
    let mut lines: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut line: Vec<(f64, f64)> = Vec::new();
    let mut bucket: Option<Bucket> = None;
    let mut previous_t = f64::NEG_INFINITY;
    for &(t, v) in points.iter().filter(|(t, v)| t.is_finite() && v.is_finite()) {
        let gap = t - previous_t > max_gap;
        previous_t = t;
        let column = column_of(t);
        match &mut bucket {
            Some(b) if !gap && b.column == column => b.add(t, v),
            _ => {
                if let Some(b) = bucket.take() {
                    b.flush(&mut line);
                }
                if gap && !line.is_empty() {
                    lines.push(std::mem::take(&mut line));
                }
                bucket = Some(Bucket::new(column, t, v));
            }
        }
    }
    if let Some(b) = bucket {
        b.flush(&mut line);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The samples of one pixel column.
struct Bucket {
    column: i64,
    first: (f64, f64),
    min: (f64, f64),
    max: (f64, f64),
    last: (f64, f64),
}

impl Bucket {
    fn new(column: i64, t: f64, v: f64) -> Bucket {
        Bucket { column, first: (t, v), min: (t, v), max: (t, v), last: (t, v) }
    }

    fn add(&mut self, t: f64, v: f64) {
        if v < self.min.1 {
            self.min = (t, v);
        }
        if v > self.max.1 {
            self.max = (t, v);
        }
        self.last = (t, v);
    }

    /// Appends the bucket's distinct points in time order.
    fn flush(self, out: &mut Vec<(f64, f64)>) {
        let mut middle = [self.min, self.max];
        middle.sort_by(|a, b| a.0.total_cmp(&b.0));
        for p in [self.first, middle[0], middle[1], self.last] {
            if out.last() != Some(&p) {
                out.push(p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, x: f64, behaviour: Option<&str>) -> TrajectorySample {
        TrajectorySample { t_s: t, x_m: x, y_m: 1.0, behaviour: behaviour.map(str::to_owned) }
    }

    #[test]
    fn trajectory_drops_close_points_and_keeps_runs_joined() {
        let samples: Vec<_> = (0..100)
            .map(|i| sample(i as f64, i as f64 * 0.002, Some(if i < 50 { "a" } else { "b" })))
            .collect();
        let runs = trajectory(&samples, 0.01);
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0].behaviour, Some("a"));
        // 50 samples 2 mm apart: every fifth kept, plus the run's last.
        assert_eq!(runs[0].points.first(), Some(&[0.0, 1.0]));
        assert_eq!(runs[0].points.last(), Some(&[49.0 * 0.002, 1.0]));
        assert!(runs[0].points.len() <= 12, "{}", runs[0].points.len());
        // The second run starts where the first ended.
        assert_eq!(runs[1].points[0], *runs[0].points.last().expect("points"));
        assert_eq!(runs[1].points.last(), Some(&[99.0 * 0.002, 1.0]));
    }

    #[test]
    fn trajectory_skips_non_finite_positions() {
        let samples = [sample(0.0, 0.0, None), sample(1.0, f64::NAN, None), sample(2.0, 1.0, None)];
        let runs = trajectory(&samples, 0.01);
        assert_eq!(runs, [Run { behaviour: None, points: vec![[0.0, 1.0], [1.0, 1.0]] }]);
    }

    #[test]
    fn series_keeps_the_envelope_of_each_column() {
        // 1000 samples of a saw tooth into 10 columns.
        let points: Vec<_> = (0..1000).map(|i| (i as f64 * 0.01, (i % 7) as f64)).collect();
        let lines = series(&points, 0.0, 10.0, 10, 1.0);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].len() <= 40, "{}", lines[0].len());
        let lo = lines[0].iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        let hi = lines[0].iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
        assert_eq!((lo, hi), (0.0, 6.0));
        assert!(lines[0].windows(2).all(|w| w[0].0 <= w[1].0), "time order");
        assert_eq!(lines[0].first(), Some(&points[0]));
        assert_eq!(lines[0].last(), points.last());
    }

    #[test]
    fn series_splits_at_gaps() {
        let points = [(0.0, 1.0), (0.1, 1.0), (5.0, 2.0), (5.1, 2.0)];
        let lines = series(&points, 0.0, 6.0, 600, 1.0);
        assert_eq!(lines, [vec![(0.0, 1.0), (0.1, 1.0)], vec![(5.0, 2.0), (5.1, 2.0)]]);
    }
}
