//! The hardware layer of orsa: everything that touches (or pretends to be) the robot.
//!
//! Its one job is to give the layers above a Nomad 200 to drive, real or simulated, behind two
//! traits that mirror the robot's two boards. Nothing here knows about behaviours or arbitration.
//!
//! Modules:
//! - [`board`]: the [`SensorBoard`](board::SensorBoard) and [`MotorBoard`](board::MotorBoard)
//!   traits, with the table that maps each method to the original Nomad 200 C function.
//! - [`comm`]: the communication objects the `nomad200` component speaks (`DistanceScan`,
//!   `ContactScan`, `BaseState`, `NavigationVelocity`, `RobotParams`).
//! - [`world`]: world files (TOML) loaded into checked, typed structs; the reference world
//!   `palazzina` ships inside the crate.
//! - [`geometry`]: segments, circles and boxes: distances, ray casts, swept-circle collision.
//! - [`sim`]: [`SimNomad200`](sim::SimNomad200), a pure, seeded, fixed-step simulator of the
//!   robot in a world, and [`SimRobot`](sim::SimRobot), which steps it on tokio's clock behind
//!   the board traits.

pub mod board;
pub mod comm;
pub mod faulty;
pub mod geometry;
pub mod sim;
pub mod world;

// The `nomad200` server component (services distanceir, distanceson, bumpers, basestate and
// navigationvelocity on top of the board traits) goes here:
pub mod server;
