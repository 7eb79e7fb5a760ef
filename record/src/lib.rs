//! # orsa-record
//!
//! Recordings and views of orsa runs: what a run wrote, what a replay runs again, what a plot
//! draws and what Foxglove is shown live. It depends on the framework, the interfaces and, for
//! replay and the recordings' metadata, on the system assembly (`orsa-assembly`); never on the
//! `orsa` library or the command line, which sit above it.
//!
//! Modules:
//! - [`record`]: writes a run as MCAP (JSON messages, a JSON Schema per channel), its events
//!   and metadata, and the run in Foxglove's own schemas (`record::views`).
//! - [`recording`]: a run's recording: the tap that writes every pattern message and control
//!   event, and the views a process draws.
//! - [`exchange`]: what a process exchanged with services in other processes, recorded where
//!   it crossed (what a replay feeds back).
//! - [`replay`]: runs a recording's deciding components again on its recorded inputs, bit for
//!   bit or with other parameters, and says what changed.
//! - [`plot`]: draws a run (trajectory over the map, offset and clearance over time) and a
//!   what-if, as SVG or PNG.
//! - [`live`]: serves a running system's views to Foxglove over WebSocket.

// The system assembly under the names the modules use for it.
use orsa_assembly::{config, faults, system};

pub mod exchange;
pub mod live;
pub mod plot;
pub mod record;
pub mod recording;
pub mod replay;
