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

use crate::board::{AxisAccelerations, AxisVelocities, BoardError, MotorBoard, MotorState, SensorBoard};
use orsa_actors::Timestamp;
use orsa_actors::param::Invalid;
use orsa_interfaces::nomad200::{
    DistanceReading, DistanceScan, MonitorCounters, RING_SIZE, RingParams, RobotParams,
};
use orsa_interfaces::range::sector_coverage;
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};
use std::sync::{Arc, Weak};
use std::time::Duration;

/// The monitor's parameters (`[safety]`), read at start only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetyParams {
    /// Whether the monitor guards the motors (default true; false only to measure what it
    /// costs).
    pub enabled: bool,
    /// The stop zone: the body grown by this much, m (default 0.03).
    pub stop_margin_m: f64,
    /// The slowdown zone: this much free path beyond the stop zone, m (default 0.1).
    pub slowdown_margin_m: f64,
    /// The speed cap in the slowdown zone, m/s (default 0.15).
    pub slow_speed_m_s: f64,
    /// Time from a reading to the brakes acting, s, on top of the monitor's period (default
    /// 0.1).
    pub latency_s: f64,
    /// The deceleration braking is counted at, m/s^2 (default: the robot's own, its
    /// `accel_m_s2`; never more).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deceleration_m_s2: Option<f64>,
    /// How often the monitor looks again at the command in force, s (default 0.04).
    pub period_s: f64,
    /// The speed cap towards a direction no healthy sensor sees, m/s (default 0.05).
    pub blind_speed_m_s: f64,
    /// A sensor view with no reading this recent is not trusted, s (default 1.0).
    pub stale_after_s: f64,
    /// How long what the sensors saw stays in view at most, carried by odometry, unless a
    /// reading sees through it first, s (default 10).
    pub memory_s: f64,
}

impl Default for SafetyParams {
    fn default() -> Self {
        SafetyParams {
            enabled: true,
            stop_margin_m: 0.03,
            slowdown_margin_m: 0.1,
            slow_speed_m_s: 0.15,
            latency_s: 0.1,
            deceleration_m_s2: None,
            period_s: 0.04,
            blind_speed_m_s: 0.05,
            stale_after_s: 1.0,
            memory_s: 10.0,
        }
    }
}

/// The table's keys, as errors name them.
const TABLE: &str = "safety";

impl SafetyParams {
    /// Why these parameters cannot be used on any robot, if they cannot.
    pub fn validate(&self) -> Result<(), Invalid> {
        let bad = |key: &str, reason: String| Err(Invalid::new(format!("{TABLE}.{key}"), reason));
        let checks: [(&str, f64, f64, f64); 8] = [
            ("stop_margin_m", self.stop_margin_m, 0.0, 1.0),
            ("slowdown_margin_m", self.slowdown_margin_m, 0.0, 10.0),
            ("slow_speed_m_s", self.slow_speed_m_s, 1e-3, 10.0),
            ("latency_s", self.latency_s, 0.0, 2.0),
            ("period_s", self.period_s, 1e-3, 0.5),
            ("blind_speed_m_s", self.blind_speed_m_s, 0.0, 10.0),
            ("stale_after_s", self.stale_after_s, 1e-3, 60.0),
            ("memory_s", self.memory_s, 0.0, 60.0),
        ];
        for (key, v, lo, hi) in checks {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return bad(key, format!("must be between {lo} and {hi}, got {v}"));
            }
        }
        if let Some(a) = self.deceleration_m_s2
            && !(a.is_finite() && a > 0.0)
        {
            return bad("deceleration_m_s2", format!("must be above 0, got {a}"));
        }
        Ok(())
    }

    /// The deceleration braking is counted at on `robot`.
    pub fn deceleration(&self, robot: &RobotParams) -> f64 {
        self.deceleration_m_s2.unwrap_or(robot.accel_m_s2)
    }

    /// The free path the robot needs to stop from `v` m/s: reaction, braking and the margin.
    pub fn stopping_distance(&self, robot: &RobotParams, v: f64) -> f64 {
        let a = self.deceleration(robot);
        v * (self.latency_s + self.period_s) + v * v / (2.0 * a) + self.stop_margin_m
    }

    /// Why these parameters cannot guard `robot`, if they cannot: braking counted harder than
    /// the robot brakes, or zones that cannot stop it from its top speed within what its
    /// sensors see ahead. `robot_keys` names where the robot's own figures come from.
    pub fn check_against(&self, robot: &RobotParams, robot_keys: &str) -> Result<(), Invalid> {
        self.validate()?;
        if !self.enabled {
            return Ok(());
        }
        let a = self.deceleration(robot);
        if !(a.is_finite() && a > 0.0) {
            return Err(Invalid::new(
                format!("{TABLE}.deceleration_m_s2"),
                format!("the robot describes no deceleration ({robot_keys} gives {a} m/s^2): give one"),
            ));
        }
        if a > robot.accel_m_s2 {
            return Err(Invalid::new(
                format!("{TABLE}.deceleration_m_s2"),
                format!(
                    "{a} m/s^2 is more than the robot brakes at ({} m/s^2, {robot_keys}): the monitor \
                     would count on stopping shorter than it can",
                    robot.accel_m_s2
                ),
            ));
        }
        let need = self.stopping_distance(robot, robot.max_v_m_s);
        let sees = [&robot.sonar, &robot.infrared]
            .iter()
            .map(|r| r.mount_radius_m + r.max_range_m - robot.body_radius_m)
            .fold(0.0, f64::max);
        if need > sees {
            return Err(Invalid::new(
                format!("{TABLE}.latency_s"),
                format!(
                    "from the robot's top speed ({} m/s, {robot_keys}) the zones need {need:.2} m to stop \
                     it (with {TABLE}.period_s, {TABLE}.deceleration_m_s2 and {TABLE}.stop_margin_m), more \
                     than its sensors see ahead ({sees:.2} m): shorten the latency or the period, or lower \
                     the top speed",
                    robot.max_v_m_s
                ),
            ));
        }
        Ok(())
    }
}

/// Why the monitor limited a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    /// Something in the stop zone: the speed it can stop from in the free path.
    Obstacle,
    /// Something in the slowdown zone.
    Slowdown,
    /// No healthy sensor sees the direction of travel.
    Blind,
    /// A bumper is pressed on the side the robot moves towards.
    Contact,
}

/// The distance the robot's centre travels along the path of `(v, omega)` before a disc of
/// radius `r` around it first touches `p` (body frame: x ahead, y left); infinite if it never
/// does, 0 if it touches `p` now and the motion brings it closer.
pub fn free_distance(p: (f64, f64), v: f64, omega: f64, r: f64) -> f64 {
    let (px, py) = p;
    if v == 0.0 {
        return f64::INFINITY;
    }
    // Straight (a turn wider than a kilometre is straight here).
    if (omega / v).abs() < 1e-3 {
        let x = px * v.signum();
        if py.abs() >= r {
            return f64::INFINITY;
        }
        let h = (r * r - py * py).sqrt();
        return if x - h > 0.0 {
            x - h
        } else if x + h <= 0.0 || x <= 0.0 {
            f64::INFINITY // behind, or inside and moving away
        } else {
            0.0
        };
    }
    // An arc about the instantaneous centre of rotation (0, rc); the robot's centre goes round
    // it at omega, from (0, -rc).
    let rc = v / omega;
    let big_r = rc.abs();
    let (qx, qy) = (px, py - rc);
    let rho = qx.hypot(qy);
    if rho < 1e-9 {
        return f64::INFINITY; // on the centre of rotation: its distance never changes
    }
    let phi0 = (-rc).atan2(0.0);
    let delta = (omega.signum() * (qy.atan2(qx) - phi0)).rem_euclid(TAU);
    let cos_contact = (big_r * big_r + rho * rho - r * r) / (2.0 * big_r * rho);
    if cos_contact >= 1.0 {
        return f64::INFINITY; // the swept annulus misses it
    }
    let contact = cos_contact.max(-1.0).acos();
    if delta > contact && delta < TAU - contact {
        return (delta - contact) * big_r;
    }
    // Touching now: closer while the angle to it shrinks towards 0 from below pi.
    if delta > 0.0 && delta < PI { 0.0 } else { f64::INFINITY }
}

/// The highest speed from which braking at `a` after a reaction time `t` stops within `d`.
pub fn stoppable_speed(d: f64, a: f64, t: f64) -> f64 {
    let d = d.max(0.0);
    if !d.is_finite() {
        return f64::INFINITY;
    }
    a * (-t + (t * t + 2.0 * d / a).sqrt())
}

/// One thing a sensor sees, in the body frame, and when it was seen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seen {
    /// Where, m (x ahead, y left).
    pub at: (f64, f64),
    /// When the reading was taken.
    pub stamp: Timestamp,
    /// How far the robot may have moved towards it that `at` does not account for, m.
    pub slack_m: f64,
}

/// A sector view's beams, as the monitor places readings on them: each sensor's origin on the
/// view's ring and the directions across its beam (every 5 degrees at most, edges included).
#[derive(Debug, Clone, Default)]
pub struct Beams {
    /// Per sensor: its origin (body frame, m) and the unit directions across its beam.
    sensors: Vec<Beam>,
    /// Per sensor: the unit direction of its axis.
    axes: Vec<(f64, f64)>,
    /// The cosine of half a beam's width.
    cos_half: f64,
    /// The shortest range a reading vouches for, m: nothing closer is seen free.
    min_range_m: f64,
}

/// A sensor's origin (body frame, m) and the unit directions across its beam.
type Beam = ((f64, f64), Vec<(f64, f64)>);

/// How much short of a reading a remembered point must lie for the reading to see through it.
pub const CLEAR_MARGIN_M: f64 = 0.05;

impl Beams {
    /// The beams of `view`.
    pub fn of(view: &RingParams) -> Self {
        let half = view.beam_width_rad / 2.0;
        let steps = (view.beam_width_rad / 5f64.to_radians()).ceil().max(1.0) as usize;
        let sensors = view
            .angles_rad
            .iter()
            .map(|&a| {
                let origin = (view.mount_radius_m * a.cos(), view.mount_radius_m * a.sin());
                let dirs = (0..=steps)
                    .map(|k| {
                        let b = a - half + view.beam_width_rad * k as f64 / steps as f64;
                        (b.cos(), b.sin())
                    })
                    .collect();
                (origin, dirs)
            })
            .collect();
        let axes = view.angles_rad.iter().map(|a| (a.cos(), a.sin())).collect();
        Beams { sensors, axes, cos_half: half.cos(), min_range_m: view.min_range_m }
    }

    /// Whether a reading of `scan` taken after `since` sees through `p` (body frame): `p` lies
    /// within a sensor's beam, beyond the shortest range it vouches for and more than
    /// [`CLEAR_MARGIN_M`] short of what it read there.
    /// `bearing` is `p`'s, from the centre, in [0, 2 pi).
    pub fn clears(&self, scan: &DistanceScan, since: Timestamp, p: (f64, f64), bearing: f64) -> bool {
        let n = self.axes.len();
        if n == 0 {
            return false;
        }
        // Only the sensors facing about where `p` lies can see it: a point in a beam lies
        // within half the beam of its axis, seen from the centre.
        let nearest = ((bearing / TAU * n as f64 + 0.5) as usize) % n;
        [n - 1, 0, 1].into_iter().any(|k| {
            let i = (nearest + k) % n;
            let Some(r) = scan
                .readings
                .get(i)
                .filter(|r| usize::from(r.sensor_id) == i)
                .or_else(|| scan.readings.iter().find(|r| usize::from(r.sensor_id) == i))
            else {
                return false;
            };
            if !(r.valid && r.stamp > since && r.distance_m.is_finite()) {
                return false;
            }
            let (((ox, oy), _), (ax, ay)) = (&self.sensors[i], self.axes[i]);
            let (vx, vy) = (p.0 - ox, p.1 - oy);
            let d2 = vx * vx + vy * vy;
            let (lo, hi) = (self.min_range_m, r.distance_m - CLEAR_MARGIN_M);
            let along = vx * ax + vy * ay;
            hi > lo
                && d2 > lo * lo
                && d2 < hi * hi
                && along > 0.0
                && along * along >= d2 * self.cos_half * self.cos_half
        })
    }

    /// The points the valid `readings` stand for: each reading anywhere across its beam.
    pub fn seen<'a>(&self, readings: impl Iterator<Item = &'a DistanceReading>, out: &mut Vec<Seen>) {
        for r in readings.filter(|r| r.valid && r.distance_m.is_finite()) {
            let Some(((ox, oy), dirs)) = self.sensors.get(usize::from(r.sensor_id)) else { continue };
            for (c, s) in dirs {
                out.push(Seen {
                    at: (ox + r.distance_m * c, oy + r.distance_m * s),
                    stamp: r.stamp,
                    slack_m: 0.0,
                });
            }
        }
    }
}

/// What the monitor knows of the robot, and decides from one look at its sensors.
#[derive(Debug, Clone)]
pub struct Monitor {
    params: SafetyParams,
    robot: RobotParams,
    /// Which sectors each view (infrared, sonar) covers at all.
    covered: [[bool; RING_SIZE]; 2],
    /// Each view's beams (infrared, sonar).
    beams: [Beams; 2],
}

/// One look at the sensors.
#[derive(Debug, Clone, Default)]
pub struct Look {
    /// What they see.
    pub seen: Vec<Seen>,
    /// Which views are fresh (infrared, sonar).
    pub fresh: [bool; 2],
    /// Bumpers pressed, by angle.
    pub pressed: Vec<f64>,
    /// Now.
    pub now: Timestamp,
}

impl Monitor {
    /// A monitor of `robot` with `params` (checked by [`SafetyParams::check_against`]).
    pub fn new(params: SafetyParams, robot: RobotParams) -> Self {
        let covered = [
            sector_coverage(&robot.range_sensors, &robot.infrared),
            sector_coverage(&robot.range_sensors, &robot.sonar),
        ];
        let beams = [Beams::of(&robot.infrared), Beams::of(&robot.sonar)];
        Monitor { params, robot, covered, beams }
    }

    /// Its parameters.
    pub fn params(&self) -> &SafetyParams {
        &self.params
    }

    /// The speed the robot may translate at on the path of `(v, omega)` given `look`, and why
    /// it is lower than `|v|` if it is.
    pub fn allowed(&self, v: f64, omega: f64, look: &Look) -> (f64, Option<Reason>) {
        let want = v.abs();
        if want < 1e-9 {
            return (want, None);
        }
        let p = &self.params;
        let travel = if v > 0.0 { 0.0 } else { PI };
        // Contact on the side it moves towards.
        if look.pressed.iter().any(|b| (b - travel).cos() > 0.2) {
            return (0.0, Some(Reason::Contact));
        }
        let a = p.deceleration(&self.robot);
        let t = p.latency_s + p.period_s;
        let r = self.robot.body_radius_m + p.stop_margin_m;
        let mut allowed = want;
        let mut reason = None;
        // The path depends on the speed at a given turn rate: look again along the slower one.
        let mut speed = want;
        for _ in 0..3 {
            let sv = speed.copysign(v);
            // Nothing farther than the path it may need can limit it (a chord is no longer
            // than its arc).
            let reach = r + p.stopping_distance(&self.robot, speed) + p.slowdown_margin_m;
            let free = look
                .seen
                .iter()
                .filter(|s| {
                    let r = reach + s.slack_m;
                    s.at.0 * s.at.0 + s.at.1 * s.at.1 <= r * r
                })
                .map(|s| free_distance(s.at, sv, omega, r) - s.slack_m)
                .fold(f64::INFINITY, f64::min);
            let stop = stoppable_speed(free, a, t);
            if stop < allowed {
                (allowed, reason) = (stop, Some(Reason::Obstacle));
            }
            if free < p.slowdown_margin_m && p.slow_speed_m_s < allowed {
                (allowed, reason) = (p.slow_speed_m_s, Some(Reason::Slowdown));
            }
            if allowed >= speed {
                break;
            }
            speed = allowed;
        }
        if p.blind_speed_m_s < allowed && !self.sees(travel, look) {
            (allowed, reason) = (p.blind_speed_m_s, Some(Reason::Blind));
        }
        if allowed < 1e-3 {
            allowed = 0.0;
        }
        (allowed, reason)
    }

    /// Whether a fresh view covers every sector within 60 degrees of `direction`.
    fn sees(&self, direction: f64, look: &Look) -> bool {
        let views = [&self.robot.infrared, &self.robot.sonar];
        (0..RING_SIZE).all(|i| {
            let axis = views[1].angles_rad.get(i).copied().unwrap_or(0.0);
            let off = ((axis - direction + PI).rem_euclid(TAU) - PI).abs();
            off > 60f64.to_radians() || (0..2).any(|v| look.fresh[v] && self.covered[v][i])
        })
    }
}

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
    /// When the sensors were last looked at.
    looked: Option<tokio::time::Instant>,
}

/// What the sensors saw lately, in the odometry frame: one point per 2 cm cell (the newest),
/// with the stamp of its reading and its slack.
#[derive(Debug, Default)]
struct Memory {
    cells: std::collections::HashMap<(i32, i32), Seen>,
    /// The newest reading stamp placed, per view and sensor.
    placed: [[Timestamp; RING_SIZE]; 2],
    scratch: Vec<Seen>,
}

/// The memory's cell size, m.
const CELL_M: f64 = 0.02;

impl Memory {
    /// Places the readings of `scan` (view `v`) newer than those placed before and within
    /// `near` m of the centre, seen from the odometry pose `pose` at `now` by a robot moving at
    /// `speed` m/s.
    #[allow(clippy::too_many_arguments)]
    fn place(
        &mut self,
        v: usize,
        scan: &DistanceScan,
        beams: &Beams,
        pose: (f64, f64, f64),
        now: Timestamp,
        speed: f64,
        near: f64,
    ) {
        let placed = &mut self.placed[v];
        let fresh = scan.readings.iter().filter(|r| {
            let i = usize::from(r.sensor_id);
            let new = i < RING_SIZE && r.stamp > placed[i];
            if new {
                placed[i] = r.stamp;
            }
            new
        });
        let seen = &mut self.scratch;
        seen.clear();
        beams.seen(fresh, seen);
        let (s, c) = pose.2.sin_cos();
        for p in seen.iter().filter(|p| p.at.0 * p.at.0 + p.at.1 * p.at.1 <= near * near) {
            let (x, y) = (pose.0 + c * p.at.0 - s * p.at.1, pose.1 + s * p.at.0 + c * p.at.1);
            let slack_m = speed * now.saturating_since(p.stamp).as_secs_f64();
            let cell = ((x / CELL_M).floor() as i32, (y / CELL_M).floor() as i32);
            self.cells.insert(cell, Seen { at: (x, y), stamp: p.stamp, slack_m });
        }
    }

    /// What it holds within `reach` m of the centre, in the body frame at odometry pose
    /// `pose`, younger than `keep` at `now` and not seen through (forgetting the rest).
    #[allow(clippy::too_many_arguments)]
    fn recall(
        &mut self,
        pose: (f64, f64, f64),
        now: Timestamp,
        keep: Duration,
        reach: f64,
        seen_through: impl Fn(&Seen, (f64, f64)) -> bool,
        out: &mut Vec<Seen>,
    ) {
        let (s, c) = pose.2.sin_cos();
        // What a reading saw through is forgotten; the rest within reach is recalled.
        self.cells.retain(|_, p| {
            let (dx, dy) = (p.at.0 - pose.0, p.at.1 - pose.1);
            let r = reach + p.slack_m;
            // What the robot left behind (beyond the farthest it may need) or that is too old
            // is forgotten.
            if dx * dx + dy * dy > r * r || now.saturating_since(p.stamp) > keep {
                return false;
            }
            let at = (c * dx + s * dy, -s * dx + c * dy);
            if seen_through(p, at) {
                return false;
            }
            out.push(Seen { at, ..*p });
            true
        });
    }
}

impl<S: SensorBoard + 'static, M: MotorBoard + 'static> Guarded<S, M> {
    /// `motors`, guarded by a monitor of `robot` reading `sensors` (none if `params` disable
    /// it), which looks again every `params.period_s` on the tokio clock. Must run inside a
    /// tokio runtime.
    pub fn new(sensors: S, motors: M, robot: RobotParams, params: SafetyParams) -> Self {
        let period = Duration::from_secs_f64(params.period_s);
        let monitor = params.enabled.then(|| Monitor::new(params, robot));
        let guarded = Guarded {
            inner: Arc::new(Inner {
                sensors,
                motors,
                monitor,
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
                None => {}
            }
        }
    }
}

impl<S: SensorBoard, M: MotorBoard> Inner<S, M> {
    /// Looks at the sensors once.
    async fn look(&self) -> Result<Look, BoardError> {
        let Some(m) = &self.monitor else { return Ok(Look::default()) };
        let motors = self.motors.read_state().await?;
        let ir = self.sensors.read_infrared().await?;
        let sonar = self.sensors.read_sonar().await?;
        let bumpers = self.sensors.read_bumpers().await?;
        let now = motors.stamp;
        let stale = Duration::from_secs_f64(m.params.stale_after_s);
        let newest = |s: &DistanceScan| s.readings.iter().map(|r| r.stamp).max().unwrap_or(s.stamp);
        let fresh = [&ir, &sonar].map(|s| now.saturating_since(newest(s)) <= stale);
        let pose = (motors.x_m, motors.y_m, motors.heading_rad);
        let mut look = Look {
            seen: Vec::new(),
            fresh,
            // The bumpers are fixed to the base; the direction of travel is `steer_rad` from it.
            pressed: bumpers
                .pressed
                .iter()
                .zip(&m.robot.bumper_angles_rad)
                .filter(|(p, _)| **p)
                .map(|(_, a)| a - motors.steer_rad)
                .collect(),
            now,
        };
        let mut st = self.state.lock();
        let speed = motors.velocities.translate_m_s.abs().max(st.applied.0.abs());
        st.looked = Some(tokio::time::Instant::now());
        let memory = &mut st.memory;
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
        let seen_through = |p: &Seen, at: (f64, f64)| {
            let bearing = at.1.atan2(at.0).rem_euclid(TAU);
            [&ir, &sonar]
                .into_iter()
                .enumerate()
                .any(|(v, scan)| fresh[v] && m.beams[v].clears(scan, p.stamp, at, bearing))
        };
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
        self.inner.motors.read_state().await
    }

    fn monitor(&self) -> Option<MonitorCounters> {
        self.inner.monitor.as_ref().map(|_| self.inner.state.lock().counters)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 0.28;

    /// Straight ahead, a point on the axis is met where the disc's front reaches it; one beside
    /// the path never is; one behind is never met going forward and is going backward.
    #[test]
    fn a_straight_path_meets_what_lies_in_its_swept_band() {
        assert!((free_distance((1.0, 0.0), 0.3, 0.0, R) - 0.72).abs() < 1e-12);
        let off_axis = free_distance((1.0, 0.2), 0.3, 0.0, R);
        assert!((off_axis - (1.0 - (R * R - 0.04f64).sqrt())).abs() < 1e-12);
        assert_eq!(free_distance((1.0, 0.3), 0.3, 0.0, R), f64::INFINITY, "beside the path");
        assert_eq!(free_distance((-1.0, 0.0), 0.3, 0.0, R), f64::INFINITY, "behind");
        assert!((free_distance((-1.0, 0.0), -0.3, 0.0, R) - 0.72).abs() < 1e-12, "backing up");
        // Touching: moving on is 0, moving away is free.
        assert_eq!(free_distance((0.2, 0.0), 0.3, 0.0, R), 0.0);
        assert_eq!(free_distance((0.2, 0.0), -0.3, 0.0, R), f64::INFINITY);
    }

    /// On an arc the distance is the arc length of the centre's path to first contact, which
    /// a fine walk along the arc finds too.
    #[test]
    fn an_arc_meets_points_where_a_walk_along_it_does() {
        let walk = |p: (f64, f64), v: f64, w: f64| -> f64 {
            let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
            let ds = 1e-4;
            let mut s = 0.0;
            while s < 6.0 {
                if (p.0 - x).hypot(p.1 - y) <= R {
                    return s;
                }
                x += ds * th.cos() * v.signum();
                y += ds * th.sin() * v.signum();
                th += ds * w / v.abs();
                s += ds;
            }
            f64::INFINITY
        };
        for (p, v, w) in [
            ((1.0, 0.3), 0.3, 0.4),
            ((1.0, -0.3), 0.3, 0.4),
            ((0.5, 0.6), 0.2, 0.6),
            ((-0.8, 0.2), -0.2, 0.3),
            ((-0.8, -0.4), -0.2, -0.5),
            ((0.0, 1.2), 0.25, 0.5),
        ] {
            let exact = free_distance(p, v, w, R);
            let walked = walk(p, v, w);
            if walked.is_finite() {
                assert!((exact - walked).abs() < 2e-3, "{p:?} v {v} w {w}: {exact} against {walked}");
            } else {
                assert!(exact > 5.9, "{p:?} v {v} w {w}: {exact} against a walk that never met it");
            }
        }
    }

    /// Braking at `a` after `t` from the speed allowed covers exactly the free distance.
    #[test]
    fn the_stoppable_speed_stops_in_the_free_distance() {
        for (d, a, t) in [(1.0, 0.5, 0.14), (0.1, 0.5, 0.14), (3.0, 1.0, 0.0)] {
            let v = stoppable_speed(d, a, t);
            assert!((v * t + v * v / (2.0 * a) - d).abs() < 1e-12);
        }
        assert_eq!(stoppable_speed(-0.1, 0.5, 0.1), 0.0);
    }
}
