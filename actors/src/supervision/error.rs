//! Errors of supervision: one enum per operation.

use std::time::Duration;
use thiserror::Error;

/// Why a supervisor did not start.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum StartError {
    /// Two children of the spec have the same id.
    #[error("supervisor `{supervisor}`: more than one child has the id `{child}`")]
    DuplicateChild {
        /// The supervisor's name.
        supervisor: String,
        /// The repeated id.
        child: String,
    },
    /// A child failed to start; the children started before it were stopped again.
    #[error("supervisor `{supervisor}`: child `{child}` failed to start: {reason}")]
    ChildStart {
        /// The supervisor's name.
        supervisor: String,
        /// The child that failed.
        child: String,
        /// Why.
        reason: String,
    },
    /// ractor could not spawn the supervisor actor.
    #[error("supervisor `{supervisor}` could not be spawned: {reason}")]
    Spawn {
        /// The supervisor's name.
        supervisor: String,
        /// Why.
        reason: String,
    },
}

/// Why a child operation (`start_child`, `terminate_child`, ...) was refused or failed.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum ChildError {
    /// The supervisor has no child with this id.
    #[error("supervisor `{supervisor}` has no child `{child}`")]
    NotFound {
        /// The supervisor's name.
        supervisor: String,
        /// The id asked for.
        child: String,
    },
    /// `start_child` with an id the supervisor already has.
    #[error("supervisor `{supervisor}` already has a child `{child}`")]
    AlreadyPresent {
        /// The supervisor's name.
        supervisor: String,
        /// The id.
        child: String,
    },
    /// `restart_child` or `delete_child` on a running child: terminate it first.
    #[error("child `{child}` of supervisor `{supervisor}` is running; terminate it first")]
    Running {
        /// The supervisor's name.
        supervisor: String,
        /// The id.
        child: String,
    },
    /// The child's start function failed.
    #[error("child `{child}` of supervisor `{supervisor}` failed to start: {reason}")]
    Start {
        /// The supervisor's name.
        supervisor: String,
        /// The id.
        child: String,
        /// Why.
        reason: String,
    },
    /// The supervisor did not answer: it has stopped or failed.
    #[error("supervisor `{supervisor}` is not running: {reason}")]
    Unreachable {
        /// The supervisor's name.
        supervisor: String,
        /// What ractor said.
        reason: String,
    },
}

/// The error a supervisor fails with when it gives up; its parent sees it in
/// `SupervisionEvent::ActorFailed` (downcast the boxed error to this type).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error(
    "supervisor `{supervisor}` gave up: more than {intensity} restarts within {period:?} \
     (last: child `{child}`: {reason})"
)]
pub struct GaveUp {
    /// The supervisor's name.
    pub supervisor: String,
    /// The child whose exit was one restart too many.
    pub child: String,
    /// That child's exit reason.
    pub reason: String,
    /// The supervisor's intensity.
    pub intensity: u32,
    /// The supervisor's period.
    pub period: Duration,
}
