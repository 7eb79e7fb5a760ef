//! The protective layer: a safety monitor between every driver and the motor board.
//!
//! Whatever drives the robot (a behaviour, teleop, a ROS 2 `/cmd_vel`, the fallback master, any
//! tool) reaches the motors through the robot server, and the robot server reaches them through
//! a [`Guarded`] motor board. The monitor reads every range sensor the robot has (its two
//! sector views, placed by the geometry the robot describes in its [`RobotParams`]) and its
//! bumpers, and limits the translation so that the robot can always stop in the free distance
//! it sees along the path it is commanded on:
//!
//! - **the stop zone**: the body, grown by `stop_margin_m`, swept along the commanded arc (a
//!   straight line, or the arc of a turn at the commanded rate) until it would first touch a
//!   point a sensor sees. The free distance `d` to there, less what the robot may have moved
//!   since the reading was taken, bounds the speed: braking at `deceleration_m_s2` after a
//!   reaction time of `latency_s` plus the monitor's own period, the robot stops within `d`:
//!   `v <= a (-T + sqrt(T^2 + 2 d / a))`. The zone grows with speed and shrinks to the margin at
//!   a crawl, so slow motion close to things stays possible (wall following at 20 cm, a 1 m
//!   door): a wall beside the path is not in it.
//! - **the slowdown zone**: within `slowdown_margin_m` more of free path the speed is capped at
//!   `slow_speed_m_s`.
//! - **blind directions**: where no sensor the robot describes covers the direction of travel
//!   (behind a 270 degree laser), or the sensors that cover it have said nothing for
//!   `stale_after_s`, the speed is capped at `blind_speed_m_s`.
//! - **contact**: while a bumper on the side the robot moves towards is pressed, it does not
//!   translate that way.
//!
//! What the sensors saw stays in view for `memory_s`, carried along by odometry: a ring's beams
//! leave gaps close to the body (a convex corner between two narrow infrared beams, below the
//! sonar's shortest range), and what the sonar saw of a door recess's corner half a metre ahead
//! still stops the robot when the corner is in no beam any more. Each point keeps as slack how
//! far the robot may have moved between the reading and the monitor placing it.
//!
//! Turning in place is never limited: the body is round, and a turn sweeps nothing. The
//! commanded turn rate is kept when the translation is limited, so a behaviour that steers away
//! from what stopped it gets away from it.
//!
//! The monitor checks every command as it reaches the board, and again every `period_s` on its
//! own task, so a command that was safe when given is slowed when something comes into the
//! path (a person stepping in), with no new command. It is not a component: it keeps guarding
//! when any component above it crashes, hangs or is killed, and it is made from parameters read
//! once at start (`[safety]`), which no client can change at run time.

use crate::board::{
    AxisAccelerations, AxisVelocities, BoardError, CompassReading, MotorBoard, MotorState, SensorBoard,
};
use orsa_interfaces::health::{Health, HealthCounters};
use orsa_interfaces::nomad200::{ContactScan, DistanceScan, MonitorCounters, RingParams, RobotParams};
use std::sync::{Arc, Weak};
use std::time::Duration;

pub mod health;
mod memory;
mod params;
mod sweep;

use health::{Judge, ViewSpec};
use memory::Memory;
pub use params::SafetyParams;
pub use sweep::{Beams, CLEAR_MARGIN_M, Look, Monitor, Reason, Seen, Sight, free_distance, stoppable_speed};

/// A motor board guarded by the safety monitor (see the module docs). Cheap to clone; the
/// monitor's own task ends with the last clone.
pub struct Guarded<S, M> {
    inner: Arc<Inner<S, M>>,
}

impl<S, M> Clone for Guarded<S, M> {
    fn clone(&self) -> Self {
        Guarded { inner: Arc::clone(&self.inner) }
    }
}

impl<S, M> std::fmt::Debug for Guarded<S, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Guarded").field("params", &self.inner.monitor.as_ref().map(Monitor::params)).finish()
    }
}

struct Inner<S, M> {
    sensors: S,
    motors: M,
    /// `None`: disabled.
    monitor: Option<Monitor>,
    /// The judge of the sensors' health (`None`: `[safety.health]` disables it).
    judge: Option<parking_lot::Mutex<Judge>>,
    /// Held while a command is decided and applied, so that the monitor's own look and a new
    /// command never apply in the wrong order.
    apply: tokio::sync::Mutex<()>,
    state: parking_lot::Mutex<GuardState>,
}

#[derive(Debug, Default)]
struct GuardState {
    /// The command in force as given (translate, turn), if the motors are to move.
    requested: Option<(f64, f64)>,
    /// What the monitor let through of it.
    applied: (f64, f64),
    /// Why it limited it, if it did.
    reason: Option<Reason>,
    counters: MonitorCounters,
    /// What the sensors saw lately, in the odometry frame (see the module docs).
    memory: Memory,
    /// What the last look's readings saw free (kept for its buffers).
    sight: Sight,
    /// When the sensors were last looked at.
    looked: Option<tokio::time::Instant>,
}

impl<S: SensorBoard + 'static, M: MotorBoard + 'static> Guarded<S, M> {
    /// `motors`, guarded by a monitor of `robot` reading `sensors` (none if `params` disable
    /// it), which looks again every `params.period_s` on the tokio clock. Must run inside a
    /// tokio runtime.
    pub fn new(sensors: S, motors: M, robot: RobotParams, params: SafetyParams) -> Self {
        let period = Duration::from_secs_f64(params.period_s);
        let judge = params.health.enabled.then(|| {
            let spec = |r: &RingParams, push_s: f64| ViewSpec {
                bearings_rad: r.angles_rad.clone(),
                mount_radius_m: r.mount_radius_m,
                beam_width_rad: r.beam_width_rad,
                period_s: (r.fire_period_s * r.angles_rad.len() as f64).max(push_s),
                min_range_m: r.min_range_m,
                max_range_m: r.max_range_m,
            };
            parking_lot::Mutex::new(Judge::new(
                params.health.clone(),
                [
                    spec(&robot.infrared, robot.push.distanceir_s),
                    spec(&robot.sonar, robot.push.distanceson_s),
                ],
                robot.push.bumpers_s,
            ))
        });
        let monitor = params.enabled.then(|| Monitor::new(params, robot));
        let guarded = Guarded {
            inner: Arc::new(Inner {
                sensors,
                motors,
                monitor,
                judge,
                apply: tokio::sync::Mutex::new(()),
                state: Default::default(),
            }),
        };
        if guarded.inner.monitor.is_some() {
            tokio::spawn(watch(Arc::downgrade(&guarded.inner), period));
        }
        guarded
    }
}

/// Looks again at the command in force every `period`, until the board is dropped.
async fn watch<S: SensorBoard, M: MotorBoard>(inner: Weak<Inner<S, M>>, period: Duration) {
    let mut next = tokio::time::Instant::now() + period;
    loop {
        tokio::time::sleep_until(next).await;
        next += period;
        let Some(inner) = inner.upgrade() else { return };
        let _turn = inner.apply.lock().await;
        let (requested, looked) = {
            let st = inner.state.lock();
            (st.requested, st.looked)
        };
        let Some((v, w)) = requested else { continue };
        // A command that came within the period looked already.
        if looked.is_some_and(|l| l.elapsed() < period) {
            account(&inner, v, period);
            continue;
        }
        let result = inner.decide_and_apply(v, w, false).await;
        account(&inner, v, period);
        if let Err(e) = result {
            tracing::warn!("safety: the motor board refused a limited command: {e}");
        }
    }
}

/// Counts a period of the command `v` in force as the monitor let it through.
fn account<S, M>(inner: &Inner<S, M>, v: f64, period: Duration) {
    {
        let mut st = inner.state.lock();
        let (av, _) = st.applied;
        let s = period.as_secs_f64();
        let reason = st.reason;
        let c = &mut st.counters;
        if av.abs() < v.abs() {
            c.limited_s += s;
            c.distance_lost_m += (v.abs() - av.abs()) * s;
            if av == 0.0 {
                c.stopped_s += s;
            }
            match reason {
                Some(Reason::Obstacle) => c.obstacle_s += s,
                Some(Reason::Slowdown) => c.slowdown_s += s,
                Some(Reason::Blind) => c.blind_s += s,
                Some(Reason::Contact) => c.contact_s += s,
                Some(Reason::Unhealthy) => c.unhealthy_s += s,
                None => {}
            }
        }
    }
}

impl<S: SensorBoard, M: MotorBoard> Inner<S, M> {
    /// Reads view `v` (0: infrared, 1: sonar) for whoever asks, and shows it to the judge.
    async fn read_view(&self, v: usize) -> Result<DistanceScan, BoardError> {
        let scan =
            if v == 0 { self.sensors.read_infrared().await? } else { self.sensors.read_sonar().await? };
        if let Some(j) = &self.judge {
            j.lock().note_scan(v, &scan);
        }
        Ok(scan)
    }

    /// Reads the bumpers, and shows them to the judge.
    async fn read_contacts(&self) -> Result<ContactScan, BoardError> {
        let scan = self.sensors.read_bumpers().await?;
        if let Some(j) = &self.judge {
            j.lock().note_bumpers(&scan);
        }
        Ok(scan)
    }

    /// Reads the motors, and shows the odometry to the judge.
    async fn read_motors(&self) -> Result<MotorState, BoardError> {
        let m = self.motors.read_state().await?;
        if let Some(j) = &self.judge {
            j.lock().note_motion(m.x_m, m.y_m, m.heading_rad, m.stamp);
        }
        Ok(m)
    }

    /// Looks at the sensors once.
    async fn look(&self) -> Result<Look, BoardError> {
        let Some(m) = &self.monitor else { return Ok(Look::default()) };
        let motors = self.read_motors().await?;
        let ir = self.read_view(0).await?;
        let sonar = self.read_view(1).await?;
        let bumpers = self.read_contacts().await?;
        let now = motors.stamp;
        let stale = Duration::from_secs_f64(m.params.stale_after_s);
        let newest = |s: &DistanceScan| s.readings.iter().map(|r| r.stamp).max().unwrap_or(s.stamp);
        let mut fresh = [&ir, &sonar].map(|s| now.saturating_since(newest(s)) <= stale);
        // A view judged unhealthy is not looked at, nor one that reads nothing with no other
        // view to vouch for its silence: their directions count as unseen.
        let (trusted, bumpers_trusted) = match &self.judge {
            Some(j) => {
                let j = j.lock();
                ([j.view_vouched(0), j.view_vouched(1)], j.bumpers_trusted())
            }
            None => ([true; 2], true),
        };
        for (f, t) in fresh.iter_mut().zip(trusted) {
            *f &= t;
        }
        let pose = (motors.x_m, motors.y_m, motors.heading_rad);
        let mut look = Look {
            seen: Vec::new(),
            fresh,
            // The bumpers are fixed to the base; the direction of travel is `steer_rad` from it.
            // Bumpers judged stuck are not listened to.
            pressed: bumpers
                .pressed
                .iter()
                .zip(&m.robot.bumper_angles_rad)
                .filter(|(p, _)| **p && bumpers_trusted)
                .map(|(_, a)| a - motors.steer_rad)
                .collect(),
            unhealthy: !(trusted[0] && trusted[1] && bumpers_trusted),
            now,
        };
        let mut st = self.state.lock();
        let speed = motors.velocities.translate_m_s.abs().max(st.applied.0.abs());
        st.looked = Some(tokio::time::Instant::now());
        let GuardState { memory, sight, .. } = &mut *st;
        // What lies beyond the path the robot may need from its top speed never limits it.
        let p = &m.params;
        let near =
            m.robot.body_radius_m + p.stopping_distance(&m.robot, m.robot.max_v_m_s) + p.slowdown_margin_m;
        for (v, scan) in [&ir, &sonar].into_iter().enumerate() {
            if fresh[v] {
                memory.place(v, scan, &m.beams[v], pose, now, speed, near);
            }
        }
        let keep = Duration::from_secs_f64(m.params.memory_s);
        // What each fresh view sees free, set out once for every point remembered (in the
        // buffers of the look before: a look allocates nothing once they have grown).
        sight.clear();
        for (v, scan) in [&ir, &sonar].into_iter().enumerate() {
            if fresh[v] {
                m.beams[v].add_to(sight, scan);
            }
        }
        let sight = &*sight;
        let seen_through = |p: &Seen, at: (f64, f64)| sight.newer_than(p.stamp) && sight.clears(p.stamp, at);
        memory.recall(pose, now, keep, near, seen_through, &mut look.seen);
        Ok(look)
    }

    /// Applies `(v, w)` as far as the monitor allows (held: `apply`); a look again at the
    /// command in force (`!new`) reaches the motors only if it changes what they were given.
    async fn decide_and_apply(&self, v: f64, w: f64, new: bool) -> Result<(), BoardError> {
        let Some(m) = &self.monitor else {
            return self.motors.move_velocity(AxisVelocities::synchro(v, w)).await;
        };
        let (allowed, reason) = match self.look().await {
            Ok(look) => m.allowed(v, w, &look),
            // A board that cannot be read cannot be trusted: crawl at most.
            Err(e) => {
                tracing::warn!("safety: cannot read the sensors: {e}");
                (v.abs().min(m.params.blind_speed_m_s), Some(Reason::Blind))
            }
        };
        let av = allowed.min(v.abs()).copysign(v);
        {
            let mut st = self.state.lock();
            if !new && st.applied == (av, w) {
                return Ok(());
            }
            if av.abs() < v.abs() && st.applied.0.abs() >= v.abs() - 1e-12 {
                st.counters.interventions += 1;
            }
            st.applied = (av, w);
            st.reason = (av.abs() < v.abs()).then_some(reason).flatten();
        }
        self.motors.move_velocity(AxisVelocities::synchro(av, w)).await
    }
}

impl<S: SensorBoard + 'static, M: MotorBoard + 'static> MotorBoard for Guarded<S, M> {
    async fn move_velocity(&self, v: AxisVelocities) -> Result<(), BoardError> {
        let _turn = self.inner.apply.lock().await;
        let (t, w) = (v.translate_m_s, v.steer_rad_s);
        self.inner.state.lock().requested = (t != 0.0 || w != 0.0).then_some((t, w));
        self.inner.decide_and_apply(t, w, true).await
    }

    async fn stop(&self) -> Result<(), BoardError> {
        let _turn = self.inner.apply.lock().await;
        {
            let mut st = self.inner.state.lock();
            st.requested = None;
            st.applied = (0.0, 0.0);
            st.reason = None;
        }
        self.inner.motors.stop().await
    }

    async fn wait_stop(&self, timeout: Duration) -> Result<(), BoardError> {
        self.inner.motors.wait_stop(timeout).await
    }

    async fn zero_axes(&self) -> Result<(), BoardError> {
        self.inner.motors.zero_axes().await
    }

    async fn set_velocity_limits(&self, limits: AxisVelocities) -> Result<(), BoardError> {
        self.inner.motors.set_velocity_limits(limits).await
    }

    async fn set_accelerations(&self, accel: AxisAccelerations) -> Result<(), BoardError> {
        self.inner.motors.set_accelerations(accel).await
    }

    async fn read_state(&self) -> Result<MotorState, BoardError> {
        self.inner.read_motors().await
    }

    fn monitor(&self) -> Option<MonitorCounters> {
        self.inner.monitor.as_ref().map(|_| self.inner.state.lock().counters)
    }

    fn health_version(&self) -> Option<u64> {
        self.inner.judge.as_ref().map(|j| j.lock().version())
    }

    fn health(&self) -> Option<(Health, HealthCounters)> {
        self.inner.judge.as_ref().map(|j| {
            let j = j.lock();
            (j.health(), j.counters())
        })
    }
}

/// The guarded board reads the sensors as the monitor does: the robot server reads them
/// through it, so the judge of their health sees every scan either reads.
impl<S: SensorBoard + 'static, M: MotorBoard + 'static> SensorBoard for Guarded<S, M> {
    async fn init(&self) -> Result<(), BoardError> {
        self.inner.sensors.init().await
    }
    async fn set_sonar_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        self.inner.sensors.set_sonar_fire_order(order).await
    }
    async fn set_sonar_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        self.inner.sensors.set_sonar_fire_period(period).await
    }
    async fn set_infrared_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        self.inner.sensors.set_infrared_fire_order(order).await
    }
    async fn set_infrared_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        self.inner.sensors.set_infrared_fire_period(period).await
    }
    async fn read_sonar(&self) -> Result<DistanceScan, BoardError> {
        self.inner.read_view(1).await
    }
    async fn read_infrared(&self) -> Result<DistanceScan, BoardError> {
        self.inner.read_view(0).await
    }
    async fn read_bumpers(&self) -> Result<ContactScan, BoardError> {
        self.inner.read_contacts().await
    }
    async fn read_compass(&self) -> Result<CompassReading, BoardError> {
        self.inner.sensors.read_compass().await
    }
}
