//! Driving from Foxglove: a client of the live view may publish velocity commands (the
//! protocol's client publish) on [`CMD_VEL`], as JSON `geometry_msgs/Twist` or
//! `geometry_msgs/TwistStamped` (ROS 1 or ROS 2 names: what Foxglove's Teleop panel and
//! Publish panel send). Each is handed to the robot server's `teleop` service and judged
//! there as every teleoperation command is: teleop takes priority over the behaviours while it
//! talks and gives control back when it is silent for the velocity timeout; a command older
//! than the timeout, or from further in the future than the clock skew allowed, is refused and
//! counted; speeds are clamped to the robot's; the safety monitor limits it as it does every
//! driver.
//!
//! A Twist has no stamp: it is stamped on arrival. A TwistStamped is judged by its header's
//! stamp (UNIX time, as orsa's clock; zero, as a panel that leaves it unset sends, means now).
//!
//! Navigation goals come on [`GOAL_POSE`], as JSON `geometry_msgs/PoseStamped` in the `map`
//! frame (what the 3D panel's pose tool publishes, set to that topic, and what RViz's "2D Goal
//! Pose" sends), where the system has a planner: each goes to the planner's `navigate` query,
//! wherever the planner runs, as `orsa goto X,Y,HEADING` would; the planner's answer is logged.
//!
//! What is refused is said to the client that sent it (a status message), logged within a
//! budget, and counted; nothing else changes: a channel on another topic or of another schema
//! or encoding (said once, when it is advertised), a message that is not such a JSON object, a
//! robot that has no teleop service.

use orsa_actors::Registry;
use orsa_actors::Timestamp;
use orsa_actors::logbudget::{LogBudget, Verdict};
use orsa_actors::query::QueryClient;
use orsa_actors::send::SendClient;
use orsa_interfaces::navigation::{NAVIGATE, NavGoal, NavReply, NavTarget};
use orsa_interfaces::nomad200::{self, NavigationVelocity};
use parking_lot::Mutex;
use serde::Deserialize;
use std::sync::atomic::{AtomicU64, Ordering};

/// The topic velocity commands are taken on.
pub const CMD_VEL: &str = "/cmd_vel";
/// The topic navigation goals are taken on.
pub const GOAL_POSE: &str = "/goal_pose";
/// The schemas taken there.
pub const POSE_SCHEMAS: [&str; 2] = ["geometry_msgs/PoseStamped", "geometry_msgs/msg/PoseStamped"];
/// How long the planner may take to answer a goal.
const ANSWER_WITHIN: std::time::Duration = std::time::Duration::from_secs(15);
/// The message encoding taken.
pub const ENCODING: &str = "json";
/// The schemas taken: a twist, stamped or not.
pub const TWIST_SCHEMAS: [&str; 2] = ["geometry_msgs/Twist", "geometry_msgs/msg/Twist"];
/// The schemas taken whose messages carry a stamp.
pub const STAMPED_SCHEMAS: [&str; 2] = ["geometry_msgs/TwistStamped", "geometry_msgs/msg/TwistStamped"];

/// What a client's channel is to orsa.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Twists, stamped on arrival.
    Twist,
    /// TwistStampeds, judged by their stamps.
    Stamped,
    /// PoseStampeds: navigation goals.
    Goal,
}

/// Whether messages on a channel of `topic`, `encoding` and `schema` are taken, and as what;
/// else why not, in words for the user.
pub fn kind_of(topic: &str, encoding: &str, schema: &str) -> Result<Kind, String> {
    if topic == GOAL_POSE {
        if encoding != ENCODING {
            return Err(format!("{GOAL_POSE}: encoding '{encoding}' is not taken (orsa takes {ENCODING})"));
        }
        if !POSE_SCHEMAS.contains(&schema) {
            return Err(format!(
                "{GOAL_POSE}: schema '{schema}' is not taken (orsa takes {})",
                POSE_SCHEMAS.join(", ")
            ));
        }
        return Ok(Kind::Goal);
    }
    if topic != CMD_VEL {
        return Err(format!(
            "orsa takes client messages on {CMD_VEL} and {GOAL_POSE} only: '{topic}' is ignored"
        ));
    }
    if encoding != ENCODING {
        return Err(format!("{CMD_VEL}: encoding '{encoding}' is not taken (orsa takes {ENCODING})"));
    }
    if TWIST_SCHEMAS.contains(&schema) {
        Ok(Kind::Twist)
    } else if STAMPED_SCHEMAS.contains(&schema) {
        Ok(Kind::Stamped)
    } else {
        Err(format!(
            "{CMD_VEL}: schema '{schema}' is not taken (orsa takes {} or {})",
            TWIST_SCHEMAS.join(", "),
            STAMPED_SCHEMAS.join(", ")
        ))
    }
}

#[derive(Debug, Deserialize)]
struct Vector3 {
    #[serde(default)]
    x: f64,
    #[serde(default)]
    y: f64,
    #[serde(default)]
    z: f64,
}

#[derive(Debug, Deserialize)]
struct Twist {
    linear: Vector3,
    angular: Vector3,
}

/// ROS 1 spells the nanoseconds `nsec`, ROS 2 `nanosec`; both are taken.
#[derive(Debug, Deserialize)]
struct Time {
    sec: u32,
    #[serde(alias = "nsec")]
    nanosec: u32,
}

#[derive(Debug, Deserialize)]
struct Header {
    stamp: Time,
}

#[derive(Debug, Deserialize)]
struct TwistStamped {
    header: Header,
    twist: Twist,
}

#[derive(Debug, Deserialize)]
struct Quaternion {
    x: f64,
    y: f64,
    z: f64,
    w: f64,
}

#[derive(Debug, Deserialize)]
struct Pose {
    position: Vector3,
    orientation: Quaternion,
}

#[derive(Debug, Deserialize)]
struct PoseHeader {
    #[serde(default)]
    frame_id: String,
}

#[derive(Debug, Deserialize)]
struct PoseStamped {
    header: PoseHeader,
    pose: Pose,
}

/// The goal a `/goal_pose` message names, or why it names none.
pub fn goal(payload: &[u8]) -> Result<NavTarget, String> {
    let m = serde_json::from_slice::<PoseStamped>(payload).map_err(|e| e.to_string())?;
    let (p, q) = (&m.pose.position, &m.pose.orientation);
    NavTarget::from_pose(&m.header.frame_id, p.x, p.y, [q.x, q.y, q.z, q.w])
}

/// The command a message of `kind` makes, `now` being its arrival; or why it is refused.
pub fn command(kind: Kind, payload: &[u8], now: Timestamp) -> Result<NavigationVelocity, String> {
    let (twist, stamp) = match kind {
        Kind::Goal => return Err(format!("{GOAL_POSE} carries goals, not commands")),
        Kind::Twist => (serde_json::from_slice::<Twist>(payload).map_err(|e| e.to_string())?, now),
        Kind::Stamped => {
            let s = serde_json::from_slice::<TwistStamped>(payload).map_err(|e| e.to_string())?;
            let ns = u64::from(s.header.stamp.sec) * 1_000_000_000 + u64::from(s.header.stamp.nanosec);
            (s.twist, if ns == 0 { now } else { Timestamp(ns) })
        }
    };
    // A ground robot takes forward speed and turn rate; what it cannot do is refused, not
    // dropped silently.
    let (l, a) = (&twist.linear, &twist.angular);
    if l.y != 0.0 || l.z != 0.0 || a.x != 0.0 || a.y != 0.0 {
        return Err(format!(
            "the robot drives linear.x and turns angular.z only (linear.y {}, linear.z {}, angular.x {}, angular.y {})",
            l.y, l.z, a.x, a.y
        ));
    }
    Ok(NavigationVelocity { stamp, v_m_s: l.x, omega_rad_s: a.z })
}

/// Hands the commands clients publish to the robot server's `teleop` service.
pub struct Teleop {
    /// The system's, once it is up.
    registry: std::sync::OnceLock<Registry>,
    robot: String,
    /// The planner goals go to, if the system has one that navigates.
    planner: Option<String>,
    /// Goals handed to the planner (which may still reject them: its answer is logged).
    goals: AtomicU64,
    /// Connected on the first command (the live view may start before the robot server).
    client: Mutex<Option<SendClient<NavigationVelocity>>>,
    taken: AtomicU64,
    refused: AtomicU64,
    log: LogBudget,
}

impl std::fmt::Debug for Teleop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Teleop").field("robot", &self.robot).finish_non_exhaustive()
    }
}

/// What clients published, for the report of the command that served them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Published {
    /// Commands handed to the robot server (which may still refuse them: its counters say).
    pub taken: u64,
    /// Messages refused here (and said to their client).
    pub refused: u64,
    /// Goals handed to the planner (which may still reject them: its answer is logged).
    pub goals: u64,
}

impl Teleop {
    /// Commands for the robot server `robot`, reached through `registry`.
    pub fn new(registry: &Registry, robot: &str) -> Teleop {
        let teleop = Teleop::pending(robot);
        teleop.ready(registry);
        teleop
    }

    /// Commands for the robot server `robot` of a system that is not up yet (the live server
    /// starts before the run): refused until [`Teleop::ready`].
    pub fn pending(robot: &str) -> Teleop {
        Teleop {
            registry: std::sync::OnceLock::new(),
            robot: robot.to_owned(),
            planner: None,
            goals: AtomicU64::new(0),
            client: Mutex::new(None),
            taken: AtomicU64::new(0),
            refused: AtomicU64::new(0),
            log: LogBudget::hostile_input(),
        }
    }

    /// Goals on [`GOAL_POSE`] go to `planner` (none: they are refused).
    pub fn with_planner(mut self, planner: Option<&str>) -> Teleop {
        self.planner = planner.map(str::to_owned);
        self
    }

    /// The system is up: commands go through `registry`.
    pub fn ready(&self, registry: &Registry) {
        let _ = self.registry.set(registry.clone());
    }

    /// What was taken and refused so far.
    pub fn published(&self) -> Published {
        Published {
            taken: self.taken.load(Ordering::Relaxed),
            refused: self.refused.load(Ordering::Relaxed),
            goals: self.goals.load(Ordering::Relaxed),
        }
    }

    /// Hands one message, published on a channel of `topic`, `encoding` and `schema`, to the
    /// robot; why not, if refused (counted, logged within the budget; the caller tells the
    /// client).
    pub fn take(&self, topic: &str, encoding: &str, schema: &str, payload: &[u8]) -> Result<(), String> {
        let sent = kind_of(topic, encoding, schema).and_then(|kind| {
            let registry = self.registry.get().ok_or("the system is not up yet")?;
            Ok((kind, registry))
        });
        if let Ok((Kind::Goal, registry)) = &sent {
            return self.goal(registry, topic, payload);
        }
        let sent = sent.and_then(|(kind, registry)| Ok((command(kind, payload, registry.now())?, registry)));
        let sent = sent.and_then(|(cmd, registry)| {
            let mut client = self.client.lock();
            if client.is_none() {
                let teleop = nomad200::TELEOP.on(&self.robot);
                *client = Some(
                    SendClient::connect(registry, teleop.clone()).map_err(|e| format!("{teleop}: {e}"))?,
                );
            }
            let Some(c) = client.as_ref() else { return Err("no teleop client".into()) };
            c.send(cmd).map_err(|e| e.to_string())
        });
        match sent {
            Ok(()) => {
                self.taken.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Err(why) => {
                self.refused.fetch_add(1, Ordering::Relaxed);
                let why = format!("{topic}: refused: {why}");
                self.log.warn(|| format!("foxglove: a client's command {why}"));
                Err(why)
            }
        }
    }

    /// Hands a goal to the planner; the answer is logged when it comes.
    fn goal(&self, registry: &Registry, topic: &str, payload: &[u8]) -> Result<(), String> {
        let planner =
            self.planner.as_deref().ok_or_else(|| "this system has no planner that navigates".to_string());
        let sent = planner.and_then(|planner| {
            let target = goal(payload)?;
            let runtime = tokio::runtime::Handle::try_current()
                .map_err(|_| "no runtime to ask the planner on".to_string())?;
            let client = QueryClient::connect(registry, NAVIGATE.on(planner))
                .map_err(|e| format!("{planner}/navigate: {e}"))?;
            let planner = planner.to_owned();
            runtime.spawn(async move {
                match client.query(NavGoal { target: target.clone() }, Some(ANSWER_WITHIN)).await {
                    Ok(NavReply::Accepted { id }) => {
                        tracing::info!("foxglove: {GOAL_POSE}: goal {id} to {target} accepted by {planner}")
                    }
                    Ok(NavReply::Rejected { reason }) => {
                        tracing::warn!(
                            "foxglove: {GOAL_POSE}: goal to {target} rejected by {planner}: {reason}"
                        )
                    }
                    Err(e) => {
                        tracing::warn!("foxglove: {GOAL_POSE}: goal to {target}: {planner}/navigate: {e}")
                    }
                }
            });
            Ok(())
        });
        match sent {
            Ok(()) => {
                self.goals.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Err(why) => {
                self.refused.fetch_add(1, Ordering::Relaxed);
                let why = format!("{topic}: refused: {why}");
                self.log.warn(|| format!("foxglove: a client's goal {why}"));
                Err(why)
            }
        }
    }

    /// Whether to tell the client about one more refusal now (within the same budget as the
    /// log: a client that floods bad messages is not flooded back).
    pub fn tell(&self) -> bool {
        matches!(self.log.judge(std::time::Instant::now()), Verdict::Log { .. })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_are_taken_on_cmd_vel_as_json_twists_only() {
        assert_eq!(kind_of("/cmd_vel", "json", "geometry_msgs/msg/Twist"), Ok(Kind::Twist));
        assert_eq!(kind_of("/cmd_vel", "json", "geometry_msgs/Twist"), Ok(Kind::Twist));
        assert_eq!(kind_of("/cmd_vel", "json", "geometry_msgs/msg/TwistStamped"), Ok(Kind::Stamped));
        assert!(
            kind_of("/goal", "json", "geometry_msgs/msg/Twist")
                .expect_err("refused")
                .contains("'/goal' is ignored")
        );
        assert_eq!(kind_of("/goal_pose", "json", "geometry_msgs/msg/PoseStamped"), Ok(Kind::Goal));
        assert_eq!(kind_of("/goal_pose", "json", "geometry_msgs/PoseStamped"), Ok(Kind::Goal));
        assert!(
            kind_of("/goal_pose", "json", "geometry_msgs/msg/Twist").expect_err("refused").contains("schema")
        );
        assert!(
            kind_of("/goal_pose", "cdr", "geometry_msgs/msg/PoseStamped")
                .expect_err("refused")
                .contains("encoding")
        );
        assert!(
            kind_of("/cmd_vel", "cdr", "geometry_msgs/msg/Twist")
                .expect_err("refused")
                .contains("encoding 'cdr'")
        );
        assert!(
            kind_of("/cmd_vel", "json", "foxglove.Vector3")
                .expect_err("refused")
                .contains("schema 'foxglove.Vector3'")
        );
    }

    #[test]
    fn twists_are_stamped_on_arrival_and_stamped_ones_by_their_header() {
        let now = Timestamp::from_secs_f64(1_800_000_000.0);
        let twist = br#"{"linear":{"x":0.2,"y":0,"z":0},"angular":{"x":0,"y":0,"z":-0.5}}"#;
        let c = command(Kind::Twist, twist, now).expect("taken");
        assert_eq!((c.stamp, c.v_m_s, c.omega_rad_s), (now, 0.2, -0.5));
        let stamped = br#"{"header":{"stamp":{"sec":1700000000,"nanosec":5},"frame_id":"base_link"},
            "twist":{"linear":{"x":0.1},"angular":{"z":0.3}}}"#;
        let c = command(Kind::Stamped, stamped, now).expect("taken");
        assert_eq!(c.stamp, Timestamp(1_700_000_000_000_000_005));
        let ros1 =
            br#"{"header":{"stamp":{"sec":0,"nsec":0}},"twist":{"linear":{"x":0.1},"angular":{"z":0}}}"#;
        assert_eq!(command(Kind::Stamped, ros1, now).expect("taken").stamp, now, "zero means now");
    }

    #[test]
    fn goals_are_poses_in_the_map_with_their_heading() {
        let msg = br#"{"header":{"stamp":{"sec":1,"nanosec":0},"frame_id":"map"},
            "pose":{"position":{"x":12.0,"y":3.0,"z":0.0},"orientation":{"x":0,"y":0,"z":0.7071067811865476,"w":0.7071067811865476}}}"#;
        let NavTarget::Pose { x_m, y_m, heading_deg: Some(h) } = goal(msg).expect("a goal") else { panic!() };
        assert_eq!((x_m, y_m), (12.0, 3.0));
        assert!((h - 90.0).abs() < 1e-9, "{h}");
        let odom = br#"{"header":{"frame_id":"odom"},"pose":{"position":{"x":1},"orientation":{"x":0,"y":0,"z":0,"w":1}}}"#;
        assert_eq!(goal(odom), Err("frame 'odom': goals are taken in 'map'".into()));
        assert!(goal(br#"{"pose":{}}"#).expect_err("no header").contains("missing field"));
        let t = Teleop::new(&Registry::new(), "nomad200");
        let e = t.take("/goal_pose", "json", "geometry_msgs/msg/PoseStamped", msg).expect_err("no planner");
        assert_eq!(e, "/goal_pose: refused: this system has no planner that navigates");
        assert_eq!(t.published(), Published { taken: 0, refused: 1, goals: 0 });
    }

    #[test]
    fn what_is_not_a_drivable_twist_is_refused_saying_why() {
        let now = Timestamp::ZERO;
        for (payload, needle) in [
            (&b"not json"[..], "expected"),
            (br#"{"linear":{"x":0.1}}"#, "missing field `angular`"),
            (br#"{"linear":{"x":"fast"},"angular":{}}"#, "invalid type"),
            (br#"{"linear":{"x":0.1,"y":0.2},"angular":{}}"#, "linear.y 0.2"),
        ] {
            let e = command(Kind::Twist, payload, now).expect_err("refused");
            assert!(e.contains(needle), "{e}");
        }
        let e =
            command(Kind::Stamped, br#"{"linear":{"x":0.1},"angular":{"z":0}}"#, now).expect_err("refused");
        assert!(e.contains("missing field `header`"), "{e}");
    }
}
