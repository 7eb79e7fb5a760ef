//! What the sensors saw lately, kept in the odometry frame until a reading sees through it.

use super::sweep::{Beams, Seen};
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{DistanceScan, RING_SIZE};
use std::time::Duration;

/// What the sensors saw lately, in the odometry frame: one point per 2 cm cell (the newest),
/// with the stamp of its reading and its slack.
#[derive(Debug, Default)]
pub(super) struct Memory {
    cells: std::collections::HashMap<(i32, i32), Seen>,
    /// The newest reading stamp placed, per view and sensor.
    placed: [[Timestamp; RING_SIZE]; 2],
    scratch: Vec<Seen>,
}

/// The memory's cell size, m.
const CELL_M: f64 = 0.02;

impl Memory {
    /// Places the readings of `scan` (view `v`) newer than those placed before and within
    /// `near` m of the centre, seen from the odometry pose `pose` at `now` by a robot moving at
    /// `speed` m/s.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn place(
        &mut self,
        v: usize,
        scan: &DistanceScan,
        beams: &Beams,
        pose: (f64, f64, f64),
        now: Timestamp,
        speed: f64,
        near: f64,
    ) {
        let placed = &mut self.placed[v];
        let fresh = scan.readings.iter().filter(|r| {
            let i = usize::from(r.sensor_id);
            let new = i < RING_SIZE && r.stamp > placed[i];
            if new {
                placed[i] = r.stamp;
            }
            new
        });
        let seen = &mut self.scratch;
        seen.clear();
        beams.seen(fresh, seen);
        let (s, c) = pose.2.sin_cos();
        for p in seen.iter().filter(|p| p.at.0 * p.at.0 + p.at.1 * p.at.1 <= near * near) {
            let (x, y) = (pose.0 + c * p.at.0 - s * p.at.1, pose.1 + s * p.at.0 + c * p.at.1);
            let slack_m = speed * now.saturating_since(p.stamp).as_secs_f64();
            let cell = ((x / CELL_M).floor() as i32, (y / CELL_M).floor() as i32);
            self.cells.insert(cell, Seen { at: (x, y), stamp: p.stamp, slack_m });
        }
    }

    /// What it holds within `reach` m of the centre, in the body frame at odometry pose
    /// `pose`, younger than `keep` at `now` and not seen through (forgetting the rest).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn recall(
        &mut self,
        pose: (f64, f64, f64),
        now: Timestamp,
        keep: Duration,
        reach: f64,
        seen_through: impl Fn(&Seen, (f64, f64)) -> bool,
        out: &mut Vec<Seen>,
    ) {
        let (s, c) = pose.2.sin_cos();
        // What a reading saw through is forgotten; the rest within reach is recalled.
        self.cells.retain(|_, p| {
            let (dx, dy) = (p.at.0 - pose.0, p.at.1 - pose.1);
            let r = reach + p.slack_m;
            // What the robot left behind (beyond the farthest it may need) or that is too old
            // is forgotten.
            if dx * dx + dy * dy > r * r || now.saturating_since(p.stamp) > keep {
                return false;
            }
            let at = (c * dx + s * dy, -s * dx + c * dy);
            if seen_through(p, at) {
                return false;
            }
            out.push(Seen { at, ..*p });
            true
        });
    }
}
