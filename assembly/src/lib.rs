//! # orsa-assembly
//!
//! Assembles an orsa system from its config, in one place: every command, the recording
//! crate's replay, the benchmarks and the whole-stack tests start their components through it.
//!
//! Modules:
//! - [`config`]: the stack's one config file (`config/orsa.toml`), deserialised into typed
//!   tables, unknown keys refused with file and line.
//! - [`spec`]: the `[system]` table (what the config file says runs where; below both the
//!   config and the system, so neither depends on the other both ways).
//! - [`system`]: the `[system]` table's re-exports, the catalog of component kinds and the builder that
//!   starts a system's components under one supervisor; the names of the processes' top
//!   supervisors; the system's live parameters by name.
//! - [`faults`]: fault plans (what to break, when, for how long), the task that carries one out
//!   and what a report says of it.
//!
//! It sits below the recording crate (`orsa-record`), which replays a recording through this
//! assembly, and below the `orsa` library, which runs missions and processes with it.

pub mod config;
pub mod faults;
pub mod spec;
pub mod system;
