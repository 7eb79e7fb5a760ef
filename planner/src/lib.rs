//! orsa-planner: the deliberative layer (a stub that runs a fixed mission).
//!
//! Its one job is to say *what* the robot should do next, never *how*: it reads a mission (a
//! sequence of goals) from the config file, gives each goal to the executive by Query, and
//! listens to the executive's goal events (started, reached, failed, preempted) to move on. A
//! planning layer that chooses goals itself replaces this component without touching the
//! executive.
//!
//! ```toml
//! [params.planner]
//! mission = [
//!   { mode = "follow_left_wall", for_s = 120 },
//!   { mode = "patrol", for_s = 3600 },
//!   { mode = "stop" },
//! ]
//! ```
//! With no mission, the planner patrols for the whole run.
//!
//! A goal the executive refuses because its mode switch failed comes with the typed failure
//! (`GoalReply::Rejected { switch }`), and the planner tells three cases apart:
//! - the switch failed while being made and everything was undone (a behaviour busy in its
//!   critical section past the step timeout, a link lost for a moment): the executive still runs
//!   the previous goal, and the planner gives the goal again after `retry_after_s`, up to
//!   `retries` times;
//! - the switch failed while being prepared (the mode names something that cannot be made): a
//!   retry cannot help, the mission is aborted naming the change;
//! - the switch could not be undone everywhere: the system is half switched (the executive has
//!   stopped the motors), the mission is aborted naming what was left.
//!
//! It knows the executive by its interface (`orsa_interfaces::executive`: the `goal` query and
//! the `goals` event) and offers its own (`orsa_interfaces::planner`), so it depends on no other
//! orsa crate than `orsa-actors` and `orsa-interfaces`.

use orsa_actors::event::{EventMode, Fired};
use orsa_actors::param::Invalid;
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::QueryClient;
use orsa_actors::switch::Phase;
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

/// Configuration of the planner (the planner's `[params.planner]` table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerParams {
    /// The goals, in order. Empty: patrol for the run's duration.
    pub mission: Vec<MissionStep>,
    /// How many times a goal whose mode switch could not be made now (nothing changed) is
    /// given again before the mission is aborted.
    pub retries: u32,
    /// How long to wait before giving it again, s.
    pub retry_after_s: f64,
}

impl Default for PlannerParams {
    fn default() -> Self {
        PlannerParams { mission: Vec::new(), retries: 3, retry_after_s: 1.0 }
    }
}

/// The most `planner.retries` may be.
pub const MAX_RETRIES: u32 = 100;
/// The longest `planner.retry_after_s` may be, s.
pub const MAX_RETRY_AFTER_S: f64 = 600.0;

impl PlannerParams {
    /// Checks the mission against the executive's modes; messages name the key.
    pub fn validate(&self, modes: &[&str]) -> Result<(), Invalid> {
        if self.retries > MAX_RETRIES {
            return Err(Invalid::new(
                "planner.retries",
                format!("must be at most {MAX_RETRIES}, not {}", self.retries),
            ));
        }
        if !(self.retry_after_s.is_finite() && (0.0..=MAX_RETRY_AFTER_S).contains(&self.retry_after_s)) {
            return Err(Invalid::new(
                "planner.retry_after_s",
                format!(
                    "must be a number of seconds from 0 to {MAX_RETRY_AFTER_S}, not {}",
                    self.retry_after_s
                ),
            ));
        }
        for (i, step) in self.mission.iter().enumerate() {
            if !modes.contains(&step.mode.as_str()) {
                return Err(Invalid::new(
                    format!("planner.mission[{i}].mode"),
                    format!("'{}' is not an executive mode {modes:?}", step.mode),
                ));
            }
            if let Some(s) = step.for_s
                && !(s.is_finite() && (0.0..=MAX_GOAL_S).contains(&s))
            {
                return Err(Invalid::new(
                    format!("planner.mission[{i}].for_s"),
                    format!("must be a number of seconds from 0 to {MAX_GOAL_S}"),
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
    /// How many times a goal whose switch could not be made now is given again.
    pub retries: u32,
    /// How long to wait before giving it again.
    pub retry_after: Duration,
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
    /// How many times the current step's goal was given again.
    retried: u32,
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
        Ok(PlannerState { step: 0, retried: 0, goal_id: None, goals, status })
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
                        st.retried = 0;
                        self.publish(st, None);
                    }
                    GoalReply::Rejected { switch: Some(f), reason }
                        if f.phase == Phase::Commit && f.nothing_changed() && st.retried < self.retries =>
                    {
                        st.retried += 1;
                        tracing::warn!(
                            "planner: goal {} ({}) could not be switched to now ({reason}); the previous goal \
                             goes on; giving it again in {:?} ({} of {})",
                            st.step,
                            step.mode,
                            self.retry_after,
                            st.retried,
                            self.retries
                        );
                        let mailbox = ctx.mailbox().clone();
                        let after = self.retry_after;
                        tokio::spawn(async move {
                            tokio::time::sleep(after).await;
                            let _ = mailbox.cast(PlannerMsg::Next);
                        });
                    }
                    GoalReply::Rejected { reason, switch } => {
                        let why = match &switch {
                            Some(f) if !f.nothing_changed() => "the system is left half switched",
                            Some(f) if f.phase == Phase::Prepare => "its mode cannot be made",
                            Some(_) => "its mode switch failed every time",
                            None => "the goal is invalid",
                        };
                        tracing::error!(
                            "planner: goal {} ({}) rejected, {why}: {reason}",
                            st.step,
                            step.mode
                        );
                        self.publish(
                            st,
                            Some(format!("aborted: step {} rejected, {why}: {reason}", st.step)),
                        );
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
            ..PlannerParams::default()
        };
        let e = bad.validate(&["patrol", "stop"]).expect_err("invalid").to_string();
        assert!(e.starts_with("planner.mission[1].mode: 'dance'"), "{e}");
        for (p, key) in [
            (PlannerParams { retries: MAX_RETRIES + 1, ..PlannerParams::default() }, "planner.retries"),
            (PlannerParams { retry_after_s: -1.0, ..PlannerParams::default() }, "planner.retry_after_s"),
            (PlannerParams { retry_after_s: f64::NAN, ..PlannerParams::default() }, "planner.retry_after_s"),
        ] {
            let e = p.validate(&["patrol"]).expect_err("invalid");
            assert_eq!(e.key, key);
            assert!(e.to_string().starts_with(key), "{e}");
        }
        assert_eq!(PlannerParams::default().validate(&["patrol"]), Ok(()));
    }
}
