//! Navigation: where the robot is on the map, the path it follows, and goals to places.
//!
//! | service | on | pattern | object |
//! |---|---|---|---|
//! | [`POSE`] | the localizer | Push newest | [`PoseEstimate`]: the pose in the map, its covariance, `map -> odom` |
//! | [`PATH`] | the path follower | Send | [`FollowPath`]: the path to follow (none: stop) |
//! | [`NAVIGATE`] | the planner | Query | [`NavGoal`] -> [`NavReply`]: go there (accepted or rejected, why) |
//! | [`CANCEL`] | the planner | Send | [`NavCancel`]: stop going there |
//! | [`NAVIGATION`] | the planner | Push newest | [`NavFeedback`]: distance left, ETA, the path, the result |
//!
//! A navigation goal has the lifecycle of a ROS 2 action: accepted or rejected with a reason,
//! feedback while it runs, a result (succeeded, aborted with a reason, canceled), and a newer
//! goal preempts the one running (which ends `canceled`, "preempted").
//!
//! The components are called [`LOCALIZER`] and [`PATHFOLLOW`] in the default configuration;
//! the goals go to the planner (`orsa_interfaces::planner::NAME`).

use orsa_actors::service::{PushNewestService, QueryService, SendService};
use orsa_actors::{Timestamp, comm_object};
use serde::{Deserialize, Serialize};

/// The localizer's name in the default configuration.
pub const LOCALIZER: &str = "localizer";
/// The path follower's name in the default configuration.
pub const PATHFOLLOW: &str = "pathfollow";

/// The robot's pose in the map, at every odometry update.
pub const POSE: PushNewestService<PoseEstimate> = PushNewestService::new("pose");
/// The path the path follower follows.
pub const PATH: SendService<FollowPath> = SendService::new("path");
/// Goals to places.
pub const NAVIGATE: QueryService<NavGoal, NavReply> = QueryService::new("navigate");
/// Cancels a goal.
pub const CANCEL: SendService<NavCancel> = SendService::new("cancel");
/// The running goal's feedback and every goal's result.
pub const NAVIGATION: PushNewestService<NavFeedback> = PushNewestService::new("navigation");

/// The robot's pose in the map (service [`POSE`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseEstimate {
    /// The odometry it was made from.
    pub stamp: Timestamp,
    /// x in the map, m.
    pub x_m: f64,
    /// y in the map, m.
    pub y_m: f64,
    /// Heading in the map, rad counter-clockwise from +x, in (-pi, pi].
    pub heading_rad: f64,
    /// Covariance of (x, y, heading), row-major: m^2, m rad, rad^2.
    pub covariance: [f64; 9],
    /// The odometry frame's pose in the map (`map -> odom`): x, m.
    pub odom_x_m: f64,
    /// `map -> odom`: y, m.
    pub odom_y_m: f64,
    /// `map -> odom`: heading, rad.
    pub odom_heading_rad: f64,
    /// The localizer has noticed that what the sensors see does not fit the map from this
    /// pose (the robot was carried elsewhere, or the estimate wandered off): it is looking for
    /// the robot, and the pose is not to be driven on until this is false again.
    #[serde(default)]
    pub lost: bool,
}
comm_object!(PoseEstimate, "orsa.navigation.PoseEstimate/1");

impl PoseEstimate {
    /// The odometry pose `(x, y, heading)` in the map, through this estimate's `map -> odom`.
    pub fn in_map(&self, x_m: f64, y_m: f64, heading_rad: f64) -> (f64, f64, f64) {
        let (s, c) = self.odom_heading_rad.sin_cos();
        let h =
            (self.odom_heading_rad + heading_rad).sin().atan2((self.odom_heading_rad + heading_rad).cos());
        (self.odom_x_m + c * x_m - s * y_m, self.odom_y_m + s * x_m + c * y_m, h)
    }
}

/// What the path follower is to follow (service [`PATH`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FollowPath {
    /// The goal it belongs to (its status names it).
    pub goal_id: u64,
    /// The points, in the map, from the robot to the goal; empty: stop.
    pub points: Vec<[f64; 2]>,
    /// The heading to turn to at the end, rad, if any.
    pub heading_rad: Option<f64>,
    /// Instead of a path (`points` empty): turn on the spot by this much, rad (positive
    /// counter-clockwise), by odometry alone, then stop. A recovery: a robot that is lost looks
    /// round, one that is stuck turns away; it needs no pose in the map.
    #[serde(default)]
    pub turn_rad: Option<f64>,
    /// Instead of a path (`points` empty, no `turn_rad`): back up straight by this much, m, by
    /// odometry alone and slowly, stopping short of what the range views see behind, then
    /// stop. A recovery: a robot stuck in a door backs out of it.
    #[serde(default)]
    pub back_m: Option<f64>,
}
comm_object!(FollowPath, "orsa.navigation.FollowPath/1");

impl FollowPath {
    /// Follow `points` for goal `goal_id`, turning to `heading_rad` at the end if given.
    pub fn along(goal_id: u64, points: Vec<[f64; 2]>, heading_rad: Option<f64>) -> Self {
        FollowPath { goal_id, points, heading_rad, turn_rad: None, back_m: None }
    }

    /// Stop.
    pub fn stop(goal_id: u64) -> Self {
        FollowPath::along(goal_id, Vec::new(), None)
    }

    /// Turn on the spot by `rad`.
    pub fn turn(goal_id: u64, rad: f64) -> Self {
        FollowPath { turn_rad: Some(rad), ..FollowPath::stop(goal_id) }
    }

    /// Back up by `m`.
    pub fn back(goal_id: u64, m: f64) -> Self {
        FollowPath { back_m: Some(m), ..FollowPath::stop(goal_id) }
    }
}

/// Where a goal goes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum NavTarget {
    /// A place named in the world.
    Place {
        /// Its name.
        name: String,
    },
    /// A pose in the map.
    Pose {
        /// x, m.
        x_m: f64,
        /// y, m.
        y_m: f64,
        /// The heading to end with, degrees counter-clockwise from +x, if any.
        heading_deg: Option<f64>,
    },
}

impl NavTarget {
    /// Reads `PLACE` or `X,Y[,HEADING_DEG]` (as `orsa goto` and `--goto` take them).
    pub fn parse(text: &str) -> Result<NavTarget, String> {
        let text = text.trim();
        let first = text.chars().next().ok_or("an empty goal: give a place's name or X,Y[,HEADING_DEG]")?;
        if !(first.is_ascii_digit() || first == '-' || first == '+' || first == '.') {
            return Ok(NavTarget::Place { name: text.to_string() });
        }
        let numbers: Result<Vec<f64>, _> = text.split(',').map(|s| s.trim().parse::<f64>()).collect();
        match numbers.as_deref() {
            Ok(n) if n.iter().all(|v| v.is_finite()) && (n.len() == 2 || n.len() == 3) => {
                Ok(NavTarget::Pose { x_m: n[0], y_m: n[1], heading_deg: n.get(2).copied() })
            }
            _ => {
                Err(format!("'{text}' is neither a place's name nor X,Y[,HEADING_DEG] in metres and degrees"))
            }
        }
    }
}

impl NavTarget {
    /// The goal a stamped pose names (ROS's `geometry_msgs/PoseStamped`, as RViz's and
    /// Foxglove's pose tools publish one): a position in `frame`, which must be the map's (or
    /// empty, taken as the map's), and the heading of the rotation `[x, y, z, w]` (any length
    /// but zero); or why it names none.
    pub fn from_pose(frame: &str, x_m: f64, y_m: f64, rotation: [f64; 4]) -> Result<NavTarget, String> {
        let map = crate::map::MAP_FRAME;
        if !(frame.trim_start_matches('/').is_empty() || frame.trim_start_matches('/') == map) {
            return Err(format!("frame '{frame}': goals are taken in '{map}'"));
        }
        if !(x_m.is_finite() && y_m.is_finite()) {
            return Err(format!("position ({x_m}, {y_m}) is not finite"));
        }
        let [qx, qy, qz, qw] = rotation;
        let norm = (qx * qx + qy * qy + qz * qz + qw * qw).sqrt();
        if !(norm.is_finite() && norm > 1e-6) {
            return Err(format!("orientation ({qx}, {qy}, {qz}, {qw}) is not a rotation"));
        }
        let (qx, qy, qz, qw) = (qx / norm, qy / norm, qz / norm, qw / norm);
        let yaw = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
        Ok(NavTarget::Pose { x_m, y_m, heading_deg: Some(yaw.to_degrees()) })
    }
}

impl std::fmt::Display for NavTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NavTarget::Place { name } => f.write_str(name),
            NavTarget::Pose { x_m, y_m, heading_deg: None } => write!(f, "{x_m:.2},{y_m:.2}"),
            NavTarget::Pose { x_m, y_m, heading_deg: Some(h) } => write!(f, "{x_m:.2},{y_m:.2},{h:.0}"),
        }
    }
}

/// A goal (service [`NAVIGATE`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NavGoal {
    /// Where to go.
    pub target: NavTarget,
}
comm_object!(NavGoal, "orsa.navigation.NavGoal/1");

/// The planner's answer to a goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NavReply {
    /// Accepted under this id: feedback and the result come on [`NAVIGATION`].
    Accepted {
        /// The goal's id.
        id: u64,
    },
    /// Refused at once, and why (a goal inside a wall, off the map, an unknown place).
    Rejected {
        /// Why.
        reason: String,
    },
}
comm_object!(NavReply, "orsa.navigation.NavReply/1");

/// Cancels a goal (service [`CANCEL`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct NavCancel {
    /// The goal to cancel; `None`: whichever runs.
    pub id: Option<u64>,
}
comm_object!(NavCancel, "orsa.navigation.NavCancel/1");

/// How a goal stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NavState {
    /// Being driven to.
    Active,
    /// Reached: within tolerance, stopped.
    Succeeded,
    /// Given up, for the reason given.
    Aborted,
    /// Canceled, or preempted by a newer goal.
    Canceled,
    /// Refused at once.
    Rejected,
}

impl NavState {
    /// Its name, as the report writes it.
    pub fn name(self) -> &'static str {
        match self {
            NavState::Active => "active",
            NavState::Succeeded => "succeeded",
            NavState::Aborted => "aborted",
            NavState::Canceled => "canceled",
            NavState::Rejected => "rejected",
        }
    }

    /// Whether the goal is over.
    pub fn is_final(self) -> bool {
        self != NavState::Active
    }
}

/// A goal's feedback or result (service [`NAVIGATION`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NavFeedback {
    /// When.
    pub stamp: Timestamp,
    /// The goal's id.
    pub id: u64,
    /// Where it goes.
    pub target: NavTarget,
    /// Its position in the map, m (`None`: it names none, e.g. an unknown place).
    pub goal: Option<[f64; 2]>,
    /// How it stands.
    pub state: NavState,
    /// Why it ended so, or what it does now (a recovery).
    pub reason: String,
    /// The distance left along the path, m.
    pub distance_left_m: f64,
    /// The time left at the path follower's cruise speed, s.
    pub eta_s: f64,
    /// The path being followed, in the map.
    pub path: Vec<[f64; 2]>,
}
comm_object!(NavFeedback, "orsa.navigation.NavFeedback/1");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_places_and_poses_and_refuse_the_rest() {
        assert_eq!(NavTarget::parse("room-3"), Ok(NavTarget::Place { name: "room-3".into() }));
        assert_eq!(
            NavTarget::parse("1.5,-2"),
            Ok(NavTarget::Pose { x_m: 1.5, y_m: -2.0, heading_deg: None })
        );
        assert_eq!(
            NavTarget::parse(" 3, 4 ,90"),
            Ok(NavTarget::Pose { x_m: 3.0, y_m: 4.0, heading_deg: Some(90.0) })
        );
        for bad in ["", "1", "1,2,3,4", "1,x", "1,NaN", "1,inf"] {
            assert!(NavTarget::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn stamped_poses_in_the_map_are_goals_with_their_heading_and_the_rest_is_refused_naming_why() {
        let half = std::f64::consts::FRAC_PI_4;
        let t = NavTarget::from_pose("map", 1.5, 2.0, [0.0, 0.0, half.sin(), half.cos()]).expect("a goal");
        let NavTarget::Pose { x_m, y_m, heading_deg: Some(h) } = t else { panic!("{t:?}") };
        assert_eq!((x_m, y_m), (1.5, 2.0));
        assert!((h - 90.0).abs() < 1e-9, "{h}");
        assert!(NavTarget::from_pose("/map", 1.0, 0.0, [0.0, 0.0, 0.0, 1.0]).is_ok());
        assert!(NavTarget::from_pose("", 1.0, 0.0, [0.0, 0.0, 0.0, 1.0]).is_ok(), "no frame: the map");
        // A rotation not of unit length is the same rotation.
        let Ok(NavTarget::Pose { heading_deg: Some(h), .. }) =
            NavTarget::from_pose("map", 1.0, 0.0, [0.0, 0.0, 2.0, 0.0])
        else {
            panic!()
        };
        assert!((h.abs() - 180.0).abs() < 1e-9, "{h}");
        let e = NavTarget::from_pose("odom", 1.0, 0.0, [0.0, 0.0, 0.0, 1.0]).expect_err("odom");
        assert_eq!(e, "frame 'odom': goals are taken in 'map'");
        let e = NavTarget::from_pose("map", f64::NAN, 0.0, [0.0, 0.0, 0.0, 1.0]).expect_err("NaN");
        assert!(e.contains("not finite"), "{e}");
        let e = NavTarget::from_pose("map", 1.0, 0.0, [0.0; 4]).expect_err("zero");
        assert!(e.contains("not a rotation"), "{e}");
    }

    #[test]
    fn the_odometry_pose_is_carried_into_the_map() {
        let e = PoseEstimate {
            stamp: Timestamp(0),
            x_m: 0.0,
            y_m: 0.0,
            heading_rad: 0.0,
            covariance: [0.0; 9],
            odom_x_m: 1.0,
            odom_y_m: 2.0,
            odom_heading_rad: std::f64::consts::FRAC_PI_2,
            lost: false,
        };
        let (x, y, h) = e.in_map(1.0, 0.0, 0.0);
        assert!((x - 1.0).abs() < 1e-12 && (y - 3.0).abs() < 1e-12, "{x} {y}");
        assert!((h - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn objects_round_trip() {
        let f = NavFeedback {
            stamp: Timestamp(5),
            id: 3,
            target: NavTarget::Pose { x_m: 1.0, y_m: 2.0, heading_deg: Some(90.0) },
            goal: Some([1.0, 2.0]),
            state: NavState::Aborted,
            reason: "no path".into(),
            distance_left_m: 2.5,
            eta_s: 10.0,
            path: vec![[0.0, 0.0], [1.0, 2.0]],
        };
        let json = serde_json::to_string(&f).expect("serialise");
        assert_eq!(serde_json::from_str::<NavFeedback>(&json).expect("deserialise"), f);
        let g = NavGoal { target: NavTarget::Place { name: "dock".into() } };
        let json = serde_json::to_string(&g).expect("serialise");
        assert_eq!(serde_json::from_str::<NavGoal>(&json).expect("deserialise"), g);
    }
}
