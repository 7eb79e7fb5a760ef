//! Odometry: the pose the encoders integrate, with drift, reported at the board's resolution.
//!
//! It integrates the motors' motion, not the body's: when the robot is blocked its wheels slip
//! and odometry keeps counting, so it drifts from the truth. Systematic errors (see
//! [`OdometryConfig`]) make it drift even when nothing blocks. The internal sums are kept
//! unrounded; only what is reported is rounded, so rounding never accumulates.

use crate::board::{AxisVelocities, MotorState};
use crate::sim::config::OdometryConfig;
use orsa_actors::Timestamp;
use std::f64::consts::{PI, TAU};

/// `a` wrapped into (-pi, pi].
pub(crate) fn wrap_angle(a: f64) -> f64 {
    let w = a.rem_euclid(TAU);
    if w > PI { w - TAU } else { w }
}

/// `v` rounded to a multiple of `resolution` (unchanged when the resolution is 0).
fn quantise(v: f64, resolution: f64) -> f64 {
    if resolution > 0.0 { (v / resolution).round() * resolution } else { v }
}

/// The encoders' running sums.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Odometry {
    x: f64,
    y: f64,
    heading: f64,
    steer: f64,
    turret: f64,
    resolution_m: f64,
    resolution_rad: f64,
    distance_error: f64,
    heading_error: f64,
    heading_error_per_m: f64,
    /// The wheels and sensors are fixed to the base (a differential drive): the steering and
    /// turret encoders, relative to the base, stay at zero while the heading turns.
    fixed_to_base: bool,
}

impl Odometry {
    pub(crate) fn new(c: &OdometryConfig, fixed_to_base: bool) -> Self {
        Odometry {
            fixed_to_base,
            x: 0.0,
            y: 0.0,
            heading: 0.0,
            steer: 0.0,
            turret: 0.0,
            resolution_m: c.resolution_m,
            resolution_rad: c.resolution_deg.to_radians(),
            distance_error: c.distance_error,
            heading_error: c.heading_error,
            heading_error_per_m: c.heading_error_deg_per_m.to_radians(),
        }
    }

    /// Counts one step of motor motion: translation `ds` (m), steering and turret turns (rad).
    pub(crate) fn integrate(&mut self, ds: f64, dsteer: f64, dturret: f64) {
        let counted_ds = ds * (1.0 + self.distance_error);
        let dheading = dsteer * (1.0 + self.heading_error) + self.heading_error_per_m * ds.abs();
        let mid = self.heading + 0.5 * dheading;
        self.x += counted_ds * mid.cos();
        self.y += counted_ds * mid.sin();
        self.heading += dheading;
        if !self.fixed_to_base {
            self.steer += dsteer;
            self.turret += dturret;
        }
    }

    /// Makes the current pose the origin.
    pub(crate) fn zero(&mut self) {
        self.x = 0.0;
        self.y = 0.0;
        self.heading = 0.0;
        self.steer = 0.0;
        self.turret = 0.0;
    }

    /// The state as the board reports it, rounded to its resolution.
    pub(crate) fn report(&self, stamp: Timestamp, v: AxisVelocities, stopped: bool) -> MotorState {
        let (m, r) = (self.resolution_m, self.resolution_rad);
        let angle = |a: f64| wrap_angle(quantise(wrap_angle(a), r));
        MotorState {
            stamp,
            x_m: quantise(self.x, m),
            y_m: quantise(self.y, m),
            heading_rad: angle(self.heading),
            steer_rad: angle(self.steer),
            turret_rad: angle(self.turret),
            velocities: AxisVelocities {
                translate_m_s: quantise(v.translate_m_s, m),
                steer_rad_s: quantise(v.steer_rad_s, r),
                turret_rad_s: quantise(v.turret_rad_s, r),
            },
            stopped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact() -> OdometryConfig {
        OdometryConfig {
            resolution_m: 0.0,
            resolution_deg: 0.0,
            distance_error: 0.0,
            heading_error: 0.0,
            heading_error_deg_per_m: 0.0,
        }
    }

    fn report(o: &Odometry) -> MotorState {
        o.report(Timestamp::ZERO, AxisVelocities::default(), true)
    }

    #[test]
    fn wraps_into_minus_pi_to_pi() {
        assert_eq!(wrap_angle(PI), PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-15);
        assert!((wrap_angle(-5.0 * TAU + 0.1) - 0.1).abs() < 1e-12);
    }

    #[test]
    fn integrates_a_square_exactly_without_errors() {
        let mut o = Odometry::new(&exact(), false);
        for _ in 0..4 {
            o.integrate(1.0, 0.0, 0.0);
            o.integrate(0.0, PI / 2.0, PI / 2.0);
        }
        let s = report(&o);
        assert!(s.x_m.abs() < 1e-12 && s.y_m.abs() < 1e-12, "{s:?}");
        assert!(wrap_angle(s.heading_rad).abs() < 1e-12);
    }

    #[test]
    fn quantises_to_the_resolution() {
        let mut o =
            Odometry::new(&OdometryConfig { resolution_m: 0.0025, resolution_deg: 0.1, ..exact() }, false);
        o.integrate(1.2345, 0.0, 0.0);
        o.integrate(0.0, 0.123f64.to_radians(), 0.0);
        let s = report(&o);
        assert!((s.x_m - 1.235).abs() < 1e-12, "{}", s.x_m);
        assert!((s.x_m / 0.0025 - (s.x_m / 0.0025).round()).abs() < 1e-9);
        assert!((s.heading_rad.to_degrees() - 0.1).abs() < 1e-9, "{}", s.heading_rad.to_degrees());
        let v = o.report(Timestamp::ZERO, AxisVelocities::synchro(0.2512, 0.0), false).velocities;
        assert!((v.translate_m_s - 0.25).abs() < 1e-12);
    }

    #[test]
    fn drift_factors_bend_and_stretch_the_path() {
        let mut o = Odometry::new(
            &OdometryConfig { distance_error: 0.01, heading_error_deg_per_m: 1.0, ..exact() },
            false,
        );
        for _ in 0..100 {
            o.integrate(0.01, 0.0, 0.0);
        }
        let s = report(&o);
        // One metre driven straight reads 1.01 m along a curve that turned 1 degree.
        assert!((s.heading_rad.to_degrees() - 1.0).abs() < 1e-9, "{}", s.heading_rad.to_degrees());
        let chord = (s.x_m.powi(2) + s.y_m.powi(2)).sqrt();
        assert!((chord - 1.01).abs() < 1e-4, "{chord}");
        assert!(s.y_m > 0.008 && s.y_m < 0.0095, "curves left: {}", s.y_m);
        let mut o = Odometry::new(&OdometryConfig { heading_error: 0.1, ..exact() }, false);
        o.integrate(0.0, 1.0, 1.0);
        assert!((report(&o).heading_rad - 1.1).abs() < 1e-12);
        assert!((report(&o).steer_rad - 1.0).abs() < 1e-12, "the steering encoder itself is exact");
    }
}
