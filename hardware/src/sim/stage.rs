//! Changing the simulated world while it runs, as people do to a real robot's: a box put down
//! in a doorway and later taken away, the robot picked up and set down elsewhere (kidnapped).
//!
//! These are the world events of a fault plan (`box_placed`, `kidnap`); they never go through
//! the board traits, and a control component never holds a [`SimStage`]. Each takes effect
//! between two steps: the next step's motion, bumpers and sensor firings meet the new world.
//! Odometry is not told: a kidnapped robot's odometry goes on counting from where it was.

use super::{MoverState, SimNomad200};
use crate::geometry::{Aabb, Circle, Point};
use parking_lot::Mutex;
use std::sync::Arc;

/// Why a world event was not carried out.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StageError {
    /// A number is not finite, or a box is empty.
    #[error("{0}")]
    Invalid(String),
    /// The box would be put down on the robot or on a person.
    #[error("a box from ({x0:.2}, {y0:.2}) to ({x1:.2}, {y1:.2}) would overlap the {what}")]
    BoxOverlaps {
        /// The box's corners.
        x0: f64,
        /// .
        y0: f64,
        /// .
        x1: f64,
        /// .
        y1: f64,
        /// What it would overlap: "robot" or "person".
        what: &'static str,
    },
    /// The robot's body would not fit where it is set down.
    #[error(
        "the robot cannot be set down at ({x:.2}, {y:.2}): the nearest obstacle is {gap_m:.2} m from its centre, its radius is {radius_m:.2} m"
    )]
    NoRoom {
        /// Where.
        x: f64,
        /// .
        y: f64,
        /// The distance from there to the nearest obstacle.
        gap_m: f64,
        /// The body's radius.
        radius_m: f64,
    },
}

impl SimNomad200 {
    /// Puts down a box from `min` to `max` (world frame, m). Refused if it would overlap a
    /// mover, or the robot's body or come within its bumpers' reach: nobody puts a box on top of
    /// either.
    pub fn place_box(&mut self, min: [f64; 2], max: [f64; 2]) -> Result<(), StageError> {
        if !(min.iter().chain(&max).all(|v| v.is_finite()) && min[0] < max[0] && min[1] < max[1]) {
            return Err(StageError::Invalid(format!(
                "a box needs finite corners with min < max on both axes, not {min:?} to {max:?}"
            )));
        }
        let b = Aabb::new(Point::new(min[0], min[1]), Point::new(max[0], max[1]));
        let overlaps = |c: Circle| b.distance(&c.center) < c.radius;
        let what = if overlaps(Circle::new(self.position, self.radius + self.clearance())) {
            Some("robot")
        } else if self.movers.iter().map(MoverState::circle).any(overlaps) {
            Some("person")
        } else {
            None
        };
        if let Some(what) = what {
            return Err(StageError::BoxOverlaps { x0: min[0], y0: min[1], x1: max[0], y1: max[1], what });
        }
        self.scene.place(b);
        self.update_bumpers();
        Ok(())
    }

    /// Takes away the box put down from `min` to `max`; whether there was one.
    pub fn remove_box(&mut self, min: [f64; 2], max: [f64; 2]) -> bool {
        let b = Aabb::new(Point::new(min[0], min[1]), Point::new(max[0], max[1]));
        let removed = self.scene.unplace(&b);
        self.update_bumpers();
        removed
    }

    /// How far a world event keeps clear of the body: its motion margin, and the bumpers'
    /// contact margin (an event that presses a bumper would be a bump the robot did not make).
    fn clearance(&self) -> f64 {
        self.margin.max(self.config.bumpers.contact_margin_m)
    }

    /// The boxes put down now, as (min, max).
    pub fn placed_boxes(&self) -> Vec<([f64; 2], [f64; 2])> {
        self.scene.placed().map(|b| ([b.min.x, b.min.y], [b.max.x, b.max.y])).collect()
    }

    /// Picks the robot up and sets it down at `(x, y)` facing `heading_rad` (world frame): the
    /// whole body turns, so the steering and the turret keep their angles to the base. The
    /// motors go on as they were; odometry does not see the move. Refused where the body does
    /// not fit clear of its bumpers' reach.
    pub fn carry_to(&mut self, x: f64, y: f64, heading_rad: f64) -> Result<(), StageError> {
        if !(x.is_finite() && y.is_finite() && heading_rad.is_finite()) {
            return Err(StageError::Invalid(format!(
                "the robot is set down at finite coordinates, not ({x}, {y}) facing {heading_rad} rad"
            )));
        }
        let p = Point::new(x, y);
        self.scratch.clear();
        self.scratch.extend(self.movers.iter().map(MoverState::circle));
        let gap = self.scene.nearest(&self.scratch, &p).unwrap_or(f64::INFINITY);
        if gap < self.radius + self.clearance() {
            return Err(StageError::NoRoom { x, y, gap_m: gap, radius_m: self.radius });
        }
        let turn = heading_rad - self.steer;
        self.position = p;
        self.steer += turn;
        self.turret += turn;
        self.base_heading += turn;
        self.update_bumpers();
        Ok(())
    }
}

/// The handle a fault plan changes the simulated world through (see the module docs).
#[derive(Debug, Clone)]
pub struct SimStage {
    pub(super) sim: Arc<Mutex<SimNomad200>>,
}

impl SimStage {
    /// See [`SimNomad200::place_box`].
    pub fn place_box(&self, min: [f64; 2], max: [f64; 2]) -> Result<(), StageError> {
        self.sim.lock().place_box(min, max)
    }

    /// See [`SimNomad200::remove_box`].
    pub fn remove_box(&self, min: [f64; 2], max: [f64; 2]) -> bool {
        self.sim.lock().remove_box(min, max)
    }

    /// See [`SimNomad200::carry_to`].
    pub fn carry_to(&self, x: f64, y: f64, heading_rad: f64) -> Result<(), StageError> {
        self.sim.lock().carry_to(x, y, heading_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::AxisVelocities;
    use crate::sim::SimConfig;
    use crate::world::World;
    use std::time::Duration;

    /// The corridor without its people (one starts 1 m ahead of the robot).
    fn sim() -> SimNomad200 {
        let mut world = World::palazzina().expect("world");
        world.movers.clear();
        SimNomad200::new(world, SimConfig::default(), 3).expect("sim")
    }

    /// A box put down ahead stops the robot and its sonar sees it; taken away, the way is free.
    #[test]
    fn a_placed_box_blocks_the_way_until_it_is_taken_away() {
        let mut s = sim();
        let (x, y) = (s.truth().x_m, s.truth().y_m);
        let (min, max) = ([x + 1.0, y - 0.6], [x + 1.4, y + 0.6]);
        s.place_box(min, max).expect("room for it");
        assert_eq!(s.placed_boxes(), vec![(min, max)]);
        s.move_velocity(AxisVelocities::synchro(0.25, 0.0)).expect("drive");
        s.run_for(Duration::from_secs(8));
        let t = s.truth();
        // Stopped short of the box: its front is 1.0 m ahead, the body's radius 0.25 m.
        assert!(t.x_m < x + 0.76 && t.x_m > x + 0.6, "{t:?}");
        // The front infrared sees it just ahead.
        let front = s.infrared().valid_distance_m(0).expect("an echo ahead");
        assert!(front < 0.2, "{front}");
        assert!(s.remove_box(min, max));
        assert!(!s.remove_box(min, max), "there is only one");
        s.run_for(Duration::from_secs(2));
        assert!(s.truth().x_m > t.x_m + 0.3, "{:?}", s.truth());
    }

    #[test]
    fn a_box_is_not_put_on_the_robot_nor_empty() {
        let mut s = sim();
        let (x, y) = (s.truth().x_m, s.truth().y_m);
        let e = s.place_box([x - 0.1, y - 0.1], [x + 0.1, y + 0.1]).expect_err("on the robot");
        assert!(e.to_string().contains("overlap the robot"), "{e}");
        let e = s.place_box([x + 2.0, y], [x + 1.0, y + 1.0]).expect_err("empty");
        assert!(e.to_string().contains("min < max"), "{e}");
        assert!(s.placed_boxes().is_empty());
        // The corridor's first person starts at (3.0, 0.6).
        let mut s =
            SimNomad200::new(World::palazzina().expect("world"), SimConfig::default(), 3).expect("sim");
        let e = s.place_box([2.9, 0.5], [3.1, 0.7]).expect_err("on a person");
        assert!(e.to_string().contains("overlap the person"), "{e}");
    }

    /// Carried 10 m along the corridor and turned around: the truth is there at once, odometry
    /// is not, and the robot drives on from there.
    #[test]
    fn a_kidnapped_robot_is_where_it_was_set_down_and_its_odometry_does_not_know() {
        let mut s = sim();
        let odom = |s: &SimNomad200| {
            let m = s.motor_state();
            (m.x_m, m.y_m, m.heading_rad)
        };
        let before = odom(&s);
        let (x, y) = (s.truth().x_m + 10.0, s.truth().y_m);
        s.carry_to(x, y, std::f64::consts::PI).expect("room there");
        let t = s.truth();
        assert_eq!((t.x_m, t.y_m), (x, y));
        assert!((t.heading_rad - std::f64::consts::PI).abs() < 1e-12, "{t:?}");
        assert_eq!(odom(&s), before);
        s.move_velocity(AxisVelocities::synchro(0.25, 0.0)).expect("drive");
        s.run_for(Duration::from_secs(2));
        assert!(s.truth().x_m < x - 0.3, "{:?}", s.truth());
        // Into a wall: refused, and the robot stays.
        let here = s.truth();
        let e = s.carry_to(here.x_m, -0.1, 0.0).expect_err("inside the wall");
        assert!(e.to_string().contains("cannot be set down"), "{e}");
        assert_eq!(s.truth().x_m, here.x_m);
    }
}
