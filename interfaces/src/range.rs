//! Any robot's range sensors and drive, described rather than assumed.
//!
//! A robot kind says what it carries in its [`RobotParams`](crate::nomad200::RobotParams): its
//! [`DriveKind`] and a list of [`RangeSensorParams`], one per sensor, each with its mount in the
//! body frame (x ahead, y left, angles counter-clockwise from the front), the direction of every
//! beam, its field of view and its range. A ring of N sensors on the body's edge (the Nomad
//! 200's sonar and infrared) and a planar laser of M beams from one mount point ahead of the
//! centre are two layouts of the same description, so what reads range data (the behaviours'
//! sector views today, a map and a localizer tomorrow) turns any of them into points in the body
//! frame with [`RangeSensorParams::hit_point`] and never counts sensors itself.
//!
//! [`project_onto_ring`] is the one place where points become the 16-sector ring view the wall
//! and centre controllers reason on: the nearest point whose bearing from the centre falls
//! within each sector, as its distance from the sector's face.

use crate::nomad200::{RING_SIZE, RingParams};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

/// How the base moves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveKind {
    /// Three wheels steered together, the sensors on a turret that turns with them (the Nomad
    /// 200): it translates along its heading and turns in place.
    #[default]
    Synchro,
    /// Two driven wheels on one axle: the same (v, omega) motion, the sensors fixed to the body,
    /// and one wheel-speed limit shared by translation and turning.
    Differential,
}

/// How a range sensor's beams are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RangeLayout {
    /// N sensors on a circle of `mount_radius_m` around the mount point, each facing outwards
    /// along its beam; a reading is measured from the sensor's face.
    Ring,
    /// M beams fanned out from the mount point; a reading is measured from that point.
    Laser,
}

/// One range sensor of a robot (a ring or a planar laser), in the body frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RangeSensorParams {
    /// The sensor's name (`sonar`, `infrared`, `laser`).
    pub name: String,
    /// Ring or laser.
    pub layout: RangeLayout,
    /// The mount point, m ahead of the body's centre.
    pub x_m: f64,
    /// The mount point, m left of the body's centre.
    pub y_m: f64,
    /// Distance from the mount point to each beam's origin, m (a ring's radius; 0 for a laser).
    pub mount_radius_m: f64,
    /// Beam `j` points `angles_rad[j]` counter-clockwise from the body's front.
    pub angles_rad: Vec<f64>,
    /// Full width of one beam, rad.
    pub beam_width_rad: f64,
    /// Shortest valid reading, m.
    pub min_range_m: f64,
    /// Longest valid reading, m.
    pub max_range_m: f64,
    /// Time a full scan takes (every beam once), s.
    pub period_s: f64,
}

impl RangeSensorParams {
    /// A ring as the Nomad 200 carries one, centred on the body, described by `ring`.
    pub fn ring(name: &str, ring: &RingParams) -> Self {
        RangeSensorParams {
            name: name.to_owned(),
            layout: RangeLayout::Ring,
            x_m: 0.0,
            y_m: 0.0,
            mount_radius_m: ring.mount_radius_m,
            angles_rad: ring.angles_rad.clone(),
            beam_width_rad: ring.beam_width_rad,
            min_range_m: ring.min_range_m,
            max_range_m: ring.max_range_m,
            period_s: ring.fire_period_s * ring.angles_rad.len() as f64,
        }
    }

    /// A planar laser `x_m` ahead of the centre, facing forward, of `beams` beams spread evenly
    /// over `fov_rad` (centred on the front; one beam alone looks straight ahead).
    pub fn laser(
        name: &str,
        x_m: f64,
        fov_rad: f64,
        beams: usize,
        range_m: (f64, f64),
        period_s: f64,
    ) -> Self {
        let step = if beams > 1 { fov_rad / (beams - 1) as f64 } else { 0.0 };
        RangeSensorParams {
            name: name.to_owned(),
            layout: RangeLayout::Laser,
            x_m,
            y_m: 0.0,
            mount_radius_m: 0.0,
            angles_rad: (0..beams).map(|j| -fov_rad / 2.0 + step * j as f64).collect(),
            beam_width_rad: step,
            min_range_m: range_m.0,
            max_range_m: range_m.1,
            period_s,
        }
    }

    /// Where beam `j` starts, in the body frame.
    pub fn beam_origin(&self, j: usize) -> Option<(f64, f64)> {
        let a = *self.angles_rad.get(j)?;
        Some((self.x_m + self.mount_radius_m * a.cos(), self.y_m + self.mount_radius_m * a.sin()))
    }

    /// The point in the body frame where beam `j` met something `range_m` from its origin.
    pub fn hit_point(&self, j: usize, range_m: f64) -> Option<(f64, f64)> {
        let a = *self.angles_rad.get(j)?;
        let (x, y) = self.beam_origin(j)?;
        Some((x + range_m * a.cos(), y + range_m * a.sin()))
    }

    /// Whether `range_m` is a reading this sensor reports as valid.
    pub fn in_range(&self, range_m: f64) -> bool {
        range_m.is_finite() && range_m >= self.min_range_m && range_m <= self.max_range_m
    }

    /// Why this description cannot be used, if it cannot; `key` prefixes the names.
    pub fn check(&self, key: &str) -> Result<(), RangeSensorError> {
        let bad =
            |field: &str, problem: String| Err(RangeSensorError { key: format!("{key}.{field}"), problem });
        if self.angles_rad.is_empty() {
            return bad("angles_rad", "a sensor needs at least one beam".into());
        }
        if let Some(a) = self.angles_rad.iter().find(|a| !a.is_finite()) {
            return bad("angles_rad", format!("every angle must be finite, got {a}"));
        }
        for (field, v) in [("x_m", self.x_m), ("y_m", self.y_m), ("mount_radius_m", self.mount_radius_m)] {
            if !v.is_finite() {
                return bad(field, format!("must be finite, got {v}"));
            }
        }
        if !(self.beam_width_rad.is_finite() && self.beam_width_rad >= 0.0) {
            return bad("beam_width_rad", format!("must be finite and >= 0, got {}", self.beam_width_rad));
        }
        if !(self.min_range_m.is_finite() && self.min_range_m >= 0.0) {
            return bad("min_range_m", format!("must be finite and >= 0, got {}", self.min_range_m));
        }
        if !(self.max_range_m.is_finite() && self.max_range_m > self.min_range_m) {
            return bad(
                "max_range_m",
                format!("must be finite and above min_range_m, got {}", self.max_range_m),
            );
        }
        if !(self.period_s.is_finite() && self.period_s >= 0.0) {
            return bad("period_s", format!("must be finite and >= 0, got {}", self.period_s));
        }
        Ok(())
    }
}

/// A range sensor description that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {problem}")]
pub struct RangeSensorError {
    /// The offending field, like `range_sensors[0].max_range_m`.
    pub key: String,
    /// What is wrong with it.
    pub problem: String,
}

/// The nearest of `points` (body frame) in each sector of `ring`, as its distance from the
/// sector's face: sector `i` takes the points whose bearing from the body's centre lies within
/// half its beam of `ring.angles_rad[i]`, and reads `|p| - mount_radius_m`. `None` where no point
/// falls. Validity against the ring's range is the caller's to judge.
pub fn project_onto_ring(
    points: impl IntoIterator<Item = (f64, f64)>,
    ring: &RingParams,
) -> [Option<f64>; RING_SIZE] {
    let mut out = [None::<f64>; RING_SIZE];
    let half = ring.beam_width_rad / 2.0;
    for (x, y) in points {
        let bearing = y.atan2(x);
        let d = x.hypot(y) - ring.mount_radius_m;
        for (slot, axis) in out.iter_mut().zip(&ring.angles_rad) {
            let off = (bearing - axis + PI).rem_euclid(TAU) - PI;
            if off.abs() <= half && slot.is_none_or(|s| d < s) {
                *slot = Some(d);
            }
        }
    }
    out
}

/// Which sectors of `ring` the robot's `sensors` can see at all: sector `i` is covered when a
/// beam of some sensor, at the middle of the sector's range (from its face), falls within the
/// sector's width as seen from the body's centre. A sector that no beam covers reads "nothing"
/// however close something is: behind a 270 degree laser, for one, so a manoeuvre must not take
/// it for open space. With no sensor described (objects from before robots were described, a
/// ROS 2 base whose laser is known only from its scans) every sector counts as covered.
pub fn sector_coverage(sensors: &[RangeSensorParams], ring: &RingParams) -> [bool; RING_SIZE] {
    if sensors.is_empty() {
        return [true; RING_SIZE];
    }
    let half = ring.beam_width_rad / 2.0;
    let reach = ring.mount_radius_m + (ring.min_range_m + ring.max_range_m.min(1e3)) / 2.0;
    let mut out = [false; RING_SIZE];
    for (slot, axis) in out.iter_mut().zip(&ring.angles_rad) {
        *slot = sensors.iter().any(|s| {
            (0..s.angles_rad.len()).any(|j| {
                // The beam's point `reach` from the centre, if it gets that far.
                let Some((ox, oy)) = s.beam_origin(j) else { return false };
                let (dx, dy) = (s.angles_rad[j].cos(), s.angles_rad[j].sin());
                // |o + t d| = reach, t >= 0.
                let b = ox * dx + oy * dy;
                let c = ox * ox + oy * oy - reach * reach;
                let disc = b * b - c;
                if disc < 0.0 {
                    return false;
                }
                let t = -b + disc.sqrt();
                if t < 0.0 {
                    return false;
                }
                let (x, y) = (ox + t * dx, oy + t * dy);
                let off = (y.atan2(x) - axis + PI).rem_euclid(TAU) - PI;
                off.abs() <= half
            })
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nomad200::ring_angle_rad;

    fn ring(radius: f64, width_deg: f64) -> RingParams {
        RingParams {
            angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
            mount_radius_m: radius,
            beam_width_rad: width_deg.to_radians(),
            min_range_m: 0.0,
            max_range_m: 6.0,
            fire_period_s: 0.0025,
        }
    }

    /// A laser's beams fan out from its mount; a ring's start on the ring, facing out.
    #[test]
    fn hit_points_start_where_the_beams_do() {
        let laser = RangeSensorParams::laser("laser", 0.1, 270f64.to_radians(), 271, (0.05, 10.0), 0.1);
        assert_eq!(laser.angles_rad.len(), 271);
        assert!((laser.angles_rad[0] + 135f64.to_radians()).abs() < 1e-12);
        assert!((laser.angles_rad[135]).abs() < 1e-12, "beam 135 looks ahead");
        assert!((laser.beam_width_rad - 1f64.to_radians()).abs() < 1e-12);
        let (x, y) = laser.hit_point(135, 2.0).expect("beam");
        assert!((x - 2.1).abs() < 1e-12 && y.abs() < 1e-12);
        let (x, y) = laser.hit_point(225, 1.0).expect("beam 225 looks left");
        assert!((x - 0.1).abs() < 1e-9 && (y - 1.0).abs() < 1e-9, "{x} {y}");
        assert_eq!(laser.hit_point(271, 1.0), None);
        let sonar = RangeSensorParams::ring("sonar", &ring(0.25, 25.0));
        assert!((sonar.period_s - 0.04).abs() < 1e-12);
        let (x, y) = sonar.hit_point(4, 0.5).expect("sensor 4 faces left");
        assert!(x.abs() < 1e-12 && (y - 0.75).abs() < 1e-12);
        laser.check("laser").expect("valid");
        let bad = RangeSensorParams { max_range_m: 0.01, ..laser };
        assert_eq!(bad.check("robot.laser").expect_err("max below min").key, "robot.laser.max_range_m");
    }

    /// A wall 0.8 m to the left of a laser 0.1 m ahead of the centre shows 0.45 m from a ring
    /// of radius 0.35 in the left sector, and nothing in the sectors that see no point.
    #[test]
    fn a_laser_projects_onto_the_sectors_that_see_its_points() {
        let laser = RangeSensorParams::laser("laser", 0.1, 270f64.to_radians(), 271, (0.05, 10.0), 0.1);
        let points = (0..271).filter_map(|j| {
            let a = laser.angles_rad[j];
            (a.sin() > 1e-9).then(|| laser.hit_point(j, 0.8 / a.sin())).flatten()
        });
        let sectors = project_onto_ring(points, &ring(0.35, 6.0));
        let left = sectors[4].expect("the left sector sees the wall");
        assert!((left - 0.45).abs() < 2e-3, "{left}");
        assert_eq!(sectors[12], None, "nothing to the right");
        assert_eq!(sectors[8], None, "the laser does not see behind");
        // The nearest point wins where several fall in one sector.
        let two = project_onto_ring([(1.0, 0.0), (0.6, 0.0), (0.0, 2.0)], &ring(0.25, 6.0));
        assert_eq!(two[0], Some(0.35));
        assert_eq!(two[4], Some(1.75));
    }

    /// A ring covers itself; a 270 degree laser leaves the sectors behind it blind.
    #[test]
    fn coverage_follows_the_beams() {
        let sonar = ring(0.25, 25.0);
        assert_eq!(sector_coverage(&[RangeSensorParams::ring("sonar", &sonar)], &sonar), [true; RING_SIZE]);
        assert_eq!(sector_coverage(&[], &sonar), [true; RING_SIZE], "nothing described: assume seen");
        let laser = RangeSensorParams::laser("laser", 0.1, 270f64.to_radians(), 271, (0.05, 10.0), 0.1);
        let wide = sector_coverage(std::slice::from_ref(&laser), &ring(0.35, 22.5));
        let blind: Vec<usize> = (0..RING_SIZE).filter(|&i| !wide[i]).collect();
        assert_eq!(blind, vec![7, 8, 9], "the laser sees 135 degrees either side");
        let near = RingParams { max_range_m: 0.6, ..ring(0.35, 6.0) };
        let narrow = sector_coverage(&[laser], &near);
        assert!(!narrow[6] && !narrow[10], "from 0.1 m ahead, 135 degrees is not seen near the body");
        assert!(narrow[5] && narrow[11] && narrow[0]);
    }
}
