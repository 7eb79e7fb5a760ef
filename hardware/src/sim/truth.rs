//! Ground truth, for metrics: where the robot really is, how it really moves, what it touches
//! and how much room it has. None of this reaches behaviours; they only get the boards.

use super::SimNomad200;
use super::movers::{MoverState, MoverTruth};
use super::odometry::wrap_angle;
use super::scene::MAX_RAYS;
use crate::geometry::{Ray, unit_at};
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{PushPeriods, RobotParams};
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

/// The robot's true state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Simulated time.
    pub stamp: Timestamp,
    /// Body centre x in the world, m.
    pub x_m: f64,
    /// Body centre y in the world, m.
    pub y_m: f64,
    /// Heading (where the wheels point, the direction of travel), rad in (-pi, pi].
    pub heading_rad: f64,
    /// Turret front (where sensor 0 faces), rad in (-pi, pi].
    pub turret_rad: f64,
    /// The base's fixed orientation (the bumpers' zero), rad.
    pub base_heading_rad: f64,
    /// The body's translation velocity at the end of the last step, m/s: the motor's, or 0
    /// if contact cut the step short.
    pub v_m_s: f64,
    /// Steering rate at the end of the last step, rad/s.
    pub omega_rad_s: f64,
    /// Turret rate at the end of the last step, rad/s.
    pub turret_omega_rad_s: f64,
    /// Whether the last step's translation was cut short by contact.
    pub translation_blocked: bool,
    /// Whether any bumper is pressed.
    pub in_contact: bool,
    /// How many times contact began (bumps).
    pub contact_onsets: u64,
    /// Distance actually travelled since the start, m.
    pub travelled_m: f64,
}

/// A side of the robot, relative to its heading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Side {
    /// +90 degrees from the heading.
    Left,
    /// -90 degrees from the heading.
    Right,
}

impl SimNomad200 {
    /// The robot's true state now.
    pub fn truth(&self) -> Truth {
        Truth {
            stamp: self.time(),
            x_m: self.position.x,
            y_m: self.position.y,
            heading_rad: wrap_angle(self.steer),
            turret_rad: wrap_angle(self.turret),
            base_heading_rad: self.base_heading,
            v_m_s: self.v_true,
            omega_rad_s: self.steer_rate,
            turret_omega_rad_s: self.turret_rate,
            translation_blocked: self.blocked,
            in_contact: self.bumpers.in_contact(),
            contact_onsets: self.bumpers.onsets(),
            travelled_m: self.travelled_m,
        }
    }

    /// The free distance from the body's edge to the first obstacle (movers included) straight
    /// out to `side`, perpendicular to the heading; `None` if nothing is there at all.
    pub fn truth_side_clearance(&self, side: Side) -> Option<f64> {
        let angle = self.steer + if side == Side::Left { FRAC_PI_2 } else { -FRAC_PI_2 };
        let edge = self.position + unit_at(angle).into_inner() * self.radius;
        let movers: Vec<_> = self.movers.iter().map(MoverState::circle).collect();
        self.scene.ray_cast(&movers, &Ray::at_angle(edge, angle), f64::INFINITY)
    }

    /// The gap between the body's edge and the nearest obstacle (movers included) on `side`:
    /// the half-plane left (or right) of the heading. This is the thesis' clearance to the
    /// followed wall: unlike [`truth_side_clearance`](Self::truth_side_clearance) it does not
    /// grow when the robot is angled to the wall. Rays every degree from the centre across the
    /// half-plane; `None` if nothing is there.
    pub fn truth_side_nearest(&self, side: Side) -> Option<f64> {
        let sign = if side == Side::Left { 1.0 } else { -1.0 };
        let movers: Vec<_> = self.movers.iter().map(MoverState::circle).collect();
        let offsets: [f64; 179] = std::array::from_fn(|k| sign * f64::from(k as u32 + 1).to_radians());
        // Cast as fans of at most MAX_RAYS rays, each looking only as far as the nearest hit so
        // far: shapes beyond it cannot lower the minimum, and the scene skips them by their
        // bounds (and shapes wholly outside a fan by its edges).
        let mut nearest: Option<f64> = None;
        for fan in offsets.chunks(MAX_RAYS) {
            let reach = nearest.unwrap_or(f64::INFINITY);
            if let Some(d) = self.scene.ray_fan(&movers, self.position, self.steer, fan, reach) {
                nearest = Some(nearest.map_or(d, |n| n.min(d)));
            }
        }
        nearest.map(|d| d - self.radius)
    }

    /// The gap between the body's edge and the nearest obstacle (movers included), in any
    /// direction; `None` in an empty world.
    pub fn truth_nearest_obstacle(&self) -> Option<f64> {
        let movers: Vec<_> = self.movers.iter().map(MoverState::circle).collect();
        self.scene.nearest(&movers, &self.position).map(|d| d - self.radius)
    }

    /// Where every mover is.
    pub fn truth_movers(&self) -> Vec<MoverTruth> {
        self.movers.iter().map(MoverState::truth).collect()
    }

    /// The robot as behaviours should know it, with the component's push periods.
    pub fn robot_params(&self, push: PushPeriods) -> RobotParams {
        self.config.robot_params(push)
    }
}
