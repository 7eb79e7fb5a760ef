//! The hardware layer of orsa: everything that touches (or pretends to be) the robot.
//!
//! Its one job is to give the layers above a Nomad 200 to drive, real or simulated, behind two
//! traits that mirror the robot's two boards. Nothing here knows about behaviours or arbitration.
//!
//! Modules:
//! - [`any`]: boards of any backend (the simulator, a ROS 2 base, a user's own) behind one type.
//! - [`board`]: the [`SensorBoard`](board::SensorBoard) and [`MotorBoard`](board::MotorBoard)
//!   traits, with the table that maps each method to the original Nomad 200 C function.
//! - [`world`]: world files (TOML) loaded into checked, typed structs; the reference world
//!   `palazzina` ships inside the crate.
//! - [`geometry`]: segments, circles and boxes: distances, ray casts, swept-circle collision.
//! - [`sim`]: [`SimNomad200`](sim::SimNomad200), a pure, seeded, fixed-step simulator of the
//!   robot in a world, and [`SimRobot`](sim::SimRobot), which steps it on tokio's clock behind
//!   the board traits.
//! - [`faulty`]: board wrappers that inject hardware faults (stuck, dead and noisy rings,
//!   stalled motors) for fault plans.
//! - [`ros2base`]: a ROS 2 robot (laser scan, odometry, velocity commands) behind the board
//!   traits, its scan resampled onto the rings; fed by the process that speaks ROS 2.
//! - [`safety`]: the safety monitor between the robot server and the motor board: stop and
//!   slowdown zones along the commanded path, blind directions, contact; for every driver.
//! - [`server`]: the robot server component `nomad200`, which offers the services of
//!   [`orsa_interfaces::nomad200`] on top of any pair of boards, with its velocity watchdog.
//!
//! The communication objects the robot speaks live in `orsa-interfaces`, so that behaviours
//! know the robot by its interface and never depend on this crate.

pub mod any;
pub mod board;
pub mod faulty;
pub mod geometry;
pub mod ros2base;
pub mod safety;
pub mod server;
pub mod sim;
pub mod world;
