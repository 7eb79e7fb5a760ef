//! Path following: drive along a path in the map to its end, and turn to its heading there.
//!
//! The path comes from the planner (`orsa_interfaces::navigation::PATH`), the robot's pose in
//! the map from the localizer (`map -> odom`, carried forward by the robot's own odometry
//! between two estimates). The controller is pure pursuit: it steers on the arc to the point
//! `lookahead_m` further along the path than the robot's projection onto it, turns in place
//! first when that point lies more than `turn_in_place_deg` off its heading, slows down
//! towards the end, and stops within `goal_tolerance_m` of it (then turns to the path's
//! heading, if it has one). The range views it reads slow it, and stop it, in front of what
//! the map does not hold (a person crossing), and push it away from what comes close on either
//! side; whatever is left, the safety monitor under every driver catches.

use crate::ring::Ranges;
use orsa_actors::Timestamp;
use orsa_actors::param::{Invalid, Parameters};
use orsa_interfaces::navigation::{FollowPath, PoseEstimate};
use orsa_interfaces::nomad200::{NavigationVelocity, RING_SIZE};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Parameters of path following (`[params.pathfollow]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PathFollowParams {
    /// Cruise speed, m/s.
    pub v_max_m_s: f64,
    /// The fastest turn, rad/s.
    pub omega_max_rad_s: f64,
    /// How far ahead along the path it steers to, m.
    pub lookahead_m: f64,
    /// Within this distance of the path's end it stops, m.
    pub goal_tolerance_m: f64,
    /// Within this angle of the path's heading it stops turning there, degrees.
    pub heading_tolerance_deg: f64,
    /// It turns in place while the point it steers to is further off its heading, degrees.
    pub turn_in_place_deg: f64,
    /// Turn rate per radian of heading error, 1/s.
    pub k_heading: f64,
    /// Speed per metre left near the end, 1/s (it slows to reach the end without overshoot).
    pub k_approach: f64,
    /// Something this close ahead (from the sensor) stops it, m.
    pub stop_m: f64,
    /// Something closer ahead than this slows it, m.
    pub slow_m: f64,
    /// Something closer on a front side than this pushes it away, m.
    pub side_m: f64,
}

impl Default for PathFollowParams {
    fn default() -> Self {
        PathFollowParams {
            v_max_m_s: 0.45,
            omega_max_rad_s: 1.2,
            lookahead_m: 0.5,
            goal_tolerance_m: 0.08,
            heading_tolerance_deg: 5.0,
            turn_in_place_deg: 50.0,
            k_heading: 2.0,
            k_approach: 0.8,
            stop_m: 0.12,
            slow_m: 0.6,
            side_m: 0.25,
        }
    }
}

impl Parameters for PathFollowParams {
    fn validate(&self) -> Result<(), Invalid> {
        PathFollowParams::validate(self)
    }
}

impl PathFollowParams {
    /// Checks every value; messages name the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        let positive = [
            ("v_max_m_s", self.v_max_m_s, 5.0),
            ("omega_max_rad_s", self.omega_max_rad_s, 10.0),
            ("lookahead_m", self.lookahead_m, 10.0),
            ("goal_tolerance_m", self.goal_tolerance_m, 1.0),
            ("heading_tolerance_deg", self.heading_tolerance_deg, 90.0),
            ("turn_in_place_deg", self.turn_in_place_deg, 180.0),
            ("k_heading", self.k_heading, 100.0),
            ("k_approach", self.k_approach, 100.0),
            ("slow_m", self.slow_m, 10.0),
        ];
        for (key, v, max) in positive {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(Invalid::new(
                    format!("pathfollow.{key}"),
                    format!("must be above 0 and at most {max}, not {v}"),
                ));
            }
        }
        for (key, v) in [("stop_m", self.stop_m), ("side_m", self.side_m)] {
            if !(v.is_finite() && (0.0..=self.slow_m).contains(&v)) {
                return Err(Invalid::new(
                    format!("pathfollow.{key}"),
                    format!("must be from 0 to slow_m, not {v}"),
                ));
            }
        }
        Ok(())
    }
}

/// What the path follower decided at a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathStep {
    /// The command.
    pub cmd: NavigationVelocity,
    /// How far the robot is off the path, m (left positive), if it follows one.
    pub offset_m: Option<f64>,
    /// The angle to the point it steers to, rad.
    pub alpha_rad: f64,
}

/// The path follower (see the module docs).
#[derive(Debug, Clone)]
pub struct PathFollower {
    p: PathFollowParams,
    path: Vec<[f64; 2]>,
    heading_rad: Option<f64>,
    /// The segment the robot was last nearest.
    progress: usize,
    /// `map -> odom`: x, y, heading.
    map_odom: Option<(f64, f64, f64)>,
    /// The newest odometry: x, y, heading.
    odom: Option<(f64, f64, f64)>,
    arrived: bool,
    /// A turn on the spot: how much is left to turn, rad (signed), and the odometry heading
    /// it was last counted from (none until odometry comes).
    turn: Option<(f64, Option<f64>)>,
    /// Backing up: how far is left, m, and the odometry position it was last counted from.
    back: Option<(f64, Option<(f64, f64)>)>,
}

fn wrap(a: f64) -> f64 {
    a.sin().atan2(a.cos())
}

impl PathFollower {
    /// A path follower with no path.
    pub fn new(params: PathFollowParams) -> Self {
        PathFollower {
            p: params,
            path: Vec::new(),
            heading_rad: None,
            progress: 0,
            map_odom: None,
            odom: None,
            arrived: false,
            turn: None,
            back: None,
        }
    }

    /// New parameters, from the next step on.
    pub fn set_params(&mut self, params: PathFollowParams) {
        self.p = params;
    }

    /// A new path (empty: stop).
    pub fn set_path(&mut self, path: &FollowPath) {
        self.path = path.points.iter().copied().filter(|p| p[0].is_finite() && p[1].is_finite()).collect();
        self.heading_rad = path.heading_rad.filter(|h| h.is_finite());
        self.progress = 0;
        self.arrived = false;
        self.turn = path
            .turn_rad
            .filter(|t| t.is_finite() && self.path.is_empty())
            .map(|t| (t.clamp(-4.0 * PI, 4.0 * PI), self.odom.map(|o| o.2)));
        self.back = path
            .back_m
            .filter(|b| b.is_finite() && *b > 0.0 && self.path.is_empty() && self.turn.is_none())
            .map(|b| (b.min(2.0), self.odom.map(|o| (o.0, o.1))));
    }

    /// Whether it is backing up (and how far is left, m).
    pub fn backing(&self) -> Option<f64> {
        self.back.map(|(left, _)| left)
    }

    /// Whether it is turning on the spot (and how much is left, rad).
    pub fn turning(&self) -> Option<f64> {
        self.turn.map(|(left, _)| left)
    }

    /// A new estimate of the pose in the map.
    pub fn note_pose(&mut self, pose: &PoseEstimate) {
        let t = (pose.odom_x_m, pose.odom_y_m, pose.odom_heading_rad);
        if t.0.is_finite() && t.1.is_finite() && t.2.is_finite() {
            self.map_odom = Some(t);
        }
    }

    /// New odometry.
    pub fn note_odometry(&mut self, x_m: f64, y_m: f64, heading_rad: f64) {
        if x_m.is_finite() && y_m.is_finite() && heading_rad.is_finite() {
            self.odom = Some((x_m, y_m, heading_rad));
            if let Some((left, from)) = &mut self.turn {
                if let Some(from) = from {
                    // Counted towards the turn only in its own direction.
                    let turned = wrap(heading_rad - *from);
                    if turned.signum() == left.signum() {
                        let after = *left - turned;
                        *left = if after.signum() == left.signum() { after } else { 0.0 };
                    }
                }
                *from = Some(heading_rad);
            }
            if let Some((left, from)) = &mut self.back {
                if let Some((fx, fy)) = from {
                    *left = (*left - (x_m - *fx).hypot(y_m - *fy)).max(0.0);
                }
                *from = Some((x_m, y_m));
            }
        }
    }

    /// The pose in the map, if both an estimate and odometry have come.
    pub fn pose(&self) -> Option<(f64, f64, f64)> {
        let ((tx, ty, tt), (x, y, h)) = (self.map_odom?, self.odom?);
        let (s, c) = tt.sin_cos();
        Some((tx + c * x - s * y, ty + s * x + c * y, wrap(tt + h)))
    }

    /// One step on the newest range views (`near` and `far`, per sector), stamped `stamp`.
    pub fn step(&mut self, near: &Ranges, far: &Ranges, stamp: Timestamp) -> PathStep {
        let stop = PathStep {
            cmd: NavigationVelocity { stamp, v_m_s: 0.0, omega_rad_s: 0.0 },
            offset_m: None,
            alpha_rad: 0.0,
        };
        if let Some((left, _)) = self.turn {
            if left == 0.0 {
                return stop;
            }
            // Slowly, so that the range views see all round: at a third of the fastest turn,
            // slowing over the last 20 degrees.
            let w = (self.p.omega_max_rad_s / 3.0).min(0.15 + 2.0 * left.abs());
            return PathStep {
                cmd: NavigationVelocity { stamp, v_m_s: 0.0, omega_rad_s: left.signum() * w },
                offset_m: None,
                alpha_rad: left,
            };
        }
        if let Some((left, _)) = self.back {
            // Straight back, slowly, and not into what the views see behind.
            let behind = [7, 8, 9]
                .iter()
                .flat_map(|&i| [near[i % RING_SIZE], far[i % RING_SIZE]])
                .flatten()
                .fold(f64::INFINITY, f64::min);
            if left == 0.0 || behind < self.p.stop_m + 0.1 {
                return stop;
            }
            return PathStep {
                cmd: NavigationVelocity { stamp, v_m_s: -(0.05 + left).min(0.1), omega_rad_s: 0.0 },
                offset_m: None,
                alpha_rad: 0.0,
            };
        }
        let (Some((x, y, th)), Some(&end)) = (self.pose(), self.path.last()) else { return stop };
        let p = &self.p;
        let d_end = (end[0] - x).hypot(end[1] - y);
        // Arrived: within the tolerance (and, once there, within twice it, so that the
        // estimate's jitter does not start it again).
        let tol = if self.arrived { 2.0 * p.goal_tolerance_m } else { p.goal_tolerance_m };
        if d_end < tol {
            self.arrived = true;
            let Some(h) = self.heading_rad else { return stop };
            let err = wrap(h - th);
            if err.abs() < p.heading_tolerance_deg.to_radians() {
                return stop;
            }
            let w = (p.k_heading * err).clamp(-p.omega_max_rad_s, p.omega_max_rad_s);
            let w = w.signum() * w.abs().max(0.15);
            return PathStep {
                cmd: NavigationVelocity { stamp, v_m_s: 0.0, omega_rad_s: w },
                offset_m: Some(0.0),
                alpha_rad: err,
            };
        }
        self.arrived = false;
        // The robot's projection onto the path, searching forward from the last one.
        let (mut best, mut best_d, mut best_t) = (self.progress, f64::INFINITY, 0.0);
        let last = self.path.len().saturating_sub(1);
        for i in self.progress..last.min(self.progress + 200) {
            let (a, b) = (self.path[i], self.path[i + 1]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len2 = dx * dx + dy * dy;
            let t =
                if len2 > 0.0 { (((x - a[0]) * dx + (y - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let d = (a[0] + t * dx - x).hypot(a[1] + t * dy - y);
            if d < best_d {
                (best, best_d, best_t) = (i, d, t);
            }
        }
        let offset = if last == 0 {
            0.0
        } else {
            self.progress = best;
            let (a, b) = (self.path[best], self.path[best + 1]);
            let cross = (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
            cross.signum() * best_d
        };
        // The point `lookahead_m` further along.
        let mut target = end;
        if last > 0 {
            let (a, b) = (self.path[best], self.path[best + 1]);
            let mut at = [a[0] + best_t * (b[0] - a[0]), a[1] + best_t * (b[1] - a[1])];
            let mut left = p.lookahead_m;
            let mut i = best + 1;
            loop {
                let nxt = self.path[i];
                let seg = (nxt[0] - at[0]).hypot(nxt[1] - at[1]);
                if seg >= left {
                    let f = left / seg;
                    target = [at[0] + f * (nxt[0] - at[0]), at[1] + f * (nxt[1] - at[1])];
                    break;
                }
                left -= seg;
                at = nxt;
                if i == last {
                    target = end;
                    break;
                }
                i += 1;
            }
        }
        let dist = (target[0] - x).hypot(target[1] - y);
        let alpha = wrap((target[1] - y).atan2(target[0] - x) - th);
        let turn_in_place = p.turn_in_place_deg.to_radians();
        if alpha.abs() > turn_in_place {
            let w = (p.k_heading * alpha).clamp(-p.omega_max_rad_s, p.omega_max_rad_s);
            return PathStep {
                cmd: NavigationVelocity { stamp, v_m_s: 0.0, omega_rad_s: w },
                offset_m: Some(offset),
                alpha_rad: alpha,
            };
        }
        let mut v = p.v_max_m_s * (1.0 - 0.7 * alpha.abs() / turn_in_place);
        v = v.min(p.k_approach * d_end + 0.03);
        // What is ahead slows and stops it.
        let nearest = |sectors: &[usize]| {
            sectors
                .iter()
                .flat_map(|&i| [near[i % RING_SIZE], far[i % RING_SIZE]])
                .flatten()
                .fold(f64::INFINITY, f64::min)
        };
        let ahead = nearest(&[15, 0, 1]);
        if ahead < p.slow_m {
            v *= ((ahead - p.stop_m) / (p.slow_m - p.stop_m)).clamp(0.0, 1.0);
        }
        let mut w = if dist > 1e-6 { 2.0 * v * alpha.sin() / dist } else { 0.0 };
        if v < 0.05 {
            // Too slow for the arc to turn it: turn towards the point in its own right.
            w += 0.5 * p.k_heading * alpha;
        }
        // What comes close on a front side pushes it away.
        let (left, right) = (nearest(&[2, 3]), nearest(&[13, 14]));
        let push = |d: f64| if d < p.side_m { (p.side_m - d) / p.side_m } else { 0.0 };
        w += p.omega_max_rad_s * 0.5 * (push(right) - push(left));
        let w = w.clamp(-p.omega_max_rad_s, p.omega_max_rad_s);
        PathStep {
            cmd: NavigationVelocity { stamp, v_m_s: v.max(0.0), omega_rad_s: w },
            offset_m: Some(offset),
            alpha_rad: alpha,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn at(f: &mut PathFollower, x: f64, y: f64, th: f64) {
        f.note_pose(&PoseEstimate {
            stamp: Timestamp(0),
            x_m: x,
            y_m: y,
            heading_rad: th,
            covariance: [0.0; 9],
            odom_x_m: 0.0,
            odom_y_m: 0.0,
            odom_heading_rad: 0.0,
            lost: false,
        });
        f.note_odometry(x, y, th);
    }

    #[test]
    fn a_turn_on_the_spot_turns_by_odometry_alone_and_then_stops() {
        let mut f = PathFollower::new(PathFollowParams::default());
        f.note_odometry(1.0, 2.0, 3.0);
        let mut turn = path(&[], None);
        turn.turn_rad = Some(2.0 * PI);
        f.set_path(&turn);
        let none = [None; RING_SIZE];
        let mut h = 3.0;
        let mut steps = 0;
        loop {
            let s = f.step(&none, &none, Timestamp(0));
            assert_eq!(s.cmd.v_m_s, 0.0, "on the spot");
            if s.cmd.omega_rad_s == 0.0 {
                break;
            }
            assert!(s.cmd.omega_rad_s > 0.0, "counter-clockwise");
            h = wrap(h + s.cmd.omega_rad_s * 0.1);
            f.note_odometry(1.0, 2.0, h);
            steps += 1;
            assert!(steps < 1000, "it never stopped");
        }
        // A whole turn, at a third of the fastest rate or slower: no pose in the map was needed.
        assert!(f.pose().is_none());
        let turned: f64 = steps as f64 * 0.1;
        assert!(turned >= 2.0 * PI / (PathFollowParams::default().omega_max_rad_s / 3.0), "{steps} steps");
        assert!(wrap(h - 3.0).abs() < 0.1, "ends where it began, turned once: {h}");
        // A path after it is followed again.
        f.set_path(&path(&[[5.0, 5.0]], None));
        assert_eq!(f.turning(), None);
    }

    #[test]
    fn backing_up_goes_straight_back_by_odometry_and_stops_short_of_what_is_behind() {
        let mut f = PathFollower::new(PathFollowParams::default());
        f.note_odometry(0.0, 0.0, 0.0);
        f.set_path(&FollowPath::back(1, 0.3));
        let none = [None; RING_SIZE];
        let mut x = 0.0;
        let mut steps = 0;
        loop {
            let s = f.step(&none, &none, Timestamp(0));
            assert_eq!(s.cmd.omega_rad_s, 0.0, "straight");
            if s.cmd.v_m_s == 0.0 {
                break;
            }
            assert!((-0.1..0.0).contains(&s.cmd.v_m_s), "slowly backwards: {}", s.cmd.v_m_s);
            x += s.cmd.v_m_s * 0.1;
            f.note_odometry(x, 0.0, 0.0);
            steps += 1;
            assert!(steps < 1000, "it never stopped");
        }
        assert!((x + 0.3).abs() < 0.011, "backed up 0.3 m: {x}");
        // Something close behind stops it at once.
        f.set_path(&FollowPath::back(1, 0.3));
        let mut behind = [None; RING_SIZE];
        behind[8] = Some(0.15);
        assert_eq!(f.step(&behind, &none, Timestamp(0)).cmd.v_m_s, 0.0);
        assert_eq!(f.step(&none, &none, Timestamp(0)).cmd.v_m_s, -0.1);
    }

    fn path(points: &[[f64; 2]], heading_rad: Option<f64>) -> FollowPath {
        FollowPath::along(1, points.to_vec(), heading_rad)
    }

    const CLEAR: Ranges = [None; RING_SIZE];

    #[test]
    fn it_follows_a_path_to_its_end_and_turns_to_its_heading() {
        let mut f = PathFollower::new(PathFollowParams::default());
        f.set_path(&path(&[[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]], Some(PI)));
        let (mut x, mut y, mut th) = (0.0, 0.0, 0.0);
        let dt = 0.04;
        let mut worst: f64 = 0.0;
        for _ in 0..2000 {
            at(&mut f, x, y, th);
            let s = f.step(&CLEAR, &CLEAR, Timestamp(0));
            if let Some(o) = s.offset_m {
                worst = worst.max(o.abs());
            }
            th = wrap(th + s.cmd.omega_rad_s * dt);
            x += s.cmd.v_m_s * th.cos() * dt;
            y += s.cmd.v_m_s * th.sin() * dt;
        }
        assert!((x - 2.0).hypot(y - 2.0) < 0.1, "ended at {x:.3}, {y:.3}");
        assert!(wrap(th - PI).abs() < 0.1, "heading {th}");
        assert!(worst < 0.3, "strayed {worst} m off the path");
        at(&mut f, x, y, th);
        assert_eq!(f.step(&CLEAR, &CLEAR, Timestamp(0)).cmd.v_m_s, 0.0, "stopped at the end");
    }

    #[test]
    fn it_turns_in_place_to_a_path_behind_it_and_stops_for_what_is_in_front() {
        let mut f = PathFollower::new(PathFollowParams::default());
        f.set_path(&path(&[[0.0, 0.0], [-3.0, 0.0]], None));
        at(&mut f, 0.0, 0.0, 0.0);
        let s = f.step(&CLEAR, &CLEAR, Timestamp(0));
        assert_eq!(s.cmd.v_m_s, 0.0);
        assert!(s.cmd.omega_rad_s.abs() > 0.5, "{s:?}");
        at(&mut f, 0.0, 0.0, PI);
        let free = f.step(&CLEAR, &CLEAR, Timestamp(0)).cmd.v_m_s;
        assert!(free > 0.3, "{free}");
        let mut blocked = CLEAR;
        blocked[0] = Some(0.1);
        assert_eq!(f.step(&blocked, &CLEAR, Timestamp(0)).cmd.v_m_s, 0.0);
        blocked[0] = Some(0.35);
        let slow = f.step(&blocked, &CLEAR, Timestamp(0)).cmd.v_m_s;
        assert!(slow > 0.0 && slow < free, "{slow} {free}");
        // No pose, or no path: it stands still.
        let mut none = PathFollower::new(PathFollowParams::default());
        none.set_path(&path(&[[0.0, 0.0], [1.0, 0.0]], None));
        assert_eq!(none.step(&CLEAR, &CLEAR, Timestamp(0)).cmd.v_m_s, 0.0);
        f.set_path(&path(&[], None));
        assert_eq!(
            f.step(&CLEAR, &CLEAR, Timestamp(0)).cmd,
            NavigationVelocity { stamp: Timestamp(0), v_m_s: 0.0, omega_rad_s: 0.0 }
        );
    }

    #[test]
    fn bad_parameters_are_named() {
        let p = PathFollowParams { v_max_m_s: f64::NAN, ..PathFollowParams::default() };
        assert_eq!(p.validate().expect_err("nan").key, "pathfollow.v_max_m_s");
        let p = PathFollowParams { stop_m: 2.0, ..PathFollowParams::default() };
        assert_eq!(p.validate().expect_err("above slow").key, "pathfollow.stop_m");
        assert_eq!(PathFollowParams::default().validate(), Ok(()));
    }
}
