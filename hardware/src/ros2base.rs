//! A ROS 2 robot behind the board traits (`orsa robot --hardware ros2`): a differential or
//! any other base that publishes a laser scan and odometry and takes velocity commands.
//!
//! Nothing here speaks ROS 2 or zenoh: the process feeds [`Ros2Base`] the scans and odometry it
//! receives ([`Ros2Base::feed_scan`], [`Ros2Base::feed_odometry`]) and gives it a function that
//! sends a velocity command; the boards ([`Ros2SensorBoard`], [`Ros2MotorBoard`]) read and
//! drive through it, so the robot server, its watchdog and the behaviours above run unchanged.
//!
//! # The rings, resampled from the scan
//!
//! Each ring is 16 virtual sensors on a circle of radius `body_radius_m` around the base's
//! centre, sensor `i` facing `i x 22.5` degrees as on the Nomad 200. Every ray of the scan is
//! turned into a point in the base's frame (the laser where the robot's TF puts it, else where
//! the config does: `laser_x_m`, `laser_y_m`, `laser_yaw_rad`); sensor `i` reads the nearest point whose bearing from the centre lies
//! within half its beam (`beam_width_rad`) of its direction, as the distance from the circle to
//! that point. A reading below the ring's `min_range_m` or with nothing within its
//! `max_range_m` is invalid, as a real sensor's would be. The infrared ring keeps its short
//! range (`ir_max_range_m`), the sonar ring its long one (`sonar_max_range_m`).
//!
//! # Safety
//!
//! The motor board sends every command at once and sends the current one again every
//! `cmd_period_s`, so a base with a command timeout of its own keeps moving while orsa drives
//! it, and stops when orsa stops sending. A stop sends zero. The robot server's watchdog stops
//! the base through this board as it stops the simulator. While there is no scan, or the newest
//! is older than `stale_s`, every ring reading is invalid (as a sensor that has not fired): the
//! behaviours never act on a picture of the world that stopped moving. Reads never fail (a
//! failed read would restart the robot server).

use crate::board::{
    AxisAccelerations, AxisVelocities, BoardError, CompassReading, MotorBoard, MotorState, SensorBoard,
};
use orsa_actors::param::Invalid;
use orsa_actors::{Clock, Timestamp};
use orsa_interfaces::nomad200::{
    BUMPER_COUNT, ContactScan, DistanceReading, DistanceScan, PushPeriods, RING_SIZE, Ring, RingParams,
    RobotParams, bumper_angle_rad, ring_angle_rad,
};
use orsa_interfaces::range::{DriveKind, project_onto_ring};
use parking_lot::Mutex;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Duration;

/// The message type a ROS 2 base takes its velocity commands in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CmdVelType {
    /// `geometry_msgs/msg/Twist`.
    Twist,
    /// `geometry_msgs/msg/TwistStamped`, stamped when sent, in `base_link`.
    TwistStamped,
}

/// The ROS 2 robot's geometry, limits and topics (`[ros2.base]` of the config).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ros2BaseParams {
    /// The base's radius, m: the virtual rings sit on it.
    pub body_radius_m: f64,
    /// Where the laser is, m ahead of the base's centre, when the robot's TF does not say
    /// (`/tf_static`, `/tf`: see [`Scan::laser`]).
    pub laser_x_m: f64,
    /// Where the laser is, m to the left of the base's centre, when TF does not say.
    pub laser_y_m: f64,
    /// Which way the laser faces, rad counter-clockwise from the base's front, when TF does
    /// not say.
    pub laser_yaw_rad: f64,
    /// Translation velocity limit, m/s.
    pub max_v_m_s: f64,
    /// Turn rate limit, rad/s.
    pub max_omega_rad_s: f64,
    /// Translation acceleration, m/s^2 (what the behaviours are told).
    pub accel_m_s2: f64,
    /// Turn acceleration, rad/s^2 (what the behaviours are told).
    pub omega_accel_rad_s2: f64,
    /// Each virtual sensor's full beam width, rad.
    pub beam_width_rad: f64,
    /// The infrared ring's longest valid reading, m.
    pub ir_max_range_m: f64,
    /// The sonar ring's shortest valid reading, m.
    pub sonar_min_range_m: f64,
    /// The sonar ring's longest valid reading, m.
    pub sonar_max_range_m: f64,
    /// The laser scan topic.
    pub scan_topic: String,
    /// The odometry topic.
    pub odom_topic: String,
    /// The velocity command topic.
    pub cmd_vel_topic: String,
    /// The type of the velocity commands sent: `twist_stamped` (what diff_drive_controller
    /// takes since Jazzy, the default) or `twist`.
    pub cmd_vel_type: CmdVelType,
    /// The current command is sent again this often, s.
    pub cmd_period_s: f64,
    /// A scan older than this is not used, s.
    pub stale_s: f64,
}

impl Default for Ros2BaseParams {
    fn default() -> Self {
        Ros2BaseParams {
            body_radius_m: 0.25,
            laser_x_m: 0.0,
            laser_y_m: 0.0,
            laser_yaw_rad: 0.0,
            max_v_m_s: 0.5,
            max_omega_rad_s: 1.0,
            accel_m_s2: 0.5,
            omega_accel_rad_s2: 2.0,
            beam_width_rad: 0.2,
            ir_max_range_m: 0.6,
            sonar_min_range_m: 0.1,
            sonar_max_range_m: 6.0,
            scan_topic: "scan".into(),
            odom_topic: "odom".into(),
            cmd_vel_topic: "cmd_vel".into(),
            cmd_vel_type: CmdVelType::TwistStamped,
            cmd_period_s: 0.1,
            stale_s: 0.5,
        }
    }
}

impl Ros2BaseParams {
    /// Checks every value; the message names the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        for (key, v, lo, hi) in [
            ("body_radius_m", self.body_radius_m, 0.01, 5.0),
            ("laser_x_m", self.laser_x_m.abs(), 0.0, 5.0),
            ("laser_y_m", self.laser_y_m.abs(), 0.0, 5.0),
            ("laser_yaw_rad", self.laser_yaw_rad.abs(), 0.0, std::f64::consts::PI),
            ("max_v_m_s", self.max_v_m_s, 0.001, 10.0),
            ("max_omega_rad_s", self.max_omega_rad_s, 0.001, 20.0),
            ("accel_m_s2", self.accel_m_s2, 0.001, 100.0),
            ("omega_accel_rad_s2", self.omega_accel_rad_s2, 0.001, 100.0),
            ("beam_width_rad", self.beam_width_rad, 0.001, 0.39),
            ("ir_max_range_m", self.ir_max_range_m, 0.01, 100.0),
            ("sonar_min_range_m", self.sonar_min_range_m, 0.0, 100.0),
            ("sonar_max_range_m", self.sonar_max_range_m, 0.01, 100.0),
            ("cmd_period_s", self.cmd_period_s, 0.005, 10.0),
            ("stale_s", self.stale_s, 0.01, 60.0),
        ] {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(Invalid::new(key, format!("must be from {lo} to {hi}, not {v}")));
            }
        }
        if self.sonar_min_range_m >= self.sonar_max_range_m {
            return Err(Invalid::new("sonar_min_range_m", "must be below sonar_max_range_m"));
        }
        for (key, t) in [
            ("scan_topic", &self.scan_topic),
            ("odom_topic", &self.odom_topic),
            ("cmd_vel_topic", &self.cmd_vel_topic),
        ] {
            if t.is_empty() || t.contains(['*', '$', '#', '?', ' ']) {
                return Err(Invalid::new(key, format!("'{t}' is not a topic name")));
            }
        }
        Ok(())
    }

    /// The laser's pose the config gives.
    pub fn laser_pose(&self) -> LaserPose {
        LaserPose { x_m: self.laser_x_m, y_m: self.laser_y_m, yaw_rad: self.laser_yaw_rad }
    }

    fn ring(&self, min_m: f64, max_m: f64) -> RingParams {
        RingParams {
            angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
            mount_radius_m: self.body_radius_m,
            beam_width_rad: self.beam_width_rad,
            min_range_m: min_m,
            max_range_m: max_m,
            fire_period_s: 0.0,
        }
    }

    /// The robot as the behaviours see it.
    pub fn robot_params(&self, push: PushPeriods) -> RobotParams {
        RobotParams {
            body_radius_m: self.body_radius_m,
            max_v_m_s: self.max_v_m_s,
            max_omega_rad_s: self.max_omega_rad_s,
            max_turret_omega_rad_s: self.max_omega_rad_s,
            accel_m_s2: self.accel_m_s2,
            steer_accel_rad_s2: self.omega_accel_rad_s2,
            turret_accel_rad_s2: self.omega_accel_rad_s2,
            sonar: self.ring(self.sonar_min_range_m, self.sonar_max_range_m),
            infrared: self.ring(0.0, self.ir_max_range_m),
            bumper_angles_rad: (0..BUMPER_COUNT).map(bumper_angle_rad).collect(),
            odometry_resolution_m: 0.0,
            odometry_resolution_rad: 0.0,
            push,
            drive: DriveKind::Differential,
            // The base's laser is known only from its scans (their angles and ranges), not from
            // the config: it is not described here.
            range_sensors: Vec::new(),
        }
    }
}

/// A laser scan, as the base publishes it (`sensor_msgs/msg/LaserScan`'s fields that count).
#[derive(Debug, Clone, PartialEq)]
pub struct Scan {
    /// When it was taken.
    pub stamp: Timestamp,
    /// The first ray's angle, rad counter-clockwise from the laser's front.
    pub angle_min: f64,
    /// The angle between rays, rad.
    pub angle_increment: f64,
    /// Readings below this are not valid, m.
    pub range_min: f64,
    /// Readings beyond this are not valid, m.
    pub range_max: f64,
    /// One range per ray, m (not finite: no reading).
    pub ranges: Vec<f32>,
    /// Where the laser that took it is on the base, if the robot's TF said (else the config's
    /// `laser_x_m`, `laser_y_m`, `laser_yaw_rad`).
    pub laser: Option<LaserPose>,
}

/// Where a laser is on the base: its position in the base's frame and the way it faces.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct LaserPose {
    /// m ahead of the base's centre.
    pub x_m: f64,
    /// m to its left.
    pub y_m: f64,
    /// rad counter-clockwise from the base's front.
    pub yaw_rad: f64,
}

/// Odometry, as the base publishes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Odom {
    /// When it was taken.
    pub stamp: Timestamp,
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// Heading, rad.
    pub yaw_rad: f64,
    /// Forward velocity, m/s.
    pub v_m_s: f64,
    /// Turn rate, rad/s.
    pub omega_rad_s: f64,
}

/// The nearest point of the scan within each of 16 sectors (see the module docs), as the
/// distance from a circle of radius `radius_m`; `None` where no valid ray falls.
pub fn resample(
    scan: &Scan,
    laser: LaserPose,
    radius_m: f64,
    beam_width_rad: f64,
) -> [Option<f64>; RING_SIZE] {
    let ring = RingParams {
        angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
        mount_radius_m: radius_m,
        beam_width_rad,
        min_range_m: 0.0,
        max_range_m: f64::INFINITY,
        fire_period_s: 0.0,
    };
    let points = scan.ranges.iter().enumerate().filter_map(|(j, r)| {
        let r = f64::from(*r);
        (r.is_finite() && r >= scan.range_min && r <= scan.range_max).then(|| {
            let a = laser.yaw_rad + scan.angle_min + j as f64 * scan.angle_increment;
            (laser.x_m + r * a.cos(), laser.y_m + r * a.sin())
        })
    });
    project_onto_ring(points, &ring)
}

/// What the base last said, and how to command it.
struct Shared {
    scan: Option<Scan>,
    odom: Option<Odom>,
    /// The velocity commanded now (translate, turn).
    command: (f64, f64),
    /// Set when the boards were given up: nothing is sent any more.
    closed: bool,
}

/// Sends one velocity command (v m/s, omega rad/s) to the base.
pub type SendCommand = Arc<dyn Fn(f64, f64) + Send + Sync>;

/// A ROS 2 base: what it last published, and the function that commands it. Cheap to clone.
#[derive(Clone)]
pub struct Ros2Base {
    params: Arc<Ros2BaseParams>,
    clock: Clock,
    shared: Arc<Mutex<Shared>>,
    send: SendCommand,
}

impl std::fmt::Debug for Ros2Base {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Base").field("params", &self.params).finish_non_exhaustive()
    }
}

impl Ros2Base {
    /// A base described by `params`, read on `clock`, commanded through `send`. Starts the
    /// task that sends the current command again every `cmd_period_s` (ended by [`close`](Self::close)).
    pub fn new(params: Ros2BaseParams, clock: Clock, send: SendCommand) -> Self {
        let base = Ros2Base {
            params: Arc::new(params),
            clock,
            shared: Arc::new(Mutex::new(Shared {
                scan: None,
                odom: None,
                command: (0.0, 0.0),
                closed: false,
            })),
            send,
        };
        let again = base.clone();
        let period = Duration::from_secs_f64(base.params.cmd_period_s);
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(period);
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            loop {
                tick.tick().await;
                let (closed, (v, w)) = {
                    let s = again.shared.lock();
                    (s.closed, s.command)
                };
                if closed {
                    break;
                }
                (again.send)(v, w);
            }
        });
        base
    }

    /// The boards over this base.
    pub fn boards(&self) -> (Ros2SensorBoard, Ros2MotorBoard) {
        (Ros2SensorBoard { base: self.clone() }, Ros2MotorBoard { base: self.clone() })
    }

    /// The base's newest scan.
    pub fn feed_scan(&self, scan: Scan) {
        self.shared.lock().scan = Some(scan);
    }

    /// The base's newest odometry.
    pub fn feed_odometry(&self, odom: Odom) {
        self.shared.lock().odom = Some(odom);
    }

    /// Stops the base (a zero command, sent now) and sends nothing more.
    pub fn close(&self) {
        let mut s = self.shared.lock();
        s.command = (0.0, 0.0);
        s.closed = true;
        drop(s);
        (self.send)(0.0, 0.0);
    }

    fn fresh(&self, stamp: Timestamp) -> bool {
        self.clock.now().saturating_since(stamp) <= Duration::from_secs_f64(self.params.stale_s)
    }

    /// A ring resampled from the newest scan; every reading invalid (as a sensor that has not
    /// fired) while there is no scan, or when it is older than `stale_s`.
    fn ring(&self, ring: Ring) -> DistanceScan {
        let s = self.shared.lock();
        let p = &self.params;
        let (min, max) = match ring {
            Ring::Infrared => (0.0, p.ir_max_range_m),
            Ring::Sonar => (p.sonar_min_range_m, p.sonar_max_range_m),
        };
        let (stamp, near) = match s.scan.as_ref().filter(|scan| self.fresh(scan.stamp)) {
            Some(scan) => {
                let laser = scan.laser.unwrap_or_else(|| p.laser_pose());
                (scan.stamp, Some(resample(scan, laser, p.body_radius_m, p.beam_width_rad)))
            }
            None => (self.clock.now(), None),
        };
        let readings = (0..RING_SIZE)
            .map(|i| {
                let (valid, distance_m) = match near.map(|n| n[i]) {
                    None => (false, 0.0),
                    Some(Some(d)) if d < min => (false, min),
                    Some(Some(d)) if d <= max => (true, d),
                    Some(_) => (false, max),
                };
                DistanceReading { sensor_id: i as u8, stamp, valid, distance_m }
            })
            .collect();
        DistanceScan { stamp, ring, readings }
    }

    fn command(&self, v: f64, w: f64) {
        let mut s = self.shared.lock();
        if s.closed {
            return;
        }
        s.command = (v, w);
        drop(s);
        (self.send)(v, w);
    }
}

/// The sensor board of a ROS 2 base: rings resampled from its scan, no bumpers, no compass.
#[derive(Debug, Clone)]
pub struct Ros2SensorBoard {
    base: Ros2Base,
}

/// The motor board of a ROS 2 base: velocity commands out, odometry in.
#[derive(Debug, Clone)]
pub struct Ros2MotorBoard {
    base: Ros2Base,
}

impl SensorBoard for Ros2SensorBoard {
    async fn init(&self) -> Result<(), BoardError> {
        Ok(())
    }
    async fn set_sonar_fire_order(&self, _: &[u8]) -> Result<(), BoardError> {
        Ok(())
    }
    async fn set_sonar_fire_period(&self, _: Duration) -> Result<(), BoardError> {
        Ok(())
    }
    async fn set_infrared_fire_order(&self, _: &[u8]) -> Result<(), BoardError> {
        Ok(())
    }
    async fn set_infrared_fire_period(&self, _: Duration) -> Result<(), BoardError> {
        Ok(())
    }
    async fn read_sonar(&self) -> Result<DistanceScan, BoardError> {
        Ok(self.base.ring(Ring::Sonar))
    }
    async fn read_infrared(&self) -> Result<DistanceScan, BoardError> {
        Ok(self.base.ring(Ring::Infrared))
    }
    async fn read_bumpers(&self) -> Result<ContactScan, BoardError> {
        Ok(ContactScan { stamp: self.base.clock.now(), pressed: vec![false; BUMPER_COUNT] })
    }
    async fn read_compass(&self) -> Result<CompassReading, BoardError> {
        Ok(CompassReading { stamp: self.base.clock.now(), heading_rad: 0.0, valid: false })
    }
}

fn finite(op: &'static str, v: &[f64]) -> Result<(), BoardError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(BoardError::InvalidArgument { operation: op, reason: format!("not finite: {v:?}") })
    }
}

impl MotorBoard for Ros2MotorBoard {
    async fn move_velocity(&self, v: AxisVelocities) -> Result<(), BoardError> {
        finite("move_velocity", &v.as_array())?;
        let p = &self.base.params;
        let t = v.translate_m_s.clamp(-p.max_v_m_s, p.max_v_m_s);
        let w = v.steer_rad_s.clamp(-p.max_omega_rad_s, p.max_omega_rad_s);
        self.base.command(t, w);
        Ok(())
    }
    async fn stop(&self) -> Result<(), BoardError> {
        self.base.command(0.0, 0.0);
        Ok(())
    }
    async fn wait_stop(&self, timeout: Duration) -> Result<(), BoardError> {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            let still = self.base.shared.lock().odom.is_none_or(|o| o.v_m_s == 0.0 && o.omega_rad_s == 0.0);
            if still {
                return Ok(());
            }
            if tokio::time::Instant::now() >= deadline {
                return Err(BoardError::Timeout { operation: "wait_stop", waited: timeout });
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
    async fn zero_axes(&self) -> Result<(), BoardError> {
        Ok(())
    }
    async fn set_velocity_limits(&self, l: AxisVelocities) -> Result<(), BoardError> {
        finite("set_velocity_limits", &l.as_array())
    }
    async fn set_accelerations(&self, a: AxisAccelerations) -> Result<(), BoardError> {
        finite("set_accelerations", &a.as_array())
    }
    async fn read_state(&self) -> Result<MotorState, BoardError> {
        let s = self.base.shared.lock();
        let (v, w) = s.command;
        // No odometry yet: at the origin, at rest (so far as anything says).
        let o = s.odom.unwrap_or(Odom {
            stamp: self.base.clock.now(),
            x_m: 0.0,
            y_m: 0.0,
            yaw_rad: 0.0,
            v_m_s: 0.0,
            omega_rad_s: 0.0,
        });
        Ok(MotorState {
            stamp: o.stamp,
            x_m: o.x_m,
            y_m: o.y_m,
            heading_rad: o.yaw_rad,
            steer_rad: o.yaw_rad,
            turret_rad: o.yaw_rad,
            velocities: AxisVelocities::synchro(o.v_m_s, o.omega_rad_s),
            stopped: v == 0.0 && w == 0.0 && o.v_m_s == 0.0 && o.omega_rad_s == 0.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(ranges: Vec<f32>) -> Scan {
        let n = ranges.len();
        Scan {
            stamp: Timestamp(0),
            angle_min: -std::f64::consts::PI,
            angle_increment: std::f64::consts::TAU / n as f64,
            range_min: 0.05,
            range_max: 8.0,
            ranges,
            laser: None,
        }
    }

    /// A wall 0.5 m to the left of a laser at the centre: the left sensor reads 0.5 - radius,
    /// its neighbours a little more (the beam's edge), the right side nothing.
    #[test]
    fn a_left_wall_is_seen_by_the_left_sensors() {
        let n = 360;
        let ranges = (0..n)
            .map(|j| {
                let a = -std::f64::consts::PI + j as f64 * std::f64::consts::TAU / n as f64;
                if a.sin() > 0.05 { (0.5 / a.sin()) as f32 } else { f32::INFINITY }
            })
            .collect();
        let near = resample(&scan(ranges), LaserPose::default(), 0.2, 0.2);
        let left = near[4].expect("sensor 4 faces the wall");
        assert!((left - 0.3).abs() < 0.01, "{left}");
        let front_left = near[3].expect("sensor 3 sees the wall too");
        assert!(front_left > left, "{front_left} vs {left}");
        assert_eq!(near[12], None);
        assert!(near[0].is_none_or(|d| d > 4.0), "the front sees the wall far ahead only: {:?}", near[0]);
    }

    /// A laser ahead of the centre: what it sees in front is that much nearer the ring.
    #[test]
    fn the_laser_offset_counts() {
        let mut ranges = vec![f32::INFINITY; 360];
        ranges[180] = 1.0; // straight ahead of the laser
        let near = resample(&scan(ranges.clone()), LaserPose { x_m: 0.1, ..Default::default() }, 0.2, 0.2);
        assert!((near[0].expect("front") - 0.9).abs() < 1e-9);
        // The same laser mounted backwards, 0.1 m behind the centre: its front ray is the
        // base's back, 1.1 m from the centre.
        let back = LaserPose { x_m: -0.1, y_m: 0.0, yaw_rad: std::f64::consts::PI };
        let near = resample(&scan(ranges), back, 0.2, 0.2);
        assert!((near[8].expect("back") - 0.9).abs() < 1e-9, "{near:?}");
        assert_eq!(near[0], None);
    }

    #[test]
    fn nan_and_out_of_range_rays_are_ignored() {
        let near = resample(&scan(vec![f32::NAN, -1.0, 0.01, 100.0]), LaserPose::default(), 0.2, 0.39);
        assert!(near.iter().all(Option::is_none), "{near:?}");
    }

    #[test]
    fn defaults_are_valid_and_bad_values_named() {
        Ros2BaseParams::default().validate().expect("defaults");
        let bad = Ros2BaseParams { beam_width_rad: f64::NAN, ..Default::default() };
        assert_eq!(bad.validate().expect_err("NaN").key, "beam_width_rad");
        let bad = Ros2BaseParams { scan_topic: "a*".into(), ..Default::default() };
        assert_eq!(bad.validate().expect_err("topic").key, "scan_topic");
    }
}
