//! Boards of any backend behind one type, so one robot server type serves them all:
//! [`AnySensorBoard`] and [`AnyMotorBoard`] forward every call to the board they hold: the
//! simulator's, a ROS 2 base's, or a user's own ([`AnySensorBoard::other`],
//! [`AnyMotorBoard::other`]: any type that implements the board traits, no edit here).
//!
//! The board traits return `impl Future`, which keeps a call free of allocation but makes them
//! unusable as trait objects; [`DynSensorBoard`] and [`DynMotorBoard`] are their object-safe
//! mirrors (a boxed future per call), implemented for every board, so a board this crate has
//! never heard of rides in the `Other` variants.

use crate::board::{
    AxisAccelerations, AxisVelocities, BoardError, CompassReading, MotorBoard, MotorState, SensorBoard,
};
use crate::ros2base::{Ros2MotorBoard, Ros2SensorBoard};
use crate::sim::{SimMotorBoard, SimSensorBoard};
use orsa_interfaces::nomad200::{ContactScan, DistanceScan};
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

/// A board call's future, boxed (see [`DynSensorBoard`]).
pub type BoardFuture<'a, T> = Pin<Box<dyn Future<Output = Result<T, BoardError>> + Send + 'a>>;

/// [`SensorBoard`] as a trait object: implemented for every sensor board.
pub trait DynSensorBoard: Send + Sync + std::fmt::Debug {
    /// [`SensorBoard::init`].
    fn dyn_init(&self) -> BoardFuture<'_, ()>;
    /// [`SensorBoard::set_sonar_fire_order`].
    fn dyn_set_sonar_fire_order<'a>(&'a self, order: &'a [u8]) -> BoardFuture<'a, ()>;
    /// [`SensorBoard::set_sonar_fire_period`].
    fn dyn_set_sonar_fire_period(&self, period: Duration) -> BoardFuture<'_, ()>;
    /// [`SensorBoard::set_infrared_fire_order`].
    fn dyn_set_infrared_fire_order<'a>(&'a self, order: &'a [u8]) -> BoardFuture<'a, ()>;
    /// [`SensorBoard::set_infrared_fire_period`].
    fn dyn_set_infrared_fire_period(&self, period: Duration) -> BoardFuture<'_, ()>;
    /// [`SensorBoard::read_sonar`].
    fn dyn_read_sonar(&self) -> BoardFuture<'_, DistanceScan>;
    /// [`SensorBoard::read_infrared`].
    fn dyn_read_infrared(&self) -> BoardFuture<'_, DistanceScan>;
    /// [`SensorBoard::read_bumpers`].
    fn dyn_read_bumpers(&self) -> BoardFuture<'_, ContactScan>;
    /// [`SensorBoard::read_compass`].
    fn dyn_read_compass(&self) -> BoardFuture<'_, CompassReading>;
}

impl<B: SensorBoard + std::fmt::Debug> DynSensorBoard for B {
    fn dyn_init(&self) -> BoardFuture<'_, ()> {
        Box::pin(self.init())
    }
    fn dyn_set_sonar_fire_order<'a>(&'a self, order: &'a [u8]) -> BoardFuture<'a, ()> {
        Box::pin(self.set_sonar_fire_order(order))
    }
    fn dyn_set_sonar_fire_period(&self, period: Duration) -> BoardFuture<'_, ()> {
        Box::pin(self.set_sonar_fire_period(period))
    }
    fn dyn_set_infrared_fire_order<'a>(&'a self, order: &'a [u8]) -> BoardFuture<'a, ()> {
        Box::pin(self.set_infrared_fire_order(order))
    }
    fn dyn_set_infrared_fire_period(&self, period: Duration) -> BoardFuture<'_, ()> {
        Box::pin(self.set_infrared_fire_period(period))
    }
    fn dyn_read_sonar(&self) -> BoardFuture<'_, DistanceScan> {
        Box::pin(self.read_sonar())
    }
    fn dyn_read_infrared(&self) -> BoardFuture<'_, DistanceScan> {
        Box::pin(self.read_infrared())
    }
    fn dyn_read_bumpers(&self) -> BoardFuture<'_, ContactScan> {
        Box::pin(self.read_bumpers())
    }
    fn dyn_read_compass(&self) -> BoardFuture<'_, CompassReading> {
        Box::pin(self.read_compass())
    }
}

/// [`MotorBoard`] as a trait object: implemented for every motor board.
pub trait DynMotorBoard: Send + Sync + std::fmt::Debug {
    /// [`MotorBoard::move_velocity`].
    fn dyn_move_velocity(&self, v: AxisVelocities) -> BoardFuture<'_, ()>;
    /// [`MotorBoard::stop`].
    fn dyn_stop(&self) -> BoardFuture<'_, ()>;
    /// [`MotorBoard::wait_stop`].
    fn dyn_wait_stop(&self, timeout: Duration) -> BoardFuture<'_, ()>;
    /// [`MotorBoard::zero_axes`].
    fn dyn_zero_axes(&self) -> BoardFuture<'_, ()>;
    /// [`MotorBoard::set_velocity_limits`].
    fn dyn_set_velocity_limits(&self, limits: AxisVelocities) -> BoardFuture<'_, ()>;
    /// [`MotorBoard::set_accelerations`].
    fn dyn_set_accelerations(&self, accel: AxisAccelerations) -> BoardFuture<'_, ()>;
    /// [`MotorBoard::read_state`].
    fn dyn_read_state(&self) -> BoardFuture<'_, MotorState>;
}

impl<B: MotorBoard + std::fmt::Debug> DynMotorBoard for B {
    fn dyn_move_velocity(&self, v: AxisVelocities) -> BoardFuture<'_, ()> {
        Box::pin(self.move_velocity(v))
    }
    fn dyn_stop(&self) -> BoardFuture<'_, ()> {
        Box::pin(self.stop())
    }
    fn dyn_wait_stop(&self, timeout: Duration) -> BoardFuture<'_, ()> {
        Box::pin(self.wait_stop(timeout))
    }
    fn dyn_zero_axes(&self) -> BoardFuture<'_, ()> {
        Box::pin(self.zero_axes())
    }
    fn dyn_set_velocity_limits(&self, limits: AxisVelocities) -> BoardFuture<'_, ()> {
        Box::pin(self.set_velocity_limits(limits))
    }
    fn dyn_set_accelerations(&self, accel: AxisAccelerations) -> BoardFuture<'_, ()> {
        Box::pin(self.set_accelerations(accel))
    }
    fn dyn_read_state(&self) -> BoardFuture<'_, MotorState> {
        Box::pin(self.read_state())
    }
}

/// The sensor board of the simulator, a ROS 2 base or a user's own robot.
#[derive(Debug, Clone)]
pub enum AnySensorBoard {
    /// The simulator's (any robot it is described as).
    Sim(SimSensorBoard),
    /// A ROS 2 base's (rings resampled from its laser scan).
    Ros2(Ros2SensorBoard),
    /// Any other board (see [`AnySensorBoard::other`]).
    Other(Arc<dyn DynSensorBoard>),
}

/// The motor board of the simulator, a ROS 2 base or a user's own robot.
#[derive(Debug, Clone)]
pub enum AnyMotorBoard {
    /// The simulator's (any robot it is described as).
    Sim(SimMotorBoard),
    /// A ROS 2 base's (velocity commands out, odometry in).
    Ros2(Ros2MotorBoard),
    /// Any other board (see [`AnyMotorBoard::other`]).
    Other(Arc<dyn DynMotorBoard>),
}

impl AnySensorBoard {
    /// A board of a kind this crate does not know: a user's own robot.
    pub fn other(board: impl SensorBoard + std::fmt::Debug + 'static) -> Self {
        AnySensorBoard::Other(Arc::new(board))
    }
}

impl AnyMotorBoard {
    /// A board of a kind this crate does not know: a user's own robot.
    pub fn other(board: impl MotorBoard + std::fmt::Debug + 'static) -> Self {
        AnyMotorBoard::Other(Arc::new(board))
    }
}

macro_rules! forward {
    ($self:ident, $b:ident => $call:expr, $dyn_call:expr) => {
        match $self {
            Self::Sim($b) => $call.await,
            Self::Ros2($b) => $call.await,
            Self::Other($b) => $dyn_call.await,
        }
    };
}

impl SensorBoard for AnySensorBoard {
    async fn init(&self) -> Result<(), BoardError> {
        forward!(self, b => b.init(), b.dyn_init())
    }
    async fn set_sonar_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        forward!(self, b => b.set_sonar_fire_order(order), b.dyn_set_sonar_fire_order(order))
    }
    async fn set_sonar_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        forward!(self, b => b.set_sonar_fire_period(period), b.dyn_set_sonar_fire_period(period))
    }
    async fn set_infrared_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        forward!(self, b => b.set_infrared_fire_order(order), b.dyn_set_infrared_fire_order(order))
    }
    async fn set_infrared_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        forward!(self, b => b.set_infrared_fire_period(period), b.dyn_set_infrared_fire_period(period))
    }
    async fn read_sonar(&self) -> Result<DistanceScan, BoardError> {
        forward!(self, b => b.read_sonar(), b.dyn_read_sonar())
    }
    async fn read_infrared(&self) -> Result<DistanceScan, BoardError> {
        forward!(self, b => b.read_infrared(), b.dyn_read_infrared())
    }
    async fn read_bumpers(&self) -> Result<ContactScan, BoardError> {
        forward!(self, b => b.read_bumpers(), b.dyn_read_bumpers())
    }
    async fn read_compass(&self) -> Result<CompassReading, BoardError> {
        forward!(self, b => b.read_compass(), b.dyn_read_compass())
    }
}

impl MotorBoard for AnyMotorBoard {
    async fn move_velocity(&self, v: AxisVelocities) -> Result<(), BoardError> {
        forward!(self, b => b.move_velocity(v), b.dyn_move_velocity(v))
    }
    async fn stop(&self) -> Result<(), BoardError> {
        forward!(self, b => b.stop(), b.dyn_stop())
    }
    async fn wait_stop(&self, timeout: Duration) -> Result<(), BoardError> {
        forward!(self, b => b.wait_stop(timeout), b.dyn_wait_stop(timeout))
    }
    async fn zero_axes(&self) -> Result<(), BoardError> {
        forward!(self, b => b.zero_axes(), b.dyn_zero_axes())
    }
    async fn set_velocity_limits(&self, limits: AxisVelocities) -> Result<(), BoardError> {
        forward!(self, b => b.set_velocity_limits(limits), b.dyn_set_velocity_limits(limits))
    }
    async fn set_accelerations(&self, accel: AxisAccelerations) -> Result<(), BoardError> {
        forward!(self, b => b.set_accelerations(accel), b.dyn_set_accelerations(accel))
    }
    async fn read_state(&self) -> Result<MotorState, BoardError> {
        forward!(self, b => b.read_state(), b.dyn_read_state())
    }
}
