//! What the sensors saw lately, kept in the odometry frame until a reading sees through it.
//!
//! Each look places the readings that are new since the last (their points, one per 2 cm cell),
//! and lets the readings that are new since they last cleared anything forget what they see
//! through: each is tested once, against every point remembered from before it, when it is
//! new. A point placed now is tested against the newest reading of every sensor instead (a
//! delayed scan may bring points older than readings already used). So a look costs what is
//! new, not what is remembered times every sensor.

use super::sweep::{Beams, Seen, Wedge};
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{DistanceScan, RING_SIZE};
use std::time::Duration;

/// What the sensors saw lately, in the odometry frame: one point per 2 cm cell (the newest),
/// with the stamp of its reading and its slack.
#[derive(Debug, Default)]
pub(super) struct Memory {
    cells: std::collections::HashMap<(i32, i32), Cell>,
    /// The newest reading stamp placed, per view and sensor.
    placed: [[Timestamp; RING_SIZE]; 2],
    /// The newest reading stamp that has cleared what it sees through, per view and sensor.
    cleared: [[Timestamp; RING_SIZE]; 2],
    /// The looks so far: a cell placed in the current one is new.
    looks: u64,
    scratch: Vec<Seen>,
    wedges: Vec<Wedge>,
}

/// One remembered point, and the look that placed it.
#[derive(Debug, Clone, Copy)]
struct Cell {
    seen: Seen,
    look: u64,
}

/// The memory's cell size, m.
const CELL_M: f64 = 0.02;

impl Memory {
    /// Starts a look: what is placed from here on is new.
    pub(super) fn begin(&mut self) {
        self.looks += 1;
        self.wedges.clear();
    }

    /// Places the readings of `scan` (view `v`) newer than those placed before and within
    /// `near` m of the centre, seen from the odometry pose `pose` at `now` by a robot moving at
    /// `speed` m/s; the readings newer than those that cleared before will clear (see
    /// [`Memory::recall`]).
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
        let (s, c) = pose.2.sin_cos();
        let cleared = &mut self.cleared[v];
        for r in &scan.readings {
            let i = usize::from(r.sensor_id);
            if i < RING_SIZE && r.stamp > cleared[i] {
                cleared[i] = r.stamp;
                self.wedges.extend(beams.wedge(r, (pose.0, pose.1), (s, c)));
            }
        }
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
        for p in seen.iter().filter(|p| p.at.0 * p.at.0 + p.at.1 * p.at.1 <= near * near) {
            let (x, y) = (pose.0 + c * p.at.0 - s * p.at.1, pose.1 + s * p.at.0 + c * p.at.1);
            let slack_m = speed * now.saturating_since(p.stamp).as_secs_f64();
            let cell = ((x / CELL_M).floor() as i32, (y / CELL_M).floor() as i32);
            self.cells
                .insert(cell, Cell { seen: Seen { at: (x, y), stamp: p.stamp, slack_m }, look: self.looks });
        }
    }

    /// What it holds within `reach` m of the centre, in the body frame at odometry pose
    /// `pose`, younger than `keep` at `now` and not seen through (forgetting the rest). A point
    /// remembered from before this look is seen through by a reading placed in this look that
    /// is newer and sees it free; one placed in this look, where `seen_through` says (the newest
    /// reading of each sensor, in the body frame).
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
        let (wedges, look) = (&self.wedges, self.looks);
        let keep_ns = u64::try_from(keep.as_nanos()).unwrap_or(u64::MAX);
        self.cells.retain(|_, cell| {
            let p = &cell.seen;
            let (dx, dy) = (p.at.0 - pose.0, p.at.1 - pose.1);
            let r = reach + p.slack_m;
            // What the robot left behind (beyond the farthest it may need) or that is too old
            // is forgotten.
            if dx * dx + dy * dy > r * r || now.0.saturating_sub(p.stamp.0) > keep_ns {
                return false;
            }
            let at = (c * dx + s * dy, -s * dx + c * dy);
            let through = if cell.look == look {
                seen_through(p, at)
            } else {
                wedges.iter().any(|w| w.stamp > p.stamp && w.clears(p.at))
            };
            if through {
                return false;
            }
            out.push(Seen { at, ..*p });
            true
        });
    }
}
