//! The deliberative layer's planner: its services and what it reports.
//!
//! | service | pattern | object |
//! |---|---|---|
//! | [`NEXT`] | Send | [`Empty`]: issue the current step's goal again |
//! | [`MISSION`] | Push newest | [`MissionStatus`]: where the mission stands |
//!
//! The planner is called [`NAME`] in the default configuration.

use orsa_actors::service::{PushNewestService, SendService};
use orsa_actors::{Empty, comm_object};
use serde::{Deserialize, Serialize};

/// The planner's name in the default configuration.
pub const NAME: &str = "planner";

/// Tells the planner to issue the current step's goal.
pub const NEXT: SendService<Empty> = SendService::new("next");
/// Where the mission stands.
pub const MISSION: PushNewestService<MissionStatus> = PushNewestService::new("mission");

/// Where a mission stands (service [`MISSION`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionStatus {
    /// Index of the current step (equal to the number of steps when done).
    pub step: usize,
    /// Number of steps.
    pub steps: usize,
    /// The current goal's mode, if any.
    pub mode: Option<String>,
    /// The current goal's executive id, if accepted.
    pub goal_id: Option<u64>,
    /// Whether the mission ended, and how.
    pub finished: Option<String>,
}
comm_object!(MissionStatus, "orsa.planner.MissionStatus/1");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_round_trips() {
        let status = MissionStatus {
            step: 1,
            steps: 2,
            mode: Some("patrol".into()),
            goal_id: Some(7),
            finished: None,
        };
        let json = serde_json::to_string(&status).expect("serialise");
        assert_eq!(serde_json::from_str::<MissionStatus>(&json).expect("deserialise"), status);
    }
}
