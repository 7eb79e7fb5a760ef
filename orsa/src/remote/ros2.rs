//! `orsa robot --ros2`: the robot as a ROS 2 node. Its sensor pushes and base state are
//! published as ROS 2 topics, and `/cmd_vel` drives it as teleoperation, judged by the robot
//! server like every other velocity command (see `docs/ros2.md`).
//!
//! | topic | type | from |
//! |---|---|---|
//! | `/scan` | `sensor_msgs/msg/LaserScan` | the sonar ring (`distanceson`), 16 rays |
//! | `/ir_scan` | `sensor_msgs/msg/LaserScan` | the infrared ring (`distanceir`), 16 rays |
//! | `/odom` | `nav_msgs/msg/Odometry` | `basestate`: `odom` -> `base_link` |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | `basestate`: `odom` -> `base_link` |
//! | `/bumper` | `std_msgs/msg/Bool` | `bumpers`: whether any bumper is pressed |
//! | `/cmd_vel` (taken) | `geometry_msgs/msg/Twist` or `TwistStamped` | -> `teleop`: a Twist stamped on arrival, a TwistStamped by its header (zero: now) |
//! | `/map` | `nav_msgs/msg/OccupancyGrid` | the map component's grid, transient local (where the system has one) |
//!
//! `orsa robot --hardware ros2` is the other way round ([`BaseLink`]): a ROS 2 robot's scan and
//! odometry feed orsa's boards ([`Ros2Base`](orsa_hardware::ros2base::Ros2Base)) and its commands go out as TwistStamped or Twist (`ros2.base.cmd_vel_type`).

use crate::config::Ros2Params;
use crate::system::live_params::ParamDirectory;
use orsa_actors::push_timed::PushTimedClient;
use orsa_actors::send::SendClient;
use orsa_actors::service::PushTimedService;
use orsa_actors::{Registry, Sink, Timestamp, Update};
use orsa_assembly::system::robots::CmdVelPublisher;
use orsa_hardware::ros2base::{CmdVelType, LaserPose, Odom, Scan};
use orsa_hardware::sim::OdometryConfig;
use orsa_interfaces::nomad200::{
    self, BaseState, ContactScan, DistanceScan, NavigationVelocity, RingParams, RobotParams,
};
use orsa_net::ros2::Either;
use orsa_net::ros2::msg::{self as m, Bool, LaserScan, Odometry, TfMessage, Twist, TwistStamped};
use orsa_net::ros2::rcl::Log;
use orsa_net::ros2::{Qos, Ros2Node, Ros2Options, Ros2Publisher, Ros2Stats, Ros2Subscription};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

pub mod goal;
pub mod map;
mod params;
mod tf;
pub use params::ParamServices;

/// What the ROS 2 side of the robot did, for `orsa robot --report`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Ros2Report {
    /// The node's messages: published, received, undecodable, wrong type.
    pub node: Ros2Stats,
    /// `/cmd_vel` messages handed to the robot server (which judges them as teleoperation).
    pub cmd_vel_forwarded: u64,
    /// `/cmd_vel` messages refused for coming faster than `ros2.cmd_vel_rate_hz` allows
    /// (beyond a burst of `ros2.cmd_vel_burst`).
    pub cmd_vel_rate_refused: u64,
    /// `/goal_pose` goals the planner accepted (where the system navigates).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal_pose_accepted: Option<u64>,
    /// `/goal_pose` goals refused: in another frame than `map`, not finite, rejected by the
    /// planner (its reason is logged), or the planner could not be reached.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal_pose_refused: Option<u64>,
    /// The version of the map last published on `/map` (0: none yet), where the system has a
    /// map component.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_version: Option<u64>,
    /// `--hardware ros2`: where the laser was placed on the base.
    #[serde(default)]
    pub laser: Option<LaserPlacement>,
}

/// A token bucket: at most `burst` at once, refilled at `rate_hz`.
#[derive(Debug, Clone)]
pub(crate) struct RateGate {
    rate_hz: f64,
    burst: f64,
    tokens: f64,
    last: Option<tokio::time::Instant>,
}

impl RateGate {
    pub(crate) fn new(rate_hz: f64, burst: u32) -> Self {
        RateGate { rate_hz, burst: f64::from(burst), tokens: f64::from(burst), last: None }
    }

    /// Whether a message arriving at `now` may pass.
    pub(crate) fn admit(&mut self, now: tokio::time::Instant) -> bool {
        if let Some(last) = self.last {
            let dt = now.saturating_duration_since(last).as_secs_f64();
            self.tokens = (self.tokens + dt * self.rate_hz).min(self.burst);
        }
        self.last = Some(now);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

/// The robot a [`RobotRos2`] shows.
#[derive(Debug, Clone, Copy)]
pub struct FacedRobot<'a> {
    /// Its name (its services' prefix).
    pub name: &'a str,
    /// Its geometry and limits.
    pub params: &'a RobotParams,
    /// Its odometry's drift model (the covariances of `/odom`).
    pub drift: &'a OdometryConfig,
    /// The planner that takes navigation goals (`/goal_pose`), if the system navigates.
    pub planner: Option<&'a str>,
    /// The map component whose grid goes out on `/map`, if the system has one here.
    pub map: Option<&'a str>,
}

/// The robot's ROS 2 face; publishing and taking commands while it lives.
pub struct RobotRos2 {
    node: Ros2Node,
    forwarded: Arc<AtomicU64>,
    rate_refused: Arc<AtomicU64>,
    _cmd_vel: Ros2Subscription,
    _clients: Vec<Box<dyn std::any::Any + Send>>,
    _params: ParamServices,
    _rosout: crate::logline::RouteGuard,
    /// `/goal_pose`, where the system has a planner that navigates.
    goals: Option<(Ros2Subscription, Arc<goal::GoalCounts>)>,
    map: Option<map::MapTopic>,
}

/// Publishes orsa's log lines ([`crate::logline`]) on `/rosout` as `rcl_interfaces/msg/Log`,
/// logger `<node>.<who>` (`orsa.robot`, `orsa.remote.ros2.params`, `orsa.orsa_net.ros2.node`),
/// while the guard lives.
async fn rosout(
    node: &Ros2Node,
    name: &str,
    registry: &Registry,
) -> anyhow::Result<crate::logline::RouteGuard> {
    let publisher: Ros2Publisher<Log> = node.publisher("/rosout", Qos::Rosout).await?;
    let (node_name, reg) = (name.to_string(), registry.clone());
    Ok(crate::logline::route(move |l| {
        let level = match l.level {
            tracing::Level::ERROR => Log::ERROR,
            tracing::Level::WARN => Log::WARN,
            tracing::Level::INFO => Log::INFO,
            _ => Log::DEBUG,
        };
        let now = reg.now();
        let log = Log {
            stamp: time(now),
            level,
            name: format!("{node_name}.{}", l.logger.trim_start_matches("orsa::").replace("::", ".")),
            msg: l.text.to_string(),
            file: l.file.to_string(),
            function: l.module.to_string(),
            line: l.line,
        };
        publisher.publish(&log, now.0);
    }))
}

/// The sink that publishes each scan of a ring (`ring` gives its geometry) as a
/// `sensor_msgs/msg/LaserScan` on `publisher`, in the push's own delivery: no queue, no task to
/// wake (a put with congestion control `Drop` does not wait). What the bench measures.
pub fn scan_sink(publisher: Ros2Publisher<LaserScan>, ring: RingParams) -> Sink<Update<DistanceScan>> {
    Sink::from_fn(move |u: Update<DistanceScan>| {
        publisher.publish(&laser_scan(&u.value, &ring), u.value.stamp.0);
        Ok(())
    })
}

impl RobotRos2 {
    /// Starts publishing robot `robot`'s services (in this process's `registry`) as ROS 2
    /// topics on `transport`'s session, in `domain`, taking `/cmd_vel`, serving the
    /// parameters of `params_of`'s components ([`ParamServices`]) and publishing orsa's log
    /// lines on `/rosout`.
    ///
    /// Each update is published where the robot server pushes it (see [`scan_sink`]).
    pub async fn start(
        registry: &Registry,
        transport: &orsa_net::ZenohTransport,
        robot: &FacedRobot<'_>,
        ros2: &Ros2Params,
        domain: u32,
        params_of: ParamDirectory,
    ) -> anyhow::Result<Self> {
        let FacedRobot { name: robot, params, drift, planner, map } = *robot;
        let options = Ros2Options { domain, namespace: ros2.namespace.clone(), name: ros2.node.clone() };
        let node = transport.ros2_node(&options).await?;
        let param_services = ParamServices::serve(&node, params_of).await?;
        let rosout = rosout(&node, &ros2.node, registry).await?;
        fn follow<T: orsa_actors::CommObject>(
            registry: &Registry,
            addr: orsa_actors::service::Addr<PushTimedService<T>>,
            sink: Sink<Update<T>>,
        ) -> anyhow::Result<Box<dyn std::any::Any + Send>> {
            let c = PushTimedClient::<T>::connect_to(registry, addr, sink)?;
            c.subscribe(1)?;
            Ok(Box::new(c))
        }
        let scan = node.publisher("scan", Qos::SensorData).await?;
        let ir_scan = node.publisher("ir_scan", Qos::SensorData).await?;
        let odom: Ros2Publisher<Odometry> = node.publisher("odom", Qos::Default).await?;
        let drift = parking_lot::Mutex::new(Drift::new(drift.clone()));
        let tf: Ros2Publisher<TfMessage> = node.publisher("/tf", Qos::Default).await?;
        let bumper: Ros2Publisher<Bool> = node.publisher("bumper", Qos::Default).await?;
        let clients = vec![
            follow(registry, nomad200::DISTANCESON.on(robot), scan_sink(scan, params.sonar.clone()))?,
            follow(registry, nomad200::DISTANCEIR.on(robot), scan_sink(ir_scan, params.infrared.clone()))?,
            follow(
                registry,
                nomad200::BASESTATE.on(robot),
                Sink::from_fn(move |u: Update<BaseState>| {
                    let (mut o, t) = odometry(&u.value);
                    let mut drift = drift.lock();
                    drift.follow(&u.value);
                    (o.pose.covariance, o.twist.covariance) = drift.covariances(&u.value);
                    odom.publish(&o, u.value.stamp.0);
                    tf.publish(&t, u.value.stamp.0);
                    Ok(())
                }),
            )?,
            follow(
                registry,
                nomad200::BUMPERS.on(robot),
                Sink::from_fn(move |u: Update<ContactScan>| {
                    bumper.publish(&Bool { data: u.value.pressed.iter().any(|b| *b) }, u.value.stamp.0);
                    Ok(())
                }),
            )?,
        ];

        let teleop = SendClient::<NavigationVelocity>::connect(registry, nomad200::TELEOP.on(robot))?;
        let forwarded = Arc::new(AtomicU64::new(0));
        let rate_refused = Arc::new(AtomicU64::new(0));
        let gate = parking_lot::Mutex::new(RateGate::new(ros2.cmd_vel_rate_hz, ros2.cmd_vel_burst));
        let (fw, rr, reg) = (Arc::clone(&forwarded), Arc::clone(&rate_refused), registry.clone());
        let cmd_vel = node
            .subscribe_either::<Twist, TwistStamped>("cmd_vel", Qos::Default, move |t, _| {
                if !gate.lock().admit(tokio::time::Instant::now()) {
                    rr.fetch_add(1, Ordering::Relaxed);
                    return;
                }
                let (twist, stamp) = command_stamp(t, reg.now());
                let cmd = NavigationVelocity { stamp, v_m_s: twist.linear.x, omega_rad_s: twist.angular.z };
                match teleop.send(cmd) {
                    Ok(()) => {
                        fw.fetch_add(1, Ordering::Relaxed);
                    }
                    Err(e) => {
                        tracing::warn!("ROS 2 /cmd_vel: cannot hand a command to the robot server: {e}")
                    }
                }
            })
            .await?;
        let goals = match planner {
            Some(p) => Some(goal::take_goals(&node, registry, p).await?),
            None => None,
        };
        let map = match map {
            Some(name) => Some(map::MapTopic::start(&node, registry, name).await?),
            None => None,
        };
        Ok(RobotRos2 {
            node,
            goals,
            map,
            forwarded,
            rate_refused,
            _cmd_vel: cmd_vel,
            _clients: clients,
            _params: param_services,
            _rosout: rosout,
        })
    }

    /// What it did so far.
    pub fn report(&self) -> Ros2Report {
        Ros2Report {
            node: self.node.stats(),
            cmd_vel_forwarded: self.forwarded.load(Ordering::Relaxed),
            cmd_vel_rate_refused: self.rate_refused.load(Ordering::Relaxed),
            goal_pose_accepted: self.goals.as_ref().map(|(_, c)| c.accepted.load(Ordering::Relaxed)),
            goal_pose_refused: self.goals.as_ref().map(|(_, c)| c.refused.load(Ordering::Relaxed)),
            map_version: self.map.as_ref().map(map::MapTopic::published),
            laser: None,
        }
    }
}

/// The link to a ROS 2 base (`orsa robot --hardware ros2`): the node that reads its scan and
/// odometry into the [`Ros2Base`](orsa_hardware::ros2base::Ros2Base) and publishes its velocity commands.
pub struct BaseLink {
    node: Ros2Node,
    placing: Arc<parking_lot::Mutex<Placing>>,
    _subscriptions: Vec<Ros2Subscription>,
}

impl BaseLink {
    /// Joins the base's ROS 2 graph (`domain`, node from `ros2`): its scans and odometry feed
    /// `base`, stamped with their arrival on `registry`'s clock (the base's clock need not agree
    /// with this one); its command publisher becomes `robot`'s.
    pub async fn connect(
        registry: &Registry,
        transport: &orsa_net::ZenohTransport,
        ros2: &Ros2Params,
        domain: u32,
        robot: &orsa_assembly::system::robots::Ros2Robot,
    ) -> anyhow::Result<Self> {
        let base = &robot.base;
        let p = &ros2.base;
        let options = Ros2Options { domain, namespace: ros2.namespace.clone(), name: ros2.node.clone() };
        let node = transport.ros2_node(&options).await?;
        // Where the laser is: from the robot's TF when it places the scan's frame under the
        // odometry's base frame, else from the config.
        let placing = Arc::new(parking_lot::Mutex::new(Placing::default()));
        let mut subscriptions = Vec::new();
        for (topic, qos) in [("/tf_static", Qos::StaticTf), ("/tf", Qos::Default)] {
            let pl = Arc::clone(&placing);
            subscriptions
                .push(node.subscribe::<TfMessage>(topic, qos, move |m, _| pl.lock().tree.add(&m)).await?);
        }
        let (b, reg, pl) = (base.clone(), registry.clone(), Arc::clone(&placing));
        let scan = node
            .subscribe::<LaserScan>(&p.scan_topic, Qos::SensorData, move |s, _| {
                let laser = pl.lock().place(&s.header.frame_id);
                b.feed_scan(Scan {
                    laser,
                    stamp: reg.now(),
                    angle_min: f64::from(s.angle_min),
                    angle_increment: f64::from(s.angle_increment),
                    range_min: f64::from(s.range_min),
                    range_max: f64::from(s.range_max),
                    ranges: s.ranges,
                });
            })
            .await?;
        let (b, reg, pl) = (base.clone(), registry.clone(), Arc::clone(&placing));
        let odom = node
            .subscribe::<Odometry>(&p.odom_topic, Qos::Default, move |o, _| {
                pl.lock().base_frame(&o.child_frame_id);
                let pose = &o.pose.pose;
                b.feed_odometry(Odom {
                    stamp: reg.now(),
                    x_m: pose.position.x,
                    y_m: pose.position.y,
                    yaw_rad: pose.orientation.yaw(),
                    v_m_s: o.twist.twist.linear.x,
                    omega_rad_s: o.twist.twist.angular.z,
                });
            })
            .await?;
        let publisher = match p.cmd_vel_type {
            CmdVelType::Twist => {
                CmdVelPublisher::Twist(node.publisher(&p.cmd_vel_topic, Qos::Default).await?)
            }
            CmdVelType::TwistStamped => {
                CmdVelPublisher::TwistStamped(node.publisher(&p.cmd_vel_topic, Qos::Default).await?)
            }
        };
        robot.connect_publisher(publisher).map_err(anyhow::Error::msg)?;
        subscriptions.extend([scan, odom]);
        Ok(BaseLink { node, placing, _subscriptions: subscriptions })
    }

    /// What its node received and refused so far, and where the laser was placed.
    pub fn report(&self) -> Ros2Report {
        let p = self.placing.lock();
        Ros2Report {
            node: self.node.stats(),
            laser: Some(LaserPlacement { from_tf: p.from_tf, by_tf: p.by_tf, by_config: p.by_config }),
            ..Default::default()
        }
    }
}

/// Where the scans' laser was placed on the base (`orsa robot --hardware ros2`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct LaserPlacement {
    /// The laser's pose on the base the robot's TF gave, last time it did.
    pub from_tf: Option<LaserPose>,
    /// Scans placed by TF.
    pub by_tf: u64,
    /// Scans placed by the config (TF did not link the scan's frame to the base frame).
    pub by_config: u64,
}

/// The TF tree, the base frame (the odometry's child frame) and what was placed how.
#[derive(Debug, Default)]
struct Placing {
    tree: tf::TfTree,
    base_frame: Option<String>,
    from_tf: Option<LaserPose>,
    by_tf: u64,
    by_config: u64,
}

impl Placing {
    fn base_frame(&mut self, frame: &str) {
        if !frame.is_empty() && self.base_frame.as_deref() != Some(frame) {
            self.base_frame = Some(frame.to_string());
        }
    }

    /// The pose of laser frame `frame` on the base, if TF says.
    fn place(&mut self, frame: &str) -> Option<LaserPose> {
        let base = self.base_frame.as_deref().unwrap_or("base_link");
        let pose = self.tree.pose_in(frame, base);
        match pose {
            Some(p) => {
                self.by_tf += 1;
                self.from_tf = Some(p);
            }
            None => self.by_config += 1,
        }
        pose
    }
}

/// A ROS time from an orsa timestamp (UNIX nanoseconds on a live clock).
fn time(t: Timestamp) -> m::Time {
    m::Time::from_nanos(t.0)
}

/// A ring as a LaserScan in `base_link`: ray `i` is sensor `i`, at the ring's angle; ranges
/// are from the robot's centre (the sensor's reading plus its mount radius). A reading that saw
/// nothing within range is +inf, one of a sensor that has not fired is NaN (REP-117).
pub fn laser_scan(scan: &DistanceScan, ring: &RingParams) -> LaserScan {
    let n = scan.readings.len();
    let first = ring.angles_rad.first().copied().unwrap_or(0.0);
    let step = if n > 1 { std::f64::consts::TAU / n as f64 } else { 0.0 };
    let r0 = ring.mount_radius_m;
    let ranges = scan
        .readings
        .iter()
        .map(|r| match (r.valid, r.distance_m > 0.0) {
            (true, _) => (r.distance_m + r0) as f32,
            (false, true) => f32::INFINITY,
            (false, false) => f32::NAN,
        })
        .collect();
    LaserScan {
        header: m::Header { stamp: time(scan.stamp), frame_id: "base_link".into() },
        angle_min: first as f32,
        angle_max: (first + step * n.saturating_sub(1) as f64) as f32,
        angle_increment: step as f32,
        time_increment: ring.fire_period_s as f32,
        scan_time: (ring.fire_period_s * n as f64) as f32,
        range_min: (ring.min_range_m + r0) as f32,
        range_max: (ring.max_range_m + r0) as f32,
        ranges,
        intensities: Vec::new(),
    }
}

/// A `/cmd_vel` message's twist and the stamp the robot server judges it by (its velocity
/// timeout runs from it): a Twist has none, so its arrival `now` is its stamp; a TwistStamped
/// has its header's (ROS time is UNIX time, as orsa's clock), which the server judges as any
/// command's: older than its timeout or than the last command applied, or from further in the
/// future than the clock skew allowed, refused and counted. A zero stamp (what `ros2 topic pub`
/// sends unless told otherwise) means now.
pub fn command_stamp(t: Either<Twist, TwistStamped>, now: Timestamp) -> (Twist, Timestamp) {
    match t {
        Either::A(twist) => (twist, now),
        Either::B(s) => {
            let ns = s.header.stamp.as_nanos();
            (s.twist, if ns == 0 { now } else { Timestamp(ns) })
        }
    }
}

/// What the odometry's covariances say: how far it may have drifted, by the simulator's own
/// drift model ([`OdometryConfig`]: a scale error on distance and on turning, a steady curve
/// per metre), from what the robot travelled and turned since its axes were zeroed, and the
/// board's resolution. A real base's errors are set in the same `[sim.odometry]` table. Each
/// error is taken as one standard deviation (the sign of a systematic error is not known to a
/// user of the odometry). z, roll and pitch are not measured: variance 1e6, as ROS bases
/// (kobuki, turtlebot) publish them, which robot_localization's 2D mode ignores.
#[derive(Debug, Clone)]
pub struct Drift {
    model: OdometryConfig,
    /// Distance travelled, m, and angle turned, rad, since the start (absolute sums).
    travelled_m: f64,
    turned_rad: f64,
    last: Option<(f64, f64, f64)>,
}

/// The variance of what is not measured.
const UNMEASURED: f64 = 1e6;

impl Drift {
    /// Nothing travelled yet.
    pub fn new(model: OdometryConfig) -> Drift {
        Drift { model, travelled_m: 0.0, turned_rad: 0.0, last: None }
    }

    /// Counts the motion since the last base state.
    pub fn follow(&mut self, b: &BaseState) {
        if let Some((x, y, h)) = self.last {
            let step = (b.x_m - x).hypot(b.y_m - y);
            let turn = (b.heading_rad - h).sin().atan2((b.heading_rad - h).cos()).abs();
            if step.is_finite() && turn.is_finite() {
                self.travelled_m += step;
                self.turned_rad += turn;
            }
        }
        self.last = Some((b.x_m, b.y_m, b.heading_rad));
    }

    /// The pose's and the twist's covariances (6x6, row major: x, y, z, roll, pitch, yaw) at
    /// `b`: along the heading, the distance error of what was travelled; across it, what the
    /// heading error does over that distance; the heading's own error; each with the
    /// resolution's (a uniform rounding: step^2 / 12).
    pub fn covariances(&self, b: &BaseState) -> (m::Covariance, m::Covariance) {
        let d = &self.model;
        let res_m2 = d.resolution_m * d.resolution_m / 12.0;
        let res_rad = d.resolution_deg.to_radians();
        let res_rad2 = res_rad * res_rad / 12.0;
        let yaw_sd = d.heading_error.abs() * self.turned_rad
            + d.heading_error_deg_per_m.abs().to_radians() * self.travelled_m;
        let along_sd = d.distance_error.abs() * self.travelled_m;
        let across_sd = self.travelled_m * yaw_sd;
        let (along, across) = (along_sd * along_sd + res_m2, across_sd * across_sd + res_m2);
        let (sin, cos) = b.heading_rad.sin_cos();
        let mut pose = [0.0; 36];
        pose[0] = cos * cos * along + sin * sin * across;
        pose[7] = sin * sin * along + cos * cos * across;
        pose[1] = sin * cos * (along - across);
        pose[6] = pose[1];
        pose[14] = UNMEASURED;
        pose[21] = UNMEASURED;
        pose[28] = UNMEASURED;
        pose[35] = yaw_sd * yaw_sd + res_rad2;
        // The velocities (in base_link): the scale errors at the speeds and the curve per
        // metre at the speed, the resolution's as a floor (sideways, a wheeled base does not
        // move: that floor alone).
        let (v, w) = (b.v_m_s.abs(), b.omega_rad_s.abs());
        let v_sd = d.distance_error.abs() * v;
        let w_sd = d.heading_error.abs() * w + d.heading_error_deg_per_m.abs().to_radians() * v;
        let mut twist = [0.0; 36];
        twist[0] = v_sd * v_sd + res_m2;
        twist[7] = res_m2;
        twist[14] = UNMEASURED;
        twist[21] = UNMEASURED;
        twist[28] = UNMEASURED;
        twist[35] = w_sd * w_sd + res_rad2;
        (m::Covariance(pose), m::Covariance(twist))
    }
}

/// The base state as odometry (`odom` -> `base_link`) and as the same transform on `/tf`.
pub fn odometry(b: &BaseState) -> (Odometry, TfMessage) {
    let header = m::Header { stamp: time(b.stamp), frame_id: "odom".into() };
    let position = m::Point { x: b.x_m, y: b.y_m, z: 0.0 };
    let orientation = m::Quaternion::from_yaw(b.heading_rad);
    let mut odom =
        Odometry { header: header.clone(), child_frame_id: "base_link".into(), ..Default::default() };
    odom.pose.pose = m::Pose { position, orientation };
    odom.twist.twist.linear.x = b.v_m_s;
    odom.twist.twist.angular.z = b.omega_rad_s;
    let tf = TfMessage {
        transforms: vec![m::TransformStamped {
            header,
            child_frame_id: "base_link".into(),
            transform: m::Transform { translation: position, rotation: orientation },
        }],
    };
    (odom, tf)
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::nomad200::{DistanceReading, Ring};
    use std::time::Duration;

    #[test]
    fn the_gate_lets_a_burst_then_the_rate_through() {
        let t0 = tokio::time::Instant::now();
        let mut g = RateGate::new(50.0, 20);
        let passed = (0..5000).filter(|_| g.admit(t0)).count();
        assert_eq!(passed, 20, "a burst of 5000 at one instant");
        // One second later: the bucket is full again, and holds no more than the burst.
        let t1 = t0 + Duration::from_secs(1);
        assert_eq!((0..5000).filter(|_| g.admit(t1)).count(), 20, "the bucket refills up to the burst only");
        // A steady 20 Hz all pass.
        let mut g = RateGate::new(50.0, 20);
        assert!((0..200).all(|i| g.admit(t0 + Duration::from_millis(50 * i))));
    }

    #[test]
    fn a_ring_is_a_scan_around_the_robot() {
        let ring = RingParams {
            angles_rad: (0..16).map(nomad200::ring_angle_rad).collect(),
            mount_radius_m: 0.25,
            beam_width_rad: 0.4,
            min_range_m: 0.15,
            max_range_m: 6.0,
            fire_period_s: 0.004,
        };
        let readings = (0..16u8)
            .map(|i| DistanceReading {
                sensor_id: i,
                stamp: Timestamp(5),
                valid: i != 3 && i != 5,
                distance_m: if i == 5 { 0.0 } else { 1.0 },
            })
            .collect();
        let scan = DistanceScan { stamp: Timestamp(2_000_000_123), ring: Ring::Sonar, readings };
        let s = laser_scan(&scan, &ring);
        assert_eq!(s.ranges.len(), 16);
        assert!((s.angle_increment - std::f32::consts::PI / 8.0).abs() < 1e-6);
        assert!((s.angle_max - 15.0 * std::f32::consts::PI / 8.0).abs() < 1e-5);
        assert_eq!(s.ranges[0], 1.25);
        assert_eq!(s.ranges[3], f32::INFINITY);
        assert!(s.ranges[5].is_nan());
        assert_eq!((s.header.stamp.sec, s.header.stamp.nanosec), (2, 123));
    }

    #[test]
    fn the_base_state_is_odometry_and_a_transform() {
        let b = BaseState {
            stamp: Timestamp(1),
            x_m: 1.0,
            y_m: 2.0,
            heading_rad: 0.5,
            v_m_s: 0.3,
            omega_rad_s: -0.1,
            steer_rad: 0.5,
            turret_rad: 0.5,
            turret_omega_rad_s: 0.0,
            compass_rad: 0.0,
            compass_valid: false,
        };
        let (o, tf) = odometry(&b);
        assert!((o.pose.pose.orientation.yaw() - 0.5).abs() < 1e-12);
        assert_eq!((o.twist.twist.linear.x, o.twist.twist.angular.z), (0.3, -0.1));
        assert_eq!(tf.transforms[0].transform.translation.y, 2.0);
        assert_eq!(tf.transforms[0].header.frame_id, "odom");
    }

    #[test]
    fn a_twist_is_stamped_on_arrival_a_twist_stamped_by_its_header_zero_meaning_now() {
        let now = Timestamp(1_800_000_000_000_000_000);
        let t = Twist { linear: m::Vector3 { x: 0.2, y: 0.0, z: 0.0 }, ..Default::default() };
        assert_eq!(command_stamp(Either::A(t), now), (t, now));
        let stamped = |ns: u64| {
            Either::B(TwistStamped {
                header: m::Header { stamp: m::Time::from_nanos(ns), frame_id: String::new() },
                twist: t,
            })
        };
        assert_eq!(command_stamp(stamped(0), now), (t, now));
        let past = now.0 - 300_000_000;
        assert_eq!(command_stamp(stamped(past), now), (t, Timestamp(past)));
        // Judged by the server, not here: a stamp ahead is kept (it refuses beyond its skew).
        assert_eq!(command_stamp(stamped(now.0 + 5), now).1, Timestamp(now.0 + 5));
    }

    #[test]
    fn odometry_covariances_grow_with_the_drift_the_model_gives_what_was_travelled() {
        let model = OdometryConfig::default();
        let mut drift = Drift::new(model.clone());
        let at = |x_m: f64, y_m: f64, heading_rad: f64| BaseState {
            stamp: Timestamp(1),
            x_m,
            y_m,
            heading_rad,
            v_m_s: 0.25,
            omega_rad_s: 0.0,
            steer_rad: heading_rad,
            turret_rad: heading_rad,
            turret_omega_rad_s: 0.0,
            compass_rad: 0.0,
            compass_valid: false,
        };
        drift.follow(&at(0.0, 0.0, 0.0));
        let (start, _) = drift.covariances(&at(0.0, 0.0, 0.0));
        // Nothing travelled: the resolution's alone, never zero (zero says certain).
        assert!(start.0[0] > 0.0 && start.0[0] < 1e-5 && start.0[35] > 0.0, "{:?}", start.0);
        assert_eq!([start.0[14], start.0[21], start.0[28]], [UNMEASURED; 3]);
        // 10 m straight along x.
        for i in 1..=100 {
            drift.follow(&at(0.1 * f64::from(i), 0.0, 0.0));
        }
        let (pose, twist) = drift.covariances(&at(10.0, 0.0, 0.0));
        let along = model.distance_error * 10.0;
        let yaw = model.heading_error_deg_per_m.to_radians() * 10.0;
        assert!((pose.0[0].sqrt() - along).abs() < 1e-3, "x sd {} want {along}", pose.0[0].sqrt());
        assert!((pose.0[7].sqrt() - 10.0 * yaw).abs() < 1e-3, "y sd {}", pose.0[7].sqrt());
        assert!((pose.0[35].sqrt() - yaw).abs() < 1e-3, "yaw sd {}", pose.0[35].sqrt());
        assert!(pose.0[1].abs() < 1e-12 && pose.0[1] == pose.0[6]);
        let floor = model.resolution_m * model.resolution_m / 12.0;
        assert!((twist.0[0] - (model.distance_error * 0.25).powi(2) - floor).abs() < 1e-15);
        assert_eq!(twist.0[7], floor, "sideways: the floor alone");
        // Heading north, the same uncertainty lies along y: the matrix turns with the robot.
        let (north, _) = drift.covariances(&at(10.0, 0.0, std::f64::consts::FRAC_PI_2));
        assert!((north.0[7] - pose.0[0]).abs() < 1e-9 && (north.0[0] - pose.0[7]).abs() < 1e-9);
        // At 45 degrees the two mix: x and y correlate.
        let (diag, _) = drift.covariances(&at(10.0, 0.0, std::f64::consts::FRAC_PI_4));
        assert!((diag.0[1] - (pose.0[0] - pose.0[7]) / 2.0).abs() < 1e-9);
    }
}
