//! orsa-executive: the master that decides which behaviour drives.
//!
//! Its one job is arbitration: it configures behaviours with the State pattern and connects
//! exactly one of them to the robot's motors with the Wiring pattern, following rules in the
//! config file, and runs the goals the deliberative layer gives it.
//!
//! Modules:
//! - [`rules`]: modes and their priority lists of conditions on sensor values.
//! - [`goal`]: the communication objects of goals, their progress and of wiring changes.
//! - [`master`]: the `master` component.

pub mod goal;
pub mod master;
pub mod rules;

pub use goal::{Goal, GoalEvent, GoalFilter, GoalReply, GoalStatus, WiringChange};
pub use master::{ExecutiveParams, Master};
