//! What a behaviour sees of the walls: ring readings fused and turned into a wall estimate.
//!
//! Conventions (the same for both sides): the wall angle `alpha` is the direction of the wall
//! relative to the robot's heading, counter-clockwise positive; equivalently `alpha = -theta`
//! where `theta` is the heading relative to the wall. So with the wall on the left, `alpha < 0`
//! means heading into the wall, and the distance obeys `d' = v sin(alpha)`; with the wall on the
//! right, `alpha > 0` means heading into it. The heading turns as `theta' = omega`, hence
//! `alpha' = -omega`.
//!
//! Two estimators of `alpha` exist:
//! - [`AngleEstimator::Original`], the thesis' formula: with `m` the side sensor with the
//!   smallest reading, `alpha = pi/8 (m - c) + asin((d[m-1] - d[m+1]) / l)` with `c` the side's
//!   middle sensor (4 left, 12 right) and `l = 0.17 m`. Where it is fragile orsa does the sound
//!   thing: the asin argument is clamped to [-1, 1]; a neighbour that is invalid (out of range)
//!   or outside the ring's side drops the fine term and keeps the coarse `pi/8 (m - c)`.
//! - [`AngleEstimator::LineFit`]: the wall through the echoes of the nearest sensor's two
//!   neighbours. A sensor reports the nearest surface anywhere in its beam; for a neighbour of
//!   the nearest sensor that is where the beam's edge closest to the perpendicular meets the
//!   wall. Placing each neighbour's echo on that edge (the sensor's position on the ring, plus
//!   its reading along the edge) puts both points exactly on a flat wall, so the line through
//!   them gives `alpha` and `d` exactly at any angle and any beam width (25 degree sonar beams
//!   included), where the original is a small-angle, narrow-beam approximation. When the two
//!   neighbours disagree with the nearest reading (they see different objects), or one is
//!   missing, it falls back to the nearest reading and the coarse angle `pi/8 (m - c)`. It is
//!   the default.

use orsa_hardware::comm::{DistanceScan, RING_SIZE, ring_angle_rad};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Which side of the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Sensors 1..=7, centred on 4.
    Left,
    /// Sensors 9..=15, centred on 12.
    Right,
}

impl Side {
    /// The side's sensors, front to back for the left, back to front for the right.
    pub fn sensors(self) -> std::ops::RangeInclusive<usize> {
        match self {
            Side::Left => 1..=7,
            Side::Right => 9..=15,
        }
    }

    /// The sensor that faces straight out of this side.
    pub fn middle(self) -> usize {
        match self {
            Side::Left => 4,
            Side::Right => 12,
        }
    }
}

/// How the wall angle is estimated (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AngleEstimator {
    /// The thesis' `pi/8 (m - c) + asin((d[m-1] - d[m+1]) / l)`, made safe at its edges.
    Original,
    /// A line through the hit points of the nearest sensor and its neighbours.
    #[default]
    LineFit,
}

/// One distance per ring sensor: `None` where the reading is invalid.
pub type Ranges = [Option<f64>; RING_SIZE];

/// The valid distances of a scan.
pub fn ranges(scan: &DistanceScan) -> Ranges {
    let mut out = [None; RING_SIZE];
    for r in &scan.readings {
        let i = usize::from(r.sensor_id);
        if i < RING_SIZE && r.valid && r.distance_m.is_finite() {
            out[i] = Some(r.distance_m);
        }
    }
    out
}

/// Fuses infrared and sonar per sensor: infrared where it reads under `ir_below_m`, sonar
/// otherwise (the original rule; infrared is precise up close, sonar sees far). Also gives each
/// sensor's half beam width: `ir_half_beam` or `sonar_half_beam`, whichever was used.
pub fn fuse(
    ir: &Ranges,
    sonar: &Ranges,
    ir_below_m: f64,
    ir_half_beam: f64,
    sonar_half_beam: f64,
) -> (Ranges, [f64; RING_SIZE]) {
    let mut out = [None; RING_SIZE];
    let mut beams = [sonar_half_beam; RING_SIZE];
    for i in 0..RING_SIZE {
        out[i] = match ir[i] {
            Some(d) if d < ir_below_m => {
                beams[i] = ir_half_beam;
                Some(d)
            }
            _ => sonar[i],
        };
    }
    (out, beams)
}

/// The sensors that look ahead, within 45 degrees of the front (14, 15, 0, 1, 2).
pub const FRONT_ARC: [usize; 5] = [14, 15, 0, 1, 2];

/// The nearest valid reading within 45 degrees of the front.
pub fn front_min(r: &Ranges) -> Option<f64> {
    FRONT_ARC.iter().filter_map(|&i| r[i]).min_by(f64::total_cmp)
}

/// Getting out of a gap barely wider than the body.
///
/// The robot is wedged when its nearest left and right obstacles (sensors 1..7 and 9..15) add
/// up to less than `tight_gap_m` and something is within `open_front_m` ahead (45 degrees each
/// side). Then it turns in place, always in the direction it first chose (toward the more open
/// front diagonal), until the front is open again: choosing anew at each step makes it rock back
/// and forth between the two sides of the gap and never leave.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Wedge {
    turn: Option<f64>,
}

impl Wedge {
    /// The turn rate to turn in place at, while wedged; `None` when free.
    pub fn step(
        &mut self,
        r: &Ranges,
        tight_gap_m: f64,
        open_front_m: f64,
        omega_max_rad_s: f64,
    ) -> Option<f64> {
        let front_open = front_min(r).is_none_or(|d| d > open_front_m);
        if front_open {
            self.turn = None;
            return None;
        }
        let tight = match (side_min(r, Side::Left), side_min(r, Side::Right)) {
            (Some((_, l)), Some((_, rt))) => l + rt < tight_gap_m,
            _ => false,
        };
        if !tight && self.turn.is_none() {
            return None;
        }
        let open = |i: usize| r[i].unwrap_or(f64::INFINITY);
        let left_more_open = open(2).min(open(1)) >= open(14).min(open(15));
        Some(*self.turn.get_or_insert(if left_more_open { omega_max_rad_s } else { -omega_max_rad_s }))
    }
}

/// Getting out of a deadlock, an orsa addition to both behaviours (`[*.unstick]` in the config).
///
/// People in orsa's worlds, like polite people, wait while the robot is close. A robot blocked
/// ahead by a waiting person, with a wall on its other side, can then turn back and forth in
/// place for ever while nobody moves (EXPERIMENTS.md). When odometry says the robot has not
/// moved `progress_m` in `after_s`, it backs straight out at `back_m_s` for `back_s` (only while
/// nothing is within `rear_clear_m` of its back, sensors 6 to 10), then turns in place toward
/// the most open direction the ring sees (the widest opening: a sensor and both its neighbours
/// far), and drives on from there: the person it was facing can walk on, and the robot goes the
/// other way.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UnstickParams {
    /// Get out of deadlocks at all.
    pub enabled: bool,
    /// Not having moved `progress_m` for this long is a deadlock, s.
    pub after_s: f64,
    /// See `after_s`, m.
    pub progress_m: f64,
    /// Back out for this long, s.
    pub back_s: f64,
    /// At this speed, m/s (positive; the robot drives backwards).
    pub back_m_s: f64,
    /// Only while nothing is this close behind (sensors 6 to 10), m.
    pub rear_clear_m: f64,
}

impl Default for UnstickParams {
    fn default() -> Self {
        UnstickParams {
            enabled: true,
            after_s: 5.0,
            progress_m: 0.05,
            back_s: 1.5,
            back_m_s: 0.10,
            rear_clear_m: 0.25,
        }
    }
}

impl UnstickParams {
    /// Checks every value; the message names the offending key under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        crate::cascade::check_positive(
            &format!("{prefix}.unstick"),
            &[
                ("after_s", self.after_s),
                ("progress_m", self.progress_m),
                ("back_s", self.back_s),
                ("back_m_s", self.back_m_s),
                ("rear_clear_m", self.rear_clear_m),
            ],
        )
    }
}

/// What [`Unstick`] is doing.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
enum Recovery {
    /// Watching for a deadlock.
    #[default]
    Watching,
    /// Backing out until then (ns).
    Backing { until: u64 },
    /// Turning in place at this rate until then (ns).
    Turning { omega: f64, until: u64 },
}

/// The state of the recovery that [`UnstickParams`] configures.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Unstick {
    /// Where the robot was when the current window began, and when (ns).
    window: Option<(u64, [f64; 2])>,
    /// The latest position (odometry), m.
    position: Option<[f64; 2]>,
    recovery: Recovery,
}

impl Unstick {
    /// The robot is at `(x, y)` (odometry, m) at `now` (ns).
    pub fn note_position(&mut self, p: &UnstickParams, x: f64, y: f64, now: u64) {
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        self.position = Some([x, y]);
        match self.window {
            Some((_, [x0, y0])) if (x - x0).hypot(y - y0) < p.progress_m => {}
            _ => self.window = Some((now, [x, y])),
        }
    }

    /// The command to give instead of the behaviour's own at `now` (ns), if it is getting out of
    /// a deadlock: `(v, omega)`.
    pub fn step(
        &mut self,
        p: &UnstickParams,
        r: &Ranges,
        omega_max_rad_s: f64,
        now: u64,
    ) -> Option<(f64, f64)> {
        if !p.enabled {
            return None;
        }
        let rear_clear = (6..=10).all(|i| r[i].is_none_or(|d| d > p.rear_clear_m));
        loop {
            match self.recovery {
                Recovery::Watching => {
                    let (since, _) = self.window?;
                    if (now.saturating_sub(since) as f64) * 1e-9 < p.after_s {
                        return None;
                    }
                    self.recovery = Recovery::Backing { until: now + secs_ns(p.back_s) };
                }
                Recovery::Backing { until } => {
                    if now < until && rear_clear {
                        return Some((-p.back_m_s, 0.0));
                    }
                    // The most open direction: the sensor whose reading and both neighbours'
                    // are farthest (an opening, not a gap beside a person), the smallest turn
                    // first among equals.
                    let far = |i: usize| r[i % RING_SIZE].unwrap_or(f64::INFINITY);
                    let mut best = (0usize, f64::NEG_INFINITY);
                    for i in [0, 1, 15, 2, 14, 3, 13, 4, 12, 5, 11, 6, 10, 7, 9, 8] {
                        let d = far(i + RING_SIZE - 1).min(far(i)).min(far(i + 1));
                        if d > best.1 {
                            best = (i, d);
                        }
                    }
                    let angle = wrap(ring_angle_rad(best.0));
                    // Steering takes about half a second to reach full rate.
                    let turn_s = angle.abs() / omega_max_rad_s + 0.5;
                    let omega = if angle >= 0.0 { omega_max_rad_s } else { -omega_max_rad_s };
                    self.recovery = if best.0 == 0 {
                        Recovery::Watching
                    } else {
                        Recovery::Turning { omega, until: now + secs_ns(turn_s) }
                    };
                    if best.0 == 0 {
                        self.restart(now);
                        return None;
                    }
                }
                Recovery::Turning { omega, until } => {
                    if now < until {
                        return Some((0.0, omega));
                    }
                    self.recovery = Recovery::Watching;
                    self.restart(now);
                    return None;
                }
            }
        }
    }

    /// A new window from where the robot is now.
    fn restart(&mut self, now: u64) {
        self.window = self.position.map(|p| (now, p));
    }
}

fn secs_ns(s: f64) -> u64 {
    (s * 1e9) as u64
}

/// Where a flat wall facing direction `phi` (rad, counter-clockwise from the front) would be,
/// measured from the robot's centre along `phi`, given sensor `i`'s reading `d`: the echo
/// comes from the edge of the beam nearest to `phi` (or its axis, if `phi` is inside the beam).
/// For a flat wall square to `phi` every sensor that sees it gives the same value.
pub fn projected(i: usize, d: f64, phi: f64, ring: &RingGeometry) -> f64 {
    let off = wrap(ring_angle_rad(i) - phi);
    let edge = (off.abs() - ring.half_beam_rad[i]).max(0.0);
    ring.radius_m * off.cos() + d * edge.cos()
}

/// An angle wrapped into (-pi, pi].
fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI { w - 2.0 * PI } else { w }
}

/// Turning round at a dead end, an orsa addition to center following.
///
/// At the closed end of a corridor the thesis' robot drove on until the master handed it to
/// wall following (front infrared under 0.50 m), which turned it round close to the end wall
/// and off the centre line. Here the robot turns round where the end is as far away as the
/// side walls, in place: the one spot from which a turn keeps it equally far from everything.
///
/// A dead end is ahead when sensors 15, 0 and 1 all see one flat wall square to the heading
/// (their readings, projected on the heading, agree within `flat_m`) no farther than the
/// farther side wall (sensors 3-5 and 11-13) plus `margin_m`, no nearer than the side walls
/// minus `margin_m + flat_m`, with the robot about as far from both sides and nothing within a
/// metre beyond that behind it (sensor 8). A person ahead does not look like that: beside the
/// one or two sensors it fills, the others see the side walls far off. The
/// robot then turns in place, always the same way (toward the more open side), until the front
/// is open and `alpha`, the wall angle, says it runs parallel to the walls again.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DeadEnd {
    /// The turn rate while turning, and the front distance when it began.
    turn: Option<(f64, f64)>,
}

impl DeadEnd {
    /// The turn rate to turn in place at; `None` when not at a dead end.
    pub fn step(
        &mut self,
        r: &Ranges,
        ring: &RingGeometry,
        alpha: Option<f64>,
        margin_m: f64,
        flat_m: f64,
        omega_max_rad_s: f64,
    ) -> Option<f64> {
        let ahead = |i: usize| r[i].map(|d| projected(i, d, 0.0, ring) - ring.radius_m);
        if let Some((turn, front_at_start)) = self.turn {
            // Open: nothing ahead within a metre beyond where the end wall was.
            let open = ahead(0).is_none_or(|d| d > front_at_start + 1.0);
            let parallel = alpha.is_some_and(|a| a.abs() < 5f64.to_radians());
            if open && parallel {
                self.turn = None;
                return None;
            }
            return Some(turn);
        }
        let (Some(f15), Some(f0), Some(f1)) = (ahead(15), ahead(0), ahead(1)) else {
            return None;
        };
        let (Some((_, left)), Some((_, right))) = (window_min(r, 3..=5), window_min(r, 11..=13)) else {
            return None;
        };
        let flat = f15.max(f0).max(f1) - f15.min(f0).min(f1) <= flat_m;
        // The way back must be open: a dead end is the end of a passage, not a tight spot.
        let behind_open = r[8].is_none_or(|d| d > f0 + 1.0);
        let centred = (left - right).abs() <= 2.0 * margin_m + flat_m;
        // As far ahead as to the sides: nearer, it is an obstacle in a passage, not its end.
        let far = left.max(right);
        let level = f0 <= far + margin_m && f0 >= far - margin_m - flat_m;
        if !flat || !behind_open || !centred || !level {
            return None;
        }
        let turn = if left >= right { omega_max_rad_s } else { -omega_max_rad_s };
        self.turn = Some((turn, f0));
        Some(turn)
    }
}

/// The wall seen on one side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallEstimate {
    /// Distance from the body's edge to the wall, m.
    pub distance_m: f64,
    /// Wall direction relative to the heading, rad (see the module docs).
    pub alpha_rad: f64,
    /// The side sensor with the smallest reading.
    pub nearest: usize,
}

/// The minimum valid reading on `side` and the sensor that gave it.
pub fn side_min(r: &Ranges, side: Side) -> Option<(usize, f64)> {
    window_min(r, side.sensors())
}

/// The minimum valid reading among `sensors` and the sensor that gave it.
pub fn window_min(r: &Ranges, sensors: std::ops::RangeInclusive<usize>) -> Option<(usize, f64)> {
    sensors.filter_map(|i| r.get(i).copied().flatten().map(|d| (i, d))).min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Where the sensors are and how wide they see.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingGeometry {
    /// Distance of the sensor faces from the centre, m.
    pub radius_m: f64,
    /// Half the beam width of each sensor's reading, rad (per sensor: a fused ring mixes
    /// infrared and sonar).
    pub half_beam_rad: [f64; RING_SIZE],
}

impl RingGeometry {
    /// A ring of identical sensors.
    pub fn uniform(radius_m: f64, beam_width_rad: f64) -> Self {
        RingGeometry { radius_m, half_beam_rad: [beam_width_rad / 2.0; RING_SIZE] }
    }
}

/// Estimates the wall on `side` from ring readings.
pub fn wall(
    r: &Ranges,
    side: Side,
    how: AngleEstimator,
    ring: &RingGeometry,
    l_m: f64,
) -> Option<WallEstimate> {
    wall_in(r, side, side.sensors(), how, ring, l_m)
}

/// Estimates the wall on `side` from the nearest reading among `window` (a sub-range of the
/// side's sensors) and its neighbours.
pub fn wall_in(
    r: &Ranges,
    side: Side,
    window: std::ops::RangeInclusive<usize>,
    how: AngleEstimator,
    ring: &RingGeometry,
    l_m: f64,
) -> Option<WallEstimate> {
    let (m, d_min) = window_min(r, window)?;
    let coarse = PI / 8.0 * (m as f64 - side.middle() as f64);
    let fallback = WallEstimate { distance_m: d_min, alpha_rad: coarse, nearest: m };
    let in_side = |i: usize| side.sensors().contains(&i);
    match how {
        AngleEstimator::Original => {
            // Neighbours are read only inside the side (m - 1 or m + 1 may be off the ring).
            let neighbour =
                |i: Option<usize>| i.filter(|&i| in_side(i)).and_then(|i| r.get(i).copied().flatten());
            let fine = match (neighbour(m.checked_sub(1)), neighbour(Some(m + 1))) {
                (Some(a), Some(b)) => ((a - b) / l_m).clamp(-1.0, 1.0).asin(),
                _ => 0.0,
            };
            Some(WallEstimate { distance_m: d_min, alpha_rad: coarse + fine, nearest: m })
        }
        AngleEstimator::LineFit => {
            let before = (m + RING_SIZE - 1) % RING_SIZE;
            let after = (m + 1) % RING_SIZE;
            let echo = |j: usize, toward: f64| {
                let d = r[j]?;
                let axis = ring_angle_rad(j);
                let edge = axis + toward * ring.half_beam_rad[j];
                Some((
                    ring.radius_m * axis.cos() + d * edge.cos(),
                    ring.radius_m * axis.sin() + d * edge.sin(),
                ))
            };
            let (Some(p), Some(q)) = (echo(before, 1.0), echo(after, -1.0)) else { return Some(fallback) };
            let Some((alpha, dist_centre)) = line_fit(&[p, q]) else { return Some(fallback) };
            let d = dist_centre - ring.radius_m;
            // The nearest reading lies on the same wall when the neighbours do: it sees the
            // wall's closest point from a face at most the ring's radius from the centre.
            if (d - d_min).abs() > 0.03 + 0.05 * d_min {
                return Some(fallback);
            }
            Some(WallEstimate { distance_m: d.min(d_min), alpha_rad: alpha, nearest: m })
        }
    }
}

/// The principal line through `pts` (at least two distinct points): its direction folded into
/// (-pi/2, pi/2] and its distance from the origin.
fn line_fit(pts: &[(f64, f64)]) -> Option<(f64, f64)> {
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = pts.iter().fold((0.0, 0.0), |(x, y), p| (x + p.0 / n, y + p.1 / n));
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (x, y) in pts {
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
        sxy += (x - mx) * (y - my);
    }
    if sxx + syy < 1e-12 {
        return None;
    }
    let mut dir = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    if dir > PI / 2.0 {
        dir -= PI;
    } else if dir <= -PI / 2.0 {
        dir += PI;
    }
    // Distance from the origin to the line through (mx, my) with direction dir.
    let dist = (mx * dir.sin() - my * dir.cos()).abs();
    Some((dir, dist))
}

#[cfg(test)]
pub(crate) mod synthetic {
    //! Scans of straight walls computed exactly, for controller tests.
    use super::*;

    /// Ring readings of a robot (sensor ring of radius `r0`) between walls: `left`/`right` are
    /// the distances from the robot's centre to the left/right walls measured perpendicular to
    /// the walls, `theta` the heading relative to the walls (CCW positive), `max` the range.
    pub(crate) fn corridor(left: Option<f64>, right: Option<f64>, theta: f64, r0: f64, max: f64) -> Ranges {
        corridor_beam(left, right, theta, r0, max, 0.0)
    }

    /// The same with beams `2 half_beam` wide: each sensor reports the nearest echo of 41 rays
    /// across its beam, cast from its face on the ring (as the simulator does).
    pub(crate) fn corridor_beam(
        left: Option<f64>,
        right: Option<f64>,
        theta: f64,
        r0: f64,
        max: f64,
        half_beam: f64,
    ) -> Ranges {
        let mut out = [None; RING_SIZE];
        for (i, slot) in out.iter_mut().enumerate() {
            let axis = ring_angle_rad(i) + theta;
            // The face, in the wall frame: y is the signed distance towards the left wall.
            let face_y = r0 * axis.sin();
            let mut best: Option<f64> = None;
            for k in 0..41 {
                let a = axis + half_beam * (f64::from(k) / 20.0 - 1.0);
                let s = a.sin();
                let hit = if s > 1e-9 {
                    left.map(|l| (l - face_y) / s)
                } else if s < -1e-9 {
                    right.map(|rr| (rr + face_y) / -s)
                } else {
                    None
                };
                if let Some(t) = hit.filter(|t| *t >= 0.0) {
                    best = Some(best.map_or(t, |b: f64| b.min(t)));
                }
            }
            *slot = best.filter(|d| *d <= max);
        }
        out
    }

    /// Ring readings in a scene of walls and discs around a robot at the origin heading along
    /// `heading` (rad): each wall is `(normal angle, distance)`, the infinite line at that
    /// distance from the centre across that direction; each disc is `(x, y, radius)`. Beams
    /// `2 half_beam` wide, 41 rays each, as in [`corridor_beam`].
    pub(crate) fn scene(
        walls: &[(f64, f64)],
        discs: &[(f64, f64, f64)],
        heading: f64,
        r0: f64,
        max: f64,
        half_beam: f64,
    ) -> Ranges {
        let mut out = [None; RING_SIZE];
        for (i, slot) in out.iter_mut().enumerate() {
            let axis = ring_angle_rad(i) + heading;
            let face = (r0 * axis.cos(), r0 * axis.sin());
            let mut best = f64::INFINITY;
            for k in 0..41 {
                let a = axis + half_beam * (f64::from(k) / 20.0 - 1.0);
                let u = (a.cos(), a.sin());
                for &(n, c) in walls {
                    let nu = n.cos() * u.0 + n.sin() * u.1;
                    if nu > 1e-9 {
                        let t = (c - (n.cos() * face.0 + n.sin() * face.1)) / nu;
                        if t >= 0.0 {
                            best = best.min(t);
                        }
                    }
                }
                for &(x, y, rad) in discs {
                    let (px, py) = (x - face.0, y - face.1);
                    let along = px * u.0 + py * u.1;
                    let across2 = px * px + py * py - along * along;
                    if along > 0.0 && across2 <= rad * rad {
                        best = best.min(along - (rad * rad - across2).sqrt());
                    }
                }
            }
            *slot = Some(best).filter(|d| *d <= max);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::synthetic::corridor;
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn line_fit_recovers_distance_and_angle_of_a_flat_wall() {
        for theta_deg in [-20.0f64, -8.0, 0.0, 5.0, 15.0] {
            let theta = theta_deg.to_radians();
            let r = corridor(Some(0.45), None, theta, 0.25, 0.6);
            let w = wall(&r, Side::Left, AngleEstimator::LineFit, &RingGeometry::uniform(0.25, 0.0), 0.17)
                .expect("wall seen");
            assert!((w.alpha_rad + theta).abs() < 1e-9, "theta {theta_deg}: alpha {}", w.alpha_rad);
            assert!((w.distance_m - 0.20).abs() < 1e-9, "theta {theta_deg}: d {}", w.distance_m);
        }
    }

    #[test]
    fn line_fit_is_exact_with_wide_beams_and_steep_angles() {
        // 25 degree sonar beams, and a robot turned up to 65 degrees into the wall.
        for (half_beam_deg, theta_deg) in
            [(12.5f64, 0.0f64), (12.5, 8.0), (12.5, -15.0), (3.0, 40.0), (3.0, 65.0)]
        {
            let (hb, theta) = (half_beam_deg.to_radians(), theta_deg.to_radians());
            let r = super::synthetic::corridor_beam(Some(0.25 + 0.9), None, theta, 0.25, 6.0, hb);
            let ring = RingGeometry::uniform(0.25, 2.0 * hb);
            let w = wall(&r, Side::Left, AngleEstimator::LineFit, &ring, 0.17).expect("wall");
            assert!(
                (w.alpha_rad + theta).abs() < 0.01,
                "beam {half_beam_deg}, theta {theta_deg}: alpha {}",
                w.alpha_rad
            );
            assert!(
                (w.distance_m - 0.9).abs() < 0.01,
                "beam {half_beam_deg}, theta {theta_deg}: d {}",
                w.distance_m
            );
        }
    }

    #[test]
    fn original_estimator_has_the_right_sign_and_is_exact_when_parallel() {
        let r = corridor(Some(0.45), None, 0.0, 0.25, 0.6);
        let w = wall(&r, Side::Left, AngleEstimator::Original, &RingGeometry::uniform(0.25, 0.0), 0.17)
            .expect("wall");
        assert_eq!(w.nearest, 4);
        assert!(w.alpha_rad.abs() < 1e-12 && (w.distance_m - 0.20).abs() < 1e-12);
        // Heading into the left wall: alpha < 0. Into the right wall: alpha > 0.
        let r = corridor(Some(0.45), None, 0.15, 0.25, 0.6);
        assert!(
            wall(&r, Side::Left, AngleEstimator::Original, &RingGeometry::uniform(0.25, 0.0), 0.17)
                .expect("wall")
                .alpha_rad
                < -0.05
        );
        let r = corridor(None, Some(0.45), -0.15, 0.25, 0.6);
        assert!(
            wall(&r, Side::Right, AngleEstimator::Original, &RingGeometry::uniform(0.25, 0.0), 0.17)
                .expect("wall")
                .alpha_rad
                > 0.05
        );
    }

    #[test]
    fn original_estimator_survives_its_fragile_cases() {
        // Only the end sensor of the side sees anything: no neighbour inside the side.
        let mut r = [None; RING_SIZE];
        r[7] = Some(0.3);
        r[8] = Some(0.2);
        let w = wall(&r, Side::Left, AngleEstimator::Original, &RingGeometry::uniform(0.25, 0.0), 0.17)
            .expect("wall");
        assert!((w.alpha_rad - 3.0 * PI / 8.0).abs() < 1e-12, "coarse only: {}", w.alpha_rad);
        // Neighbours so different that the asin argument leaves [-1, 1].
        let mut r = [None; RING_SIZE];
        r[3] = Some(0.05);
        r[4] = Some(0.04);
        r[5] = Some(0.59);
        let w = wall(&r, Side::Left, AngleEstimator::Original, &RingGeometry::uniform(0.25, 0.0), 0.17)
            .expect("wall");
        assert!((w.alpha_rad + PI / 2.0).abs() < 1e-12 && w.alpha_rad.is_finite());
        assert!(
            wall(
                &[None; RING_SIZE],
                Side::Left,
                AngleEstimator::Original,
                &RingGeometry::uniform(0.25, 0.0),
                0.17
            )
            .is_none()
        );
    }

    #[test]
    fn original_estimator_is_safe_at_the_right_sides_last_sensor() {
        let mut r = [None; RING_SIZE];
        r[15] = Some(0.2);
        r[14] = Some(0.3);
        r[0] = Some(0.25);
        let w = wall(&r, Side::Right, AngleEstimator::Original, &RingGeometry::uniform(0.25, 0.0), 0.17)
            .expect("wall");
        assert_eq!(w.nearest, 15);
        assert!((w.alpha_rad - 3.0 * PI / 8.0).abs() < 1e-12, "coarse only: {}", w.alpha_rad);
    }

    #[test]
    fn a_wedged_robot_keeps_turning_one_way_until_the_front_is_open() {
        let mut w = Wedge::default();
        let mut r = [None; RING_SIZE];
        r[4] = Some(0.05);
        r[12] = Some(0.02);
        r[1] = Some(0.10);
        r[15] = Some(0.20);
        // Wedged; the right diagonal is more open: turn right.
        assert_eq!(w.step(&r, 0.15, 0.3, 0.8), Some(-0.8));
        // The diagonals swap as it turns: it keeps turning right, it does not rock back.
        r[1] = Some(0.25);
        r[15] = Some(0.05);
        assert_eq!(w.step(&r, 0.15, 0.3, 0.8), Some(-0.8));
        // Front open: free again.
        for i in [14, 15, 0, 1, 2] {
            r[i] = None;
        }
        assert_eq!(w.step(&r, 0.15, 0.3, 0.8), None);
        // Sides wide apart: not wedged, whatever is ahead.
        let mut r = [None; RING_SIZE];
        r[4] = Some(0.5);
        r[12] = Some(0.5);
        r[0] = Some(0.1);
        assert_eq!(Wedge::default().step(&r, 0.15, 0.3, 0.8), None);
    }

    #[test]
    fn fusion_takes_infrared_up_close_and_sonar_beyond() {
        let mut ir = [None; RING_SIZE];
        let mut so = [None; RING_SIZE];
        ir[1] = Some(0.3);
        so[1] = Some(0.35);
        ir[2] = Some(0.65);
        so[2] = Some(0.66);
        so[3] = Some(2.0);
        let (f, beams) = fuse(&ir, &so, 0.6, 0.05, 0.2);
        assert_eq!((f[1], f[2], f[3], f[4]), (Some(0.3), Some(0.66), Some(2.0), None));
        assert_eq!((beams[1], beams[2]), (0.05, 0.2));
    }

    /// A dead end 1.2 m wide each side of a robot heading along +x, its end wall `end` m ahead
    /// of the centre; 25 degree sonar beams.
    fn dead_end_view(end: f64, heading: f64, discs: &[(f64, f64, f64)]) -> (Ranges, RingGeometry) {
        let hb = 12.5f64.to_radians();
        let walls = [(FRAC_PI_2, 1.2), (-FRAC_PI_2, 1.2), (0.0, end)];
        // The scene is given in the corridor's frame; turning the robot turns it the other way.
        let walls: Vec<_> = walls.iter().map(|&(n, c)| (n - heading, c)).collect();
        let discs: Vec<_> = discs
            .iter()
            .map(|&(x, y, r)| {
                (x * heading.cos() + y * heading.sin(), y * heading.cos() - x * heading.sin(), r)
            })
            .collect();
        (super::synthetic::scene(&walls, &discs, 0.0, 0.25, 6.0, hb), RingGeometry::uniform(0.25, 2.0 * hb))
    }

    #[test]
    fn projected_readings_of_a_flat_wall_agree() {
        let (r, ring) = dead_end_view(1.2, 0.0, &[]);
        for i in [15, 0, 1] {
            let p = projected(i, r[i].expect("in range"), 0.0, &ring);
            assert!((p - 1.2).abs() < 0.01, "sensor {i}: {p}");
        }
    }

    #[test]
    fn a_dead_end_turns_the_robot_round_where_the_end_is_as_far_as_the_sides() {
        let w = 45f64.to_radians();
        let mut d = DeadEnd::default();
        let (far, ring) = dead_end_view(2.0, 0.0, &[]);
        assert_eq!(d.step(&far, &ring, Some(0.0), 0.05, 0.10, w), None, "the end is still far");
        let (near, ring) = dead_end_view(1.22, 0.0, &[]);
        let turn = d.step(&near, &ring, Some(0.0), 0.05, 0.10, w).expect("turns round here");
        assert_eq!(turn.abs(), w);
        // Half way round the end wall is beside it: it keeps turning the same way.
        let (side, ring) = dead_end_view(1.22, FRAC_PI_2, &[]);
        assert_eq!(d.step(&side, &ring, Some(0.4), 0.05, 0.10, w), Some(turn));
        // Round, but not yet parallel to the walls: still turning.
        let (round, ring) = dead_end_view(1.22, PI, &[]);
        assert_eq!(d.step(&round, &ring, Some(0.2), 0.05, 0.10, w), Some(turn));
        // Round and parallel: done, and the wall now behind does not start it again.
        assert_eq!(d.step(&round, &ring, Some(0.01), 0.05, 0.10, w), None);
        assert_eq!(d.step(&round, &ring, Some(0.01), 0.05, 0.10, w), None);
    }

    #[test]
    fn a_person_ahead_or_behind_is_not_a_dead_end() {
        let w = 45f64.to_radians();
        // A corridor with no end, a person straight ahead at 1.2 m from the centre.
        let (r, ring) = dead_end_view(40.0, 0.0, &[(1.45, 0.0, 0.25)]);
        assert!(r[0].is_some_and(|d| d < 1.0), "the person is seen: {:?}", r[0]);
        assert_eq!(DeadEnd::default().step(&r, &ring, Some(0.0), 0.05, 0.10, w), None);
        // A real dead end with somebody close behind: no room to have come from, no turn.
        let (r, ring) = dead_end_view(1.22, 0.0, &[(-0.9, 0.0, 0.25)]);
        assert_eq!(DeadEnd::default().step(&r, &ring, Some(0.0), 0.05, 0.10, w), None);
        // The end seen off the centre line: not the turning spot.
        let hb = 12.5f64.to_radians();
        let walls = [(FRAC_PI_2, 0.7), (-FRAC_PI_2, 1.7), (0.0, 1.22)];
        let r = super::synthetic::scene(&walls, &[], 0.0, 0.25, 6.0, hb);
        assert_eq!(
            DeadEnd::default().step(&r, &RingGeometry::uniform(0.25, 2.0 * hb), Some(0.0), 0.05, 0.10, w),
            None
        );
    }

    const S: u64 = 1_000_000_000;

    #[test]
    fn a_robot_that_stopped_making_progress_backs_out_and_turns_to_the_open_side() {
        let p = UnstickParams::default();
        let w = 45f64.to_radians();
        let mut u = Unstick::default();
        // Blocked all round but behind (sensors 7-9), and a gap (sensor 4) beside a person.
        let mut r: Ranges = [Some(0.3); RING_SIZE];
        r[4] = None;
        r[6] = Some(2.0);
        r[7..=9].fill(Some(3.0));
        u.note_position(&p, 1.0, 1.0, 0);
        // Creeping 1 cm a second is no progress.
        for k in 0..5 {
            u.note_position(&p, 1.0 + 0.01 * k as f64, 1.0, k * S);
            assert_eq!(u.step(&p, &r, w, k * S), None, "{k} s: still its own command");
        }
        // Five seconds without 5 cm: back out, straight.
        assert_eq!(u.step(&p, &r, w, 5 * S), Some((-0.10, 0.0)));
        assert_eq!(u.step(&p, &r, w, 6 * S), Some((-0.10, 0.0)));
        // After 1.5 s, turn toward the widest opening (sensor 8, half a turn, not the farther
        // but narrow gap of sensor 4; left first among equals) for pi/w + 0.5 s.
        let (v, omega) = u.step(&p, &r, w, 6 * S + S / 2).expect("turning");
        assert_eq!((v, omega), (0.0, w));
        let turn_ns = ((PI / w + 0.5) * 1e9) as u64;
        assert_eq!(u.step(&p, &r, w, 6 * S + S / 2 + turn_ns - 1), Some((0.0, w)));
        assert_eq!(u.step(&p, &r, w, 6 * S + S / 2 + turn_ns), None, "done: drives on");
        // And watches afresh from there.
        assert_eq!(u.step(&p, &r, w, 10 * S + turn_ns), None);
    }

    #[test]
    fn progress_keeps_it_quiet_and_a_blocked_back_skips_the_backing() {
        let p = UnstickParams::default();
        let w = 45f64.to_radians();
        let mut u = Unstick::default();
        let mut r: Ranges = [None; RING_SIZE];
        for k in 0..60 {
            u.note_position(&p, 0.1 * k as f64, 0.0, k * S);
            assert_eq!(u.step(&p, &r, w, k * S), None, "moving: never");
        }
        // Stuck with somebody right behind (sensor 7) and the right side open (sensors 11-13).
        r = [Some(0.3); RING_SIZE];
        r[7] = Some(0.1);
        r[11..=13].fill(Some(2.0));
        let mut u = Unstick::default();
        u.note_position(&p, 0.0, 0.0, 0);
        assert_eq!(u.step(&p, &r, w, 5 * S), Some((0.0, -w)), "no backing into the person: turn right");
        // Disabled: nothing, ever.
        let off = UnstickParams { enabled: false, ..p };
        let mut u = Unstick::default();
        u.note_position(&off, 0.0, 0.0, 0);
        assert_eq!(u.step(&off, &r, w, 100 * S), None);
        assert!(
            UnstickParams { back_s: 0.0, ..p }.validate("centerfollow").is_err_and(|e| e.contains("back_s"))
        );
    }
}
