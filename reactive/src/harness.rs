//! One behaviour component for every controller: a controller says what it reads and how it
//! steps ([`Controller`]); [`Behaviour`] gives it everything a behaviour has.
//!
//! What every behaviour gets from the harness, written once:
//! - **its states**: it computes only while its main state is `active`, holding substate
//!   `compute` for the instant of each step, so a master silences it with the State pattern;
//! - **its `param` service**: its parameters are live (`orsa param`, Foxglove's Parameters
//!   panel), checked by the table's own `validate()`, kept across a restart;
//! - **the robot's geometry**: it asks `robotparams` when it starts, so no robot dimension is
//!   hard-coded ([`Controller::new`] gets them);
//! - **its inputs**: it subscribes to the scans the controller reads ([`Controller::READS`]);
//!   every update of one makes a step on the newest of each, stamped with the oldest of them;
//! - **odometry and contact**: `basestate` goes to [`Controller::note_odometry`], the robot's
//!   `contact` event (while a bumper is pressed) to [`Controller::note_contact`] as a direction
//!   from the direction of travel;
//! - **its `vel` port and its `status`**: each step's command is sent on the wireable `vel` port
//!   whether it is wired or not (an unwired send is simply not delivered), and what it saw and
//!   decided is pushed on `status`;
//! - **judging its inputs**: a scan older than [`INPUT_AGE_PERIODS`] of its push period slows
//!   the behaviour, down to a stop at twice that age, and a scan of a sensor the robot judges
//!   unhealthy (its `health` service) is not steered on at all: the controller sees it as
//!   absent. Without a scan that alone sees close to the body (the near view: the sonar sees
//!   nothing under 0.30 m) the behaviour stops; without one that only sees farther it goes on
//!   what is left at [`WITHOUT_ONE_INPUT`] of its speed. Its status says why (`holding`), and it
//!   resumes when fresh, healthy data comes.
//!
//! - **navigation**, for a controller that drives to places ([`Controller::NAVIGATES`]): the
//!   paths it is given on `path` and the localizer's estimate of the pose in the map.
//!
//! A new behaviour is one file: a controller and its `impl Controller`, registered in the
//! catalog as `Behaviour::<MyController> { params, robot }` (`examples/new_behaviour.rs`).

use crate::manoeuvres::contact_direction;
use crate::ring::{Ranges, ranges};
use orsa_actors::event::{EventMode, Fired};
use orsa_actors::param::{Invalid, LiveParams, ParamReply, ParamRequest, Parameters};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::QueryRequest;
use orsa_actors::state::StateSpec;
use orsa_actors::wiring::SendPort;
use orsa_actors::{Component, ComponentError, Ctx, Empty, PatternError, Stamped, Timestamp, Update};
use orsa_interfaces::behaviour::{ACTIVE, BehaviourStatus, COMPUTE, STATUS, VEL};
use orsa_interfaces::health::{self, Health};
use orsa_interfaces::navigation::{self, FollowPath, PoseEstimate};
use orsa_interfaces::nomad200::{
    self, BaseState, ContactScan, DistanceScan, NavigationVelocity, RING_SIZE, RobotParams,
};
use std::time::Duration;

/// A scan a controller can read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scan {
    /// `distanceir`: the near view (the infrared ring on a Nomad 200).
    Infrared,
    /// `distanceson`: the far view (the sonar ring on a Nomad 200).
    Sonar,
}

/// What a controller sees at a step: the newest of each scan it reads, as valid ranges per
/// sector (all `None` for a scan it does not read or that has not come yet).
#[derive(Debug, Clone, Copy)]
pub struct Seen<'a> {
    /// The stamp of the step: the oldest of the scans it fuses.
    pub stamp: Timestamp,
    /// The near view.
    pub infrared: &'a Ranges,
    /// The far view.
    pub sonar: &'a Ranges,
}

/// What a controller decided at a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The command, stamped with the step's stamp.
    pub cmd: NavigationVelocity,
    /// The wall it follows, if it follows one, m.
    pub wall_m: Option<f64>,
    /// Its offset from where it wants to be, if it has one, m.
    pub offset_m: Option<f64>,
    /// The angle of what it steers by, rad.
    pub alpha_rad: f64,
}

/// A pure controller that [`Behaviour`] makes a component of.
pub trait Controller: Send + Sync + 'static {
    /// Its parameters: its table in the config, live through its `param` service.
    type Params: Parameters + std::fmt::Debug;
    /// The scans it reads (at least one); every update of one makes a step.
    const READS: &'static [Scan];
    /// A controller with `params` for the robot `robot` describes.
    fn new(params: Self::Params, robot: &RobotParams) -> Self;
    /// New parameters (already checked), from the next step on.
    fn set_params(&mut self, params: Self::Params);
    /// The robot's odometry.
    fn note_odometry(&mut self, _base: &BaseState) {}
    /// The bumpers report contact at `stamp`, `direction_rad` from the direction of travel.
    fn note_contact(&mut self, _direction_rad: f64, _stamp: Timestamp) {}
    /// One step.
    fn step(&mut self, seen: &Seen<'_>) -> Step;
    /// Its parameters that are translation speeds (name as its table spells it, and value,
    /// m/s): a live set that puts one above the robot's top speed is refused.
    fn speeds(_params: &Self::Params) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// Whether it drives to places: the harness then serves its `path` service
    /// (`orsa_interfaces::navigation::PATH`) and subscribes to the localizer's `pose`.
    const NAVIGATES: bool = false;
    /// A new estimate of the robot's pose in the map (only if it [navigates](Self::NAVIGATES)).
    fn note_pose(&mut self, _pose: &PoseEstimate) {}
    /// A new path to follow (only if it [navigates](Self::NAVIGATES)).
    fn note_path(&mut self, _path: &FollowPath) {}
}

/// The component every behaviour is: a controller `C` inside the harness (see the module).
#[derive(Debug, Clone)]
pub struct Behaviour<C: Controller> {
    /// The controller's parameters.
    pub params: C::Params,
    /// The robot server component's name.
    pub robot: String,
}

/// Messages of a [`Behaviour`].
#[derive(Debug)]
pub enum BehaviourMsg {
    /// A new infrared scan.
    Ir(Update<DistanceScan>),
    /// A new sonar scan.
    Sonar(Update<DistanceScan>),
    /// New odometry.
    Base(Update<BaseState>),
    /// The bumpers report contact.
    Contact(Fired<ContactScan>),
    /// A request to its `param` service.
    Param(QueryRequest<ParamRequest, ParamReply>),
    /// The robot's judgement of its sensors.
    Health(Update<Health>),
    /// The robot's pose in the map (a controller that navigates).
    Pose(Update<PoseEstimate>),
    /// A path to follow (a controller that navigates).
    Path(Stamped<FollowPath>),
}

/// A scan older than this many of its push periods slows the behaviour; twice as old, it stops.
pub const INPUT_AGE_PERIODS: f64 = 5.0;

/// The speed a behaviour keeps, of what its controller asks, while it steers without one of the
/// scans it reads.
pub const WITHOUT_ONE_INPUT: f64 = 0.6;

/// The running state of a [`Behaviour`].
pub struct BehaviourState<C: Controller> {
    ctl: C,
    params: LiveParams<C::Params>,
    /// The direction of travel relative to the base (odometry), for where a contact is.
    steer_rad: f64,
    vel: SendPort<NavigationVelocity>,
    status: PushNewestServer<BehaviourStatus>,
    ir: Option<(Timestamp, Ranges)>,
    sonar: Option<(Timestamp, Ranges)>,
    /// The age beyond which each scan (infrared, sonar) slows it, s.
    age_limit_s: [f64; 2],
    /// The shortest range each scan sees, m.
    min_range_m: [f64; 2],
    health: Option<Health>,
}

/// Asks the robot server `robot` what the robot is.
pub async fn robot_params(
    ctx: &Ctx<impl ractor::Message>,
    robot: &str,
) -> Result<RobotParams, ComponentError> {
    let params: RobotParams = ctx
        .query_client(nomad200::ROBOTPARAMS.on(robot))?
        .query(Empty {}, Some(Duration::from_secs(2)))
        .await
        .map_err(|e| format!("{}: cannot get {robot}/robotparams: {e}", ctx.name()))?;
    Ok(params)
}

/// The check of a live set beyond the table's own: no speed of `C`'s above the top speed of
/// the robot `robot` describes (a value the robot cannot drive would only mislead whoever set
/// it). The config file's values are the robot configuration's business and are not refused
/// here.
fn within_top_speed<C: Controller>(robot: &RobotParams) -> orsa_actors::param::Check<C::Params> {
    let top = robot.max_v_m_s;
    std::sync::Arc::new(move |p: &C::Params| {
        for (name, v) in C::speeds(p) {
            if v > top {
                return Err(Invalid::new(
                    name,
                    format!("{v} m/s is above the robot's top speed of {top} m/s"),
                ));
            }
        }
        Ok(())
    })
}

fn sent(result: Result<(), PatternError>) -> bool {
    match result {
        Ok(()) => true,
        Err(PatternError::Disconnected(_)) => false,
        Err(e) => {
            tracing::debug!("velocity not delivered: {e}");
            false
        }
    }
}

impl<C: Controller> Component for Behaviour<C> {
    type Msg = BehaviourMsg;
    type State = BehaviourState<C>;

    async fn setup(&self, ctx: &Ctx<BehaviourMsg>) -> Result<BehaviourState<C>, ComponentError> {
        if C::READS.is_empty() {
            return Err(format!("{}: its controller reads no scan", ctx.name()).into());
        }
        ctx.declare_states(StateSpec::new().main_state(ACTIVE, &[COMPUTE]))?;
        let robot = robot_params(ctx, &self.robot).await?;
        let params =
            ctx.parameters(&self.params, Some(within_top_speed::<C>(&robot)), BehaviourMsg::Param)?;
        let vel = ctx.send_port(VEL)?;
        let status = ctx.push_newest_server(STATUS)?;
        for scan in [Scan::Infrared, Scan::Sonar] {
            match scan {
                _ if !C::READS.contains(&scan) => {}
                Scan::Infrared => {
                    ctx.subscribe_timed(nomad200::DISTANCEIR.on(&self.robot), 1, BehaviourMsg::Ir)?;
                }
                Scan::Sonar => {
                    ctx.subscribe_timed(nomad200::DISTANCESON.on(&self.robot), 1, BehaviourMsg::Sonar)?;
                }
            }
        }
        ctx.subscribe_timed(nomad200::BASESTATE.on(&self.robot), 1, BehaviourMsg::Base)?;
        ctx.subscribe_newest(health::HEALTH.on(&self.robot), BehaviourMsg::Health)?;
        if C::NAVIGATES {
            ctx.send_server(navigation::PATH, BehaviourMsg::Path)?;
            ctx.subscribe_newest(navigation::POSE.on(navigation::LOCALIZER), BehaviourMsg::Pose)?;
        }
        ctx.activate_event(
            nomad200::CONTACT.on(&self.robot),
            EventMode::Continuous,
            Empty {},
            BehaviourMsg::Contact,
        )?;
        let age_limit_s = [robot.push.distanceir_s, robot.push.distanceson_s].map(|p| INPUT_AGE_PERIODS * p);
        let min_range_m = [robot.infrared.min_range_m, robot.sonar.min_range_m];
        Ok(BehaviourState {
            age_limit_s,
            min_range_m,
            health: None,
            ctl: C::new(params.current(), &robot),
            params,
            steer_rad: 0.0,
            vel,
            status,
            ir: None,
            sonar: None,
        })
    }

    async fn handle(
        &self,
        ctx: &Ctx<BehaviourMsg>,
        st: &mut BehaviourState<C>,
        msg: BehaviourMsg,
    ) -> Result<(), ComponentError> {
        match msg {
            BehaviourMsg::Ir(s) => st.ir = Some((s.stamp, ranges(&s))),
            BehaviourMsg::Sonar(s) => st.sonar = Some((s.stamp, ranges(&s))),
            BehaviourMsg::Base(b) => {
                st.ctl.note_odometry(&b);
                st.steer_rad = b.steer_rad;
                return Ok(());
            }
            BehaviourMsg::Contact(c) => {
                if let Some(direction) = contact_direction(&c.event.value.pressed, st.steer_rad) {
                    st.ctl.note_contact(direction, c.event.value.stamp);
                }
                return Ok(());
            }
            BehaviourMsg::Param(q) => {
                if let Some(p) = st.params.handle(q, ctx.now()) {
                    st.ctl.set_params(p);
                }
                return Ok(());
            }
            BehaviourMsg::Health(h) => {
                st.health = Some(h.value.clone());
                return Ok(());
            }
            BehaviourMsg::Pose(p) => {
                st.ctl.note_pose(&p.value);
                return Ok(());
            }
            BehaviourMsg::Path(p) => {
                st.ctl.note_path(&p.value);
                return Ok(());
            }
        }
        let Ok(_computing) = ctx.state().try_acquire(COMPUTE) else { return Ok(()) };
        let none = [None; RING_SIZE];
        // The command is as old as the oldest of the scans it fuses.
        let stamp = [st.ir.as_ref(), st.sonar.as_ref()].into_iter().flatten().map(|(t, _)| *t).min();
        let judged = judge_inputs(
            C::READS,
            [st.ir.as_ref(), st.sonar.as_ref()],
            [st.age_limit_s, st.min_range_m],
            st.health.as_ref(),
            ctx.now(),
        );
        let seen = Seen {
            stamp: stamp.unwrap_or(Timestamp::ZERO),
            infrared: st.ir.as_ref().filter(|_| judged.usable[0]).map_or(&none, |(_, r)| r),
            sonar: st.sonar.as_ref().filter(|_| judged.usable[1]).map_or(&none, |(_, r)| r),
        };
        let mut step = st.ctl.step(&seen);
        if judged.speed < 1.0 {
            step.cmd.v_m_s *= judged.speed;
            if judged.speed == 0.0 {
                step.cmd.omega_rad_s = 0.0;
            }
        }
        let delivered = sent(st.vel.send(step.cmd));
        st.status.put(BehaviourStatus {
            stamp: seen.stamp,
            cmd: step.cmd,
            wall_m: step.wall_m,
            offset_m: step.offset_m,
            alpha_rad: step.alpha_rad,
            delivered,
            holding: judged.why,
        });
        Ok(())
    }
}

/// What a behaviour makes of its inputs at a step (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Judged {
    /// Whether each scan (infrared, sonar) may be steered on.
    pub usable: [bool; 2],
    /// The share of the controller's speed it keeps (0: it stops, turning included).
    pub speed: f64,
    /// Why it holds back, if it does.
    pub why: Option<String>,
}

/// Judges the scans a controller `reads` (the newest of each, with its stamp: infrared,
/// sonar) at `now`, against their age limits and the robot's `health`; `limits` are each
/// scan's age limit, s, and shortest range, m.
pub fn judge_inputs(
    reads: &[Scan],
    scans: [Option<&(Timestamp, Ranges)>; 2],
    limits: [[f64; 2]; 2],
    health: Option<&Health>,
    now: Timestamp,
) -> Judged {
    let [age_limit_s, min_range_m] = limits;
    let mut j = Judged { usable: [true; 2], speed: 1.0, why: None };
    let mut reasons = Vec::new();
    let (mut read, mut left) = (0, 0);
    for (i, (scan, name)) in [(Scan::Infrared, "infrared"), (Scan::Sonar, "sonar")].into_iter().enumerate() {
        if !reads.contains(&scan) {
            continue;
        }
        // Not come yet: the controller starts without it, as it always has.
        let Some((stamp, _)) = scans[i] else { continue };
        read += 1;
        let verdict = health.map_or(health::Verdict::Healthy, |h| h.verdict(name));
        let age = now.0.saturating_sub(stamp.0) as f64 * 1e-9;
        let limit = age_limit_s[i];
        if verdict != health::Verdict::Healthy {
            j.usable[i] = false;
            reasons.push(format!("{name} judged {}", verdict.name()));
        } else if age > 2.0 * limit {
            j.usable[i] = false;
            reasons.push(format!("{name} {age:.2} s old (limit {limit:.2} s)"));
        } else {
            left += 1;
            if age > limit {
                j.speed = j.speed.min(2.0 - age / limit);
                reasons.push(format!("{name} {age:.2} s old (limit {limit:.2} s)"));
            }
        }
    }
    // What the scans left see closest; a scan dropped that saw closer leaves the robot blind
    // next to its body.
    let nearest_left = (0..2)
        .filter(|&i| j.usable[i] && scans[i].is_some())
        .map(|i| min_range_m[i])
        .fold(f64::INFINITY, f64::min);
    let near_lost = (0..2).any(|i| !j.usable[i] && min_range_m[i] < nearest_left);
    if read > 0 && (left == 0 || near_lost) {
        j.speed = 0.0;
    } else if left < read {
        j.speed = j.speed.min(WITHOUT_ONE_INPUT);
    }
    if !reasons.is_empty() {
        j.why = Some(reasons.join(", "));
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::health::{SensorHealth, Verdict};

    const S: u64 = 1_000_000_000;

    fn health(ir: Verdict) -> Health {
        Health {
            stamp: Timestamp(0),
            sensors: vec![SensorHealth { sensor: "infrared".into(), verdict: ir, ..Default::default() }],
        }
    }

    #[test]
    fn fresh_healthy_inputs_are_used_whole() {
        let r = [None; RING_SIZE];
        let (ir, so) = ((Timestamp(10 * S), r), (Timestamp(10 * S), r));
        let j = judge_inputs(
            &[Scan::Infrared, Scan::Sonar],
            [Some(&ir), Some(&so)],
            [[0.2, 0.32], [0.0, 0.3]],
            Some(&health(Verdict::Healthy)),
            Timestamp(10 * S + S / 10),
        );
        assert_eq!(j, Judged { usable: [true, true], speed: 1.0, why: None });
    }

    #[test]
    fn an_old_input_slows_then_is_dropped_and_an_unhealthy_one_is_never_steered_on() {
        let r = [None; RING_SIZE];
        let reads = [Scan::Infrared, Scan::Sonar];
        let (ir, so) = ((Timestamp(10 * S), r), (Timestamp(10 * S), r));
        // Infrared 0 to 0.6 m, sonar 0.3 to 6 m, with these age limits.
        let limits = |ir_age: f64, so_age: f64| [[ir_age, so_age], [0.0, 0.3]];
        let at = |s: u64, tenths: u64| Timestamp(s * S + tenths * S / 10);
        // Infrared 0.3 s old against a 0.2 s limit: half speed on it.
        let j = judge_inputs(&reads, [Some(&ir), Some(&so)], limits(0.2, 1.0), None, at(10, 3));
        assert!((j.speed - 0.5).abs() < 1e-9 && j.usable == [true, true], "{j:?}");
        assert!(j.why.as_deref().is_some_and(|w| w.starts_with("infrared 0.30 s old")), "{j:?}");
        // 0.5 s old: past twice the limit, dropped; the sonar sees nothing under 0.3 m, so the
        // behaviour stops.
        let j = judge_inputs(&reads, [Some(&ir), Some(&so)], limits(0.2, 1.0), None, at(10, 5));
        assert_eq!((j.usable, j.speed), ([false, true], 0.0));
        // Fresh but judged stuck by the robot: not steered on, and the same.
        let stuck = health(Verdict::Stuck);
        let j = judge_inputs(&reads, [Some(&ir), Some(&so)], limits(0.2, 1.0), Some(&stuck), at(10, 0));
        assert_eq!((j.usable, j.speed), ([false, true], 0.0));
        assert_eq!(j.why.as_deref(), Some("infrared judged stuck"));
        // The sonar too old instead: the infrared sees everything close, and the behaviour goes
        // on it, slower.
        let j = judge_inputs(&reads, [Some(&ir), Some(&so)], limits(1.0, 0.2), None, at(10, 5));
        assert_eq!((j.usable, j.speed), ([true, false], WITHOUT_ONE_INPUT));
        // A controller that reads the infrared alone has nothing left: it stops.
        let dead = health(Verdict::Dead);
        let j = judge_inputs(&[Scan::Infrared], [Some(&ir), None], limits(0.2, 1.0), Some(&dead), at(10, 0));
        assert_eq!((j.usable[0], j.speed), (false, 0.0));
    }
}
