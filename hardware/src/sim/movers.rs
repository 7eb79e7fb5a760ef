//! People: round obstacles walking their paths forth and back for ever.
//!
//! A mover stands at the start of its path until its start delay has passed, then walks at its
//! speed, turning back at each end. It pauses while the gap between its edge and the robot's
//! edge is below its yield distance, and it never steps into the robot: a step that would bring
//! it closer than a hair to the robot is not taken. So any contact is the robot's doing. A mover
//! with a patience gives up waiting after that long, as people do: it turns back the way it came
//! and walks away from the robot (a step that would not take it away is not taken while the
//! robot is that close), and walks its path as before once it is clear of the robot.
//! Movers ignore walls, obstacles and each other; a world's author keeps their paths clear.

use crate::geometry::{self, Circle, Point, Shape};
use crate::world::Mover;
use serde::{Deserialize, Serialize};

/// Where a mover is, for metrics and views.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MoverTruth {
    /// Centre x, m.
    pub x_m: f64,
    /// Centre y, m.
    pub y_m: f64,
    /// Radius, m.
    pub radius_m: f64,
    /// Whether it paused for the robot in the last step.
    pub yielding: bool,
}

/// A mover walking its path.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MoverState {
    radius: f64,
    speed: f64,
    yield_distance: f64,
    start_delay_ns: u64,
    /// How long it waits for the robot before it turns back; `None`: for ever.
    patience_ns: Option<u64>,
    /// How long it has been within its yield distance of the robot.
    waited_ns: u64,
    /// Whether it has turned back since it came within its yield distance.
    turned_back: bool,
    path: Vec<Point>,
    /// Arc length at each path point, from 0 to `length`.
    at: Vec<f64>,
    length: f64,
    /// Arc length where it is now.
    s: f64,
    forward: bool,
    position: Point,
    yielding: bool,
}

impl MoverState {
    pub(crate) fn new(m: &Mover) -> Self {
        let path = m.path_points();
        let mut at = Vec::with_capacity(path.len());
        let mut sum = 0.0;
        for (i, p) in path.iter().enumerate() {
            if i > 0 {
                sum += (p - path[i - 1]).norm();
            }
            at.push(sum);
        }
        let position = path.first().copied().unwrap_or_else(Point::origin);
        MoverState {
            radius: m.radius,
            speed: m.speed,
            yield_distance: m.yield_distance,
            start_delay_ns: super::config::nanos(m.start_delay),
            patience_ns: m.patience.map(super::config::nanos),
            waited_ns: 0,
            turned_back: false,
            path,
            at,
            length: sum,
            s: 0.0,
            forward: true,
            position,
            yielding: false,
        }
    }

    pub(crate) fn position(&self) -> Point {
        self.position
    }

    pub(crate) fn circle(&self) -> Circle {
        Circle::new(self.position, self.radius)
    }

    pub(crate) fn truth(&self) -> MoverTruth {
        MoverTruth {
            x_m: self.position.x,
            y_m: self.position.y,
            radius_m: self.radius,
            yielding: self.yielding,
        }
    }

    /// The point at arc length `s` (0..=length).
    fn point_at(&self, s: f64) -> Point {
        if self.path.len() < 2 {
            return self.position; // not a valid world; such a mover stands
        }
        let i = self.at.partition_point(|&a| a <= s).clamp(1, self.path.len() - 1);
        let (a, b) = (self.path[i - 1], self.path[i]);
        let seg = self.at[i] - self.at[i - 1];
        if seg <= 0.0 { b } else { a + (b - a) * ((s - self.at[i - 1]) / seg) }
    }

    /// Where walking `distance` from `s` in direction `forward` ends, turning back at the ends.
    fn walk(&self, mut s: f64, mut forward: bool, distance: f64) -> (f64, bool) {
        if self.length <= 0.0 {
            return (0.0, forward);
        }
        // Whole round trips change nothing.
        let mut left = distance % (2.0 * self.length);
        while left > 0.0 {
            let room = if forward { self.length - s } else { s };
            if left < room {
                s += if forward { left } else { -left };
                left = 0.0;
            } else {
                s = if forward { self.length } else { 0.0 };
                left -= room;
                forward = !forward;
            }
        }
        (s, forward)
    }

    /// Advances over the step from `t0_ns` to `t1_ns`, given the robot's body `robot` at the
    /// start of the step; `margin` is the gap it keeps from the robot at the very least.
    pub(crate) fn step(&mut self, t0_ns: u64, t1_ns: u64, robot: &Circle, margin: f64) {
        let walk_ns = t1_ns.saturating_sub(t0_ns.max(self.start_delay_ns));
        if walk_ns == 0 || self.speed == 0.0 {
            self.yielding = false;
            return;
        }
        let gap = (self.position - robot.center).norm() - self.radius - robot.radius;
        let close = gap < self.yield_distance;
        if close {
            self.waited_ns = self.waited_ns.saturating_add(walk_ns);
            if self.patience_ns.is_none_or(|p| self.waited_ns < p) {
                self.yielding = true;
                return;
            }
            if !self.turned_back {
                self.turned_back = true;
                self.forward = !self.forward;
            }
        } else {
            self.waited_ns = 0;
            self.turned_back = false;
        }
        let (s, forward) = self.walk(self.s, self.forward, self.speed * walk_ns as f64 * 1e-9);
        let next = self.point_at(s);
        if close && (next - robot.center).norm() <= (self.position - robot.center).norm() {
            // Out of patience, but the way back leads no farther from the robot: wait on.
            self.yielding = true;
            return;
        }
        let room = geometry::max_travel_fraction(
            &Shape::Circle(*robot),
            &self.position,
            &(next - self.position),
            self.radius + margin,
        );
        self.yielding = room < 1.0;
        if !self.yielding {
            self.s = s;
            self.forward = forward;
            self.position = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mover(path: Vec<[f64; 2]>, speed: f64) -> MoverState {
        MoverState::new(&Mover {
            radius: 0.25,
            speed,
            path,
            yield_distance: 0.6,
            start_delay: 1.0,
            patience: None,
        })
    }

    fn patient(path: Vec<[f64; 2]>, speed: f64, patience: f64) -> MoverState {
        let m = Mover {
            radius: 0.25,
            speed,
            path,
            yield_distance: 0.6,
            start_delay: 0.0,
            patience: Some(patience),
        };
        MoverState::new(&m)
    }

    const FAR: Circle = Circle { center: Point::new(100.0, 100.0), radius: 0.25 };

    fn run(m: &mut MoverState, from_s: f64, to_s: f64, robot: &Circle) {
        let (mut t, end) = ((from_s * 1e9) as u64, (to_s * 1e9) as u64);
        while t < end {
            m.step(t, t + 10_000_000, robot, 1e-6);
            t += 10_000_000;
        }
    }

    #[test]
    fn waits_its_start_delay_then_walks_forth_and_back() {
        let mut m = mover(vec![[0.0, 0.0], [3.0, 0.0], [3.0, 1.0]], 1.0);
        run(&mut m, 0.0, 1.0, &FAR);
        assert_eq!(m.position(), Point::new(0.0, 0.0), "still waiting");
        run(&mut m, 1.0, 4.5, &FAR);
        assert!((m.position() - Point::new(3.0, 0.5)).norm() < 1e-9, "{}", m.position());
        // Length 4: at t = 1 + 5 it has turned at the end and come 1 m back, to (3, 0).
        run(&mut m, 4.5, 6.0, &FAR);
        assert!((m.position() - Point::new(3.0, 0.0)).norm() < 1e-9, "{}", m.position());
        // A full round trip (8 s) later it is back there, going the same way.
        run(&mut m, 6.0, 14.0, &FAR);
        assert!((m.position() - Point::new(3.0, 0.0)).norm() < 1e-9, "{}", m.position());
    }

    #[test]
    fn yields_to_the_robot_and_never_walks_into_it() {
        let mut m = mover(vec![[0.0, 0.0], [10.0, 0.0]], 1.0);
        let robot = Circle::new(Point::new(3.0, 0.0), 0.25);
        run(&mut m, 0.0, 20.0, &robot);
        let gap = (m.position() - robot.center).norm() - 0.5;
        assert!(m.truth().yielding);
        assert!(gap < 0.6 && gap > 0.6 - 0.011, "stopped just inside its yield distance: {gap}");
        // The robot leaves: it walks on.
        run(&mut m, 20.0, 21.0, &FAR);
        assert!(!m.truth().yielding);
        assert!(m.position().x > 2.0);
    }

    #[test]
    fn a_patient_mover_waits_its_patience_then_turns_back_and_walks_away() {
        let mut m = patient(vec![[0.0, 0.0], [10.0, 0.0]], 1.0, 5.0);
        let robot = Circle::new(Point::new(3.0, 0.0), 0.25);
        // It walks up to the robot (about 1.9 s) and waits there.
        run(&mut m, 0.0, 4.0, &robot);
        let stopped = m.position();
        assert!(m.truth().yielding);
        run(&mut m, 4.0, 6.5, &robot);
        assert_eq!(m.position(), stopped, "still waiting, within its patience");
        // Five seconds of waiting are up by t = 7: it turns back and walks away.
        run(&mut m, 6.5, 8.0, &robot);
        assert!(!m.truth().yielding);
        assert!(m.position().x < stopped.x - 0.5, "walked back: {} from {}", m.position(), stopped);
        run(&mut m, 8.0, 8.5, &robot);
        assert!(m.position().x < 1.0, "{}", m.position());
        // Clear of the robot it walks its path as before: to the start (t = 8.9), then towards
        // the robot again (there by t = 10.8), and waits there once more for its whole patience.
        run(&mut m, 8.5, 12.0, &robot);
        assert!(m.truth().yielding && (m.position() - stopped).norm() < 0.02, "{}", m.position());
        run(&mut m, 12.0, 15.5, &robot);
        assert!((m.position() - stopped).norm() < 0.02, "waits its patience again: {}", m.position());
        run(&mut m, 15.5, 16.5, &robot);
        assert!(m.position().x < stopped.x - 0.3, "and turns back again: {}", m.position());
    }

    #[test]
    fn a_mover_out_of_patience_never_steps_towards_the_robot() {
        // At the end of its path, the way back leads towards the robot behind it: it waits on.
        let mut m = patient(vec![[0.0, 0.0], [2.0, 0.0]], 1.0, 1.0);
        let robot = Circle::new(Point::new(-0.9, 0.0), 0.25);
        let start = m.position();
        for t in 0..400 {
            m.step(t * 10_000_000, (t + 1) * 10_000_000, &robot, 1e-6);
            assert!((m.position() - robot.center).norm() >= (start - robot.center).norm() - 1e-9);
        }
    }

    #[test]
    fn a_standing_mover_never_moves() {
        let mut m = mover(vec![[0.0, 0.0], [10.0, 0.0]], 0.0);
        run(&mut m, 0.0, 5.0, &FAR);
        assert_eq!(m.position(), Point::new(0.0, 0.0));
    }
}
