//! The executive's master: its services, and the goals the deliberative layer gives it.
//!
//! | service | pattern | object |
//! |---|---|---|
//! | [`GOAL`] | Query | [`Goal`] -> [`GoalReply`]: run a mode, for a while or until preempted |
//! | [`GOALS`] | Event | [`GoalFilter`] -> [`GoalEvent`]: started, reached, failed, preempted |
//! | [`DRIVING`] | Push newest | [`WiringChange`]: which behaviour drives, in which mode |
//!
//! The master is called [`NAME`] in the default configuration.

use orsa_actors::service::{EventService, PushNewestService, QueryService};
use orsa_actors::{Timestamp, comm_object};
use serde::{Deserialize, Serialize};

/// The master's name in the default configuration.
pub const NAME: &str = "master";

/// Goals from the deliberative layer.
pub const GOAL: QueryService<Goal, GoalReply> = QueryService::new("goal");
/// Progress of goals, to the activations whose filter matches.
pub const GOALS: EventService<GoalFilter, GoalEvent> = EventService::new("goals");
/// Every change of the behaviour wired to the motors.
pub const DRIVING: PushNewestService<WiringChange> = PushNewestService::new("driving");

/// The longest goal, s (about a year): longer ones are refused rather than overflow a timer.
pub const MAX_GOAL_S: f64 = 3.2e7;

/// What the planner asks of the executive: run a mode, for a while or until told otherwise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Goal {
    /// The mode to run (a key of `executive.modes`, e.g. `patrol`, `follow_left_wall`, `stop`).
    pub mode: String,
    /// How long, in seconds of robot time; `None` until another goal preempts it.
    pub for_s: Option<f64>,
}
comm_object!(Goal, "orsa.executive.Goal/1");

/// The executive's answer to a goal.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GoalReply {
    /// Accepted under this id; progress comes as [`GoalEvent`]s.
    Accepted {
        /// The goal's id.
        id: u64,
    },
    /// Refused, and why.
    Rejected {
        /// What was wrong.
        reason: String,
        /// When the goal was refused because its mode switch failed: which change failed, in
        /// which phase, and what it left (a caller can tell a switch that could not be made
        /// now, with nothing changed, from a mode that can never be made, or from a system
        /// left half switched).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        switch: Option<orsa_actors::switch::SwitchFailure>,
    },
}
comm_object!(GoalReply, "orsa.executive.GoalReply/1");

/// How a goal stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GoalStatus {
    /// The mode is running.
    Started,
    /// Its time is up: done.
    Reached,
    /// It could not be run (a behaviour could not be activated, ...).
    Failed,
    /// Another goal replaced it before it was reached.
    Preempted,
}

/// A goal's progress (the executive's `goals` event).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GoalEvent {
    /// The goal's id.
    pub id: u64,
    /// Its mode.
    pub mode: String,
    /// What happened.
    pub status: GoalStatus,
    /// When.
    pub stamp: Timestamp,
    /// Details (why it failed).
    pub detail: String,
}
comm_object!(GoalEvent, "orsa.executive.GoalEvent/1");

/// Which goal events a client wants: one goal's, or all (`goal: None`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalFilter {
    /// The goal id to watch, or all.
    pub goal: Option<u64>,
}
comm_object!(GoalFilter, "orsa.executive.GoalFilter/1");

/// A change of which behaviour drives (the executive's `driving` push).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct WiringChange {
    /// When it took effect.
    pub stamp: Timestamp,
    /// The behaviour now wired to the motors, if any.
    pub driving: Option<String>,
    /// The mode in force.
    pub mode: Option<String>,
}
comm_object!(WiringChange, "orsa.executive.WiringChange/1");
