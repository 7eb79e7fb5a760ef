//! Center following: stay in the middle of a corridor, fusing sonar and infrared.
//!
//! The controller ([`CenterFollower`]) is pure: the latest infrared and sonar scans in, one
//! velocity out. Per sensor it takes infrared where infrared reads under `ir_below` and sonar
//! otherwise; the lateral error is half the difference between the nearest left (1..7) and the
//! nearest right (9..15) distance (positive: the left wall is farther, move left), and the wall
//! angle comes from the nearer side; both go through the [`cascade`](crate::cascade). Speed is
//! proportional to the nearest fused front distance (sensors 15, 0, 1), capped at `v_max`;
//! anything closer than `stop_below` within 45 degrees of the front (sensors 14 to 2) stops
//! forward motion while the robot turns, so it never drives its front into what it turns away
//! from.
//!
//! The side windows are configurable: `left_sensors`/`right_sensors` give the distances (default
//! the thesis' 1..7 and 9..15), `angle_left_sensors`/`angle_right_sensors` the wall angle
//! (default 1..5 and 11..15: a round person close behind gives only a coarse angle), taken from
//! the side whose angle window sees the nearer wall. With equal windows this is exactly the
//! thesis' single-window controller.
//!
//! The wall angle can also be held through odometry where the ring sees no flat wall (beside a
//! person, a recess), `[params.centerfollow.walls]`, on by default: see [`crate::walldir`].
//!
//! Sound handling of what the original leaves open: with only one side in range the robot keeps
//! its heading parallel to that side's wall (zero lateral error); with neither it goes straight.

use crate::cascade::{CascadeParams, check_positive};
use crate::manoeuvres::{DeadEnd, Unstick, UnstickParams, Wedge};
use crate::ring::{AngleEstimator, Ranges, RingGeometry, Side, WallEstimate, front_min, fuse, wall_in};
use crate::walldir::{WallDirParams, WallDirection};
use orsa_actors::Timestamp;
use orsa_actors::param::Invalid;
use orsa_interfaces::nomad200::{NavigationVelocity, RING_SIZE};
use serde::{Deserialize, Serialize};

/// Parameters of center following (the `[params.centerfollow]` table of the config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CenterFollowParams {
    /// Top speed, m/s.
    pub v_max_m_s: f64,
    /// Speed per m of free space in front, 1/s.
    pub k_v: f64,
    /// Slowest speed while something is in front, m/s.
    pub v_min_m_s: f64,
    /// Anything this close within 45 degrees of the front: turn in place, m.
    pub stop_below_m: f64,
    /// Left plus right clearance under this, with something within `open_front_m` ahead: the
    /// robot is wedged; it turns in place, always the same way, until the front is open, m.
    pub tight_gap_m: f64,
    /// The front (45 degrees each side) counts as open when nothing is nearer than this, m.
    pub open_front_m: f64,
    /// Turn round in place at a dead end, where the end wall is as far as the side walls
    /// (an orsa addition, see [`DeadEnd`] and EXPERIMENTS.md); `false` drives on until the
    /// master hands over.
    pub dead_end_turn: bool,
    /// A dead end counts when the wall ahead is at most this much farther than the farther
    /// side wall, m (the robot is still braking when it decides).
    pub dead_end_margin_m: f64,
    /// Sensors 15, 0 and 1 see one flat wall when their readings, projected on the heading,
    /// agree within this, m.
    pub dead_end_flat_m: f64,
    /// Infrared is trusted under this distance, sonar beyond, m.
    pub ir_below_m: f64,
    /// Baseline of the original angle formula, m.
    pub l_m: f64,
    /// How the wall angle is estimated.
    pub estimator: AngleEstimator,
    /// The left sensors whose nearest reading is the left wall, first and last (the thesis:
    /// 1 to 7).
    pub left_sensors: [usize; 2],
    /// The right sensors, first and last (the thesis: 9 to 15).
    pub right_sensors: [usize; 2],
    /// The left sensors the wall angle is taken from, first and last (by default the same as
    /// `left_sensors`). Widening `left_sensors` backwards (to the thesis' 1 to 7) lets the
    /// distance see a person following close behind, but the angle must not come from there:
    /// the nearest reading on a round person behind gives only the coarse `pi/8 (m - c)`,
    /// 45 to 67 degrees off, and the robot weaves (EXPERIMENTS.md).
    pub angle_left_sensors: [usize; 2],
    /// The right sensors the wall angle is taken from, first and last (see
    /// `angle_left_sensors`).
    pub angle_right_sensors: [usize; 2],
    /// The two loops (`[...loops]` in the config file).
    pub loops: CascadeParams,
    /// Backing out of a deadlock (`[...unstick]`).
    pub unstick: UnstickParams,
    /// Holding the walls' direction through odometry (`[...walls]`).
    pub walls: WallDirParams,
}

impl Default for CenterFollowParams {
    fn default() -> Self {
        CenterFollowParams {
            v_max_m_s: 0.25,
            k_v: 0.5,
            v_min_m_s: 0.07,
            stop_below_m: 0.08,
            tight_gap_m: 0.15,
            open_front_m: 0.30,
            dead_end_turn: true,
            dead_end_margin_m: 0.05,
            dead_end_flat_m: 0.10,
            ir_below_m: 0.70,
            l_m: 0.17,
            estimator: AngleEstimator::default(),
            left_sensors: [1, 7],
            right_sensors: [9, 15],
            angle_left_sensors: [1, 5],
            angle_right_sensors: [11, 15],
            loops: CascadeParams { k_d: 7.0, k_alpha: -2.0, alpha_max_deg: 45.0, omega_max_deg_s: 45.0 },
            unstick: UnstickParams::default(),
            walls: WallDirParams::default(),
        }
    }
}

impl orsa_actors::param::Parameters for CenterFollowParams {
    fn validate(&self) -> Result<(), Invalid> {
        CenterFollowParams::validate(self)
    }
}

impl CenterFollowParams {
    /// Checks every value; the message names the offending key.
    pub fn validate(&self) -> Result<(), Invalid> {
        check_positive(
            "centerfollow",
            &[
                ("v_max_m_s", self.v_max_m_s),
                ("k_v", self.k_v),
                ("v_min_m_s", self.v_min_m_s),
                ("stop_below_m", self.stop_below_m),
                ("tight_gap_m", self.tight_gap_m),
                ("open_front_m", self.open_front_m),
                ("dead_end_margin_m", self.dead_end_margin_m),
                ("dead_end_flat_m", self.dead_end_flat_m),
                ("ir_below_m", self.ir_below_m),
                ("l_m", self.l_m),
            ],
        )?;
        if self.v_min_m_s > self.v_max_m_s {
            return Err(Invalid::new(
                "centerfollow.v_min_m_s",
                format!("{} is above v_max_m_s ({})", self.v_min_m_s, self.v_max_m_s),
            ));
        }
        for (key, [a, b]) in
            [("left_sensors", self.left_sensors), ("angle_left_sensors", self.angle_left_sensors)]
        {
            if !(1..=7).contains(&a) || !(a..=7).contains(&b) {
                return Err(Invalid::new(
                    format!("centerfollow.{key}"),
                    format!("[{a}, {b}] must be first and last of 1..7"),
                ));
            }
        }
        for (key, [a, b]) in
            [("right_sensors", self.right_sensors), ("angle_right_sensors", self.angle_right_sensors)]
        {
            if !(9..=15).contains(&a) || !(a..=15).contains(&b) {
                return Err(Invalid::new(
                    format!("centerfollow.{key}"),
                    format!("[{a}, {b}] must be first and last of 9..15"),
                ));
            }
        }
        self.unstick.validate("centerfollow")?;
        self.walls.validate("centerfollow")?;
        self.loops.validate("centerfollow")
    }
}

/// The pure center-following controller.
#[derive(Debug, Clone)]
pub struct CenterFollower {
    params: CenterFollowParams,
    /// Getting out of gaps barely wider than the body.
    wedge: Wedge,
    /// Turning round at the end of a corridor.
    dead_end: DeadEnd,
    /// Backing out of a deadlock.
    unstick: Unstick,
    /// The walls' direction, held through odometry.
    walls: WallDirection,
    radius_m: f64,
    ir_half_beam_rad: f64,
    sonar_half_beam_rad: f64,
}

/// What the controller saw and decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CenterFollowStep {
    /// The command.
    pub cmd: NavigationVelocity,
    /// Estimated offset from the centre, m, positive to the left of it (None: not both sides).
    pub offset_m: Option<f64>,
    /// The wall angle used, rad.
    pub alpha_rad: f64,
}

impl CenterFollower {
    /// A controller for a robot whose sensors sit at `radius_m` from its centre, with
    /// infrared and sonar beams of these widths.
    pub fn new(params: CenterFollowParams, radius_m: f64, ir_beam_rad: f64, sonar_beam_rad: f64) -> Self {
        CenterFollower {
            wedge: Wedge::default(),
            dead_end: DeadEnd::default(),
            unstick: Unstick::default(),
            walls: WallDirection::default(),
            params,
            radius_m,
            ir_half_beam_rad: ir_beam_rad / 2.0,
            sonar_half_beam_rad: sonar_beam_rad / 2.0,
        }
    }

    /// The robot's odometry at `stamp`: where it is (for getting out of deadlocks), where it
    /// The sectors that neither view covers (a laser's blind rear): getting out of a
    /// deadlock never backs into them.
    pub fn with_blind(mut self, blind: [bool; RING_SIZE]) -> Self {
        self.unstick.set_blind(blind);
        self
    }

    /// heads and how fast it turns (for holding the walls' direction).
    pub fn note_odometry(
        &mut self,
        x_m: f64,
        y_m: f64,
        heading_rad: f64,
        omega_rad_s: f64,
        stamp: Timestamp,
    ) {
        self.unstick.note_position(&self.params.unstick, x_m, y_m, stamp.0);
        self.walls.note_heading(heading_rad, omega_rad_s, stamp.0);
    }

    /// The bumpers report contact at `stamp` in `direction_rad` from the direction of travel
    /// (see [`crate::manoeuvres::contact_direction`]): ahead of or beside the body, the robot
    /// backs out at once.
    pub fn note_contact(&mut self, direction_rad: f64, stamp: Timestamp) {
        self.unstick.note_contact(direction_rad, stamp.0);
    }

    /// The parameters.
    pub fn params(&self) -> &CenterFollowParams {
        &self.params
    }

    /// New parameters (checked), from the next step on; the walls' direction and what the
    /// controller has learnt of its progress are kept.
    pub fn set_params(&mut self, params: CenterFollowParams) {
        self.params = params;
    }

    /// One control step on the latest infrared and sonar ranges; the command carries `stamp`
    /// (the component passes the older of the two scans' stamps: the command is as old as the
    /// oldest data it used).
    pub fn step(&mut self, ir: &Ranges, sonar: &Ranges, stamp: Timestamp) -> CenterFollowStep {
        let p = &self.params;
        let (r, half_beam_rad) =
            fuse(ir, sonar, p.ir_below_m, self.ir_half_beam_rad, self.sonar_half_beam_rad);
        let ring = RingGeometry { radius_m: self.radius_m, half_beam_rad };
        let [l0, l1] = p.left_sensors;
        let [r0, r1] = p.right_sensors;
        let left = wall_in(&r, Side::Left, l0..=l1, p.estimator, &ring, p.l_m).map(WallEstimate::as_line);
        let right = wall_in(&r, Side::Right, r0..=r1, p.estimator, &ring, p.l_m).map(WallEstimate::as_line);
        let [a0, a1] = p.angle_left_sensors;
        let [b0, b1] = p.angle_right_sensors;
        let angle_left =
            wall_in(&r, Side::Left, a0..=a1, p.estimator, &ring, p.l_m).map(WallEstimate::as_line);
        let angle_right =
            wall_in(&r, Side::Right, b0..=b1, p.estimator, &ring, p.l_m).map(WallEstimate::as_line);
        // The angle the ring alone gives (the nearer side's), and its flat walls nearest first.
        let (near, far) = match (angle_left, angle_right) {
            (Some(l), Some(rt)) if rt.distance_m < l.distance_m => (Some(rt), Some(l)),
            (l, rt) => (l.or(rt), l.and(rt)),
        };
        let mut fits = [0.0; 2];
        let mut n = 0;
        for w in [near, far].into_iter().flatten().filter(|w| w.fitted) {
            fits[n] = w.alpha_rad;
            n += 1;
        }
        let angle = self.walls.alpha(
            &p.walls,
            &fits[..n],
            near.map(|w| w.alpha_rad),
            near.map(|w| w.distance_m),
            stamp.0,
        );
        let (error_left, alpha, offset) = match (left, right) {
            (Some(l), Some(rt)) => {
                let e = (l.distance_m - rt.distance_m) / 2.0;
                let nearer = if l.distance_m <= rt.distance_m { l.alpha_rad } else { rt.alpha_rad };
                let alpha = angle.unwrap_or(nearer);
                // Left wall farther (e > 0): the robot is right of the centre.
                (e, alpha, Some(-e))
            }
            (Some(w), None) | (None, Some(w)) => (0.0, angle.unwrap_or(w.alpha_rad), None),
            (None, None) => (0.0, angle.unwrap_or(0.0), None),
        };
        let mut omega = p.loops.omega(error_left, alpha);
        let wmax = p.loops.omega_max_deg_s.to_radians();
        let mut wedged = self.wedge.step(&r, p.tight_gap_m, p.open_front_m, wmax);
        if p.dead_end_turn {
            let turning = self.dead_end.step(&r, &ring, angle, p.dead_end_margin_m, p.dead_end_flat_m, wmax);
            wedged = wedged.or(turning);
        }
        if let Some(turn) = wedged {
            omega = turn;
        }
        let front = [15, 0, 1].iter().filter_map(|&i| r[i]).fold(f64::INFINITY, f64::min);
        let mut v = if wedged.is_some() || front_min(&r).is_some_and(|d| d < p.stop_below_m) {
            0.0
        } else if front.is_finite() {
            (p.k_v * front).clamp(p.v_min_m_s, p.v_max_m_s)
        } else {
            p.v_max_m_s
        };
        if let Some(cmd) = self.unstick.step(&p.unstick, &r, wmax, stamp.0) {
            (v, omega) = cmd;
        }
        CenterFollowStep {
            cmd: NavigationVelocity { stamp, v_m_s: v, omega_rad_s: omega },
            offset_m: offset,
            alpha_rad: alpha,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ring::synthetic::corridor;
    use std::f64::consts::PI;

    /// Infrared (0.6 m) and sonar (0.3..6 m) views of a corridor `width` wide, robot `y` above
    /// its centre (positive: nearer the left wall when heading along +x), heading `theta`.
    fn views(width: f64, y: f64, theta: f64) -> (Ranges, Ranges) {
        let (l, r) = (width / 2.0 - y, width / 2.0 + y);
        let ir = corridor(Some(l), Some(r), theta, 0.25, 0.6);
        let mut so = corridor(Some(l), Some(r), theta, 0.25, 6.0);
        for d in so.iter_mut() {
            *d = d.filter(|d| *d >= 0.3);
        }
        (ir, so)
    }

    #[test]
    fn centred_and_parallel_goes_straight() {
        let (ir, so) = views(2.4, 0.0, 0.0);
        let s =
            CenterFollower::new(CenterFollowParams::default(), 0.25, 0.0, 0.0).step(&ir, &so, Timestamp(3));
        assert!(s.cmd.omega_rad_s.abs() < 1e-9 && s.offset_m.is_some_and(|o| o.abs() < 1e-9));
        assert_eq!(s.cmd.v_m_s, 0.25);
    }

    #[test]
    fn off_centre_turns_back_toward_the_middle() {
        let mut c = CenterFollower::new(CenterFollowParams::default(), 0.25, 0.0, 0.0);
        let (ir, so) = views(2.4, 0.3, 0.0);
        assert!(c.step(&ir, &so, Timestamp(0)).cmd.omega_rad_s < -0.05, "left of centre: turn right");
        let (ir, so) = views(2.4, -0.3, 0.0);
        assert!(c.step(&ir, &so, Timestamp(0)).cmd.omega_rad_s > 0.05, "right of centre: turn left");
    }

    #[test]
    fn offset_is_positive_left_of_the_centre_and_speeds_are_checked() {
        let (ir, so) = views(2.4, 0.3, 0.0);
        let s =
            CenterFollower::new(CenterFollowParams::default(), 0.25, 0.0, 0.0).step(&ir, &so, Timestamp(0));
        assert!((s.offset_m.expect("both sides") - 0.3).abs() < 0.01, "{:?}", s.offset_m);
        let bad = CenterFollowParams { v_min_m_s: 0.3, ..Default::default() };
        assert!(
            bad.validate().expect_err("v_min above v_max").to_string().starts_with("centerfollow.v_min_m_s")
        );
    }

    #[test]
    fn a_person_close_behind_moves_the_distance_but_not_the_angle() {
        // Centred and parallel; someone 0.5 m away behind-left, seen by sensor 7 only.
        let (mut ir, mut so) = views(2.4, 0.0, 0.0);
        ir[7] = Some(0.5);
        so[7] = Some(0.5);
        let wide = CenterFollowParams::default();
        assert_eq!((wide.left_sensors, wide.angle_left_sensors), ([1, 7], [1, 5]), "the defaults");
        assert!(wide.validate().is_ok());
        let s = CenterFollower::new(wide, 0.25, 0.0, 0.0).step(&ir, &so, Timestamp(0));
        assert!(s.offset_m.is_some_and(|o| o > 0.2), "the person counts on the left: {:?}", s.offset_m);
        assert!(s.alpha_rad.abs() < 1e-9, "the angle still comes from the walls: {}", s.alpha_rad);
        assert!(s.cmd.omega_rad_s < -0.05, "moves right, away from the person");
        // The angle from the same wide window is the coarse guess of sensor 7, far from 0.
        let same = CenterFollowParams { angle_left_sensors: [1, 7], angle_right_sensors: [9, 15], ..wide };
        let s = CenterFollower::new(same, 0.25, 0.0, 0.0).step(&ir, &so, Timestamp(0));
        assert!(s.alpha_rad > 0.5, "coarse angle of sensor 7: {}", s.alpha_rad);
        // Narrow windows (1-5 and 11-15 for both): the person behind is not seen.
        let narrow = CenterFollowParams { left_sensors: [1, 5], right_sensors: [11, 15], ..wide };
        let s = CenterFollower::new(narrow, 0.25, 0.0, 0.0).step(&ir, &so, Timestamp(0));
        assert!(s.offset_m.is_some_and(|o| o.abs() < 1e-9) && s.cmd.omega_rad_s.abs() < 1e-9);
        let bad = CenterFollowParams { angle_right_sensors: [8, 15], ..Default::default() };
        assert!(
            bad.validate()
                .expect_err("8 is the back")
                .to_string()
                .starts_with("centerfollow.angle_right_sensors")
        );
    }

    #[test]
    fn beside_a_person_the_held_wall_direction_steers() {
        // Heading 30 degrees left of the corridor, a person 0.6 m away at the left (sensor 3
        // only): the ring's nearer side is the person, with the coarse angle of sensor 3.
        let theta = 30f64.to_radians();
        let (mut ir, mut so) = views(2.4, 0.0, theta);
        ir[3] = None;
        so[3] = Some(0.6);
        assert!(CenterFollowParams::default().walls.enabled, "on by default");
        let mut c = CenterFollower::new(CenterFollowParams::default(), 0.25, 0.0, 0.0);
        // Odometry says the robot heads 1.0 rad; a moment earlier it saw the walls flat.
        c.note_odometry(0.0, 0.0, 1.0, 0.0, Timestamp(0));
        let (ir0, so0) = views(2.4, 0.0, theta);
        assert!((c.step(&ir0, &so0, Timestamp(0)).alpha_rad + theta).abs() < 0.02, "walls fitted");
        let s = c.step(&ir, &so, Timestamp(40_000_000));
        assert!((s.alpha_rad + theta).abs() < 0.02, "held: {}", s.alpha_rad.to_degrees());
        // Without the held direction the ring's coarse angle of the person is used.
        let walls = WallDirParams { enabled: false, ..Default::default() };
        let mut plain =
            CenterFollower::new(CenterFollowParams { walls, ..Default::default() }, 0.25, 0.0, 0.0);
        plain.note_odometry(0.0, 0.0, 1.0, 0.0, Timestamp(0));
        let s = plain.step(&ir, &so, Timestamp(40_000_000));
        assert!((s.alpha_rad + PI / 8.0).abs() < 1e-9, "coarse pi/8 (3 - 4): {}", s.alpha_rad.to_degrees());
    }

    #[test]
    fn closed_loop_settles_on_the_centre_line() {
        let mut c = CenterFollower::new(CenterFollowParams::default(), 0.25, 0.0, 0.0);
        let (mut y, mut theta) = (0.5f64, 0.2f64);
        let dt = 0.064;
        for _ in 0..(30.0 / dt) as usize {
            let (ir, so) = views(2.4, y, theta);
            let cmd = c.step(&ir, &so, Timestamp(0)).cmd;
            y += cmd.v_m_s * theta.sin() * dt;
            theta += cmd.omega_rad_s * dt;
        }
        assert!(y.abs() < 0.01, "settled {y} m off centre");
    }
}
