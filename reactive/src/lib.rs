//! orsa-reactive: behaviour components.
//!
//! Each behaviour is a pure controller (scan in, velocity out, unit tested on synthetic scans)
//! inside a thin component that subscribes to the robot's sensor pushes and sends on a wireable
//! `vel` port. Behaviours compute all the time, wired or not; the executive decides which one
//! reaches the motors.
//!
//! Modules:
//! - [`ring`]: fused ring readings and the wall estimate per side (sign conventions live here).
//! - [`walldir`]: the walls' direction, held through odometry where no wall is seen flat.
//! - [`cascade`]: the two cascaded proportional loops both behaviours use.
//! - [`wallfollow`]: hold a distance from the left wall (infrared).
//! - [`centerfollow`]: stay mid-corridor (sonar fused with infrared).
//! - [`pathfollow`]: drive along a path in the map (pure pursuit), slowed by what is ahead.
//! - [`manoeuvres`]: backing out of a contact and getting unstuck, shared by both.
//! - [`harness`]: the one behaviour component every controller runs in ([`harness::Controller`]
//!   is what a controller implements; [`harness::Behaviour`] gives it states, live parameters,
//!   inputs, odometry, contact, a wireable `vel` port and `status`).
//! - [`components`]: wall following and center following as controllers in the harness.
//!
//! The behaviours know the robot only by its interface (`orsa_interfaces::nomad200`: the sensor
//! scans they subscribe to, the command they send, the parameters they ask for) and offer the
//! behaviour interface (`orsa_interfaces::behaviour`); they do not depend on the robot crate.

pub mod cascade;
pub mod centerfollow;
pub mod components;
pub mod harness;
pub mod manoeuvres;
pub mod pathfollow;
pub mod ring;
pub mod walldir;
pub mod wallfollow;

pub use components::{CenterFollow, PathFollow, WallFollow};
pub use harness::{Behaviour, Controller};
