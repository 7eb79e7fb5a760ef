//! The synchro drive's three motor axes, and the simulator's motor-board operations.
//!
//! Each axis (translate, steer, turret) is velocity-controlled: it ramps from its velocity
//! towards its commanded one at its acceleration, saturated at its velocity limit. The
//! displacement of a step is the exact integral of that ramp (trapezoid). This is the motors'
//! own motion, what the encoders count; whether the body actually moves is decided by the
//! collision check in the simulator.

use super::SimNomad200;
use crate::board::{AxisAccelerations, AxisVelocities, BoardError, MotorState};
use crate::sim::config::DriveConfig;
use orsa_interfaces::range::DriveKind;

/// One velocity-controlled axis.
#[derive(Debug, Clone, PartialEq)]
struct Axis {
    /// The commanded velocity, before saturation.
    command: f64,
    /// The velocity now.
    velocity: f64,
    /// The velocity limit now (at most `max_limit`).
    limit: f64,
    /// The acceleration now (at most `max_accel`).
    accel: f64,
    max_limit: f64,
    max_accel: f64,
}

impl Axis {
    fn new(max_limit: f64, accel: f64, max_accel: f64) -> Self {
        Axis { command: 0.0, velocity: 0.0, limit: max_limit, accel, max_limit, max_accel }
    }

    /// The commanded velocity saturated at the limit.
    fn target(&self) -> f64 {
        self.command.max(-self.limit).min(self.limit)
    }

    /// Advances by `dt` seconds; returns the displacement.
    fn advance(&mut self, dt: f64) -> f64 {
        let target = self.target();
        let v0 = self.velocity;
        let dv_max = self.accel * dt;
        // The tolerance lets a ramp land exactly on its target despite rounding in the sum.
        let v1 = if (target - v0).abs() <= dv_max * (1.0 + 1e-9) {
            target
        } else {
            v0 + dv_max.copysign(target - v0)
        };
        self.velocity = v1;
        0.5 * (v0 + v1) * dt
    }
}

/// The three axes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Drive {
    axes: [Axis; 3],
    /// Differential drive: half the distance between the wheels, m (`None`: synchro drive).
    half_base: Option<f64>,
}

const AXIS_NAMES: [&str; 3] = ["translate", "steer", "turret"];

fn check(operation: &'static str, values: [f64; 3], max: [f64; 3], positive: bool) -> Result<(), BoardError> {
    for ((name, v), m) in AXIS_NAMES.iter().zip(values).zip(max) {
        let ok = v.is_finite() && (!positive || (v > 0.0 && v <= m));
        if !ok {
            let rule =
                if positive { format!("must be > 0 and at most {m}") } else { "must be finite".to_owned() };
            return Err(BoardError::InvalidArgument {
                operation,
                reason: format!("{name}: {rule}, got {v}"),
            });
        }
    }
    Ok(())
}

impl Drive {
    pub(crate) fn new(c: &DriveConfig) -> Self {
        // A differential drive has no turret: its "turret" axis mirrors the steering, so that
        // the sensors turn with the body and every limit set on the steering holds for both.
        let (turret_max, turret_accel, turret_max_accel) = match c.kind {
            DriveKind::Synchro => (c.max_turret_deg_s, c.turret_accel_deg_s2, c.max_turret_accel_deg_s2),
            DriveKind::Differential => (c.max_steer_deg_s, c.steer_accel_deg_s2, c.max_steer_accel_deg_s2),
        };
        Drive {
            half_base: (c.kind == DriveKind::Differential).then_some(c.wheel_base_m / 2.0),
            axes: [
                Axis::new(c.max_translate_m_s, c.translate_accel_m_s2, c.max_translate_accel_m_s2),
                Axis::new(
                    c.max_steer_deg_s.to_radians(),
                    c.steer_accel_deg_s2.to_radians(),
                    c.max_steer_accel_deg_s2.to_radians(),
                ),
                Axis::new(turret_max.to_radians(), turret_accel.to_radians(), turret_max_accel.to_radians()),
            ],
        }
    }

    pub(crate) fn command(&mut self, v: AxisVelocities) -> Result<(), BoardError> {
        check("move_velocity", v.as_array(), [0.0; 3], false)?;
        let mut c = v.as_array();
        if let Some(half_base) = self.half_base {
            // Both wheels within the translation limit, the curvature kept; no turret.
            let wheel = c[0].abs() + c[1].abs() * half_base;
            let max = self.axes[0].limit;
            if wheel > max {
                let k = max / wheel;
                c = [c[0] * k, c[1] * k, c[1] * k];
            }
            c[2] = c[1];
        }
        for (axis, c) in self.axes.iter_mut().zip(c) {
            axis.command = c;
        }
        Ok(())
    }

    pub(crate) fn stop(&mut self) {
        for axis in &mut self.axes {
            axis.command = 0.0;
        }
    }

    pub(crate) fn set_limits(&mut self, v: AxisVelocities) -> Result<(), BoardError> {
        check("set_velocity_limits", v.as_array(), self.axes.clone().map(|a| a.max_limit), true)?;
        let mut l = v.as_array();
        if self.half_base.is_some() {
            l[2] = l[1];
        }
        for (axis, l) in self.axes.iter_mut().zip(l) {
            axis.limit = l;
        }
        Ok(())
    }

    pub(crate) fn set_accels(&mut self, a: AxisAccelerations) -> Result<(), BoardError> {
        check("set_accelerations", a.as_array(), self.axes.clone().map(|a| a.max_accel), true)?;
        let mut acc = a.as_array();
        if self.half_base.is_some() {
            acc[2] = acc[1];
        }
        for (axis, acc) in self.axes.iter_mut().zip(acc) {
            axis.accel = acc;
        }
        Ok(())
    }

    /// Advances all axes by `dt`; returns their displacements (m, rad, rad).
    pub(crate) fn advance(&mut self, dt: f64) -> [f64; 3] {
        [self.axes[0].advance(dt), self.axes[1].advance(dt), self.axes[2].advance(dt)]
    }

    pub(crate) fn velocities(&self) -> AxisVelocities {
        AxisVelocities {
            translate_m_s: self.axes[0].velocity,
            steer_rad_s: self.axes[1].velocity,
            turret_rad_s: self.axes[2].velocity,
        }
    }

    /// Whether every axis is at rest and commanded to stay so (right after a move command,
    /// before the motors have ramped, the robot is not "stopped").
    pub(crate) fn stopped(&self) -> bool {
        self.axes.iter().all(|a| a.velocity == 0.0 && a.target() == 0.0)
    }
}

/// The motor board, synchronously (see [`MotorBoard`](crate::board::MotorBoard) for the
/// asynchronous trait these back).
impl SimNomad200 {
    /// Moves the axes at these velocities (saturated at the limits) until told otherwise.
    pub fn move_velocity(&mut self, v: AxisVelocities) -> Result<(), BoardError> {
        self.drive.command(v)
    }

    /// Brings all axes to rest at their accelerations.
    pub fn stop(&mut self) {
        self.drive.stop();
    }

    /// Whether all axes are at rest and commanded to stay at rest.
    pub fn is_stopped(&self) -> bool {
        self.drive.stopped()
    }

    /// Declares the current pose the odometry origin.
    pub fn zero_axes(&mut self) {
        self.odometry.zero();
    }

    /// Sets the velocity limit of each axis (positive, at most the configured maximum).
    pub fn set_velocity_limits(&mut self, limits: AxisVelocities) -> Result<(), BoardError> {
        self.drive.set_limits(limits)
    }

    /// Sets the acceleration of each axis (positive, at most the configured maximum).
    pub fn set_accelerations(&mut self, accel: AxisAccelerations) -> Result<(), BoardError> {
        self.drive.set_accels(accel)
    }

    /// The encoders' state now: quantised odometry and axis velocities.
    pub fn motor_state(&self) -> MotorState {
        self.odometry.report(self.time(), self.drive.velocities(), self.drive.stopped())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_ramps_at_its_acceleration_and_saturates() {
        let mut a = Axis::new(0.5, 0.5, 1.0);
        a.command = 2.0; // saturates at 0.5
        let mut travelled = 0.0;
        for _ in 0..100 {
            travelled += a.advance(0.01);
        }
        // One second at 0.5 m/s^2 from rest: reaches 0.5 m/s exactly, travels 0.25 m.
        assert_eq!(a.velocity, 0.5);
        assert!((travelled - 0.25).abs() < 1e-12, "{travelled}");
        a.command = 0.0;
        let mut steps = 0;
        while a.velocity != 0.0 {
            a.advance(0.01);
            steps += 1;
        }
        assert_eq!(steps, 100, "one second to stop");
    }

    #[test]
    fn a_commanded_axis_is_not_stopped_before_it_moves() {
        let mut d = Drive::new(&DriveConfig::default());
        assert!(d.stopped());
        d.command(AxisVelocities { translate_m_s: 0.0, steer_rad_s: 0.0, turret_rad_s: 0.1 }).expect("cmd");
        assert!(!d.stopped(), "commanded, not yet moving");
        d.advance(0.01);
        d.stop();
        assert!(!d.stopped(), "still turning");
        d.advance(0.01);
        assert!(d.stopped());
    }

    #[test]
    fn limits_and_accelerations_are_checked() {
        let mut d = Drive::new(&DriveConfig::default());
        let e = d.set_limits(AxisVelocities::synchro(0.6, 0.1)).expect_err("over max");
        assert!(e.to_string().contains("translate: must be > 0 and at most 0.5, got 0.6"), "{e}");
        assert!(d.set_limits(AxisVelocities::synchro(0.2, 0.0)).is_err(), "zero limit");
        assert!(d.command(AxisVelocities::synchro(f64::NAN, 0.0)).is_err());
        assert!(
            d.set_accels(AxisAccelerations { translate_m_s2: 0.1, steer_rad_s2: 0.1, turret_rad_s2: 9.0 })
                .is_err()
        );
        d.set_limits(AxisVelocities::synchro(0.2, 0.1)).expect("within");
        d.command(AxisVelocities::synchro(1.0, -1.0)).expect("saturates");
        for _ in 0..200 {
            d.advance(0.01);
        }
        assert_eq!(d.velocities(), AxisVelocities::synchro(0.2, -0.1));
    }

    /// A differential drive's wheels share the translation limit: a command beyond it is
    /// scaled down whole (same curvature), and the sensors turn with the body.
    #[test]
    fn a_differential_drive_shares_its_wheel_speed() {
        let c = DriveConfig {
            kind: DriveKind::Differential,
            wheel_base_m: 0.5,
            max_translate_m_s: 1.0,
            max_steer_deg_s: 180.0,
            steer_accel_deg_s2: 720.0,
            max_steer_accel_deg_s2: 720.0,
            translate_accel_m_s2: 1.0,
            ..DriveConfig::default()
        };
        let mut d = Drive::new(&c);
        // Wheels at 0.8 +- 2 x 0.25 = 1.3 and 0.3 m/s: scaled by 1 / 1.3.
        d.command(AxisVelocities { translate_m_s: 0.8, steer_rad_s: 2.0, turret_rad_s: -5.0 }).expect("cmd");
        for _ in 0..300 {
            d.advance(0.01);
        }
        let v = d.velocities();
        assert!((v.translate_m_s - 0.8 / 1.3).abs() < 1e-12, "{v:?}");
        assert!((v.steer_rad_s - 2.0 / 1.3).abs() < 1e-12, "{v:?}");
        assert_eq!(v.turret_rad_s, v.steer_rad_s, "no turret of its own");
        assert!(v.translate_m_s + v.steer_rad_s * 0.25 <= 1.0 + 1e-12);
        // Within the limit nothing is scaled.
        d.command(AxisVelocities::synchro(0.5, 1.0)).expect("cmd");
        for _ in 0..300 {
            d.advance(0.01);
        }
        assert_eq!(d.velocities(), AxisVelocities::synchro(0.5, 1.0));
    }
}
