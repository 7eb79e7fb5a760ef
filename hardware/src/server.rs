//! The `nomad200` component: the robot server, built only from the patterns.
//!
//! It is the thesis' smartNomad200Server. Behaviours never touch the boards; they use these
//! services:
//!
//! | service | pattern | object | what |
//! |---|---|---|---|
//! | `distanceir` | push timed, 40 ms | [`DistanceScan`] | latest infrared ring |
//! | `distanceson` | push timed, 64 ms | [`DistanceScan`] | latest sonar ring |
//! | `bumpers` | push timed, 30 ms | [`ContactScan`] | bumper ring |
//! | `basestate` | push timed, 100 ms | [`BaseState`] | odometry pose, velocities, compass |
//! | `navigationvelocity` | send | [`NavigationVelocity`] | drive (v, omega), clamped to the limits |
//! | `teleop` | send | [`NavigationVelocity`] | drive by hand: takes priority over `navigationvelocity` |
//! | `robotparams` | query | [`Empty`] -> [`RobotParams`] | geometry, limits, sensor layout |
//! | `contact` | event | [`Empty`] -> [`ContactScan`] | fires with every bumper reading in which a bumper is pressed |
//!
//! `omega` is applied to steer and turret together, as the original did, so the sensor rings
//! keep facing the direction of travel.
//!
//! Safety: a command is judged by its own timestamp. It is refused if it is older than
//! `cmd_timeout` when it arrives, older than the last command applied (out of order), or stamped
//! in the future by more than `max_clock_skew`. A command applied may drive the robot until its
//! stamp (or now, if earlier) plus `cmd_timeout`; at that deadline, unless a fresher command has
//! moved it, a watchdog stops the motors itself, exactly on tokio's clock, retrying until the
//! board accepts. The watchdog holds its own handle on the motor board and outlives a failed or
//! killed server instance, so a robot that loses its commander, or its server, stops, every
//! time. When the component stops normally, it stops the motors and waits for the axes to come
//! to rest, as the original's RobotConnection destructor did.
//!
//! Teleoperation: a command on `teleop` passes the same checks and, once applied, holds the
//! robot for teleoperation until its deadline: meanwhile `navigationvelocity` commands are
//! counted as `overridden` and not applied. When teleop goes silent the watchdog stops the
//! robot at that deadline, and the next behaviour command drives again.

use crate::board::{AxisVelocities, CompassReading, MotorBoard, MotorState, SensorBoard};
use orsa_actors::event::EventServer;
use orsa_actors::param::Invalid;
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::push_timed::{PushTimedServer, Tick};
use orsa_actors::query::QueryRequest;
use orsa_actors::{Component, ComponentError, Ctx, Empty, Stamped, Timestamp};
use orsa_interfaces::health::Health;
use orsa_interfaces::nomad200::{
    self, BaseState, ContactScan, DistanceScan, NavigationVelocity, PushPeriods, RobotParams, SafetyCounters,
};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;
use tokio::sync::watch;

/// Configuration of the robot server (the robot server's `[params.NAME]` table of the config file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ServerParams {
    /// The component's name.
    pub name: String,
    /// Push periods, s.
    pub distanceir_period_s: f64,
    /// Sonar push period, s.
    pub distanceson_period_s: f64,
    /// Bumper push period, s.
    pub bumpers_period_s: f64,
    /// Base state push period, s.
    pub basestate_period_s: f64,
    /// A command older than this is not acted on, and the robot stops this long after the
    /// last fresh command, s.
    pub cmd_timeout_s: f64,
    /// How long to wait for the axes to stop when the component stops, s.
    pub stop_wait_s: f64,
    /// A command stamped later than now by more than this is refused (a peer's clock is
    /// ahead), s.
    pub max_clock_skew_s: f64,
}

impl Default for ServerParams {
    fn default() -> Self {
        let p = PushPeriods::default();
        ServerParams {
            name: "nomad200".into(),
            distanceir_period_s: p.distanceir_s,
            distanceson_period_s: p.distanceson_s,
            bumpers_period_s: p.bumpers_s,
            basestate_period_s: p.basestate_s,
            cmd_timeout_s: 0.5,
            stop_wait_s: 3.0,
            max_clock_skew_s: 0.05,
        }
    }
}

impl ServerParams {
    /// Checks every value; the message names the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        if !orsa_actors::addr::valid_name(&self.name) {
            return Err(Invalid::new("robot.name", format!("'{}' is not a valid component name", self.name)));
        }
        for (key, v) in [
            ("distanceir_period_s", self.distanceir_period_s),
            ("distanceson_period_s", self.distanceson_period_s),
            ("bumpers_period_s", self.bumpers_period_s),
            ("basestate_period_s", self.basestate_period_s),
            ("cmd_timeout_s", self.cmd_timeout_s),
            ("stop_wait_s", self.stop_wait_s),
            ("max_clock_skew_s", self.max_clock_skew_s),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 3600.0) {
                return Err(Invalid::new(
                    format!("robot.{key}"),
                    format!("must be a positive number of seconds, not {v}"),
                ));
            }
        }
        Ok(())
    }

    /// The push periods, as [`RobotParams`] report them.
    pub fn push_periods(&self) -> PushPeriods {
        PushPeriods {
            distanceir_s: self.distanceir_period_s,
            distanceson_s: self.distanceson_period_s,
            bumpers_s: self.bumpers_period_s,
            basestate_s: self.basestate_period_s,
        }
    }
}

/// The `contact` event's condition: it fires, with the scan, while a bumper is pressed. (A
/// replay's stand-in for the robot server tests the same condition on the recorded bumpers.)
pub fn contact_fires(_: &mut Empty, scan: &ContactScan) -> Option<ContactScan> {
    scan.any().then(|| scan.clone())
}

/// How often the health is pushed when it does not change.
pub const HEALTH_EVERY: Duration = Duration::from_secs(1);

/// The `healthchanges` event's condition: the server puts the health only when it changed, so
/// every put fires.
pub fn health_fires(_: &mut Empty, health: &Health) -> Option<Health> {
    Some(health.clone())
}

/// The robot server over any pair of boards.
pub struct Nomad200<S, M> {
    params: ServerParams,
    robot: RobotParams,
    sensors: S,
    motors: M,
}

impl<S, M> Nomad200<S, M> {
    /// A server for these boards; `robot` describes the robot (its push periods are replaced by
    /// the server's own).
    pub fn new(params: ServerParams, mut robot: RobotParams, sensors: S, motors: M) -> Self {
        robot.push = params.push_periods();
        Nomad200 { params, robot, sensors, motors }
    }
}

/// Messages of the robot server.
#[derive(Debug)]
pub enum Nomad200Msg {
    /// Time to push the infrared ring.
    Ir(Tick),
    /// Time to push the sonar ring.
    Sonar(Tick),
    /// Time to push the bumpers.
    Bumpers(Tick),
    /// Time to push the base state.
    Base(Tick),
    /// A velocity command.
    Velocity(Stamped<NavigationVelocity>),
    /// A teleoperation command.
    Teleop(Stamped<NavigationVelocity>),
    /// A request for the robot's parameters.
    Params(QueryRequest<Empty, RobotParams>),
    /// A request for the safety counters.
    Safety(QueryRequest<Empty, SafetyCounters>),
}

/// The server's running state.
pub struct Nomad200State {
    ir: PushTimedServer<DistanceScan>,
    sonar: PushTimedServer<DistanceScan>,
    bumpers: PushTimedServer<ContactScan>,
    /// Fires to every activation while something presses the bumpers.
    contact: EventServer<Empty, ContactScan, ContactScan>,
    base: PushTimedServer<BaseState>,
    /// The sensors' health, pushed and fired on every change.
    health: PushNewestServer<Health>,
    health_changes: EventServer<Empty, Health, Health>,
    /// The judge's version last pushed.
    health_version: Option<u64>,
    /// When the health was last pushed.
    health_pushed: Option<Timestamp>,
    deadline: watch::Sender<Option<Timestamp>>,
    /// Whether the watchdog waits for a deadline (it enforced the last one).
    watchdog_idle: Arc<AtomicBool>,
    last_applied: Option<Timestamp>,
    /// Until when teleoperation holds the robot.
    teleop_until: Option<Timestamp>,
    counters: SafetyCounters,
    /// The counters as the last instance left them (restarts do not reset them).
    kept: Arc<parking_lot::Mutex<SafetyCounters>>,
    timeouts: Arc<AtomicU64>,
}

fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(s)
}

impl<S, M> Nomad200<S, M>
where
    S: SensorBoard + 'static,
    M: MotorBoard + Clone + 'static,
{
    /// Pushes the sensors' health if it changed since it was last pushed, or if
    /// [`HEALTH_EVERY`] has passed since (so that a subscriber that comes late, such as
    /// `orsa list`, has it within that time); fires it only when it changed.
    fn push_health(&self, st: &mut Nomad200State, now: Timestamp) {
        let version = self.motors.health_version();
        if version.is_none() {
            return;
        }
        let changed = version != st.health_version;
        let due = st.health_pushed.is_none_or(|t| now.saturating_since(t) >= HEALTH_EVERY);
        if !(changed || due) {
            return;
        }
        st.health_version = version;
        st.health_pushed = Some(now);
        if let Some((health, _)) = self.motors.health() {
            if changed {
                if st.health_version.is_some_and(|v| v > 0) {
                    tracing::info!("sensor health: {}", health.summary());
                }
                st.health_changes.put(&health);
            }
            st.health.put(health);
        }
    }

    async fn drive(&self, st: &mut Nomad200State, v: f64, omega: f64) -> bool {
        match self.motors.move_velocity(AxisVelocities::synchro(v, omega)).await {
            Ok(()) => true,
            Err(e) => {
                st.counters.failed += 1;
                tracing::warn!("nomad200: motor board refused ({v}, {omega}): {e}");
                false
            }
        }
    }

    async fn on_velocity(
        &self,
        ctx: &Ctx<Nomad200Msg>,
        st: &mut Nomad200State,
        cmd: NavigationVelocity,
        teleop: bool,
    ) {
        let now = ctx.now();
        let timeout = secs(self.params.cmd_timeout_s);
        if !teleop && st.teleop_until.is_some_and(|t| now < t) {
            st.counters.overridden += 1;
            return;
        }
        if cmd.stamp > now.after(secs(self.params.max_clock_skew_s)) {
            st.counters.future_refused += 1;
            tracing::warn!("nomad200: refused a command stamped {} in the future at {now}", cmd.stamp);
            return;
        }
        if now.saturating_since(cmd.stamp) > timeout || st.last_applied.is_some_and(|l| cmd.stamp < l) {
            st.counters.stale_refused += 1;
            tracing::debug!("nomad200: refused a stale command stamped {} at {now}", cmd.stamp);
            return;
        }
        if !(cmd.v_m_s.is_finite() && cmd.omega_rad_s.is_finite()) {
            st.counters.failed += 1;
            tracing::warn!("nomad200: refused a command that is not finite: {cmd:?}");
            return;
        }
        let v = cmd.v_m_s.clamp(-self.robot.max_v_m_s, self.robot.max_v_m_s);
        let w = cmd.omega_rad_s.clamp(-self.robot.max_omega_rad_s, self.robot.max_omega_rad_s);
        if v != cmd.v_m_s || w != cmd.omega_rad_s {
            st.counters.clamped += 1;
        }
        if self.drive(st, v, w).await {
            st.counters.applied += 1;
            if ctx.now().saturating_since(cmd.stamp) > timeout {
                st.counters.stale_applied += 1;
                tracing::warn!("nomad200: a command stamped {} reached the motors stale", cmd.stamp);
            }
            st.last_applied = Some(cmd.stamp);
            // The robot may go on with this command until it is cmd_timeout old (counted from
            // now at the latest, whatever a skewed clock says).
            let deadline = cmd.stamp.min(now).after(timeout);
            // The watchdog sleeps until the deadline it last read and looks again when it
            // wakes, so a deadline that moves later, the usual case, needs no wake-up. It is
            // woken when it waits for a deadline (none yet, or it enforced the last one), and
            // when the deadline stays or moves earlier: a command with the deadline being
            // enforced may land while the watchdog stops the robot, and drive it again.
            st.deadline.send_if_modified(|d| {
                let wake = (*d).is_none_or(|d| deadline <= d) || st.watchdog_idle.load(Ordering::SeqCst);
                *d = Some(deadline);
                wake
            });
            if teleop {
                st.teleop_until = Some(deadline);
            }
        }
    }
}

impl<S, M> Component for Nomad200<S, M>
where
    S: SensorBoard + 'static,
    M: MotorBoard + Clone + 'static,
{
    type Msg = Nomad200Msg;
    type State = Nomad200State;

    async fn setup(&self, ctx: &Ctx<Nomad200Msg>) -> Result<Nomad200State, ComponentError> {
        self.params.validate()?;
        let p = &self.params;
        let ir = ctx.push_timed_server(nomad200::DISTANCEIR, secs(p.distanceir_period_s), Nomad200Msg::Ir)?;
        let sonar =
            ctx.push_timed_server(nomad200::DISTANCESON, secs(p.distanceson_period_s), Nomad200Msg::Sonar)?;
        let bumpers =
            ctx.push_timed_server(nomad200::BUMPERS, secs(p.bumpers_period_s), Nomad200Msg::Bumpers)?;
        let base =
            ctx.push_timed_server(nomad200::BASESTATE, secs(p.basestate_period_s), Nomad200Msg::Base)?;
        ctx.send_server(nomad200::NAVIGATIONVELOCITY, Nomad200Msg::Velocity)?;
        ctx.send_server(nomad200::TELEOP, Nomad200Msg::Teleop)?;
        ctx.query_server(nomad200::ROBOTPARAMS, Nomad200Msg::Params)?;
        ctx.query_server(nomad200::SAFETY, Nomad200Msg::Safety)?;
        let contact = ctx.event_server(nomad200::CONTACT, contact_fires)?;
        let health = ctx.push_newest_server(orsa_interfaces::health::HEALTH)?;
        let health_changes = ctx.event_server(orsa_interfaces::health::HEALTH_CHANGES, health_fires)?;
        // A (re)started server does not trust whatever the motors were doing.
        self.motors.stop().await?;
        for s in [&ir, &sonar] {
            s.start();
        }
        bumpers.start();
        base.start();

        // The watchdog: an activity of this instance with its own handle on the motors. It
        // sleeps until the current command deadline and stops the robot there; if the instance
        // ends (its deadline sender is dropped) it still stops the robot at the last deadline.
        let (deadline, rx) = watch::channel::<Option<Timestamp>>(None);
        // The counters cover the component's whole life, not one instance's.
        let timeouts = ctx.keep("timeouts", || Arc::new(AtomicU64::new(0)))?;
        let kept = ctx.keep("safety", || Arc::new(parking_lot::Mutex::new(SafetyCounters::default())))?;
        let counters = *kept.lock();
        let watchdog_idle = Arc::new(AtomicBool::new(false));
        ctx.spawn_activity(watchdog(
            self.motors.clone(),
            ctx.clock(),
            rx,
            Arc::clone(&watchdog_idle),
            Arc::clone(&timeouts),
        ));
        Ok(Nomad200State {
            ir,
            sonar,
            bumpers,
            contact,
            base,
            health,
            health_changes,
            health_version: None,
            health_pushed: None,
            deadline,
            watchdog_idle,
            last_applied: None,
            teleop_until: None,
            counters,
            kept,
            timeouts,
        })
    }

    async fn handle(
        &self,
        ctx: &Ctx<Nomad200Msg>,
        st: &mut Nomad200State,
        msg: Nomad200Msg,
    ) -> Result<(), ComponentError> {
        match msg {
            Nomad200Msg::Ir(_) => {
                st.ir.put(self.sensors.read_infrared().await?);
                self.push_health(st, ctx.now());
            }
            Nomad200Msg::Sonar(_) => {
                st.sonar.put(self.sensors.read_sonar().await?);
            }
            Nomad200Msg::Bumpers(_) => {
                let scan = self.sensors.read_bumpers().await?;
                st.contact.put(&scan);
                st.bumpers.put(scan);
            }
            Nomad200Msg::Base(_) => {
                let m = self.motors.read_state().await?;
                let c = self.sensors.read_compass().await?;
                st.base.put(base_state(&m, &c));
                self.push_health(st, ctx.now());
            }
            Nomad200Msg::Velocity(cmd) => self.on_velocity(ctx, st, cmd.value, false).await,
            Nomad200Msg::Teleop(cmd) => self.on_velocity(ctx, st, cmd.value, true).await,
            Nomad200Msg::Params(q) => {
                let _ = q.answer(self.robot.clone());
            }
            Nomad200Msg::Safety(q) => {
                let counters = SafetyCounters {
                    timeouts: st.timeouts.load(Ordering::Relaxed),
                    monitor: self.motors.monitor(),
                    health: self.motors.health().map(|(_, c)| c),
                    ..st.counters
                };
                let _ = q.answer(counters);
            }
        }
        *st.kept.lock() = st.counters;
        Ok(())
    }

    async fn teardown(&self, _ctx: &Ctx<Nomad200Msg>, _st: &mut Nomad200State) {
        if let Err(e) = self.motors.stop().await {
            tracing::warn!("nomad200: cannot stop the motors on shutdown: {e}");
            return;
        }
        if let Err(e) = self.motors.wait_stop(secs(self.params.stop_wait_s)).await {
            tracing::warn!("nomad200: the axes did not come to rest: {e}");
        }
    }
}

/// Stops the motors at each command deadline, retrying until the board accepts; ends once the
/// instance that set the deadlines is gone and the last one has been enforced.
///
/// The server moves a deadline later without waking this task (see `on_velocity`): on waking
/// at the deadline it slept for, it looks at the current one and sleeps on if it moved.
async fn watchdog<M: MotorBoard>(
    motors: M,
    clock: orsa_actors::Clock,
    mut rx: watch::Receiver<Option<Timestamp>>,
    idle: Arc<AtomicBool>,
    timeouts: Arc<AtomicU64>,
) {
    loop {
        let current = *rx.borrow_and_update();
        let Some(d) = current else {
            if rx.changed().await.is_err() {
                return; // no command was ever applied and the instance is gone
            }
            continue;
        };
        let instance_gone = tokio::select! {
            () = tokio::time::sleep_until(clock.instant_of(d)) => false,
            changed = rx.changed() => {
                if changed.is_ok() {
                    continue; // a command set the deadline again, or earlier
                }
                true
            }
        };
        // What the server set last, silent moves included (readable after it is gone too).
        let last = rx.borrow().unwrap_or(d);
        if instance_gone {
            tokio::time::sleep_until(clock.instant_of(last)).await;
        } else if last != d {
            continue; // a fresher command moved the deadline
        }
        let moving = motors.read_state().await.map(|m| !m.stopped).unwrap_or(true);
        if !instance_gone && *rx.borrow() != Some(last) {
            continue; // a fresher command moved the deadline meanwhile
        }
        if moving {
            tracing::info!("nomad200: no fresh command since {last}: stopping");
            timeouts.fetch_add(1, Ordering::Relaxed);
            stop_until_accepted(&motors).await;
        }
        if instance_gone {
            return;
        }
        // Wait for a new command's deadline. Saying so before looking: a deadline set before
        // the look is seen, one set after it wakes us (the server reads `idle` under the
        // watch's lock).
        idle.store(true, Ordering::SeqCst);
        if *rx.borrow() == Some(d) && rx.changed().await.is_err() {
            return;
        }
        idle.store(false, Ordering::SeqCst);
    }
}

/// Stops the motors, retrying every 50 ms while the board refuses (but not once it is gone).
async fn stop_until_accepted<M: MotorBoard>(motors: &M) {
    loop {
        match motors.stop().await {
            Ok(()) => return,
            Err(crate::board::BoardError::Disconnected(e)) => {
                tracing::warn!("nomad200: cannot stop the motors, the board is gone: {e}");
                return;
            }
            Err(e) => {
                tracing::warn!("nomad200: the motor board refused to stop: {e}; retrying");
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
    }
}
/// The base state from the motor board's encoders and the latest compass sample, stamped when
/// the encoders were read.
fn base_state(motors: &MotorState, compass: &CompassReading) -> BaseState {
    BaseState {
        stamp: motors.stamp,
        x_m: motors.x_m,
        y_m: motors.y_m,
        heading_rad: motors.heading_rad,
        v_m_s: motors.velocities.translate_m_s,
        omega_rad_s: motors.velocities.steer_rad_s,
        steer_rad: motors.steer_rad,
        turret_rad: motors.turret_rad,
        turret_omega_rad_s: motors.velocities.turret_rad_s,
        compass_rad: compass.heading_rad,
        compass_valid: compass.valid,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base_state_takes_each_field_from_its_reading() {
        let motors = MotorState {
            stamp: Timestamp(7),
            x_m: 1.0,
            y_m: 2.0,
            heading_rad: 0.3,
            steer_rad: 0.25,
            turret_rad: -0.5,
            velocities: AxisVelocities { translate_m_s: 0.2, steer_rad_s: 0.1, turret_rad_s: -0.1 },
            stopped: false,
        };
        let compass = CompassReading { stamp: Timestamp(5), heading_rad: 1.5, valid: true };
        let b = base_state(&motors, &compass);
        assert_eq!((b.stamp, b.x_m, b.y_m, b.heading_rad), (Timestamp(7), 1.0, 2.0, 0.3));
        assert_eq!((b.v_m_s, b.omega_rad_s, b.turret_omega_rad_s), (0.2, 0.1, -0.1));
        assert_eq!((b.steer_rad, b.turret_rad, b.compass_rad, b.compass_valid), (0.25, -0.5, 1.5, true));
    }
}
