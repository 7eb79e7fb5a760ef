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

use orsa_interfaces::nomad200::{DistanceScan, RING_SIZE, ring_angle_rad};
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
pub(crate) fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI { w - 2.0 * PI } else { w }
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
    /// Whether the angle comes from a flat wall seen by the nearest sensor's neighbours
    /// (otherwise it is the coarse `pi/8 (m - c)`).
    pub fitted: bool,
}

impl WallEstimate {
    /// The estimate with its angle folded into (-pi/2, pi/2], as the wall's line gives it
    /// without regard to the side: the smaller turn to parallel either way, for a behaviour to
    /// which both directions along a wall are the same (center following).
    pub fn as_line(self) -> Self {
        WallEstimate { alpha_rad: fold_line(wrap(self.alpha_rad)), ..self }
    }
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
    let fallback = WallEstimate { distance_m: d_min, alpha_rad: coarse, nearest: m, fitted: false };
    let in_side = |i: usize| side.sensors().contains(&i);
    match how {
        AngleEstimator::Original => {
            // Neighbours are read only inside the side (m - 1 or m + 1 may be off the ring).
            let neighbour =
                |i: Option<usize>| i.filter(|&i| in_side(i)).and_then(|i| r.get(i).copied().flatten());
            let fine = match (neighbour(m.checked_sub(1)), neighbour(Some(m + 1))) {
                (Some(a), Some(b)) => Some(((a - b) / l_m).clamp(-1.0, 1.0).asin()),
                _ => None,
            };
            Some(WallEstimate {
                distance_m: d_min,
                alpha_rad: coarse + fine.unwrap_or(0.0),
                nearest: m,
                fitted: fine.is_some(),
            })
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
            let Some((dir, dist_centre)) = line_fit(&[p, q]) else { return Some(fallback) };
            let alpha = side_angle(dir, p, side);
            let d = dist_centre - ring.radius_m;
            // The nearest reading lies on the same wall when the neighbours do: it sees the
            // wall's closest point from a face at most the ring's radius from the centre, and
            // its echo, placed on the beam edge nearest the wall's normal, is on the line. (Two
            // neighbours can see different surfaces whose line happens to pass at the right
            // distance: the wall ahead and the back of a door recess beside it gave a line
            // 160 degrees off, and wall following turned into the wall.)
            let tolerance = 0.03 + 0.05 * d_min;
            let normal = match side {
                Side::Left => alpha + PI / 2.0,
                Side::Right => alpha - PI / 2.0,
            };
            if (d - d_min).abs() > tolerance
                || (projected(m, d_min, normal, ring) - dist_centre).abs() > tolerance
            {
                return Some(fallback);
            }
            Some(WallEstimate { distance_m: d.min(d_min), alpha_rad: alpha, nearest: m, fitted: true })
        }
    }
}

/// The wall angle (see the module docs) of a line with direction `dir` through `point`, for a
/// wall on `side`. A line's direction alone is ambiguous by half a turn, and folding it into
/// (-pi/2, pi/2] flips its sign where the wall is square to the heading: a wall ahead would
/// read now as "heading into it" (turn away), now as "heading away from it" (turn toward it),
/// and a behaviour flips between the two from one scan to the next. The side resolves it:
/// the perpendicular from the robot's centre meets a wall on the left at `phi = alpha + pi/2`
/// (on the right at `alpha - pi/2`), so `alpha` is taken from that foot's direction. A wall
/// ahead then reads as a little past or short of `-pi/2` on the left (turn right, keeping it
/// on the left) and of `+pi/2` on the right, continuously.
fn side_angle(dir: f64, point: (f64, f64), side: Side) -> f64 {
    let (ux, uy) = (dir.cos(), dir.sin());
    let along = point.0 * ux + point.1 * uy;
    let foot = (point.0 - along * ux, point.1 - along * uy);
    if foot.0.hypot(foot.1) < 1e-9 {
        return dir;
    }
    let phi = foot.1.atan2(foot.0);
    match side {
        Side::Left => wrap(phi - PI / 2.0),
        Side::Right => wrap(phi + PI / 2.0),
    }
}

/// An angle in [-pi, pi] folded into (-pi/2, pi/2], as a line's direction.
fn fold_line(a: f64) -> f64 {
    if a > PI / 2.0 {
        a - PI
    } else if a <= -PI / 2.0 {
        a + PI
    } else {
        a
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
    let dir = fold_line(0.5 * (2.0 * sxy).atan2(sxx - syy));
    // Distance from the origin to the line through (mx, my) with direction dir.
    let dist = (mx * dir.sin() - my * dir.cos()).abs();
    Some((dir, dist))
}

#[cfg(test)]
pub(crate) mod synthetic {
    //! Scans of straight walls computed exactly, for controller tests.
    use super::*;
    use std::f64::consts::FRAC_PI_2;

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
        let walls: Vec<_> = [(FRAC_PI_2, left), (-FRAC_PI_2, right)]
            .into_iter()
            .filter_map(|(n, d)| d.map(|d| (n, d)))
            .collect();
        scene(&walls, &[], theta, r0, max, half_beam)
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

    /// A corridor 2.4 m wide closed by an end wall `end` m ahead of the robot, which heads along
    /// `heading` (rad, 0: toward the end), with discs `(x, y, radius)` in the corridor's frame;
    /// 25 degree sonar beams, and the ring that reads them.
    pub(crate) fn dead_end(end: f64, heading: f64, discs: &[(f64, f64, f64)]) -> (Ranges, RingGeometry) {
        let hb = 12.5f64.to_radians();
        let walls = [(FRAC_PI_2, 1.2), (-FRAC_PI_2, 1.2), (0.0, end)];
        (scene(&walls, discs, heading, 0.25, 6.0, hb), RingGeometry::uniform(0.25, 2.0 * hb))
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
    fn a_wall_square_ahead_reads_continuously_as_heading_into_it() {
        // Turned 80 to 90 degrees into the left wall: a line's direction alone, folded into
        // (-90, 90], flips from -89.5 to +90 degrees; the side keeps it -80 .. -90 (turn right,
        // wall on the left). Past 90 the wall's nearest point is in sensor 0's sector, outside
        // the side: wall following reads sensor 0 as a wall ahead then.
        let ring = RingGeometry::uniform(0.25, 0.0);
        for theta_deg in [80.0f64, 86.0, 89.0, 89.5, 90.0] {
            let theta = theta_deg.to_radians();
            let r = corridor(Some(0.25 + 0.35), None, theta, 0.25, 0.8);
            let w = wall(&r, Side::Left, AngleEstimator::LineFit, &ring, 0.17).expect("wall");
            assert!(w.fitted, "theta {theta_deg}");
            assert!(
                (w.alpha_rad + theta).abs() < 1e-6,
                "theta {theta_deg}: alpha {}",
                w.alpha_rad.to_degrees()
            );
            // The same wall as a line: the smaller turn to parallel.
            let folded = w.as_line().alpha_rad;
            assert!(folded > -FRAC_PI_2 && folded <= FRAC_PI_2);
            assert!((wrap(folded - w.alpha_rad).abs() % PI) < 1e-9, "a line's direction: {folded}");
            // Mirrored: turned into the right wall reads as +theta.
            let r = corridor(None, Some(0.25 + 0.35), -theta, 0.25, 0.8);
            let w = wall(&r, Side::Right, AngleEstimator::LineFit, &ring, 0.17).expect("wall");
            assert!(
                (w.alpha_rad - theta).abs() < 1e-6,
                "right, theta {theta_deg}: {}",
                w.alpha_rad.to_degrees()
            );
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

    #[test]
    fn projected_readings_of_a_flat_wall_agree() {
        let (r, ring) = super::synthetic::dead_end(1.2, 0.0, &[]);
        for i in [15, 0, 1] {
            let p = projected(i, r[i].expect("in range"), 0.0, &ring);
            assert!((p - 1.2).abs() < 0.01, "sensor {i}: {p}");
        }
    }
}
