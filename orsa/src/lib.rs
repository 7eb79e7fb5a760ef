//! # orsa
//!
//! Robot control software out of supervised actors. Components talk only through a small set of
//! communication patterns with fixed semantics (Send, Query, Push newest, Push timed, Event,
//! State, Wiring), carrying typed communication objects; supervisors restart what fails.
//!
//! This library runs orsa's systems: the corridor mission in one process, and the robot, the
//! executive, teleoperation and the tools as processes over zenoh. The `orsa` binary (crate
//! `orsa-cli`, at the workspace root) only parses arguments and calls it; nothing here knows of
//! a command line.
//!
//! It re-exports the layers, one crate each:
//! - [`actors`]: the framework core: patterns, components, supervision, registry, clock.
//! - [`interfaces`]: every communication object and one typed descriptor per service.
//! - [`hardware`]: the Nomad 200 behind board traits, its simulator and its robot server.
//! - [`reactive`]: behaviour components (wall following, center following).
//! - [`executive`]: the master that arbitrates behaviours by Wiring and State.
//! - [`planner`]: the deliberative layer that issues goals.
//! - [`system`], [`config`], [`faults`] (crate `orsa-assembly`): assembles a system from the
//!   config, in one place (every command, the benchmarks and the whole-stack tests use it; new
//!   kinds of component register there); the stack's one config file; fault plans.
//! - [`record`], [`replay`], [`plot`], [`live`] (crate `orsa-record`): writes runs as MCAP,
//!   runs a recording's deciding components again, draws runs, serves views to Foxglove.
//!
//! Its own modules:
//! - [`mission`]: runs the corridor mission and measures it.
//! - [`remote`]: the robot, the executive, teleoperation and the tools as separate processes
//!   over zenoh (crate `orsa-net`), each run from a plain options struct.
//! - [`ending`]: how a long-running command ends (time, signal, giving up, fatal error), its
//!   [`Outcome`](ending::Outcome) and exit code; [`logline`]: its log lines, to stderr and to
//!   `/rosout`; [`output`]: what a command writes (lines on
//!   stdout, files in folders that may not exist yet).
//!
//! The benchmark harness is the crate `orsa-bench` (`cargo run --release -p orsa-bench`), and
//! `examples/` shows how to add a component, a behaviour and a remote client.

pub use orsa_actors as actors;
pub use orsa_assembly::{config, faults, system};
pub use orsa_executive as executive;
pub use orsa_hardware as hardware;
pub use orsa_interfaces as interfaces;
pub use orsa_planner as planner;
pub use orsa_reactive as reactive;
pub use orsa_record::{live, plot, record, replay};

pub mod ending;
mod keyboard;
pub mod logline;
pub mod mission;
pub mod output;
pub mod remote;
