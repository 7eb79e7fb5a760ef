//! Wall following: hold a set distance from the left wall with the infrared ring.
//!
//! The controller ([`WallFollower`]) is pure: one infrared scan in, one velocity out. The wall
//! distance is the smallest reading of side sensors 1..7 (or the line fitted through the nearest
//! sensor and its neighbours, see [`crate::ring`]); the lateral error is `d - target` (positive:
//! the wall is too far, move left) and goes through the [`cascade`](crate::cascade). Speed is
//! proportional to infrared sensor 1 (front-left), capped at `v_max`, and drops to `v_slow` when
//! any of the three front sensors (15, 0, 1) reads under `slow_below`. Where the original is
//! silent about contact orsa adds one rule: anything closer than `stop_below` within 45 degrees
//! of the front (sensors 14 to 2) stops forward motion, and the robot turns in place (a
//! cylinder turning in place moves into nothing), instead of creeping into it at `v_slow`.
//!
//! It adds a second: heading into the wall at `theta = -alpha`, the robot goes no faster than
//! `omega_max (d - target) / (1 - cos theta)`, the speed at which turning parallel at the top
//! turn rate ends exactly at the set distance. The original's speed law (free space seen by
//! sensor 1) knows nothing of the heading, so a robot that meets a wall square on drove into
//! it while it turned, and ended its turn 5 to 10 cm from the wall instead of 20. Parallel to
//! the wall or heading away from it the limit is infinite; `limit_approach = false` turns it
//! off.
//!
//! And a third: the original looks only at the wall it follows, so it drove its right side into
//! a person standing 70 cm from the wall, where its 50 cm body fits only with 10 cm to spare
//! each side (following the wall alone, seed 1, then pinned there for the rest of the hour).
//! When something seen by sensors 12 to 14 (90 to 45 degrees right) is within `share_within`
//! (5 cm) of the right edge of the band the body sweeps, or in it, the robot holds half the gap
//! between it and the wall instead of `target`, and passes in the middle; `share_gaps = false`
//! turns it off. Only that close: from 20 cm it also steered the robot into door recesses,
//! where a person waiting at the mouth trapped it (EXPERIMENTS.md).
//!
//! Where the original is silent or fragile orsa does the sound thing:
//! - with no wall in infrared range on the left, the robot is told the wall is at the end of the
//!   range, so it arcs left to find it (the original read out-of-range as its maximum too);
//! - a reading of the front sensor 0 under the wall distance counts as a wall ahead (angle
//!   -90 degrees): the robot turns right, away from it, rather than ignoring what is straight in
//!   front of it.

use crate::cascade::{CascadeParams, check_positive};
use crate::manoeuvres::{Unstick, UnstickParams, Wedge};
use crate::ring::{AngleEstimator, Ranges, RingGeometry, Side, front_min, side_min, wall};
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{NavigationVelocity, RING_SIZE, ring_angle_rad};
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

/// Parameters of wall following (the `[params.wallfollow]` table of the config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WallFollowParams {
    /// Distance to hold from the wall, m.
    pub target_m: f64,
    /// Top speed, m/s.
    pub v_max_m_s: f64,
    /// Speed per m of free space seen by infrared sensor 1, 1/s.
    pub k_v: f64,
    /// Speed when something is close in front, m/s.
    pub v_slow_m_s: f64,
    /// "Close in front": a front sensor under this, m.
    pub slow_below_m: f64,
    /// Anything this close within 45 degrees of the front: turn in place, m.
    pub stop_below_m: f64,
    /// Left plus right clearance under this, with something within `open_front_m` ahead: the
    /// robot is wedged and turns in place, always the same way, until the front is open, m.
    pub tight_gap_m: f64,
    /// The front (45 degrees each side) counts as open when nothing is nearer than this, m.
    pub open_front_m: f64,
    /// Infrared range: an invalid reading means free space up to here, m.
    pub ir_range_m: f64,
    /// Baseline of the original angle formula, m.
    pub l_m: f64,
    /// How the wall angle is estimated.
    pub estimator: AngleEstimator,
    /// Heading into the wall, never go faster than turning parallel at the top turn rate
    /// allows without closing in past `target_m` (an orsa addition, see the module docs).
    pub limit_approach: bool,
    /// Something on the right within `share_within_m` of the band the body sweeps: hold half
    /// the gap between it and the wall instead of `target_m` (an orsa addition, see the module
    /// docs).
    pub share_gaps: bool,
    /// See `share_gaps`, m.
    pub share_within_m: f64,
    /// Something on the right inside the band the body sweeps going straight on: turn in place
    /// rather than drive into it (for a body that a gap beside a person can be too narrow for;
    /// the Nomad 200's 45 degree `stop_below_m` does without). Off unless set.
    #[serde(default)]
    pub stop_in_path: bool,
    /// The two loops (`[...loops]` in the config file).
    pub loops: CascadeParams,
    /// Backing out of a deadlock (`[...unstick]`).
    pub unstick: UnstickParams,
}

impl Default for WallFollowParams {
    fn default() -> Self {
        WallFollowParams {
            target_m: 0.20,
            v_max_m_s: 0.25,
            k_v: 0.6,
            v_slow_m_s: 0.07,
            slow_below_m: 0.20,
            stop_below_m: 0.08,
            tight_gap_m: 0.15,
            open_front_m: 0.30,
            ir_range_m: 0.60,
            l_m: 0.17,
            estimator: AngleEstimator::default(),
            limit_approach: true,
            share_gaps: true,
            share_within_m: 0.05,
            stop_in_path: false,
            loops: CascadeParams { k_d: 5.0, alpha_max_deg: 45.0, ..CascadeParams::default() },
            unstick: UnstickParams::default(),
        }
    }
}

impl orsa_actors::param::Parameters for WallFollowParams {
    fn validate(&self) -> Result<(), orsa_actors::param::Invalid> {
        WallFollowParams::validate(self)
    }
}

impl WallFollowParams {
    /// Checks every value; the message names the offending key.
    pub fn validate(&self) -> Result<(), orsa_actors::param::Invalid> {
        check_positive(
            "wallfollow",
            &[
                ("target_m", self.target_m),
                ("v_max_m_s", self.v_max_m_s),
                ("k_v", self.k_v),
                ("v_slow_m_s", self.v_slow_m_s),
                ("slow_below_m", self.slow_below_m),
                ("stop_below_m", self.stop_below_m),
                ("tight_gap_m", self.tight_gap_m),
                ("open_front_m", self.open_front_m),
                ("share_within_m", self.share_within_m),
                ("ir_range_m", self.ir_range_m),
                ("l_m", self.l_m),
            ],
        )?;
        if self.v_slow_m_s > self.v_max_m_s {
            return Err(orsa_actors::param::Invalid::new(
                "wallfollow.v_slow_m_s",
                format!("{} is above v_max_m_s ({})", self.v_slow_m_s, self.v_max_m_s),
            ));
        }
        self.unstick.validate("wallfollow")?;
        self.loops.validate("wallfollow")
    }
}

/// The pure wall-following controller.
#[derive(Debug, Clone)]
pub struct WallFollower {
    params: WallFollowParams,
    ring: RingGeometry,
    wedge: Wedge,
    unstick: Unstick,
}

/// What the controller saw and decided, for logs and plots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallFollowStep {
    /// The command.
    pub cmd: NavigationVelocity,
    /// Estimated distance to the wall, m (None: no wall in range).
    pub wall_m: Option<f64>,
    /// Estimated wall angle, rad.
    pub alpha_rad: f64,
}

impl WallFollower {
    /// A controller for a robot whose infrared ring is `ring`.
    pub fn new(params: WallFollowParams, ring: RingGeometry) -> Self {
        WallFollower { params, ring, wedge: Wedge::default(), unstick: Unstick::default() }
    }

    /// The sectors of the ring that no sensor of the robot covers (a laser's blind rear):
    /// getting out of a deadlock never backs into them.
    pub fn with_blind(mut self, blind: [bool; RING_SIZE]) -> Self {
        self.unstick.set_blind(blind);
        self
    }

    /// The robot's odometry: where it is at `stamp` (for getting out of deadlocks).
    pub fn note_position(&mut self, x_m: f64, y_m: f64, stamp: Timestamp) {
        self.unstick.note_position(&self.params.unstick, x_m, y_m, stamp.0);
    }

    /// The bumpers report contact at `stamp` in `direction_rad` from the direction of travel
    /// (see [`crate::manoeuvres::contact_direction`]): ahead of or beside the body, the robot
    /// backs out at once.
    pub fn note_contact(&mut self, direction_rad: f64, stamp: Timestamp) {
        self.unstick.note_contact(direction_rad, stamp.0);
    }

    /// The parameters.
    pub fn params(&self) -> &WallFollowParams {
        &self.params
    }

    /// New parameters (checked), from the next step on; what the controller has learnt of its
    /// progress and the gaps it is in is kept.
    pub fn set_params(&mut self, params: WallFollowParams) {
        self.params = params;
    }

    /// One control step on the infrared ranges of a scan stamped `stamp`; the command carries
    /// the scan's stamp, so its age says how old the data it was computed from is.
    pub fn step(&mut self, ir: &Ranges, stamp: Timestamp) -> WallFollowStep {
        let p = &self.params;
        let estimate = wall(ir, Side::Left, p.estimator, &self.ring, p.l_m);
        let (mut d, mut alpha) = match estimate {
            Some(w) => (w.distance_m, w.alpha_rad),
            None => (p.ir_range_m, 0.0),
        };
        if let Some(front) = ir[0].filter(|f| *f < d) {
            d = front;
            alpha = -FRAC_PI_2;
        }
        let shared = estimate.filter(|_| p.share_gaps).and_then(|w| {
            let right = right_of_path(ir, &self.ring).filter(|r| *r < p.share_within_m)?;
            Some(((w.distance_m + right) / 2.0).clamp(0.0, p.target_m))
        });
        let target = shared.unwrap_or(p.target_m);
        let mut omega = p.loops.omega(d - target, alpha);
        let wedged = self.wedge.step(ir, p.tight_gap_m, p.open_front_m, p.loops.omega_max_deg_s.to_radians());
        if let Some(turn) = wedged {
            omega = turn;
        }
        let front_close = [15, 0, 1].iter().any(|&i| ir[i].is_some_and(|x| x < p.slow_below_m));
        let in_path = p.stop_in_path && right_of_path(ir, &self.ring).is_some_and(|r| r < 0.0);
        let mut v = if wedged.is_some() || in_path || front_min(ir).is_some_and(|d| d < p.stop_below_m) {
            0.0
        } else if front_close {
            p.v_slow_m_s
        } else {
            ir[1].map_or(p.v_max_m_s, |d1| (p.k_v * d1).min(p.v_max_m_s))
        };
        if p.limit_approach {
            v = v.min(approach_limit(d - target, alpha, p.loops.omega_max_deg_s.to_radians()));
        }
        if let Some(cmd) = self.unstick.step(&p.unstick, ir, p.loops.omega_max_deg_s.to_radians(), stamp.0) {
            (v, omega) = cmd;
        }
        WallFollowStep {
            cmd: NavigationVelocity { stamp, v_m_s: v, omega_rad_s: omega },
            wall_m: estimate.map(|w| w.distance_m),
            alpha_rad: alpha,
        }
    }

    /// The nearest valid left reading, for diagnostics.
    pub fn nearest_left(ir: &Ranges) -> Option<(usize, f64)> {
        side_min(ir, Side::Left)
    }
}

/// How far what the right-hand sensors see beside and ahead of the body (sensors 12 to 14,
/// 90 to 45 degrees right) is from the right edge of the band the body sweeps going straight
/// on: the smallest `(R + d) sin(-phi) - R` (negative: in the way), m.
fn right_of_path(ir: &Ranges, ring: &RingGeometry) -> Option<f64> {
    (12..=14)
        .filter_map(|i| {
            let d = ir[i]?;
            Some((ring.radius_m + d) * (-ring_angle_rad(i)).sin() - ring.radius_m)
        })
        .min_by(f64::total_cmp)
}

/// The fastest the robot may go while heading into the wall at `-alpha` with `margin_m` to
/// spare before the set distance, if it turns parallel at `omega_max`: turning from `theta`
/// to 0 at rate `omega` and speed `v` closes in by `(v / omega) (1 - cos theta)`.
fn approach_limit(margin_m: f64, alpha: f64, omega_max: f64) -> f64 {
    if alpha >= 0.0 {
        return f64::INFINITY;
    }
    let closing = 1.0 - (-alpha).min(std::f64::consts::PI).cos();
    if closing <= 0.0 { f64::INFINITY } else { omega_max * margin_m.max(0.0) / closing }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ring::synthetic::corridor;

    fn ctl() -> WallFollower {
        WallFollower::new(WallFollowParams::default(), RingGeometry::uniform(0.25, 0.0))
    }

    /// The scan of a robot `left_edge_m` from the left wall (edge to wall), heading `theta`.
    fn scan(left_edge_m: f64, theta: f64) -> Ranges {
        corridor(Some(left_edge_m + 0.25), None, theta, 0.25, 0.6)
    }

    #[test]
    fn parallel_at_target_drives_straight_at_full_speed() {
        let s = ctl().step(&scan(0.20, 0.0), Timestamp(7));
        assert!(s.cmd.omega_rad_s.abs() < 1e-9);
        assert_eq!(s.cmd.v_m_s, 0.25);
        assert_eq!(s.cmd.stamp, Timestamp(7));
    }

    #[test]
    fn too_far_turns_left_too_close_turns_right_heading_in_turns_out() {
        assert!(ctl().step(&scan(0.30, 0.0), Timestamp(0)).cmd.omega_rad_s > 0.05);
        assert!(ctl().step(&scan(0.12, 0.0), Timestamp(0)).cmd.omega_rad_s < -0.05);
        assert!(ctl().step(&scan(0.20, 0.3), Timestamp(0)).cmd.omega_rad_s < -0.05);
    }

    #[test]
    fn no_wall_arcs_left_and_a_wall_ahead_turns_right() {
        let mut none = [None; 16];
        assert!(ctl().step(&none, Timestamp(0)).cmd.omega_rad_s > 0.0);
        none[0] = Some(0.15);
        let s = ctl().step(&none, Timestamp(0));
        assert!(s.cmd.omega_rad_s < 0.0);
        assert_eq!(s.cmd.v_m_s, 0.0, "inside the set distance, square on: turn in place");
        let original = WallFollowParams { limit_approach: false, ..Default::default() };
        let s = WallFollower::new(original, RingGeometry::uniform(0.25, 0.0)).step(&none, Timestamp(0));
        assert!(s.cmd.omega_rad_s < 0.0);
        assert_eq!(s.cmd.v_m_s, 0.07, "the original creeps on at v_slow");
    }

    #[test]
    fn something_in_the_way_on_the_right_moves_the_robot_toward_the_wall() {
        use crate::ring::synthetic::scene;
        let (shared, plain) = (ctl(), WallFollowParams { share_gaps: false, ..Default::default() });
        let mut plain = WallFollower::new(plain, RingGeometry::uniform(0.25, 0.0));
        // Parallel, 20 cm from the wall; a person (radius 0.25) beside the right front whose
        // edge reaches 5 cm into the band the body sweeps.
        let wall = [(FRAC_PI_2, 0.45)];
        let r = scene(&wall, &[(0.35, -0.45, 0.25)], 0.0, 0.25, 0.6, 0.0);
        assert!(right_of_path(&r, &shared.ring).is_some_and(|x| x < 0.0), "{r:?}");
        let mut shared = shared;
        let toward_wall = shared.step(&r, Timestamp(0)).cmd.omega_rad_s;
        assert!(toward_wall > 0.3, "turns left to pass in the middle of the gap: {toward_wall}");
        assert_eq!(plain.step(&r, Timestamp(0)).cmd.omega_rad_s, 0.0, "the original holds 20 cm");
        // The far side of an ordinary corridor, or a wall 10 cm right of the body's path,
        // changes nothing.
        for right in [1.95, 0.35] {
            let r = scene(&[(FRAC_PI_2, 0.45), (-FRAC_PI_2, right)], &[], 0.0, 0.25, 2.0, 0.0);
            assert_eq!(shared.step(&r, Timestamp(0)).cmd, plain.step(&r, Timestamp(0)).cmd, "{right}");
        }
        // In a passage with 12 cm to spare on the left and 4 on the right, it moves to the
        // middle, left, where the original turns right, toward the wall 4 cm away, to get 20 cm
        // from the left one.
        let r = scene(&[(FRAC_PI_2, 0.37), (-FRAC_PI_2, 0.29)], &[], 0.0, 0.25, 0.6, 0.0);
        let (s, o) =
            (shared.step(&r, Timestamp(0)).cmd.omega_rad_s, plain.step(&r, Timestamp(0)).cmd.omega_rad_s);
        assert!(s > 0.05 && o < -0.05, "shared {s}, original {o}");
    }

    #[test]
    fn something_touching_ahead_stops_forward_motion_but_not_the_turn() {
        let mut r = scan(0.20, 0.0);
        r[2] = Some(0.03);
        let s = ctl().step(&r, Timestamp(0));
        assert_eq!(s.cmd.v_m_s, 0.0);
        assert!(s.cmd.omega_rad_s < 0.0, "turns right, away from the left");
    }

    #[test]
    fn speed_follows_sensor_one_and_its_cap() {
        let mut r = scan(0.20, 0.0);
        r[1] = Some(0.3);
        assert!((ctl().step(&r, Timestamp(0)).cmd.v_m_s - 0.18).abs() < 1e-9);
        r[1] = Some(0.55);
        assert_eq!(ctl().step(&r, Timestamp(0)).cmd.v_m_s, 0.25);
    }

    /// Runs the controller on an ideal straight left wall from `edge` (m, edge to wall) and
    /// heading `theta` (into the wall positive) for `secs`; gives the closest it came and where
    /// it ended.
    fn drive(params: WallFollowParams, mut edge: f64, mut theta: f64, secs: f64) -> (f64, f64, f64) {
        let mut c = WallFollower::new(params, RingGeometry::uniform(0.25, 0.0));
        let dt = 0.04;
        let mut closest = edge;
        for _ in 0..(secs / dt) as usize {
            let cmd = c.step(&scan(edge, theta), Timestamp(0)).cmd;
            edge += -cmd.v_m_s * theta.sin() * dt;
            theta += cmd.omega_rad_s * dt;
            closest = closest.min(edge);
        }
        (closest, edge, theta)
    }

    /// Meeting a wall 0.35 m away at 60 to 90 degrees: the original speed law (free space at
    /// sensor 1) drives on while the robot turns and ends inside the set distance (down to
    /// 0.13 m square on); the approach limit turns it parallel without closing in past the
    /// target, then holds it.
    #[test]
    fn meeting_a_wall_steeply_turns_parallel_without_closing_in_past_the_target() {
        for theta_deg in [60.0f64, 80.0, 90.0] {
            let theta = theta_deg.to_radians();
            let original = WallFollowParams { limit_approach: false, ..Default::default() };
            let (closest, _, _) = drive(original, 0.35, theta, 8.0);
            assert!(closest < 0.19, "{theta_deg} deg, original speed law: closest {closest}");
            let (closest, edge, heading) = drive(WallFollowParams::default(), 0.35, theta, 15.0);
            assert!(closest > 0.199, "{theta_deg} deg, limited: closest {closest}");
            assert!((edge - 0.20).abs() < 0.001, "{theta_deg} deg: settled at {edge}");
            assert!(heading.abs() < 0.01, "{theta_deg} deg: heading {heading}");
        }
    }

    #[test]
    fn the_approach_limit_binds_only_heading_into_the_wall() {
        let w = 45f64.to_radians();
        assert_eq!(approach_limit(0.1, 0.0, w), f64::INFINITY);
        assert_eq!(approach_limit(0.1, 0.3, w), f64::INFINITY, "heading away");
        assert_eq!(approach_limit(-0.05, -0.3, w), 0.0, "inside the target: turn in place");
        // Square on with 0.2 m to spare: turning a quarter turn at 45 deg/s takes 2 s.
        assert!((approach_limit(0.2, -FRAC_PI_2, w) - 0.2 * w).abs() < 1e-12);
        assert!(approach_limit(0.2, -0.1, w) > 10.0, "nearly parallel: no limit in practice");
    }

    /// Closed loop on an ideal straight wall: from 0.35 m and 10 degrees off, the controller
    /// settles at the target within a few seconds, with both estimators.
    #[test]
    fn closed_loop_converges_to_the_target_distance() {
        for estimator in [AngleEstimator::LineFit, AngleEstimator::Original] {
            let params = WallFollowParams { estimator, ..Default::default() };
            let mut c = WallFollower::new(params, RingGeometry::uniform(0.25, 0.0));
            let (mut edge, mut theta) = (0.35f64, -10f64.to_radians());
            let dt = 0.04;
            for _ in 0..(15.0 / dt) as usize {
                let cmd = c.step(&scan(edge, theta), Timestamp(0)).cmd;
                edge += -cmd.v_m_s * theta.sin() * dt;
                theta += cmd.omega_rad_s * dt;
            }
            assert!((edge - 0.20).abs() < 0.005, "{estimator:?}: settled at {edge}");
            assert!(theta.abs() < 0.02, "{estimator:?}: heading {theta}");
        }
    }
}
