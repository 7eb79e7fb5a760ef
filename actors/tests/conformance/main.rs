//! Pattern conformance: each test's name starts with the pattern it tests. Every test runs on
//! tokio's paused clock unless it needs real threads (rewiring under traffic).

mod event;
mod fault;
mod ledger;
mod push_newest;
mod push_timed;
mod query;
mod restart;
mod send;
mod state;
mod tap;
mod wiring;

use orsa_actors::{Stamped, comm_object};
use serde::{Deserialize, Serialize};
use tokio::sync::mpsc;

/// A velocity command, as behaviours send them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Velocity {
    /// Forward speed.
    pub v_m_s: f64,
    /// Turn rate.
    pub omega_rad_s: f64,
}
comm_object!(Velocity, "orsa.test.Velocity/1");

/// Receives everything from a channel that is there now.
pub fn drain<T>(rx: &mut mpsc::UnboundedReceiver<Stamped<T>>) -> Vec<Stamped<T>> {
    let mut out = Vec::new();
    while let Ok(m) = rx.try_recv() {
        out.push(m);
    }
    out
}
