//! What a supervisor reports: one [`SupervisorEvent`] per child exit, restart and give-up.

use crate::{Timestamp, comm_object};
use serde::{Deserialize, Serialize};
use std::fmt;

/// What happened to a child (or to the supervisor).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SupervisorEventKind {
    /// The child exited abnormally: a handler returned an error or panicked, or it was killed.
    ChildFailed,
    /// The child stopped normally.
    ChildExited,
    /// Starting the child (during a restart) failed; the supervisor will try again, which counts
    /// as one more restart.
    StartFailed,
    /// The child was started again (after its own exit or a sibling's, or by `restart_child`).
    Restarted,
    /// The restart intensity was exceeded: the supervisor stopped its children and fails itself,
    /// escalating to its parent. `child` is the child whose exit was one restart too many.
    GaveUp,
}

impl fmt::Display for SupervisorEventKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SupervisorEventKind::ChildFailed => "child failed",
            SupervisorEventKind::ChildExited => "child exited",
            SupervisorEventKind::StartFailed => "start failed",
            SupervisorEventKind::Restarted => "restarted",
            SupervisorEventKind::GaveUp => "gave up",
        })
    }
}

/// One supervision event, stamped with the supervisor's clock.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SupervisorEvent {
    /// The supervisor's name.
    pub supervisor: String,
    /// The child's id.
    pub child: String,
    /// What happened.
    pub kind: SupervisorEventKind,
    /// Why: the exit reason, or what triggered the restart.
    pub reason: String,
    /// How many times this child has been restarted so far (after this event).
    pub restart_count: u32,
    /// The restarts the supervisor counts in its sliding window (after this event).
    pub restarts_in_period: u32,
    /// When it happened.
    pub at: Timestamp,
}
comm_object!(SupervisorEvent, "orsa.SupervisorEvent/1");

impl fmt::Display for SupervisorEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} supervisor `{}`: {} `{}` ({}; restarts: {}, in period: {})",
            self.at,
            self.supervisor,
            self.kind,
            self.child,
            self.reason,
            self.restart_count,
            self.restarts_in_period
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CommObject;

    #[test]
    fn event_round_trips() {
        let e = SupervisorEvent {
            supervisor: "base".into(),
            child: "nomad200".into(),
            kind: SupervisorEventKind::Restarted,
            reason: "child failed: bumper driver lost".into(),
            restart_count: 2,
            restarts_in_period: 1,
            at: Timestamp(1_500_000_000),
        };
        let json = serde_json::to_string(&e).expect("serialise");
        assert!(json.contains("\"kind\":\"restarted\""), "{json}");
        let back: SupervisorEvent = serde_json::from_str(&json).expect("deserialise");
        assert_eq!(back, e);
        assert_eq!(SupervisorEvent::ID, "orsa.SupervisorEvent/1");
    }
}
