//! orsa-executive: the master that decides which behaviour drives.
//!
//! Its one job is arbitration: it configures behaviours with the State pattern and connects
//! exactly one of them to the robot's motors with the Wiring pattern, following rules in the
//! config file, and runs the goals the deliberative layer gives it.
//!
//! Modules:
//! - [`rules`]: modes and their priority lists of conditions on sensor values.
//! - [`master`]: the `master` component.
//!
//! The master's services and the goal objects are in `orsa_interfaces::executive`; it knows the
//! behaviours by `orsa_interfaces::behaviour` and the robot by `orsa_interfaces::nomad200`, and
//! depends on neither crate.

pub mod master;
pub mod rules;

pub use master::{ExecutiveParams, Master};
