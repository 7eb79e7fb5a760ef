//! The two built-in behaviours as components: wall following and center following, each its
//! controller inside the one behaviour harness ([`crate::harness::Behaviour`]), which gives it
//! its states, its live `param` service, the robot's geometry, its inputs, odometry and contact,
//! its wireable `vel` port and its `status`.

use crate::centerfollow::{CenterFollowParams, CenterFollower};
use crate::harness::{Behaviour, BehaviourMsg, Controller, Scan, Seen, Step};
use crate::pathfollow::{PathFollowParams, PathFollower};
use crate::ring::RingGeometry;
use crate::wallfollow::{WallFollowParams, WallFollower};
use orsa_actors::Timestamp;
use orsa_interfaces::navigation::{FollowPath, PoseEstimate};
use orsa_interfaces::nomad200::{BaseState, RING_SIZE, RingParams, RobotParams};

/// Wall following as a component (`wallfollow` in the default configuration).
pub type WallFollow = Behaviour<WallFollower>;
/// Messages of [`WallFollow`].
pub type WallFollowMsg = BehaviourMsg;
/// Center following as a component (`centerfollow` in the default configuration).
pub type CenterFollow = Behaviour<CenterFollower>;
/// Messages of [`CenterFollow`].
pub type CenterFollowMsg = BehaviourMsg;
/// Path following as a component (`pathfollow` in the default configuration).
pub type PathFollow = Behaviour<PathFollower>;

/// The sectors none of `views` covers, given the robot's range sensors.
pub fn blind_sectors(robot: &RobotParams, views: &[&RingParams]) -> [bool; RING_SIZE] {
    let mut blind = [true; RING_SIZE];
    for view in views {
        let covered = orsa_interfaces::range::sector_coverage(&robot.range_sensors, view);
        for (b, c) in blind.iter_mut().zip(covered) {
            *b &= !c;
        }
    }
    blind
}

impl Controller for WallFollower {
    type Params = WallFollowParams;
    const READS: &'static [Scan] = &[Scan::Infrared];

    fn speeds(p: &WallFollowParams) -> Vec<(&'static str, f64)> {
        vec![("v_max_m_s", p.v_max_m_s), ("v_slow_m_s", p.v_slow_m_s)]
    }

    fn new(params: WallFollowParams, robot: &RobotParams) -> Self {
        let ring = RingGeometry::uniform(robot.infrared.mount_radius_m, robot.infrared.beam_width_rad);
        WallFollower::new(params, ring).with_blind(blind_sectors(robot, &[&robot.infrared]))
    }

    fn set_params(&mut self, params: WallFollowParams) {
        WallFollower::set_params(self, params);
    }

    fn note_odometry(&mut self, b: &BaseState) {
        self.note_position(b.x_m, b.y_m, b.stamp);
    }

    fn note_contact(&mut self, direction_rad: f64, stamp: Timestamp) {
        WallFollower::note_contact(self, direction_rad, stamp);
    }

    fn step(&mut self, seen: &Seen<'_>) -> Step {
        let s = WallFollower::step(self, seen.infrared, seen.stamp);
        Step { cmd: s.cmd, wall_m: s.wall_m, offset_m: None, alpha_rad: s.alpha_rad }
    }
}

impl Controller for CenterFollower {
    type Params = CenterFollowParams;
    const READS: &'static [Scan] = &[Scan::Infrared, Scan::Sonar];

    fn speeds(p: &CenterFollowParams) -> Vec<(&'static str, f64)> {
        vec![("v_max_m_s", p.v_max_m_s), ("v_min_m_s", p.v_min_m_s)]
    }

    fn new(params: CenterFollowParams, robot: &RobotParams) -> Self {
        CenterFollower::new(
            params,
            robot.infrared.mount_radius_m,
            robot.infrared.beam_width_rad,
            robot.sonar.beam_width_rad,
        )
        .with_blind(blind_sectors(robot, &[&robot.infrared, &robot.sonar]))
    }

    fn set_params(&mut self, params: CenterFollowParams) {
        CenterFollower::set_params(self, params);
    }

    fn note_odometry(&mut self, b: &BaseState) {
        CenterFollower::note_odometry(self, b.x_m, b.y_m, b.heading_rad, b.omega_rad_s, b.stamp);
    }

    fn note_contact(&mut self, direction_rad: f64, stamp: Timestamp) {
        CenterFollower::note_contact(self, direction_rad, stamp);
    }

    fn step(&mut self, seen: &Seen<'_>) -> Step {
        let s = CenterFollower::step(self, seen.infrared, seen.sonar, seen.stamp);
        Step { cmd: s.cmd, wall_m: None, offset_m: s.offset_m, alpha_rad: s.alpha_rad }
    }
}

impl Controller for PathFollower {
    type Params = PathFollowParams;
    const READS: &'static [Scan] = &[Scan::Infrared, Scan::Sonar];
    const NAVIGATES: bool = true;

    fn speeds(p: &PathFollowParams) -> Vec<(&'static str, f64)> {
        vec![("v_max_m_s", p.v_max_m_s)]
    }

    fn new(params: PathFollowParams, _robot: &RobotParams) -> Self {
        PathFollower::new(params)
    }

    fn set_params(&mut self, params: PathFollowParams) {
        PathFollower::set_params(self, params);
    }

    fn note_odometry(&mut self, b: &BaseState) {
        PathFollower::note_odometry(self, b.x_m, b.y_m, b.heading_rad);
    }

    fn note_pose(&mut self, pose: &PoseEstimate) {
        PathFollower::note_pose(self, pose);
    }

    fn note_path(&mut self, path: &FollowPath) {
        self.set_path(path);
    }

    fn step(&mut self, seen: &Seen<'_>) -> Step {
        let s = PathFollower::step(self, seen.infrared, seen.sonar, seen.stamp);
        Step { cmd: s.cmd, wall_m: None, offset_m: s.offset_m, alpha_rad: s.alpha_rad }
    }
}
