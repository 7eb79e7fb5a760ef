//! The `master`: arbitrates behaviours by Wiring and activates them by State.
//!
//! The master subscribes to the robot's infrared ring (every `subscribe_every`-th scan: 10 x 40
//! ms, one decision per 400 ms, as in the thesis) and, if any rule needs it, to the sonar ring.
//! On every scan it runs the current mode's priority list ([`crate::rules`]) and, if the answer
//! changed, hands the motors over in one [`Switch`]: the old behaviour's `vel` port is
//! disconnected, then the new one is connected to the robot's `navigationvelocity`, all or
//! nothing (`orsa_actors::switch`). Two behaviours are never wired at once, and a switch that
//! fails half-way is undone, so the behaviour that drove goes on driving. Whenever the master
//! leaves nothing wired (a mode without a rule that applies, between goals, after a switch it
//! could not undo) it sends the motors a zero command, and the robot server's timeout stops them
//! in any case.
//!
//! Goals arrive by Query on `goal` ([`Goal`] -> [`GoalReply`]): a goal names a mode and how
//! long to run it. Starting a goal is one switch too: it activates the mode's behaviours (State
//! `active`), deactivates every other behaviour (State `neutral`) and wires the one the new
//! mode's rules pick, preempting the previous goal; if any step fails or takes longer than
//! `switch_step_s`, everything is undone, the goal is rejected with the reason, and the
//! previous goal goes on. Progress
//! goes out on the Event service `goals` ([`GoalEvent`]: started, reached, failed, preempted);
//! every change of driver goes out on the Push newest service `driving` ([`WiringChange`]).
//!
//! When the robot was away (its infrared scans stopped for a second, or count from 1 again:
//! a new robot process), the master checks that the robot's side is as it set it: the driver wired to the
//! motors and nobody else, every behaviour in the state its mode gives it. Where it is not (a
//! restarted robot process comes back with nothing wired), it sets it again in one switch, so
//! the system comes back by itself. The check is made on a scan, an input a replay feeds back
//! at its recorded place, so a replay makes it at the same point.

use crate::rules::{Arbiter, Mode, Readings, validate_modes};
use orsa_actors::event::EventServer;
use orsa_actors::param::{Check, Invalid, LiveParams, ParamReply, ParamRequest};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::QueryRequest;
use orsa_actors::send::SendClient;
use orsa_actors::service::{Addr, SendService};
use orsa_actors::state::{NEUTRAL, StateMaster};
use orsa_actors::switch::{Switch, SwitchError, SwitchMaster};
use orsa_actors::wiring::WiringMaster;
use orsa_actors::{Component, ComponentError, Ctx, Update};
use orsa_interfaces::behaviour::{ACTIVE, VEL};
use orsa_interfaces::executive::{
    DRIVING, GOAL, GOALS, Goal, GoalEvent, GoalFilter, GoalReply, GoalStatus, MAX_GOAL_S, WiringChange,
};
use orsa_interfaces::nomad200::{self, DistanceScan, NavigationVelocity};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

/// Configuration of the executive (the master's `[params.master]` table of the config file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ExecutiveParams {
    /// The robot server component.
    pub robot: String,
    /// The master looks at every n-th scan.
    pub subscribe_every: u32,
    /// How long each step of a mode switch may take before the switch is undone, s.
    pub switch_step_s: f64,
    /// The modes goals can name.
    pub modes: BTreeMap<String, Mode>,
}

impl Default for ExecutiveParams {
    fn default() -> Self {
        let text = r#"
            [modes.patrol]
            behaviours = ["wallfollow", "centerfollow"]
            rules = [
              { drive = "wallfollow", when = [{ ring = "infrared", sensors = [0], below_m = 0.5 }],
                hold_while = [{ ring = "infrared", sensors = [3, 4, 5], below_m = 0.37 }],
                release_when = [{ ring = "sonar", sensors = [15, 0], above_m = 1.0 }],
                release_after_s = 30.0 },
              { drive = "centerfollow" },
            ]
            [modes.follow_left_wall]
            behaviours = ["wallfollow"]
            rules = [{ drive = "wallfollow" }]
            [modes.stop]
        "#;
        #[derive(Deserialize)]
        struct Modes {
            modes: BTreeMap<String, Mode>,
        }
        // The text above is part of the program, and a test parses it.
        let modes = toml::from_str::<Modes>(text).map(|m| m.modes).unwrap_or_default();
        ExecutiveParams { robot: "nomad200".into(), subscribe_every: 10, switch_step_s: 0.2, modes }
    }
}

impl orsa_actors::param::Parameters for ExecutiveParams {
    /// The robot, the scans the master subscribes to and which behaviours a mode uses are set
    /// up when it starts.
    const FIXED: &'static [&'static str] = &["robot", "subscribe_every", "modes.*.behaviours"];

    fn validate(&self) -> Result<(), Invalid> {
        ExecutiveParams::validate(self)
    }
}

impl ExecutiveParams {
    /// Checks every value; messages name the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        if self.subscribe_every == 0 {
            return Err(Invalid::new("executive.subscribe_every", "must be at least 1"));
        }
        let step = self.switch_step_s;
        if !(step.is_finite() && (0.001..=10.0).contains(&step)) {
            return Err(Invalid::new(
                "executive.switch_step_s",
                format!("must be from 0.001 to 10 seconds, not {step}"),
            ));
        }
        if self.modes.is_empty() {
            return Err(Invalid::new("executive.modes", "define at least one mode"));
        }
        validate_modes(&self.modes)
    }

    /// Every behaviour any mode names.
    pub fn behaviours(&self) -> Vec<String> {
        let mut all: Vec<String> = self.modes.values().flat_map(|m| m.behaviours.clone()).collect();
        all.sort();
        all.dedup();
        all
    }
}

/// The master component.
#[derive(Clone)]
pub struct Master {
    /// Its configuration (the values it starts from: its rules are live parameters).
    pub params: ExecutiveParams,
    /// What a set of its parameters must also pass (what the config file checks against other
    /// tables, such as `switch_step_s` against the robot's command timeout).
    pub check: Option<Check<ExecutiveParams>>,
}

impl std::fmt::Debug for Master {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Master").field("params", &self.params).finish_non_exhaustive()
    }
}

impl Master {
    /// A master configured by `params`.
    pub fn new(params: ExecutiveParams) -> Master {
        Master { params, check: None }
    }
}

fn mode<'a>(p: &'a ExecutiveParams, st: &MasterState) -> Option<&'a Mode> {
    st.goal.as_ref().and_then(|g| p.modes.get(&g.mode))
}

/// No infrared scan for this long and the master checks the robot's wiring when they come
/// back (it may be a new robot process).
const SILENCE: Duration = Duration::from_secs(1);
/// After a wiring check that could not be made (a behaviour did not answer), the next waits
/// this long by the scans' clock, doubling at each failure in a row up to 16 times, so a
/// behaviour that never answers does not hold the master's handler at every scan.
const CHECK_RETRY: Duration = Duration::from_millis(500);

/// Messages of the [`Master`].
#[derive(Debug)]
pub enum MasterMsg {
    /// An infrared scan (every n-th).
    Ir(Update<DistanceScan>),
    /// A sonar scan (every n-th), if rules need sonar.
    Sonar(Update<DistanceScan>),
    /// A goal from the deliberative layer.
    Goal(QueryRequest<Goal, GoalReply>),
    /// A goal's time is up.
    Deadline(u64),
    /// A request to its `param` service.
    Param(QueryRequest<ParamRequest, ParamReply>),
}

#[derive(Debug, Clone)]
struct Current {
    id: u64,
    mode: String,
}

/// What the master keeps across restarts: the goal it pursues and the next goal id.
#[derive(Debug, Default)]
struct Kept {
    goal: Option<Current>,
    next_id: u64,
}

/// The master's running state.
pub struct MasterState {
    params: LiveParams<ExecutiveParams>,
    /// The parameters now.
    p: Arc<ExecutiveParams>,
    readings: Readings,
    /// The newest scan's time, s: the rules' clock.
    readings_s: f64,
    arbiter: Arbiter,
    goal: Option<Current>,
    next_id: u64,
    driving: Option<String>,
    wiring: WiringMaster,
    switch: SwitchMaster,
    motors: SendClient<NavigationVelocity>,
    motors_addr: Addr<SendService<NavigationVelocity>>,
    states: BTreeMap<String, StateMaster>,
    events: EventServer<GoalFilter, GoalEvent, GoalEvent>,
    wiring_push: PushNewestServer<WiringChange>,
    kept: Arc<parking_lot::Mutex<Kept>>,
    /// The newest infrared scan's sequence number and when it was sent.
    ir_seq: u64,
    ir_at: orsa_actors::Timestamp,
    /// The robot server started again: the wiring and states are to be checked (until the
    /// check could be made).
    check_pending: bool,
    /// Wiring checks in a row that could not be made, and the scan time before which the
    /// next is not tried.
    check_failures: u32,
    check_after: orsa_actors::Timestamp,
}

impl Component for Master {
    type Msg = MasterMsg;
    type State = MasterState;

    async fn setup(&self, ctx: &Ctx<MasterMsg>) -> Result<MasterState, ComponentError> {
        let params = ctx.parameters(&self.params, self.check.clone(), MasterMsg::Param)?;
        let p = Arc::new(params.current());
        p.validate()?;
        let robot = p.robot.as_str();
        ctx.query_server(GOAL, MasterMsg::Goal)?;
        let events = ctx.event_server(GOALS, |f: &mut GoalFilter, e: &GoalEvent| {
            f.goal.is_none_or(|g| g == e.id).then(|| e.clone())
        })?;
        let wiring_push = ctx.push_newest_server(DRIVING)?;
        let mut states = BTreeMap::new();
        for b in p.behaviours() {
            let sm = StateMaster::connect(ctx.registry(), &b)
                .map_err(|e| format!("master: behaviour '{b}' named in executive.modes: {e}"))?;
            states.insert(b, sm);
        }
        let every = p.subscribe_every;
        ctx.subscribe_timed(nomad200::DISTANCEIR.on(robot), every, MasterMsg::Ir)?;
        if p.modes.values().any(Mode::uses_sonar) {
            ctx.subscribe_timed(nomad200::DISTANCESON.on(robot), every, MasterMsg::Sonar)?;
        }
        let motors_addr = nomad200::NAVIGATIONVELOCITY.on(robot);
        let kept = ctx.keep("goal", || Arc::new(parking_lot::Mutex::new(Kept { goal: None, next_id: 1 })))?;
        let mut st = MasterState {
            params,
            p: p.clone(),
            readings: Readings::default(),
            readings_s: ctx.now().as_secs_f64(),
            arbiter: Arbiter::new(),
            goal: None,
            next_id: 1,
            driving: None,
            wiring: WiringMaster::new(ctx.registry()),
            switch: SwitchMaster::new(ctx.registry(), ctx.name()),
            motors: ctx.send_client(&motors_addr)?,
            motors_addr,
            states,
            events,
            wiring_push,
            kept,
            ir_seq: 0,
            ir_at: orsa_actors::Timestamp(0),
            check_pending: false,
            check_failures: 0,
            check_after: orsa_actors::Timestamp(0),
        };
        st.next_id = st.kept.lock().next_id;
        // Nothing drives until the goal is known again: a first start has none; a restarted
        // master resumes the goal it was pursuing (the planner is not asked again).
        for b in st.states.keys() {
            st.wiring.disconnect(b, VEL).await?;
        }
        stop_motors(ctx, &mut st);
        let resumed = st.kept.lock().goal.clone();
        if let Some(goal) = resumed
            && let Some(mode) = p.modes.get(&goal.mode)
        {
            for (name, sm) in &st.states {
                let target = if mode.behaviours.contains(name) { ACTIVE } else { NEUTRAL };
                sm.set_state(target)
                    .await
                    .map_err(|e| format!("master: resuming goal {}: {name}: {e}", goal.id))?;
            }
            tracing::info!(goal = goal.id, mode = %goal.mode, "master: resumed after a restart");
            st.goal = Some(goal);
        }
        Ok(st)
    }

    async fn handle(
        &self,
        ctx: &Ctx<MasterMsg>,
        st: &mut MasterState,
        msg: MasterMsg,
    ) -> Result<(), ComponentError> {
        match msg {
            MasterMsg::Ir(scan) => {
                // A robot server that started again (a new robot process) counts its scans
                // from 1 again, and the scans stop meanwhile: after either the master looks.
                let silent = scan.sent_at.saturating_since(st.ir_at) > SILENCE;
                if (scan.seq < st.ir_seq || silent) && st.ir_seq > 0 {
                    tracing::info!(
                        seq = scan.seq,
                        before = st.ir_seq,
                        "master: the robot was away: checking its wiring"
                    );
                    st.check_pending = true;
                    st.check_failures = 0;
                    st.check_after = scan.sent_at;
                }
                st.ir_seq = scan.seq;
                st.ir_at = scan.sent_at;
                if st.check_pending && scan.sent_at >= st.check_after {
                    if self.check_wiring(ctx, st).await {
                        st.check_pending = false;
                        st.check_failures = 0;
                    } else {
                        let backoff = CHECK_RETRY * (1u32 << st.check_failures.min(4));
                        st.check_failures = st.check_failures.saturating_add(1);
                        st.check_after = scan.sent_at.after(backoff);
                    }
                }
                fill(&mut st.readings.infrared, &scan);
                st.readings_s = st.readings_s.max(scan.stamp.as_secs_f64());
                self.arbitrate(ctx, st).await;
            }
            MasterMsg::Sonar(scan) => {
                fill(&mut st.readings.sonar, &scan);
                st.readings_s = st.readings_s.max(scan.stamp.as_secs_f64());
                self.arbitrate(ctx, st).await;
            }
            MasterMsg::Goal(q) => {
                let reply = self.start_goal(ctx, st, q.request.value.clone()).await;
                // The planner may have given up waiting; the goal stands regardless.
                let _ = q.answer(reply);
            }
            MasterMsg::Param(q) => {
                // The new rules apply from the next scan on.
                if let Some(p) = st.params.handle(q, ctx.now()) {
                    st.p = Arc::new(p);
                }
            }
            MasterMsg::Deadline(id) => {
                if st.goal.as_ref().is_some_and(|g| g.id == id) {
                    let done = st.goal.take();
                    if let Some(g) = done {
                        fire(ctx, st, g.id, &g.mode, GoalStatus::Reached, String::new());
                    }
                    self.arbitrate(ctx, st).await;
                }
            }
        }
        let mut kept = st.kept.lock();
        kept.goal.clone_from(&st.goal);
        kept.next_id = st.next_id;
        Ok(())
    }
}

fn fill(ring: &mut [Option<f64>; nomad200::RING_SIZE], scan: &DistanceScan) {
    *ring = [None; nomad200::RING_SIZE];
    for r in &scan.readings {
        if let Some(slot) = ring.get_mut(usize::from(r.sensor_id)) {
            *slot = (r.valid && r.distance_m.is_finite()).then_some(r.distance_m);
        }
    }
}

fn fire(ctx: &Ctx<MasterMsg>, st: &MasterState, id: u64, mode: &str, status: GoalStatus, detail: String) {
    tracing::info!(goal = id, mode, ?status, "{detail}");
    st.events.put(&GoalEvent { id, mode: mode.to_string(), status, stamp: ctx.now(), detail });
}

fn stop_motors(ctx: &Ctx<MasterMsg>, st: &mut MasterState) {
    let zero = NavigationVelocity { stamp: ctx.now(), v_m_s: 0.0, omega_rad_s: 0.0 };
    if let Err(e) = st.motors.send(zero) {
        tracing::warn!("master: cannot stop the motors: {e}");
    }
}

impl Master {
    /// A switch that hands the motors from whoever drives to `want`, with `more` changes.
    fn handover(&self, st: &MasterState, want: Option<&str>, more: Switch) -> Switch {
        let mut switch = more.step_timeout(Duration::from_secs_f64(st.p.switch_step_s));
        if let Some(old) = st.driving.as_deref()
            && want != Some(old)
        {
            switch = switch.disconnect(old, VEL);
        }
        if let Some(new) = want
            && st.driving.as_deref() != Some(new)
        {
            switch = switch.connect(new, VEL, &st.motors_addr);
        }
        switch
    }

    /// After a switch failed: if it could not undo everything, nobody is known to drive, so
    /// unwire every behaviour one by one and stop the motors.
    async fn after_failed_switch(&self, ctx: &Ctx<MasterMsg>, st: &mut MasterState, e: &SwitchError) {
        tracing::warn!("master: {e}");
        if e.nothing_changed() {
            return;
        }
        for b in st.states.keys() {
            if let Err(e) = st.wiring.disconnect(b, VEL).await {
                tracing::warn!("master: cannot unwire {b}: {e}");
            }
        }
        st.driving = None;
        stop_motors(ctx, st);
    }

    async fn arbitrate(&self, ctx: &Ctx<MasterMsg>, st: &mut MasterState) {
        let p = st.p.clone();
        let want = mode(&p, st).and_then(|m| {
            let rule = st.arbiter.decide(m, &st.readings, st.readings_s)?;
            m.rules.get(rule).map(|r| r.drive.clone())
        });
        if want == st.driving {
            return;
        }
        let switch = self.handover(st, want.as_deref(), Switch::new());
        match st.switch.apply(&switch).await {
            Ok(()) => st.driving = want,
            Err(e) => self.after_failed_switch(ctx, st, &e).await,
        }
        if st.driving.is_none() {
            stop_motors(ctx, st);
        }
        self.push_driving(ctx, st);
    }

    /// Checks that the driver, and nobody else, is wired to the motors and that every behaviour
    /// is in its mode's state; sets it all again in one switch where it is not. Whether the
    /// check could be made (a robot it cannot reach yet is checked again at the next scan).
    async fn check_wiring(&self, ctx: &Ctx<MasterMsg>, st: &mut MasterState) -> bool {
        let p = st.p.clone();
        let Some(mode) = mode(&p, st) else { return true };
        let motors = st.motors_addr.untyped();
        let step = Duration::from_secs_f64(p.switch_step_s);
        let mut switch = Switch::new().step_timeout(step);
        let mut wrong = Vec::new();
        for (name, sm) in &st.states {
            // Each look within a switch step: a robot that does not answer now (frozen, cut
            // off) holds the master's handler no longer than that.
            let look = async { (st.wiring.ports(name).await, sm.status().await) };
            let Ok((Ok(ports), Ok(status))) = tokio::time::timeout(step, look).await else {
                return false;
            };
            let wired = ports.iter().any(|p| p.port == VEL.name() && p.target.as_ref() == Some(&motors));
            let drives = st.driving.as_deref() == Some(name.as_str());
            if wired && !drives {
                switch = switch.disconnect(name, VEL);
                wrong.push(format!("{name} wired"));
            }
            if drives && !wired {
                switch = switch.connect(name, VEL, &st.motors_addr);
                wrong.push(format!("{name} not wired"));
            }
            let want = if mode.behaviours.contains(name) { ACTIVE } else { NEUTRAL };
            if status.current != want && status.pending.as_deref() != Some(want) {
                switch = switch.state(name, want);
                wrong.push(format!("{name} {} instead of {want}", status.current));
            }
        }
        if wrong.is_empty() {
            return true;
        }
        tracing::warn!(
            "master: the robot is not as the master set it ({}): setting it again",
            wrong.join(", ")
        );
        if let Err(e) = st.switch.apply(&switch).await {
            self.after_failed_switch(ctx, st, &e).await;
            if st.driving.is_none() {
                stop_motors(ctx, st);
            }
            self.push_driving(ctx, st);
            return !e.nothing_changed();
        }
        true
    }

    fn push_driving(&self, ctx: &Ctx<MasterMsg>, st: &MasterState) {
        st.wiring_push.put(WiringChange {
            stamp: ctx.now(),
            driving: st.driving.clone(),
            mode: st.goal.as_ref().map(|g| g.mode.clone()),
        });
    }

    async fn start_goal(&self, ctx: &Ctx<MasterMsg>, st: &mut MasterState, goal: Goal) -> GoalReply {
        let p = st.p.clone();
        let Some(mode) = p.modes.get(&goal.mode) else {
            let known: Vec<&String> = p.modes.keys().collect();
            return GoalReply::Rejected {
                reason: format!("unknown mode '{}' (known: {known:?})", goal.mode),
                switch: None,
            };
        };
        if let Some(s) = goal.for_s
            && !(s.is_finite() && (0.0..=MAX_GOAL_S).contains(&s))
        {
            return GoalReply::Rejected {
                reason: format!("for_s must be a number of seconds from 0 to {MAX_GOAL_S}, not {s}"),
                switch: None,
            };
        }
        // The whole mode change is one switch: unwire whoever drives (if the new mode's rules
        // pick someone else), set every behaviour's state, wire the new driver. If any of it
        // fails, all of it is undone and the previous goal goes on.
        let mut arbiter = Arbiter::new();
        let want = arbiter
            .decide(mode, &st.readings, st.readings_s)
            .and_then(|i| mode.rules.get(i))
            .map(|r| r.drive.clone());
        let states = st.states.keys().fold(Switch::new(), |sw, name| {
            sw.state(name, if mode.behaviours.contains(name) { ACTIVE } else { NEUTRAL })
        });
        let switch = self.handover(st, want.as_deref(), states);
        if let Err(e) = st.switch.apply(&switch).await {
            self.after_failed_switch(ctx, st, &e).await;
            if st.driving.is_none() {
                stop_motors(ctx, st);
            }
            let id = st.next_id;
            st.next_id += 1;
            let reason = e.to_string();
            fire(ctx, st, id, &goal.mode, GoalStatus::Failed, reason.clone());
            return GoalReply::Rejected { reason, switch: Some((&e).into()) };
        }
        if let Some(old) = st.goal.take() {
            fire(ctx, st, old.id, &old.mode, GoalStatus::Preempted, format!("by a '{}' goal", goal.mode));
        }
        let id = st.next_id;
        st.next_id += 1;
        st.arbiter = arbiter;
        st.driving = want;
        if st.driving.is_none() {
            stop_motors(ctx, st);
        }
        st.goal = Some(Current { id, mode: goal.mode.clone() });
        if let Some(secs) = goal.for_s {
            let mailbox = ctx.mailbox().clone();
            tokio::spawn(async move {
                tokio::time::sleep(Duration::from_secs_f64(secs)).await;
                // A master that is gone has no goal to end.
                let _ = mailbox.cast(MasterMsg::Deadline(id));
            });
        }
        fire(ctx, st, id, &goal.mode, GoalStatus::Started, String::new());
        self.push_driving(ctx, st);
        GoalReply::Accepted { id }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_modes_parse_and_validate() {
        let p = ExecutiveParams::default();
        assert_eq!(p.modes.keys().collect::<Vec<_>>(), vec!["follow_left_wall", "patrol", "stop"]);
        p.validate().expect("valid");
        assert_eq!(p.behaviours(), vec!["centerfollow", "wallfollow"]);
    }
}
