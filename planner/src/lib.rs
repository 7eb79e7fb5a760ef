//! orsa-planner: the deliberative layer (a stub that runs a fixed mission).
//!
//! Its one job is to say *what* the robot should do next, never *how*: it reads a mission (a
//! sequence of goals) from the config file, gives each goal to the executive by Query, and
//! listens to the executive's goal events (started, reached, failed, preempted) to move on. A
//! planning layer that chooses goals itself replaces this component without touching the
//! executive.
//!
//! ```toml
//! [planner]
//! mission = [
//!   { mode = "follow_left_wall", for_s = 120 },
//!   { mode = "patrol", for_s = 3600 },
//!   { mode = "stop" },
//! ]
//! ```
//! With no mission, the planner patrols for the whole run.
//!
//! It knows the executive by its interface (`orsa_interfaces::executive`: the `goal` query and
//! the `goals` event) and offers its own (`orsa_interfaces::planner`), so it depends on no other
//! orsa crate than `orsa-actors` and `orsa-interfaces`.

use orsa_actors::event::{EventMode, Fired};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::QueryClient;
use orsa_actors::{Component, ComponentError, Ctx};
use orsa_interfaces::executive::{self, Goal, GoalEvent, GoalFilter, GoalReply, GoalStatus, MAX_GOAL_S};
use orsa_interfaces::planner::{MISSION, MissionStatus, NEXT};
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// One goal of a mission, as written in the config file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionStep {
    /// The executive mode to run.
    pub mode: String,
    /// For how long, s (absent: until the run ends).
    pub for_s: Option<f64>,
}

/// Configuration of the planner (the `[planner]` table).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerParams {
    /// The goals, in order. Empty: patrol for the run's duration.
    pub mission: Vec<MissionStep>,
}

impl PlannerParams {
    /// Checks the mission against the executive's modes; messages name the key.
    pub fn validate(&self, modes: &[&str]) -> Result<(), String> {
        for (i, step) in self.mission.iter().enumerate() {
            if !modes.contains(&step.mode.as_str()) {
                return Err(format!(
                    "planner.mission[{i}].mode: '{}' is not an executive mode {modes:?}",
                    step.mode
                ));
            }
            if let Some(s) = step.for_s
                && !(s.is_finite() && (0.0..=MAX_GOAL_S).contains(&s))
            {
                return Err(format!(
                    "planner.mission[{i}].for_s: must be a number of seconds from 0 to {}",
                    MAX_GOAL_S
                ));
            }
        }
        Ok(())
    }

    /// The mission to run in a run of `duration_s`: the configured one, or patrol throughout.
    pub fn mission_for(&self, duration_s: f64) -> Vec<MissionStep> {
        if self.mission.is_empty() {
            vec![MissionStep { mode: "patrol".into(), for_s: Some(duration_s) }]
        } else {
            self.mission.clone()
        }
    }
}

/// The planner component.
#[derive(Debug, Clone)]
pub struct Planner {
    /// The goals to run, in order.
    pub mission: Vec<MissionStep>,
    /// The executive component's name.
    pub executive: String,
}

/// Messages of the [`Planner`].
#[derive(Debug)]
pub enum PlannerMsg {
    /// Issue the current step's goal.
    Next,
    /// A goal event from the executive.
    Event(Fired<GoalEvent>),
}

/// The planner's running state.
pub struct PlannerState {
    step: usize,
    goal_id: Option<u64>,
    goals: QueryClient<Goal, GoalReply>,
    status: PushNewestServer<MissionStatus>,
}

impl Planner {
    fn publish(&self, st: &PlannerState, finished: Option<String>) {
        st.status.put(MissionStatus {
            step: st.step,
            steps: self.mission.len(),
            mode: self.mission.get(st.step).map(|s| s.mode.clone()),
            goal_id: st.goal_id,
            finished,
        });
    }
}

impl Component for Planner {
    type Msg = PlannerMsg;
    type State = PlannerState;

    async fn setup(&self, ctx: &Ctx<PlannerMsg>) -> Result<PlannerState, ComponentError> {
        let exec = self.executive.as_str();
        let goals = ctx.query_client(executive::GOAL.on(exec))?;
        let events = ctx.event_client(executive::GOALS.on(exec))?;
        events.activate_to(
            EventMode::Continuous,
            GoalFilter { goal: None },
            ctx.mailbox().sink(PlannerMsg::Event),
        )?;
        ctx.send_server(NEXT, |_| PlannerMsg::Next)?;
        let status = ctx.push_newest_server(MISSION)?;
        ctx.mailbox().cast(PlannerMsg::Next).map_err(|_| "planner: cannot reach its own mailbox")?;
        Ok(PlannerState { step: 0, goal_id: None, goals, status })
    }

    async fn handle(
        &self,
        ctx: &Ctx<PlannerMsg>,
        st: &mut PlannerState,
        msg: PlannerMsg,
    ) -> Result<(), ComponentError> {
        match msg {
            PlannerMsg::Next => {
                let Some(step) = self.mission.get(st.step) else {
                    self.publish(st, Some("completed".into()));
                    return Ok(());
                };
                let goal = Goal { mode: step.mode.clone(), for_s: step.for_s };
                match st.goals.query(goal, Some(Duration::from_secs(5))).await? {
                    GoalReply::Accepted { id } => {
                        st.goal_id = Some(id);
                        self.publish(st, None);
                    }
                    GoalReply::Rejected { reason } => {
                        tracing::error!("planner: goal {} ({}) rejected: {reason}", st.step, step.mode);
                        self.publish(st, Some(format!("aborted: step {} rejected: {reason}", st.step)));
                    }
                }
            }
            PlannerMsg::Event(fired) => {
                let ev = fired.event.value;
                if Some(ev.id) != st.goal_id {
                    return Ok(());
                }
                match ev.status {
                    GoalStatus::Started => {}
                    GoalStatus::Reached => {
                        st.step += 1;
                        st.goal_id = None;
                        ctx.mailbox()
                            .cast(PlannerMsg::Next)
                            .map_err(|_| "planner: own mailbox unreachable")?;
                    }
                    GoalStatus::Failed | GoalStatus::Preempted => {
                        tracing::warn!("planner: goal {} {:?}: {}", ev.id, ev.status, ev.detail);
                        st.goal_id = None;
                        self.publish(
                            st,
                            Some(format!("aborted: goal {} {:?} {}", ev.id, ev.status, ev.detail)),
                        );
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_mission_patrols_for_the_run_and_bad_steps_are_named() {
        let p = PlannerParams::default();
        assert_eq!(p.mission_for(60.0), vec![MissionStep { mode: "patrol".into(), for_s: Some(60.0) }]);
        let bad = PlannerParams {
            mission: vec![
                MissionStep { mode: "patrol".into(), for_s: None },
                MissionStep { mode: "dance".into(), for_s: None },
            ],
        };
        let e = bad.validate(&["patrol", "stop"]).expect_err("invalid");
        assert!(e.starts_with("planner.mission[1].mode: 'dance'"), "{e}");
    }
}
