//! The behaviour components: thin actors around the pure controllers.
//!
//! Each behaviour subscribes to the robot server's sensor pushes, runs its controller on every
//! update and sends the result on its wireable `vel` port, whether the port is wired or not (an
//! unwired send is simply not delivered). It computes only while its main state is `active`
//! (it holds substate `compute` for the instant of each step), so a master can silence it with
//! the State pattern. It asks the robot for its geometry (`robotparams`) when it starts, so no
//! robot dimension is hard-coded, and publishes what it saw and decided on `status`. It also
//! follows the robot's odometry (`basestate`), only to notice when it has stopped making
//! progress, and activates the robot's `contact` event, to back out when it touches something
//! (see [`crate::manoeuvres::UnstickParams`]).

use crate::centerfollow::{CenterFollowParams, CenterFollower};
use crate::manoeuvres::contact_direction;
use crate::ring::{Ranges, RingGeometry, ranges};
use crate::wallfollow::{WallFollowParams, WallFollower};
use orsa_actors::event::{EventMode, Fired};
use orsa_actors::param::{LiveParams, ParamReply, ParamRequest};
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

fn states() -> StateSpec {
    StateSpec::new().main_state(ACTIVE, &[COMPUTE])
}

async fn robot_params(ctx: &Ctx<impl ractor::Message>, robot: &str) -> Result<RobotParams, ComponentError> {
    let params: RobotParams = ctx
        .query_client(nomad200::ROBOTPARAMS.on(robot))?
        .query(Empty {}, Some(Duration::from_secs(2)))
        .await
        .map_err(|e| format!("{}: cannot get {robot}/robotparams: {e}", ctx.name()))?;
    Ok(params)
}

/// The sectors none of `views` covers, given the robot's range sensors.
fn blind(robot: &RobotParams, views: &[&nomad200::RingParams]) -> [bool; RING_SIZE] {
    let mut blind = [true; RING_SIZE];
    for view in views {
        let covered = orsa_interfaces::range::sector_coverage(&robot.range_sensors, view);
        for (b, c) in blind.iter_mut().zip(covered) {
            *b &= !c;
        }
    }
    blind
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

/// Wall following as a component (`wallfollow` in the default configuration).
#[derive(Debug, Clone)]
pub struct WallFollow {
    /// Controller parameters.
    pub params: WallFollowParams,
    /// The robot server component's name.
    pub robot: String,
}

/// Messages of [`WallFollow`].
#[derive(Debug)]
pub enum WallFollowMsg {
    /// A new infrared scan.
    Ir(Update<DistanceScan>),
    /// New odometry.
    Base(Update<BaseState>),
    /// The bumpers report contact.
    Contact(Fired<ContactScan>),
    /// A request to its `param` service.
    Param(QueryRequest<ParamRequest, ParamReply>),
}

/// The running state of [`WallFollow`].
pub struct WallFollowState {
    ctl: WallFollower,
    params: LiveParams<WallFollowParams>,
    /// The direction of travel relative to the base (odometry), for where a contact is.
    steer_rad: f64,
    vel: SendPort<NavigationVelocity>,
    status: PushNewestServer<BehaviourStatus>,
}

impl Component for WallFollow {
    type Msg = WallFollowMsg;
    type State = WallFollowState;

    async fn setup(&self, ctx: &Ctx<WallFollowMsg>) -> Result<WallFollowState, ComponentError> {
        ctx.declare_states(states())?;
        let params = ctx.parameters(&self.params, None, WallFollowMsg::Param)?;
        let robot = robot_params(ctx, &self.robot).await?;
        let ring = RingGeometry::uniform(robot.infrared.mount_radius_m, robot.infrared.beam_width_rad);
        let vel = ctx.send_port(VEL)?;
        let status = ctx.push_newest_server(STATUS)?;
        ctx.subscribe_timed(nomad200::DISTANCEIR.on(&self.robot), 1, WallFollowMsg::Ir)?;
        ctx.subscribe_timed(nomad200::BASESTATE.on(&self.robot), 1, WallFollowMsg::Base)?;
        ctx.activate_event(
            nomad200::CONTACT.on(&self.robot),
            EventMode::Continuous,
            Empty {},
            WallFollowMsg::Contact,
        )?;
        let ctl = WallFollower::new(params.current(), ring).with_blind(blind(&robot, &[&robot.infrared]));
        Ok(WallFollowState { ctl, params, steer_rad: 0.0, vel, status })
    }

    async fn handle(
        &self,
        ctx: &Ctx<WallFollowMsg>,
        st: &mut WallFollowState,
        msg: WallFollowMsg,
    ) -> Result<(), ComponentError> {
        let scan = match msg {
            WallFollowMsg::Ir(scan) => scan,
            WallFollowMsg::Base(b) => {
                st.ctl.note_position(b.x_m, b.y_m, b.stamp);
                st.steer_rad = b.steer_rad;
                return Ok(());
            }
            WallFollowMsg::Contact(c) => {
                if let Some(direction) = contact_direction(&c.event.value.pressed, st.steer_rad) {
                    st.ctl.note_contact(direction, c.event.value.stamp);
                }
                return Ok(());
            }
            WallFollowMsg::Param(q) => {
                if let Some(p) = st.params.handle(q, ctx.now()) {
                    st.ctl.set_params(p);
                }
                return Ok(());
            }
        };
        let Ok(_computing) = ctx.state().try_acquire(COMPUTE) else { return Ok(()) };
        let step = st.ctl.step(&ranges(&scan), scan.stamp);
        let delivered = sent(st.vel.send(step.cmd));
        st.status.put(BehaviourStatus {
            stamp: scan.stamp,
            cmd: step.cmd,
            wall_m: step.wall_m,
            offset_m: None,
            alpha_rad: step.alpha_rad,
            delivered,
        });
        Ok(())
    }
}

/// Center following as a component (`centerfollow` in the default configuration).
#[derive(Debug, Clone)]
pub struct CenterFollow {
    /// Controller parameters.
    pub params: CenterFollowParams,
    /// The robot server component's name.
    pub robot: String,
}

/// Messages of [`CenterFollow`].
#[derive(Debug)]
pub enum CenterFollowMsg {
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

/// The running state of [`CenterFollow`].
pub struct CenterFollowState {
    ctl: CenterFollower,
    params: LiveParams<CenterFollowParams>,
    /// The direction of travel relative to the base (odometry), for where a contact is.
    steer_rad: f64,
    vel: SendPort<NavigationVelocity>,
    status: PushNewestServer<BehaviourStatus>,
    ir: Option<(Timestamp, Ranges)>,
    sonar: Option<(Timestamp, Ranges)>,
}

impl Component for CenterFollow {
    type Msg = CenterFollowMsg;
    type State = CenterFollowState;

    async fn setup(&self, ctx: &Ctx<CenterFollowMsg>) -> Result<CenterFollowState, ComponentError> {
        ctx.declare_states(states())?;
        let params = ctx.parameters(&self.params, None, CenterFollowMsg::Param)?;
        let robot = robot_params(ctx, &self.robot).await?;
        let vel = ctx.send_port(VEL)?;
        let status = ctx.push_newest_server(STATUS)?;
        ctx.subscribe_timed(nomad200::DISTANCEIR.on(&self.robot), 1, CenterFollowMsg::Ir)?;
        ctx.subscribe_timed(nomad200::DISTANCESON.on(&self.robot), 1, CenterFollowMsg::Sonar)?;
        ctx.subscribe_timed(nomad200::BASESTATE.on(&self.robot), 1, CenterFollowMsg::Base)?;
        ctx.activate_event(
            nomad200::CONTACT.on(&self.robot),
            EventMode::Continuous,
            Empty {},
            CenterFollowMsg::Contact,
        )?;
        Ok(CenterFollowState {
            ctl: CenterFollower::new(
                params.current(),
                robot.infrared.mount_radius_m,
                robot.infrared.beam_width_rad,
                robot.sonar.beam_width_rad,
            )
            .with_blind(blind(&robot, &[&robot.infrared, &robot.sonar])),
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
        ctx: &Ctx<CenterFollowMsg>,
        st: &mut CenterFollowState,
        msg: CenterFollowMsg,
    ) -> Result<(), ComponentError> {
        match msg {
            CenterFollowMsg::Ir(s) => st.ir = Some((s.stamp, ranges(&s))),
            CenterFollowMsg::Sonar(s) => st.sonar = Some((s.stamp, ranges(&s))),
            CenterFollowMsg::Base(b) => {
                st.ctl.note_odometry(b.x_m, b.y_m, b.heading_rad, b.omega_rad_s, b.stamp);
                st.steer_rad = b.steer_rad;
                return Ok(());
            }
            CenterFollowMsg::Contact(c) => {
                if let Some(direction) = contact_direction(&c.event.value.pressed, st.steer_rad) {
                    st.ctl.note_contact(direction, c.event.value.stamp);
                }
                return Ok(());
            }
            CenterFollowMsg::Param(q) => {
                if let Some(p) = st.params.handle(q, ctx.now()) {
                    st.ctl.set_params(p);
                }
                return Ok(());
            }
        }
        let Ok(_computing) = ctx.state().try_acquire(COMPUTE) else { return Ok(()) };
        let none = [None; RING_SIZE];
        let (ir_stamp, ir) = st.ir.as_ref().map_or((Timestamp::ZERO, &none), |(t, r)| (*t, r));
        let (so_stamp, sonar) = st.sonar.as_ref().map_or((Timestamp::ZERO, &none), |(t, r)| (*t, r));
        // The command is as old as the older of the two scans it fuses.
        let stamp = if st.ir.is_some() && st.sonar.is_some() {
            ir_stamp.min(so_stamp)
        } else {
            ir_stamp.max(so_stamp)
        };
        let step = st.ctl.step(ir, sonar, stamp);
        let delivered = sent(st.vel.send(step.cmd));
        st.status.put(BehaviourStatus {
            stamp,
            cmd: step.cmd,
            wall_m: None,
            offset_m: step.offset_m,
            alpha_rad: step.alpha_rad,
            delivered,
        });
        Ok(())
    }
}
