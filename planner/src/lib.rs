//! orsa-planner: the deliberative layer: missions of modes and of places to go to.
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
//! A step may also send the robot to a place (`{ goto = "room-3" }`, or `"X,Y[,HEADING_DEG]"`)
//! or patrol for a time (`{ patrol = 600 }`). Going to a place is a navigation goal
//! ([`navigate`]): the planner plans the body's path on the known map from the localizer's
//! pose, gives it to the path follower, asks the executive for the mode `navigate` (which wires
//! the path follower to the motors), follows the goal's progress, and when the robot has made
//! none for `stuck_s` climbs a ladder of recoveries (back up 0.3 m; forget the obstacle layer
//! and back up; turn round on the spot; each followed by a new plan from where it is, up to
//! `recoveries` times) before it aborts naming why. While the localizer says the robot is
//! lost, the goal holds and the robot turns on the spot until it is found (at most `lost_s`). A step that aborts is skipped, tried again
//! once, or ends the mission (`on_abort`). The same goals come from outside on the planner's
//! `navigate` query (`orsa goto`), with feedback and results on `navigation`
//! (`orsa_interfaces::navigation`); a newer goal preempts the one running.
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
//! the `goals` event) and offers its own (`orsa_interfaces::planner`,
//! `orsa_interfaces::navigation`); below it, it uses only the navigation layer's planner
//! (`orsa-navigation`).

pub mod navigate;

use navigate::{GoalPose, Judge, NavMap, Progress, Verdict, blocked, distance_left, route};
use orsa_actors::event::{EventMode, Fired};
use orsa_actors::param::Invalid;
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::{QueryClient, QueryRequest};
use orsa_actors::send::SendClient;
use orsa_actors::switch::Phase;
use orsa_actors::{Component, ComponentError, Ctx, Empty, Stamped, Update};
use orsa_interfaces::executive::{self, Goal, GoalEvent, GoalFilter, GoalReply, GoalStatus, MAX_GOAL_S};
use orsa_interfaces::map::{self, KnownMap};
use orsa_interfaces::navigation::{
    self, CANCEL, FollowPath, NAVIGATE, NAVIGATION, NavCancel, NavFeedback, NavGoal, NavReply, NavState,
    NavTarget, PoseEstimate,
};
use orsa_interfaces::nomad200::{self, BaseState, DistanceScan, RingParams, RobotParams};
use orsa_interfaces::planner::{MISSION, MissionStatus, NEXT};
use orsa_navigation::layer::ObstacleLayer;
use orsa_navigation::localizer::ring_beams;
use orsa_navigation::mcl::Pose2;
use orsa_navigation::plan::PlanParams;
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// Echoes this close to what the known map holds are the map's own walls, m (the obstacle
/// layer leaves them out).
pub const EXPLAINED_M: f64 = 0.1;

/// The executive mode that drives to places: the path follower wired to the motors.
pub const NAVIGATE_MODE: &str = "navigate";

/// One step of a mission, as written in the config file: exactly one of `mode` (with
/// `for_s`), `goto` or `patrol`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionStep {
    /// The executive mode to run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<String>,
    /// For how long, s (absent: until the run ends).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub for_s: Option<f64>,
    /// A place to go to: its name, or `X,Y[,HEADING_DEG]` in the map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goto: Option<String>,
    /// Patrol for this many seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub patrol: Option<f64>,
}

/// What a step asks for.
#[derive(Debug, Clone, PartialEq)]
pub enum StepKind {
    /// Run a mode, for a time or until preempted.
    Mode(String, Option<f64>),
    /// Go to a place.
    Goto(NavTarget),
}

impl MissionStep {
    /// A step that runs `mode` for `for_s`.
    pub fn mode(mode: &str, for_s: Option<f64>) -> Self {
        MissionStep { mode: Some(mode.into()), for_s, ..MissionStep::default() }
    }

    /// A step that goes to `target` (a place's name or `X,Y[,HEADING_DEG]`).
    pub fn goto(target: &str) -> Self {
        MissionStep { goto: Some(target.into()), ..MissionStep::default() }
    }

    /// What it asks for, or why it is not a step.
    pub fn kind(&self) -> Result<StepKind, String> {
        match (&self.mode, &self.goto, self.patrol) {
            (Some(m), None, None) => Ok(StepKind::Mode(m.clone(), self.for_s)),
            (None, Some(g), None) if self.for_s.is_none() => NavTarget::parse(g).map(StepKind::Goto),
            (None, None, Some(s)) if self.for_s.is_none() => Ok(StepKind::Mode("patrol".into(), Some(s))),
            _ => Err("give exactly one of `mode` (with `for_s`), `goto` or `patrol`".into()),
        }
    }
}

/// What the planner does when a step aborts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OnAbort {
    /// Go on with the next step.
    #[default]
    Skip,
    /// Try the step once more, then go on.
    Retry,
    /// End the mission.
    Abort,
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
    /// What to do when a step aborts.
    pub on_abort: OnAbort,
    /// A place is reached when the estimate is this close to it and the robot has stopped, m.
    pub arrive_m: f64,
    /// ... and within this angle of its heading, degrees.
    pub arrive_deg: f64,
    /// Without coming 0.2 m closer for this long, the robot is stuck: next recovery, s.
    pub stuck_s: f64,
    /// How many recoveries (back up, clear the layer and back up, turn round: each then plans
    /// again from where it is) before a goal aborts.
    pub recoveries: u32,
    /// The speed the ETA assumes, m/s.
    pub cruise_m_s: f64,
    /// The least gap a path leaves between the body and what the map holds, m.
    pub clearance_m: f64,
    /// While the localizer says the robot is lost, a goal holds (the robot turns on the spot
    /// to look round); lost this long, it aborts, s.
    pub lost_s: f64,
}

impl Default for PlannerParams {
    fn default() -> Self {
        PlannerParams {
            mission: Vec::new(),
            retries: 3,
            retry_after_s: 1.0,
            on_abort: OnAbort::Skip,
            arrive_m: 0.15,
            arrive_deg: 10.0,
            stuck_s: 20.0,
            recoveries: 3,
            cruise_m_s: 0.4,
            clearance_m: 0.05,
            lost_s: 60.0,
        }
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
        for (key, v, lo, hi) in [
            ("arrive_m", self.arrive_m, 0.01, 5.0),
            ("arrive_deg", self.arrive_deg, 0.1, 180.0),
            ("stuck_s", self.stuck_s, 1.0, 3600.0),
            ("lost_s", self.lost_s, 1.0, 3600.0),
            ("cruise_m_s", self.cruise_m_s, 0.01, 10.0),
            ("clearance_m", self.clearance_m, 0.0, 2.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(Invalid::new(
                    format!("planner.{key}"),
                    format!("must be from {lo} to {hi}, not {v}"),
                ));
            }
        }
        if self.recoveries > 100 {
            return Err(Invalid::new("planner.recoveries", "must be at most 100"));
        }
        for (i, step) in self.mission.iter().enumerate() {
            let kind = step.kind().map_err(|e| Invalid::new(format!("planner.mission[{i}]"), e))?;
            let (mode, for_s, key) = match &kind {
                StepKind::Mode(m, s) if step.patrol.is_some() => (m.as_str(), *s, "patrol"),
                StepKind::Mode(m, s) => (m.as_str(), *s, "for_s"),
                StepKind::Goto(_) => (NAVIGATE_MODE, None, "goto"),
            };
            if !modes.contains(&mode) {
                let at = if key == "for_s" { "mode" } else { key };
                let hint = match key {
                    "goto" => {
                        " (a mission with places needs the navigation components: `orsa run --goto`, or config/navigation.toml)"
                    }
                    _ => "",
                };
                return Err(Invalid::new(
                    format!("planner.mission[{i}].{at}"),
                    format!("'{mode}' is not an executive mode {modes:?}{hint}"),
                ));
            }
            if let Some(s) = for_s
                && !(s.is_finite() && (0.0..=MAX_GOAL_S).contains(&s))
            {
                return Err(Invalid::new(
                    format!("planner.mission[{i}].{key}"),
                    format!("must be a number of seconds from 0 to {MAX_GOAL_S}"),
                ));
            }
        }
        Ok(())
    }

    /// The mission to run in a run of `duration_s`: the configured one, or patrol throughout.
    pub fn mission_for(&self, duration_s: f64) -> Vec<MissionStep> {
        if self.mission.is_empty() {
            vec![MissionStep::mode("patrol", Some(duration_s))]
        } else {
            self.mission.clone()
        }
    }

    /// Whether a step goes to a place.
    pub fn navigates(&self) -> bool {
        self.mission.iter().any(|s| s.goto.is_some())
    }

    /// How goals are judged.
    pub fn judge(&self) -> Judge {
        Judge {
            arrive_m: self.arrive_m,
            arrive_rad: self.arrive_deg.to_radians(),
            progress_m: 0.2,
            stuck_s: self.stuck_s,
            lost_s: self.lost_s,
        }
    }
}

/// What the planner needs to send the robot to places.
#[derive(Debug, Clone)]
pub struct NavSetup {
    /// The map component: the known map and its places come from it (`known`), wherever the
    /// planner runs.
    pub map: String,
    /// The robot server (its odometry says when it has stopped; its geometry sizes paths).
    pub robot: String,
    /// How goals are judged.
    pub judge: Judge,
    /// Recoveries before a goal aborts.
    pub recoveries: u32,
    /// The speed the ETA assumes, m/s.
    pub cruise_m_s: f64,
    /// The least gap a path leaves, m.
    pub clearance_m: f64,
}

/// How often a lost robot is told to turn round again while the localizer looks, s (a turn
/// at the path follower's default pace takes about 16 s).
const LOOK_ROUND_S: f64 = 20.0;
/// How far a stuck robot backs up, m.
const BACK_M: f64 = 0.3;
/// How long backing up is given, s (0.3 m at 0.1 m/s, and a margin).
const BACK_S: f64 = 5.0;
/// How far a robot backs off from something close that blocks its way, m: a person who
/// pauses for the robot (most keep 0.6 m) walks on once it has.
const BACK_OFF_M: f64 = 0.5;
/// Within this of the body's inflated edge, what blocks the way is close, m.
const BACK_OFF_NEAR_M: f64 = 0.6;

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
    /// What to do when a step aborts.
    pub on_abort: OnAbort,
    /// The map, if the planner sends the robot to places.
    pub nav: Option<NavSetup>,
}

/// Messages of the [`Planner`].
#[derive(Debug)]
pub enum PlannerMsg {
    /// Issue the current step's goal.
    Next,
    /// A goal event from the executive.
    Event(Fired<GoalEvent>),
    /// The localizer's estimate.
    Pose(Update<PoseEstimate>),
    /// The robot's odometry.
    Base(Update<BaseState>),
    /// The robot's near range view (what the obstacle layer is made of).
    Ir(Update<DistanceScan>),
    /// A navigation goal from outside.
    Navigate(QueryRequest<NavGoal, NavReply>),
    /// A cancel from outside.
    Cancel(Stamped<NavCancel>),
}

/// A navigation goal being driven to.
struct Active {
    id: u64,
    target: NavTarget,
    goal: GoalPose,
    path: Vec<[f64; 2]>,
    progress: Progress,
    recoveries: u32,
    from_mission: bool,
    /// Since when no path gets past what the layer holds, s.
    blocked_since: Option<f64>,
    /// When a blocked goal last tried to plan again, s.
    tried_s: f64,
    /// Whether the layer was cleared for it already (a recovery).
    cleared: bool,
    /// Whether it backed off from something close in its way already.
    backed_off: bool,
    /// When feedback was last published, s.
    told_s: f64,
    /// Since when the localizer says the robot is lost, s, and when it was last told to turn
    /// on the spot.
    lost: Option<(f64, f64)>,
    /// A recovery manoeuvre under way: until when, s, and what it is.
    recovering: Option<(f64, String)>,
}

/// What the planner keeps for navigation.
struct NavState_ {
    /// The known map and its places, as the map component gave them.
    map: NavMap,
    path: SendClient<FollowPath>,
    feedback: PushNewestServer<NavFeedback>,
    plan: PlanParams,
    pose: Option<(f64, f64, f64)>,
    /// Whether the localizer says the robot is lost (the pose is not to be driven on).
    lost: bool,
    stopped: bool,
    next_id: u64,
    active: Option<Active>,
    /// A mission step waits for the first estimate.
    waiting: bool,
    /// A goal from outside, accepted before the first estimate, waits for it: its id and
    /// target.
    pending: Option<(u64, NavTarget)>,
    /// What the near range view saw that the map does not hold.
    layer: ObstacleLayer,
    /// The newest near range view.
    ir: Option<DistanceScan>,
    /// Where its sensors are.
    ring: RingParams,
    beams: Vec<orsa_navigation::mcl::Beam>,
}

/// The planner's running state.
pub struct PlannerState {
    step: usize,
    /// How many times the current step's goal was given again.
    retried: u32,
    /// How many times the current step was tried after aborting.
    attempts: u32,
    goal_id: Option<u64>,
    goals: QueryClient<Goal, GoalReply>,
    status: PushNewestServer<MissionStatus>,
    nav: Option<NavState_>,
    /// The steps given up and skipped (the skip policy), each `step N why`: the mission's
    /// end says so.
    skipped: Vec<String>,
}

/// Publishes how goal `id` to `target` stands, for a goal with no path (rejected, waiting,
/// canceled before it started).
fn tell(
    ctx: &Ctx<PlannerMsg>,
    nav: &NavState_,
    id: u64,
    target: &NavTarget,
    goal: Option<GoalPose>,
    state: NavState,
    reason: &str,
) {
    nav.feedback.put(NavFeedback {
        stamp: ctx.now(),
        id,
        target: target.clone(),
        goal: goal.map(|g| [g.x_m, g.y_m]),
        state,
        reason: reason.into(),
        distance_left_m: 0.0,
        eta_s: 0.0,
        path: Vec::new(),
    });
}

fn secs(ctx: &Ctx<PlannerMsg>) -> f64 {
    ctx.now().0 as f64 * 1e-9
}

impl Planner {
    fn publish(&self, st: &PlannerState, finished: Option<String>) {
        let mode = self.mission.get(st.step).and_then(|s| match s.kind() {
            Ok(StepKind::Mode(m, _)) => Some(m),
            Ok(StepKind::Goto(t)) => Some(format!("goto {t}")),
            Err(_) => None,
        });
        st.status.put(MissionStatus {
            step: st.step,
            steps: self.mission.len(),
            mode,
            goal_id: st.goal_id,
            finished,
        });
    }

    fn next(ctx: &Ctx<PlannerMsg>) -> Result<(), ComponentError> {
        ctx.mailbox().cast(PlannerMsg::Next).map_err(|_| "planner: cannot reach its own mailbox".into())
    }

    /// Asks the executive for `mode`; the reply.
    async fn ask(
        &self,
        st: &mut PlannerState,
        mode: &str,
        for_s: Option<f64>,
    ) -> Result<GoalReply, ComponentError> {
        Ok(st.goals.query(Goal { mode: mode.into(), for_s }, Some(Duration::from_secs(5))).await?)
    }

    fn feedback(&self, ctx: &Ctx<PlannerMsg>, nav: &NavState_, a: &Active, state: NavState, reason: &str) {
        let Some(setup) = &self.nav else { return };
        let left = nav.pose.map_or(f64::NAN, |p| distance_left(&a.path, p.0, p.1));
        nav.feedback.put(NavFeedback {
            stamp: ctx.now(),
            id: a.id,
            target: a.target.clone(),
            goal: Some([a.goal.x_m, a.goal.y_m]),
            state,
            reason: reason.into(),
            distance_left_m: left,
            eta_s: left / setup.cruise_m_s,
            path: a.path.clone(),
        });
    }

    /// Starts driving to `target` (as goal `id` if it was accepted already, else under a new
    /// id); its id, or why it is rejected.
    async fn start_goal(
        &self,
        ctx: &Ctx<PlannerMsg>,
        st: &mut PlannerState,
        target: NavTarget,
        from_mission: bool,
        id: Option<u64>,
    ) -> Result<u64, String> {
        let Some(nav) = st.nav.as_mut() else {
            return Err("this planner has no map: it cannot send the robot to places".into());
        };
        let id = id.unwrap_or_else(|| {
            nav.next_id += 1;
            nav.next_id
        });
        let refuse = |nav: &NavState_, why: String, goal: Option<GoalPose>| {
            tell(ctx, nav, id, &target, goal, NavState::Rejected, &why);
            why
        };
        let goal = nav.map.resolve(&target).map_err(|why| refuse(nav, why, None))?;
        let pose =
            nav.pose.ok_or_else(|| refuse(nav, "no estimate of the robot's pose yet".into(), Some(goal)))?;
        // Rejected at once if the known map has no way there; around what the sensors see if
        // there is one.
        let known =
            nav.map.route((pose.0, pose.1), goal, &nav.plan).map_err(|why| refuse(nav, why, Some(goal)))?;
        let path = if nav.layer.marks() > 0 {
            nav.layer.clear_near(pose.0, pose.1, nav.plan.robot_radius_m + 0.05);
            route(&nav.layer.grid(), (pose.0, pose.1), goal, &nav.plan).unwrap_or(known)
        } else {
            known
        };
        if let Some(old) = nav.active.take() {
            self.feedback(ctx, nav, &old, NavState::Canceled, &format!("preempted by goal {id}"));
        }
        nav.path
            .send(FollowPath::along(id, path.clone(), goal.heading_rad))
            .map_err(|e| format!("the path follower cannot be reached: {e}"))?;
        let left = distance_left(&path, pose.0, pose.1);
        let a = Active {
            id,
            target,
            goal,
            path,
            progress: Progress::new(left, secs(ctx)),
            recoveries: 0,
            from_mission,
            told_s: secs(ctx),
            blocked_since: None,
            tried_s: secs(ctx),
            cleared: false,
            backed_off: false,
            lost: None,
            recovering: None,
        };
        self.feedback(ctx, nav, &a, NavState::Active, "");
        nav.active = Some(a);
        match self.ask(st, NAVIGATE_MODE, None).await {
            Ok(GoalReply::Accepted { id: exec }) => {
                st.goal_id = Some(exec);
                Ok(id)
            }
            Ok(GoalReply::Rejected { reason, .. }) => {
                self.end_goal(
                    ctx,
                    st,
                    NavState::Aborted,
                    &format!("the executive refused to navigate: {reason}"),
                )
                .map_err(|e| e.to_string())?;
                Err(format!("the executive refused to navigate: {reason}"))
            }
            Err(e) => Err(format!("the executive cannot be reached: {e}")),
        }
    }

    /// Ends the running goal as `state`, stops the path follower, and moves the mission on.
    fn end_goal(
        &self,
        ctx: &Ctx<PlannerMsg>,
        st: &mut PlannerState,
        state: NavState,
        reason: &str,
    ) -> Result<(), ComponentError> {
        let Some(nav) = st.nav.as_mut() else { return Ok(()) };
        let Some(a) = nav.active.take() else { return Ok(()) };
        let _ = nav.path.send(FollowPath::stop(a.id));
        if state == NavState::Aborted {
            // What blocked it may be gone by the next goal (a person who stood in a door), and
            // marks no beam passes again would hold every later goal there: the next starts on
            // the known map, and what is still there is seen again.
            nav.layer.clear_all();
        }
        self.feedback(ctx, nav, &a, state, reason);
        match state {
            NavState::Succeeded => tracing::info!("planner: goal {} ({}) reached", a.id, a.target),
            _ => tracing::warn!("planner: goal {} ({}) {}: {reason}", a.id, a.target, state.name()),
        }
        if a.from_mission {
            self.step_ended(ctx, st, state == NavState::Succeeded, reason)?;
        }
        Ok(())
    }

    /// A mission step ended, well or not: the next one, as `on_abort` says.
    fn step_ended(
        &self,
        ctx: &Ctx<PlannerMsg>,
        st: &mut PlannerState,
        ok: bool,
        reason: &str,
    ) -> Result<(), ComponentError> {
        st.goal_id = None;
        if !ok {
            match self.on_abort {
                OnAbort::Retry if st.attempts == 0 => {
                    st.attempts += 1;
                    return Self::next(ctx);
                }
                OnAbort::Abort => {
                    self.publish(st, Some(format!("aborted: step {} {reason}", st.step)));
                    return Ok(());
                }
                _ => st.skipped.push(format!("step {} {reason}", st.step)),
            }
        }
        st.step += 1;
        st.attempts = 0;
        Self::next(ctx)
    }

    /// How a mission whose steps all ran ended: `completed`, `completed with N of M steps
    /// skipped: ...` if some were given up, or `failed: all M steps skipped: ...` if every one
    /// was (a mission that reached nothing did not complete).
    fn mission_end(&self, st: &PlannerState) -> String {
        let steps = self.mission.len();
        match st.skipped.len() {
            0 => "completed".into(),
            n if n == steps => format!("failed: all {steps} steps skipped: {}", st.skipped.join("; ")),
            n => format!("completed with {n} of {steps} steps skipped: {}", st.skipped.join("; ")),
        }
    }

    /// Follows the running goal on a new pose: the obstacle layer, a path blocked, progress,
    /// arrival, and the ladder of recoveries.
    fn on_pose(&self, ctx: &Ctx<PlannerMsg>, st: &mut PlannerState) -> Result<(), ComponentError> {
        let (Some(setup), Some(nav)) = (&self.nav, st.nav.as_mut()) else { return Ok(()) };
        let Some(pose) = nav.pose else { return Ok(()) };
        if nav.active.is_none() {
            return Ok(());
        }
        let now = secs(ctx);
        if let Some(a) = nav.active.as_mut() {
            // Lost: the goal holds while the robot turns on the spot (the localizer looks for
            // it); found again, it plans from where the robot truly is.
            match (nav.lost, a.lost) {
                (true, _) => {
                    let (since, turned) = a.lost.unwrap_or((now, f64::NEG_INFINITY));
                    if now - since >= setup.judge.lost_s {
                        let why = format!(
                            "lost: the localizer did not find where the robot is within {:.0} s",
                            now - since
                        );
                        return self.end_goal(ctx, st, NavState::Aborted, &why);
                    }
                    // A turn takes 2 pi / (a third of the fastest turn): about 16 s.
                    if now - turned >= LOOK_ROUND_S {
                        a.lost = Some((since, now));
                        let _ = nav.path.send(FollowPath::turn(a.id, std::f64::consts::TAU));
                        if turned == f64::NEG_INFINITY {
                            let a = nav.active.as_ref().ok_or("planner: no goal")?;
                            self.feedback(
                                ctx,
                                nav,
                                a,
                                NavState::Active,
                                "recovery: lost, turning on the spot to find where it is",
                            );
                        }
                    }
                    return Ok(());
                }
                (false, Some((since, _))) => {
                    a.lost = None;
                    // What was seen from the wrong pose is in the wrong place.
                    nav.layer.clear_all();
                    let what =
                        format!("found where it is after {:.0} s lost: planned from there", now - since);
                    return self.replan(ctx, st, pose, &what);
                }
                (false, None) => {}
            }
        }
        // A recovery manoeuvre runs to its end, then the goal is planned again from there.
        if let Some(a) = nav.active.as_mut()
            && let Some((until, what)) = a.recovering.clone()
        {
            if now < until {
                return Ok(());
            }
            a.recovering = None;
            return self.replan(ctx, st, pose, &format!("{what}, planned again"));
        }
        let radius = nav.plan.robot_radius_m + nav.plan.clearance_m;
        // What the near view sees that the map does not hold.
        let mut changed = false;
        if let Some(ir) = &nav.ir {
            nav.beams.clear();
            ring_beams(ir, &nav.ring, &mut nav.beams);
            changed = nav.layer.observe(Pose2::new(pose.0, pose.1, pose.2), &nav.beams);
        }
        changed |= nav.layer.clear_near(pose.0, pose.1, nav.plan.robot_radius_m);
        let stopped = nav.stopped;
        let Some(a) = nav.active.as_mut() else { return Ok(()) };
        // A path blocked by what the sensors see: plan around it, or wait for a way.
        let retry = a.blocked_since.is_some() && now - a.tried_s >= 2.0;
        if (changed && blocked(&mut nav.layer, &a.path, pose.0, pose.1, radius, 3.0)) || retry {
            a.tried_s = now;
            match route(&nav.layer.grid(), (pose.0, pose.1), a.goal, &nav.plan) {
                Ok(path) => {
                    a.path = path;
                    a.blocked_since = None;
                    a.progress.restart(distance_left(&a.path, pose.0, pose.1), now);
                    let cmd = FollowPath::along(a.id, a.path.clone(), a.goal.heading_rad);
                    let _ = nav.path.send(cmd);
                    let a = nav.active.as_ref().ok_or("planner: no goal")?;
                    self.feedback(ctx, nav, a, NavState::Active, "planned around an obstacle");
                    return Ok(());
                }
                Err(why) => {
                    if a.blocked_since.is_none() {
                        a.blocked_since = Some(now);
                        // Something close ahead in the way (a person, who may be waiting for
                        // the robot as it waits for them): back off once a goal, to give it
                        // room, and wait there. Backing away from what is behind would not.
                        let (s, c) = pose.2.sin_cos();
                        let ahead = |(x, y): (f64, f64)| (x - pose.0) * c + (y - pose.1) * s > 0.0;
                        let close = nav
                            .layer
                            .nearest_mark_where(pose.0, pose.1, radius + BACK_OFF_NEAR_M, ahead)
                            .is_some();
                        let (cmd, what) = if close && !a.backed_off {
                            a.backed_off = true;
                            (FollowPath::back(a.id, BACK_OFF_M), format!(", backed off {BACK_OFF_M} m"))
                        } else {
                            (FollowPath::stop(a.id), String::new())
                        };
                        let _ = nav.path.send(cmd);
                        let a = nav.active.as_ref().ok_or("planner: no goal")?;
                        self.feedback(
                            ctx,
                            nav,
                            a,
                            NavState::Active,
                            &format!("recovery: waiting for a way ({why}){what}"),
                        );
                        return Ok(());
                    }
                }
            }
        }
        if let Some(since) = a.blocked_since {
            if now - since < setup.judge.stuck_s / 2.0 {
                return Ok(());
            }
            if a.cleared {
                let seen = nav
                    .layer
                    .nearest_mark(pose.0, pose.1, 3.0)
                    .map(|(x, y)| format!(", something seen at ({x:.2}, {y:.2})"))
                    .unwrap_or_default();
                let why = format!(
                    "no path: the way to ({:.2}, {:.2}) is blocked (seen from ({:.2}, {:.2}) for {:.0} s{seen})",
                    a.goal.x_m,
                    a.goal.y_m,
                    pose.0,
                    pose.1,
                    now - since
                );
                return self.end_goal(ctx, st, NavState::Aborted, &why);
            }
            // Recovery: forget what was seen (it may have gone), and go on the known map.
            a.cleared = true;
            a.blocked_since = None;
            nav.layer.clear_all();
            return self.replan(ctx, st, pose, "recovery: cleared the obstacle layer and planned again");
        }
        let left = distance_left(&a.path, pose.0, pose.1);
        match a.progress.check(&setup.judge, a.goal, pose, left, stopped, now) {
            Verdict::Arrived => return self.end_goal(ctx, st, NavState::Succeeded, "reached"),
            Verdict::Stuck if a.recoveries >= setup.recoveries => {
                let why = format!(
                    "no progress for {:.0} s at ({:.2}, {:.2}), {:.1} m short, after {} recoveries",
                    setup.judge.stuck_s, pose.0, pose.1, left, a.recoveries
                );
                return self.end_goal(ctx, st, NavState::Aborted, &why);
            }
            Verdict::Stuck => {
                // The ladder: back out of where it is stuck (a door's jamb, a corner), then the
                // same with what the layer holds forgotten, then a full turn on the spot (the
                // rings see all round, the layer is seen afresh); each ends in a new plan.
                a.recoveries += 1;
                let (cmd, what, for_s) = match a.recoveries {
                    1 => (FollowPath::back(a.id, BACK_M), "backed up", BACK_S),
                    2 => {
                        nav.layer.clear_all();
                        (FollowPath::back(a.id, BACK_M), "cleared the obstacle layer, backed up", BACK_S)
                    }
                    _ => (
                        FollowPath::turn(a.id, std::f64::consts::TAU),
                        "turned round on the spot",
                        LOOK_ROUND_S,
                    ),
                };
                let what = format!(
                    "recovery {}: no progress for {:.0} s, {what}",
                    a.recoveries, setup.judge.stuck_s
                );
                a.recovering = Some((now + for_s, what.clone()));
                let _ = nav.path.send(cmd);
                let a = nav.active.as_ref().ok_or("planner: no goal")?;
                self.feedback(ctx, nav, a, NavState::Active, &format!("{what}..."));
                return Ok(());
            }
            Verdict::Going => {
                if now - a.told_s >= 1.0 {
                    a.told_s = now;
                    let a = nav.active.as_ref().ok_or("planner: no goal")?;
                    self.feedback(ctx, nav, a, NavState::Active, "");
                }
            }
        }
        Ok(())
    }

    /// Plans the running goal again from `pose` on the layered map; aborts it if there is no
    /// way.
    fn replan(
        &self,
        ctx: &Ctx<PlannerMsg>,
        st: &mut PlannerState,
        pose: (f64, f64, f64),
        what: &str,
    ) -> Result<(), ComponentError> {
        let Some(nav) = st.nav.as_mut() else { return Ok(()) };
        let Some(a) = nav.active.as_mut() else { return Ok(()) };
        let now = secs(ctx);
        nav.layer.clear_near(pose.0, pose.1, nav.plan.robot_radius_m + 0.05);
        match route(&nav.layer.grid(), (pose.0, pose.1), a.goal, &nav.plan) {
            Ok(path) => {
                tracing::info!("planner: goal {}: {what}", a.id);
                a.path = path;
                a.progress.restart(distance_left(&a.path, pose.0, pose.1), now);
                let cmd = FollowPath::along(a.id, a.path.clone(), a.goal.heading_rad);
                let _ = nav.path.send(cmd);
                let a = nav.active.as_ref().ok_or("planner: no goal")?;
                self.feedback(ctx, nav, a, NavState::Active, what);
                Ok(())
            }
            Err(why) => self.end_goal(ctx, st, NavState::Aborted, &why),
        }
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
        let nav = match &self.nav {
            None => None,
            Some(setup) => {
                let robot: RobotParams = ctx
                    .query_client(nomad200::ROBOTPARAMS.on(&setup.robot))?
                    .query(Empty {}, Some(Duration::from_secs(2)))
                    .await
                    .map_err(|e| format!("planner: cannot get {}/robotparams: {e}", setup.robot))?;
                let plan = PlanParams {
                    robot_radius_m: robot.body_radius_m,
                    clearance_m: setup.clearance_m,
                    ..PlanParams::default()
                };
                let known: KnownMap = ctx
                    .query_client(map::KNOWN.on(&setup.map))?
                    .query(Empty {}, Some(Duration::from_secs(5)))
                    .await
                    .map_err(|e| format!("planner: cannot get the map from {}/known: {e}", setup.map))?;
                known.validate().map_err(|e| format!("planner: the map from {}/known: {e}", setup.map))?;
                let map = NavMap::from(known);
                let feedback = ctx.push_newest_server(NAVIGATION)?;
                ctx.query_server(NAVIGATE, PlannerMsg::Navigate)?;
                ctx.send_server(CANCEL, PlannerMsg::Cancel)?;
                let path = ctx.send_client(navigation::PATH.on(navigation::PATHFOLLOW))?;
                ctx.subscribe_newest(navigation::POSE.on(navigation::LOCALIZER), PlannerMsg::Pose)?;
                ctx.subscribe_timed(nomad200::BASESTATE.on(&setup.robot), 1, PlannerMsg::Base)?;
                ctx.subscribe_timed(nomad200::DISTANCEIR.on(&setup.robot), 1, PlannerMsg::Ir)?;
                let layer = ObstacleLayer::new((*map.grid).clone(), robot.infrared.max_range_m, 0.05)
                    .map_err(|e| format!("planner: the map: {e}"))?
                    .explaining(EXPLAINED_M);
                Some(NavState_ {
                    map,
                    path,
                    feedback,
                    plan,
                    pose: None,
                    lost: false,
                    stopped: false,
                    next_id: 0,
                    active: None,
                    waiting: false,
                    pending: None,
                    layer,
                    ir: None,
                    ring: robot.infrared.clone(),
                    beams: Vec::new(),
                })
            }
        };
        Self::next(ctx)?;
        Ok(PlannerState {
            step: 0,
            retried: 0,
            attempts: 0,
            goal_id: None,
            goals,
            status,
            nav,
            skipped: Vec::new(),
        })
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
                    self.publish(st, Some(self.mission_end(st)));
                    return Ok(());
                };
                let (mode, for_s) = match step.kind() {
                    Ok(StepKind::Mode(m, s)) => (m, s),
                    Ok(StepKind::Goto(target)) => {
                        if st.nav.as_ref().is_some_and(|n| n.pose.is_none()) {
                            // The first estimate starts it.
                            if let Some(n) = st.nav.as_mut() {
                                n.waiting = true;
                            }
                            return Ok(());
                        }
                        self.publish(st, None);
                        if let Err(why) = self.start_goal(ctx, st, target.clone(), true, None).await {
                            tracing::warn!("planner: step {} (goto {target}) rejected: {why}", st.step);
                            if st.nav.as_ref().is_some_and(|n| n.active.is_none()) {
                                self.step_ended(ctx, st, false, &format!("rejected: {why}"))?;
                            }
                        }
                        return Ok(());
                    }
                    Err(why) => {
                        self.publish(st, Some(format!("aborted: step {}: {why}", st.step)));
                        return Ok(());
                    }
                };
                match self.ask(st, &mode, for_s).await? {
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
                            "planner: goal {} ({mode}) could not be switched to now ({reason}); the previous goal \
                             goes on; giving it again in {:?} ({} of {})",
                            st.step,
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
                        tracing::error!("planner: goal {} ({mode}) rejected, {why}: {reason}", st.step);
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
                let navigating = st.nav.as_ref().is_some_and(|n| n.active.is_some());
                match ev.status {
                    GoalStatus::Started => {}
                    GoalStatus::Reached if !navigating => {
                        st.step += 1;
                        st.goal_id = None;
                        Self::next(ctx)?;
                    }
                    GoalStatus::Reached => {}
                    GoalStatus::Failed | GoalStatus::Preempted if navigating => {
                        let why = format!("the executive's goal {} {:?}: {}", ev.id, ev.status, ev.detail);
                        self.end_goal(ctx, st, NavState::Aborted, &why)?;
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
            PlannerMsg::Pose(p) => {
                let p = p.value;
                let Some(nav) = st.nav.as_mut() else { return Ok(()) };
                nav.pose = Some((p.x_m, p.y_m, p.heading_rad));
                nav.lost = p.lost;
                if std::mem::take(&mut nav.waiting) {
                    Self::next(ctx)?;
                }
                if let Some((id, target)) = nav.pending.take()
                    && let Err(why) = self.start_goal(ctx, st, target.clone(), false, Some(id)).await
                {
                    tracing::warn!("planner: goal {id} to {target} rejected: {why}");
                }
                self.on_pose(ctx, st)?;
            }
            PlannerMsg::Ir(s) => {
                if let Some(nav) = st.nav.as_mut() {
                    nav.ir = Some(s.value.clone());
                }
            }
            PlannerMsg::Base(b) => {
                if let Some(nav) = st.nav.as_mut() {
                    nav.stopped = b.value.v_m_s.abs() < 0.01 && b.value.omega_rad_s.abs() < 0.02;
                }
            }
            PlannerMsg::Navigate(q) => {
                let target = q.request.value.target.clone();
                // Before the localizer's first estimate (a goal given as the system comes up),
                // a goal to a place the map has is accepted and waits for it.
                if let Some(nav) = st.nav.as_mut().filter(|n| n.pose.is_none())
                    && let Ok(goal) = nav.map.resolve(&target)
                {
                    nav.next_id += 1;
                    let id = nav.next_id;
                    let waiting = "waiting for the first estimate of the robot's pose";
                    tell(ctx, nav, id, &target, Some(goal), NavState::Active, waiting);
                    if let Some((old, old_target)) = nav.pending.replace((id, target)) {
                        let why = format!("preempted by goal {id}");
                        tell(ctx, nav, old, &old_target, None, NavState::Canceled, &why);
                    }
                    let _ = q.answer(NavReply::Accepted { id });
                    return Ok(());
                }
                let reply = match self.start_goal(ctx, st, target.clone(), false, None).await {
                    Ok(id) => NavReply::Accepted { id },
                    Err(reason) => {
                        tracing::warn!("planner: goal to {target} rejected: {reason}");
                        NavReply::Rejected { reason }
                    }
                };
                let _ = q.answer(reply);
            }
            PlannerMsg::Cancel(c) => {
                if let Some(nav) = st.nav.as_mut()
                    && let Some((id, target)) =
                        nav.pending.take_if(|(id, _)| c.value.id.is_none_or(|c| c == *id))
                {
                    tell(ctx, nav, id, &target, None, NavState::Canceled, "canceled");
                }
                let active = st.nav.as_ref().and_then(|n| n.active.as_ref()).map(|a| a.id);
                if active.is_some() && c.value.id.is_none_or(|id| Some(id) == active) {
                    self.end_goal(ctx, st, NavState::Canceled, "canceled")?;
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
        assert_eq!(p.mission_for(60.0), vec![MissionStep::mode("patrol", Some(60.0))]);
        let bad = PlannerParams {
            mission: vec![MissionStep::mode("patrol", None), MissionStep::mode("dance", None)],
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
