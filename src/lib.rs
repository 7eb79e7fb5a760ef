//! # orsa
//!
//! Robot control software out of supervised actors. Components talk only through a small set of
//! communication patterns with fixed semantics (Send, Query, Push newest, Push timed, Event,
//! State, Wiring), carrying typed communication objects; supervisors restart what fails.
//!
//! This facade re-exports the layers, one crate each:
//! - [`actors`]: the framework core: patterns, components, supervision, registry, clock.
//! - [`interfaces`]: every communication object and one typed descriptor per service.
//! - [`hardware`]: the Nomad 200 behind board traits, its simulator and its robot server.
//! - [`reactive`]: behaviour components (wall following, center following).
//! - [`executive`]: the master that arbitrates behaviours by Wiring and State.
//! - [`planner`]: the deliberative layer that issues goals.
//!
//! Its own modules:
//! - [`system`]: assembles a system from the config, in one place (every command, the
//!   benchmarks and the whole-stack tests use it); new kinds of component register there.
//! - [`mission`]: runs the corridor mission and measures it; [`config`]: the stack's one
//!   config file.
//! - [`record`]: writes runs as MCAP; [`plot`]: draws them; [`replay`]: runs a recording's
//!   deciding components again, bit for bit or with other parameters; [`live`]: serves a
//!   running system's views to Foxglove (`--foxglove`).
//! - [`remote`]: the robot, the executive, teleoperation and the tools as separate processes
//!   over zenoh (crate `orsa-net`).
//! - [`faults`]: reads fault plans and breaks a running stack on purpose; [`ending`]: how a
//!   long-running command ends (time, signal, giving up, fatal error) and reports it.
//! - [`cli`]: the `orsa` command line; the binary only parses arguments and calls it.
//!
//! The benchmark harness is the crate `orsa-bench` (`cargo run --release -p orsa-bench`), and
//! `examples/` shows how to add a component, a behaviour and a remote client.

pub use orsa_actors as actors;
pub use orsa_executive as executive;
pub use orsa_hardware as hardware;
pub use orsa_interfaces as interfaces;
pub use orsa_planner as planner;
pub use orsa_reactive as reactive;

pub mod cli;
pub mod config;
pub mod ending;
pub mod faults;
mod keyboard;
pub mod live;
pub mod mission;
pub mod plot;
pub mod record;
pub mod remote;
pub mod replay;
pub mod system;
