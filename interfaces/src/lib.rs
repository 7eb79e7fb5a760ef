//! # orsa-interfaces: what orsa's components offer each other
//!
//! A component's interface is a list of services, each a communication pattern plus a
//! communication object (the idea orsa keeps from SmartSoft). This crate writes those lists
//! down, once, for every component of the corridor mission: each service is a typed constant
//! ([`orsa_actors::service`]) that names it and fixes its pattern and objects, so a server that
//! declares it and a client that connects to it cannot disagree without a compile error.
//!
//! It depends only on `orsa-actors`. Behaviours, the executive and the planner depend on it and
//! not on the robot crate: they know the robot by its interface, not by its code.
//!
//! | module | component | what it holds |
//! |---|---|---|
//! | [`nomad200`] | the robot server | sensor scans, odometry, velocity commands, robot parameters, safety counters |
//! | [`behaviour`] | every behaviour | the wireable `vel` port, `status`, the `active` state |
//! | [`executive`] | the master | goals and goal events, which behaviour drives |
//! | [`planner`] | the planner | where the mission stands |
//! | [`map`] | the map | the occupancy grid of the robot's world |
//! | [`navigation`] | localizer, path follower, planner | the pose in the map, the path to follow, goals to places |
//! | [`range`] | any robot | its drive and range sensors described (ring or laser), and their projection onto sectors |
//!
//! Every communication object is a plain serde struct in SI units with unit-suffixed field names
//! and a stable identifier (`orsa.nomad200.DistanceScan/1`), with a round-trip test.
//!
//! ```
//! use orsa_interfaces::{behaviour, nomad200};
//!
//! // The robot's infrared ring, hosted by a component called "nomad200".
//! let ir = nomad200::DISTANCEIR.on(nomad200::NAME);
//! assert_eq!(ir.to_string(), "nomad200/distanceir");
//! // A behaviour's `vel` port connects to a Send service of the same object, and only to one.
//! assert_eq!(behaviour::VEL.name(), "vel");
//! ```

pub mod behaviour;
pub mod executive;
pub mod health;
pub mod map;
pub mod navigation;
pub mod nomad200;
pub mod planner;
pub mod range;
