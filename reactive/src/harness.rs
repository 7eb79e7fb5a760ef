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
//!   decided is pushed on `status`.
//!
//! A new behaviour is one file: a controller and its `impl Controller`, registered in the
//! catalog as `Behaviour::<MyController> { params, robot }` (`examples/new_behaviour.rs`).

use crate::manoeuvres::contact_direction;
use crate::ring::{Ranges, ranges};
use orsa_actors::event::{EventMode, Fired};
use orsa_actors::param::{LiveParams, ParamReply, ParamRequest, Parameters};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::QueryRequest;
use orsa_actors::state::StateSpec;
use orsa_actors::wiring::SendPort;
use orsa_actors::{Component, ComponentError, Ctx, Empty, PatternError, Timestamp, Update};
use orsa_interfaces::behaviour::{ACTIVE, BehaviourStatus, COMPUTE, STATUS, VEL};
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
}

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
        let params = ctx.parameters(&self.params, None, BehaviourMsg::Param)?;
        let robot = robot_params(ctx, &self.robot).await?;
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
        ctx.activate_event(
            nomad200::CONTACT.on(&self.robot),
            EventMode::Continuous,
            Empty {},
            BehaviourMsg::Contact,
        )?;
        Ok(BehaviourState {
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
        }
        let Ok(_computing) = ctx.state().try_acquire(COMPUTE) else { return Ok(()) };
        let none = [None; RING_SIZE];
        // The command is as old as the oldest of the scans it fuses.
        let stamp = [st.ir.as_ref(), st.sonar.as_ref()].into_iter().flatten().map(|(t, _)| *t).min();
        let seen = Seen {
            stamp: stamp.unwrap_or(Timestamp::ZERO),
            infrared: st.ir.as_ref().map_or(&none, |(_, r)| r),
            sonar: st.sonar.as_ref().map_or(&none, |(_, r)| r),
        };
        let step = st.ctl.step(&seen);
        let delivered = sent(st.vel.send(step.cmd));
        st.status.put(BehaviourStatus {
            stamp: seen.stamp,
            cmd: step.cmd,
            wall_m: step.wall_m,
            offset_m: step.offset_m,
            alpha_rad: step.alpha_rad,
            delivered,
        });
        Ok(())
    }
}
