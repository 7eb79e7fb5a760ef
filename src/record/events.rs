//! Control events a recording holds that are not pattern messages: what a process did on its
//! own (the robot's link watchdog) and when its fault plan's clock started. A replay feeds them
//! back at their recorded times (see [`crate::replay`]).

use serde::{Deserialize, Serialize};

/// Topic of the robot's link watchdog: an executive lost or back.
pub const LINK_EVENTS: &str = "link/events";
/// Communication object of [`LINK_EVENTS`].
pub const LINK_EVENT: &str = "orsa.LinkEvent/1";
/// Topic with one message, at the instant a process's fault plan started (its `at` 0), when
/// that is not the start of the run (`orsa robot --faults` starts it once on the network).
pub const FAULTS_STARTED: &str = "faults/started";
/// Communication object of [`FAULTS_STARTED`].
pub const FAULTS_STARTED_TYPE: &str = "orsa.FaultsStarted/1";

/// What the robot's link watchdog did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinkEvent {
    /// The executive's zenoh id.
    pub executive: String,
    /// Lost (the robot unwired its behaviours and commanded zero), or back.
    pub event: LinkEventKind,
    /// Why, in words.
    pub why: String,
    /// The command it then sent the motors (zero, stamped by the live clock), if any: a replay
    /// sends it again, as it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command: Option<orsa_interfaces::nomad200::NavigationVelocity>,
}

/// See [`LinkEvent::event`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinkEventKind {
    /// The executive was lost: the behaviours were unwired and the motors commanded to zero.
    Lost,
    /// It was heard again.
    Back,
}

/// The message on [`FAULTS_STARTED`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FaultsStarted {
    /// Faults in the plan.
    pub faults: usize,
}
