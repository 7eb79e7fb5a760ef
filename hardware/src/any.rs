//! Boards of either backend, so one robot server type serves the simulator or a ROS 2 base:
//! [`AnySensorBoard`] and [`AnyMotorBoard`] forward every call to the board they hold.

use crate::board::{
    AxisAccelerations, AxisVelocities, BoardError, CompassReading, MotorBoard, MotorState, SensorBoard,
};
use crate::ros2base::{Ros2MotorBoard, Ros2SensorBoard};
use crate::sim::{SimMotorBoard, SimSensorBoard};
use orsa_interfaces::nomad200::{ContactScan, DistanceScan};
use std::time::Duration;

/// The sensor board of the simulator or of a ROS 2 base.
#[derive(Debug, Clone)]
pub enum AnySensorBoard {
    /// The simulated Nomad 200's.
    Sim(SimSensorBoard),
    /// A ROS 2 base's (rings resampled from its laser scan).
    Ros2(Ros2SensorBoard),
}

/// The motor board of the simulator or of a ROS 2 base.
#[derive(Debug, Clone)]
pub enum AnyMotorBoard {
    /// The simulated Nomad 200's.
    Sim(SimMotorBoard),
    /// A ROS 2 base's (velocity commands out, odometry in).
    Ros2(Ros2MotorBoard),
}

macro_rules! forward {
    ($self:ident, $b:ident => $call:expr) => {
        match $self {
            Self::Sim($b) => $call.await,
            Self::Ros2($b) => $call.await,
        }
    };
}

impl SensorBoard for AnySensorBoard {
    async fn init(&self) -> Result<(), BoardError> {
        forward!(self, b => b.init())
    }
    async fn set_sonar_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        forward!(self, b => b.set_sonar_fire_order(order))
    }
    async fn set_sonar_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        forward!(self, b => b.set_sonar_fire_period(period))
    }
    async fn set_infrared_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        forward!(self, b => b.set_infrared_fire_order(order))
    }
    async fn set_infrared_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        forward!(self, b => b.set_infrared_fire_period(period))
    }
    async fn read_sonar(&self) -> Result<DistanceScan, BoardError> {
        forward!(self, b => b.read_sonar())
    }
    async fn read_infrared(&self) -> Result<DistanceScan, BoardError> {
        forward!(self, b => b.read_infrared())
    }
    async fn read_bumpers(&self) -> Result<ContactScan, BoardError> {
        forward!(self, b => b.read_bumpers())
    }
    async fn read_compass(&self) -> Result<CompassReading, BoardError> {
        forward!(self, b => b.read_compass())
    }
}

impl MotorBoard for AnyMotorBoard {
    async fn move_velocity(&self, v: AxisVelocities) -> Result<(), BoardError> {
        forward!(self, b => b.move_velocity(v))
    }
    async fn stop(&self) -> Result<(), BoardError> {
        forward!(self, b => b.stop())
    }
    async fn wait_stop(&self, timeout: Duration) -> Result<(), BoardError> {
        forward!(self, b => b.wait_stop(timeout))
    }
    async fn zero_axes(&self) -> Result<(), BoardError> {
        forward!(self, b => b.zero_axes())
    }
    async fn set_velocity_limits(&self, limits: AxisVelocities) -> Result<(), BoardError> {
        forward!(self, b => b.set_velocity_limits(limits))
    }
    async fn set_accelerations(&self, accel: AxisAccelerations) -> Result<(), BoardError> {
        forward!(self, b => b.set_accelerations(accel))
    }
    async fn read_state(&self) -> Result<MotorState, BoardError> {
        forward!(self, b => b.read_state())
    }
}
