//! The thesis' measures of a corridor run, taken from ground truth.
//!
//! - **behaviour share**: the fraction of time each behaviour was wired to the motors;
//! - **bumps**: contact onsets (the bumper ring going from free to pressed);
//! - **wall-following clearance**: while wall following, the distance from the robot's edge to
//!   the nearest obstacle on the followed (left) side;
//! - **center-following offset**: while center following, half the difference between the
//!   left and right clearances (positive: left of the centre), each clearance measured as for
//!   wall following: the distance from the robot's edge to the nearest obstacle in that side's
//!   half-plane, left or right of the heading. Along a corridor this is the perpendicular
//!   definition; while the robot turns round at a corridor's end it stays bounded, where
//!   perpendicular rays would run the corridor's length and report tens of metres;
//! - **stalls**: 60 s windows (from the start, back to back) in which the robot travelled less
//!   than 0.10 m.
//!
//! [`Metrics`] is a pure accumulator fed with [`Sample`]s at a fixed period; the mission samples
//! the simulator's truth on tokio's clock. The figures of one hour of a run are a second
//! accumulator fed the same samples ([`Metrics::after`]), so they are computed as the whole
//! run's are. [`process_memory`] reads what the process holds, for the hourly rows.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One look at the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Simulated time, s.
    pub t_s: f64,
    /// Position, m.
    pub x_m: f64,
    /// Position, m.
    pub y_m: f64,
    /// Distance travelled since the start, m.
    pub travelled_m: f64,
    /// The behaviour wired to the motors, if any.
    pub driving: Option<String>,
    /// Its kind in the catalog (the thesis' measures are taken by kind: the clearance while a
    /// `wallfollow` drives, whatever it is named, the offset while a `centerfollow` does).
    pub kind: Option<String>,
    /// Nearest obstacle in the left half-plane (needed while a behaviour drives), m.
    pub left_m: Option<f64>,
    /// Nearest obstacle in the right half-plane (needed while center following), m.
    pub right_m: Option<f64>,
    /// Contact onsets so far.
    pub bumps: u64,
}

/// Mean and standard deviation of a series (Welford's running algorithm: no cancellation, so
/// a nearly constant series over an hour keeps its small deviation exact).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Samples.
    pub n: u64,
    mean: f64,
    m2: f64,
}

impl Stats {
    fn add(&mut self, v: f64) {
        self.n += 1;
        let delta = v - self.mean;
        self.mean += delta / self.n as f64;
        self.m2 += delta * (v - self.mean);
    }

    /// The mean (None without samples).
    pub fn mean(&self) -> Option<f64> {
        (self.n > 0).then_some(self.mean)
    }

    /// The population standard deviation (None without samples).
    pub fn std(&self) -> Option<f64> {
        (self.n > 0).then(|| (self.m2 / self.n as f64).max(0.0).sqrt())
    }
}

/// The accumulated measures of a run.
#[derive(Debug, Clone, Default)]
pub struct Metrics {
    period_s: f64,
    /// Whether the series for the plot (`trajectory`, `offset_series`, `clearance_series`) are
    /// kept: they grow with the run's length.
    keep_series: bool,
    last_t_s: Option<f64>,
    /// Seconds each behaviour (or "none") drove.
    pub driving_s: BTreeMap<String, f64>,
    /// Seconds each kind of behaviour (or "none") drove.
    pub kind_s: BTreeMap<String, f64>,
    /// Clearance while wall following.
    pub clearance: Stats,
    /// Signed offset while center following.
    pub offset: Stats,
    /// |offset| while center following.
    pub abs_offset: Stats,
    /// Windows of 60 s that count as stalls.
    pub stalls: u64,
    window_start: (f64, f64),
    /// Contact onsets.
    pub bumps: u64,
    /// Distance travelled, m.
    pub distance_m: f64,
    /// Trajectory and series for the plot: (t, x, y, driving).
    pub trajectory: Vec<(f64, f64, f64, Option<String>)>,
    /// (t, offset) while center following.
    pub offset_series: Vec<(f64, f64)>,
    /// (t, clearance) while wall following.
    pub clearance_series: Vec<(f64, f64)>,
    /// (t, x, y) of each bump.
    pub bump_points: Vec<(f64, f64, f64)>,
    /// The behaviour driving at each bump (parallel to `bump_points`).
    pub bump_drivers: Vec<Option<String>>,
    /// A navigation run's goals, paths planned and estimates, for the plot.
    pub navigation: Option<orsa_record::plot::NavigationTrace>,
}

/// The label of "no behaviour wired".
pub const NONE: &str = "none";

impl Metrics {
    /// An accumulator for samples taken every `period_s`, keeping the series for the plot.
    pub fn new(period_s: f64) -> Self {
        Metrics { period_s, keep_series: true, ..Default::default() }
    }

    /// An accumulator that takes over after `last`: the next sample stands for the time since
    /// `last`, its 60 s stall windows start there, and only later contacts count as bumps
    /// (`bumps` and `distance_m` stay cumulated, as in the samples). It keeps no series.
    pub fn after(period_s: f64, last: &Sample) -> Self {
        Metrics {
            period_s,
            keep_series: false,
            last_t_s: Some(last.t_s),
            window_start: (last.t_s, last.travelled_m),
            bumps: last.bumps,
            distance_m: last.travelled_m,
            ..Default::default()
        }
    }

    /// This accumulator, keeping the series for the plot or not (they take memory in
    /// proportion to the run's length: a few MB an hour at 10 Hz).
    pub fn keeping_series(mut self, keep: bool) -> Self {
        self.keep_series = keep;
        self
    }

    /// Adds one sample; each sample stands for the `period_s` before it.
    pub fn add(&mut self, s: &Sample) {
        let dt = match self.last_t_s {
            Some(t) => s.t_s - t,
            None => self.period_s.min(s.t_s),
        };
        self.last_t_s = Some(s.t_s);
        let who = s.driving.clone().unwrap_or_else(|| NONE.to_string());
        *self.driving_s.entry(who).or_insert(0.0) += dt;
        let kind = s.kind.clone().unwrap_or_else(|| NONE.to_string());
        *self.kind_s.entry(kind).or_insert(0.0) += dt;
        match s.kind.as_deref() {
            Some("wallfollow") => {
                if let Some(c) = s.left_m {
                    self.clearance.add(c);
                    if self.keep_series {
                        self.clearance_series.push((s.t_s, c));
                    }
                }
            }
            Some("centerfollow") => {
                if let (Some(l), Some(r)) = (s.left_m, s.right_m) {
                    let off = (r - l) / 2.0;
                    self.offset.add(off);
                    self.abs_offset.add(off.abs());
                    if self.keep_series {
                        self.offset_series.push((s.t_s, off));
                    }
                }
            }
            _ => {}
        }
        if s.bumps > self.bumps {
            self.bump_points.push((s.t_s, s.x_m, s.y_m));
            self.bump_drivers.push(s.driving.clone());
        }
        self.bumps = s.bumps;
        self.distance_m = s.travelled_m;
        // Whole 60 s windows that ended at or before this sample.
        while s.t_s >= self.window_start.0 + 60.0 - 1e-9 {
            if s.travelled_m - self.window_start.1 < 0.10 {
                self.stalls += 1;
            }
            self.window_start = (self.window_start.0 + 60.0, s.travelled_m);
        }
        if self.keep_series {
            self.trajectory.push((s.t_s, s.x_m, s.y_m, s.driving.clone()));
        }
    }

    /// Each behaviour's share of the time.
    pub fn shares(&self) -> BTreeMap<String, f64> {
        fractions(&self.driving_s)
    }

    /// Each kind of behaviour's share of the time.
    pub fn kind_shares(&self) -> BTreeMap<String, f64> {
        fractions(&self.kind_s)
    }
}

/// Each entry's fraction of the sum.
fn fractions(seconds: &BTreeMap<String, f64>) -> BTreeMap<String, f64> {
    let total: f64 = seconds.values().sum();
    seconds.iter().map(|(k, v)| (k.clone(), if total > 0.0 { v / total } else { 0.0 })).collect()
}

/// What the process holds in memory: (resident now, resident at its peak), KiB, from
/// `VmRSS` and `VmHWM` in `/proc/self/status` (Linux); `None` where that cannot be read.
pub fn process_memory() -> (Option<u64>, Option<u64>) {
    match std::fs::read_to_string("/proc/self/status") {
        Ok(status) => parse_status(&status),
        Err(_) => (None, None),
    }
}

/// `VmRSS` and `VmHWM` of a `/proc/<pid>/status` text, KiB.
fn parse_status(status: &str) -> (Option<u64>, Option<u64>) {
    let field = |name: &str| {
        status.lines().find_map(|l| {
            let rest = l.strip_prefix(name)?.strip_prefix(':')?;
            rest.trim().strip_suffix("kB")?.trim().parse::<u64>().ok()
        })
    };
    (field("VmRSS"), field("VmHWM"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, travelled: f64, driving: Option<&str>, bumps: u64) -> Sample {
        Sample {
            t_s: t,
            x_m: t,
            y_m: 0.0,
            travelled_m: travelled,
            driving: driving.map(str::to_string),
            kind: driving.map(str::to_string),
            left_m: Some(if driving == Some("wallfollow") { 0.21 } else { 1.0 }),
            right_m: Some(0.8),
            bumps,
        }
    }

    #[test]
    fn shares_clearance_offset_bumps_and_stalls() {
        let mut m = Metrics::new(1.0);
        for k in 1..=180 {
            let t = f64::from(k);
            // 0-59 s wall following and moving; 60-119 s center following, barely moving;
            // 120-180 center following and moving again; one bump at 150 s.
            let (who, travelled) = match k {
                1..=60 => ("wallfollow", 0.2 * t),
                61..=120 => ("centerfollow", 12.0 + 0.001 * (t - 60.0)),
                _ => ("centerfollow", 12.06 + 0.2 * (t - 120.0)),
            };
            m.add(&sample(t, travelled, Some(who), u64::from(k >= 150)));
        }
        let shares = m.shares();
        assert!((shares["wallfollow"] - 60.0 / 180.0).abs() < 1e-12);
        assert_eq!(m.stalls, 1, "only the second minute");
        assert_eq!(m.bumps, 1);
        assert_eq!(m.bump_points, vec![(150.0, 150.0, 0.0)]);
        assert!((m.clearance.mean().expect("samples") - 0.21).abs() < 1e-12);
        assert!((m.offset.mean().expect("samples") + 0.1).abs() < 1e-12, "left farther: right of centre");
        assert!(m.offset.std().expect("samples") < 1e-12);
        let mut s = Stats::default();
        for v in [0.18, 0.22, 0.20, 0.20] {
            s.add(v);
        }
        // Deviations of +-0.02, 0, 0: variance 0.0002.
        assert!((s.std().expect("samples") - 0.0002f64.sqrt()).abs() < 1e-12);
        assert_eq!(m.clearance.n, 60);
    }

    #[test]
    fn an_hour_after_a_sample_counts_only_what_follows_it() {
        let mut whole = Metrics::new(1.0);
        let mut hour: Option<Metrics> = None;
        for k in 1..=240 {
            let t = f64::from(k);
            // Moving for 120 s (one bump at 100 s), then still for 120 s (one bump at 200 s).
            let travelled = 0.2 * t.min(120.0);
            let s = sample(t, travelled, Some("wallfollow"), u64::from(k >= 100) + u64::from(k >= 200));
            whole.add(&s);
            if let Some(h) = hour.as_mut() {
                h.add(&s);
            } else if k == 120 {
                hour = Some(Metrics::after(1.0, &s));
            }
        }
        let hour = hour.expect("the second half");
        assert_eq!(whole.stalls, 2);
        assert_eq!(hour.stalls, 2, "the same windows, counted from the hand-over");
        assert_eq!((whole.bumps, hour.bumps), (2, 2), "bumps stay cumulated");
        assert_eq!(hour.bump_points, vec![(200.0, 200.0, 0.0)], "only the later contact");
        assert!((hour.driving_s["wallfollow"] - 120.0).abs() < 1e-12);
        assert_eq!(hour.clearance.n, 120);
        assert!(hour.trajectory.is_empty() && hour.clearance_series.is_empty(), "no series");
        assert_eq!(whole.trajectory.len(), 240);
        let status = "Name:\torsa\nVmHWM:\t   20480 kB\nVmRSS:\t   18000 kB\nThreads:\t3\n";
        assert_eq!(parse_status(status), (Some(18000), Some(20480)));
        assert_eq!(parse_status("Name: x\n"), (None, None));
    }
}
