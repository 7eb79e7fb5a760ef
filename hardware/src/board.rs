//! The Nomad 200's two boards as traits: [`SensorBoard`] and [`MotorBoard`].
//!
//! The real robot has a sensor board (sonar, infrared, bumpers, compass) and a motor board
//! (three axes: translate, steer, turret) on a serial line. These traits keep that split, so a
//! driver for the real boards can implement them beside the simulator
//! ([`SimSensorBoard`](crate::sim::SimSensorBoard), [`SimMotorBoard`](crate::sim::SimMotorBoard)).
//! Every method is asynchronous (a serial driver awaits its reply) and returns
//! `Result<_, BoardError>`. All values are SI: metres, radians, seconds.
//!
//! # The original functions
//!
//! The original server's `sensors.c` and `motor.c` wrapped the robot's serial commands. Their C
//! names below are as the project remembers them, not checked against the original source;
//! those marked (*) are reconstructed guesses. The matching command of Nomadic's own client
//! library (`Nclient.h`) is given as a cross-check.
//!
//! | Trait method                           | `sensors.c` / `motor.c`            | Nclient        |
//! |----------------------------------------|------------------------------------|----------------|
//! | [`SensorBoard::init`]                  | `sens_init`                        | -              |
//! | [`SensorBoard::set_sonar_fire_order`]  | `set_sonar_fireorder`              | `conf_sn`      |
//! | [`SensorBoard::set_sonar_fire_period`] | `set_sonar_fire_rate`              | `conf_sn`      |
//! | [`SensorBoard::set_infrared_fire_order`] | `set_IR_fireorder`               | `conf_ir`      |
//! | [`SensorBoard::set_infrared_fire_period`] | `set_IR_fire_rate` (*)          | -              |
//! | [`SensorBoard::read_sonar`]            | `get_sonar`                        | `get_sn`       |
//! | [`SensorBoard::read_infrared`]         | `get_IR`                           | `get_ir`       |
//! | [`SensorBoard::read_bumpers`]          | `get_bumper`                       | `get_bp`       |
//! | [`SensorBoard::read_compass`]          | `get_compass`                      | `get_cp`       |
//! | [`MotorBoard::move_velocity`]          | `motor_move` in velocity mode      | `vm` / `mv(MV_VM, ..)` |
//! | [`MotorBoard::stop`]                   | `motor_stop`                       | `st`           |
//! | [`MotorBoard::wait_stop`]              | `motor_wait_stop`                  | `ws`           |
//! | [`MotorBoard::zero_axes`]              | `motor_zero_axis`                  | `dp` + `da` (see below) |
//! | [`MotorBoard::set_velocity_limits`]    | `motor_set_velocity_limit` (*)     | `sp`           |
//! | [`MotorBoard::set_accelerations`]      | `motor_set_accel` (*)              | `ac`           |
//! | [`MotorBoard::read_state`]             | `motor_get_position` + `motor_get_velocity` (*) | `get_rc` + `get_rv` |
//!
//! Differences from the original, on purpose: fire periods are durations, not multiples of
//! 4 ms; velocities are SI, not tenths of inches or degrees per second; `zero_axes` redefines the
//! current pose as zero (like `dp(0, 0)` and `da(0, 0)`) rather than physically turning steering
//! and turret back to the bumper zero as `zr` does. Position-mode moves (`pr`) are not offered:
//! nothing above the hardware layer uses them.

use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{ContactScan, DistanceScan};
use serde::{Deserialize, Serialize};
use std::future::Future;
use std::time::Duration;

/// Why a board operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BoardError {
    /// An argument the board cannot accept (out of range, not finite, wrong length).
    #[error("invalid argument to {operation}: {reason}")]
    InvalidArgument {
        /// The operation, named as the trait method.
        operation: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The board did not reach the awaited state in time.
    #[error("{operation} timed out after {waited:?}")]
    Timeout {
        /// The operation.
        operation: &'static str,
        /// How long it waited.
        waited: Duration,
    },
    /// The board is gone: its driver was shut down or the line is closed.
    #[error("board disconnected: {0}")]
    Disconnected(String),
    /// The line to the board failed (a real driver's I/O or protocol error).
    #[error("board communication failed: {0}")]
    Communication(String),
}

/// Velocities for the three axes of the motor board.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct AxisVelocities {
    /// Translation, m/s (negative backs up).
    pub translate_m_s: f64,
    /// Steering, rad/s counter-clockwise.
    pub steer_rad_s: f64,
    /// Turret, rad/s counter-clockwise.
    pub turret_rad_s: f64,
}

impl AxisVelocities {
    /// Translate at `v_m_s` and turn steering and turret together at `omega_rad_s`, so the
    /// sensor rings keep facing the direction of travel (what `navigationvelocity` commands).
    pub fn synchro(v_m_s: f64, omega_rad_s: f64) -> Self {
        AxisVelocities { translate_m_s: v_m_s, steer_rad_s: omega_rad_s, turret_rad_s: omega_rad_s }
    }

    /// The values, in axis order (translate, steer, turret).
    pub fn as_array(&self) -> [f64; 3] {
        [self.translate_m_s, self.steer_rad_s, self.turret_rad_s]
    }
}

/// Accelerations for the three axes of the motor board.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisAccelerations {
    /// Translation, m/s^2.
    pub translate_m_s2: f64,
    /// Steering, rad/s^2.
    pub steer_rad_s2: f64,
    /// Turret, rad/s^2.
    pub turret_rad_s2: f64,
}

impl AxisAccelerations {
    /// The values, in axis order (translate, steer, turret).
    pub fn as_array(&self) -> [f64; 3] {
        [self.translate_m_s2, self.steer_rad_s2, self.turret_rad_s2]
    }
}

/// What the motor board's encoders say: odometry pose, axis angles and velocities.
///
/// All of it is integrated from the motors, quantised to the board's resolution, and drifts
/// from the truth (it keeps counting when the robot is blocked and its wheels slip).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotorState {
    /// When it was read.
    pub stamp: Timestamp,
    /// Odometry x, m, from where the axes were zeroed.
    pub x_m: f64,
    /// Odometry y, m.
    pub y_m: f64,
    /// Odometry heading (the direction of travel), rad in (-pi, pi].
    pub heading_rad: f64,
    /// Steering encoder angle, rad in (-pi, pi].
    pub steer_rad: f64,
    /// Turret encoder angle, rad in (-pi, pi].
    pub turret_rad: f64,
    /// Axis velocities now (after acceleration limits), per the encoders.
    pub velocities: AxisVelocities,
    /// Whether all three axes are at rest and commanded to stay at rest.
    pub stopped: bool,
}

/// A compass reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CompassReading {
    /// When it was sampled.
    pub stamp: Timestamp,
    /// Heading of the turret, rad counter-clockwise from the world's +x, in (-pi, pi].
    pub heading_rad: f64,
    /// Whether a sample has been taken yet.
    pub valid: bool,
}

/// The sensor board: sonar and infrared rings, bumpers, compass.
///
/// Each ring fires one sensor at a time, in its fire order, one every fire period; a read
/// returns the latest reading of every sensor, each with the time it fired.
pub trait SensorBoard: Send + Sync {
    /// Resets the board: default fire orders and periods, all readings invalid (`sens_init`).
    fn init(&self) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Sets which sonar transducers fire, in which order (indices 0..16, at least one, at most
    /// 16). Sensors left out keep their last reading.
    fn set_sonar_fire_order(&self, order: &[u8]) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Sets the time between two sonar transducers firing.
    fn set_sonar_fire_period(&self, period: Duration) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Sets which infrared sensors fire, in which order.
    fn set_infrared_fire_order(&self, order: &[u8]) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Sets the time between two infrared sensors firing.
    fn set_infrared_fire_period(
        &self,
        period: Duration,
    ) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// The latest reading of each sonar transducer.
    fn read_sonar(&self) -> impl Future<Output = Result<DistanceScan, BoardError>> + Send;

    /// The latest reading of each infrared sensor.
    fn read_infrared(&self) -> impl Future<Output = Result<DistanceScan, BoardError>> + Send;

    /// The bumper ring's state now.
    fn read_bumpers(&self) -> impl Future<Output = Result<ContactScan, BoardError>> + Send;

    /// The latest compass sample.
    fn read_compass(&self) -> impl Future<Output = Result<CompassReading, BoardError>> + Send;
}

/// The motor board: translate, steer and turret axes, each velocity- and
/// acceleration-limited.
pub trait MotorBoard: Send + Sync {
    /// Moves the three axes at these velocities until told otherwise (`motor_move`, velocity
    /// mode). Velocities beyond the current limits are saturated at them, as the board does;
    /// a value that is not finite is an error. Each axis reaches its velocity at its
    /// acceleration limit.
    fn move_velocity(&self, v: AxisVelocities) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Brings all axes to rest at their acceleration limits (`motor_stop`).
    fn stop(&self) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Waits until all axes are at rest with nothing commanded, or fails with
    /// [`BoardError::Timeout`] after `timeout` (`motor_wait_stop`). It does not stop the robot.
    fn wait_stop(&self, timeout: Duration) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Declares the current pose the odometry origin: x, y, heading, steering and turret angles
    /// read zero from now on (`motor_zero_axis`).
    fn zero_axes(&self) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Sets the velocity limit of each axis (positive, at most the hardware's maximum).
    fn set_velocity_limits(
        &self,
        limits: AxisVelocities,
    ) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// Sets the acceleration of each axis (positive, at most the hardware's maximum).
    fn set_accelerations(
        &self,
        accel: AxisAccelerations,
    ) -> impl Future<Output = Result<(), BoardError>> + Send;

    /// The encoders' state now.
    fn read_state(&self) -> impl Future<Output = Result<MotorState, BoardError>> + Send;

    /// What a safety monitor guarding this board did, if one does (see [`crate::safety`]).
    fn monitor(&self) -> Option<orsa_interfaces::nomad200::MonitorCounters> {
        None
    }

    /// Changes whenever the health of a sensor changes (`None`: nothing judges the sensors).
    fn health_version(&self) -> Option<u64> {
        None
    }

    /// The health of the robot's sensors and how long each was judged what, where the board
    /// judges them (a guarded board, [`crate::safety::Guarded`]).
    fn health(&self) -> Option<(orsa_interfaces::health::Health, orsa_interfaces::health::HealthCounters)> {
        None
    }
}
