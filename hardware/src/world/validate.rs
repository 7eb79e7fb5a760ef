//! The rules of the world format (SCHEMA.md), checked on a deserialised world.
//!
//! Checks run in file order and stop at the first problem, reported with its key path. No value
//! is ever adjusted.

use super::locate::KeyPath;
use super::{Mover, Place, World};
use crate::geometry::{Point, Shape};

/// A broken rule: where and what.
#[derive(Debug)]
pub(crate) struct Problem {
    pub(crate) path: KeyPath,
    pub(crate) problem: String,
}

type Check = Result<(), Problem>;

fn fail(path: KeyPath, problem: impl Into<String>) -> Check {
    Err(Problem { path, problem: problem.into() })
}

fn finite(path: KeyPath, v: f64) -> Check {
    if v.is_finite() { Ok(()) } else { fail(path, format!("must be a finite number, got {v}")) }
}

fn positive(path: KeyPath, v: f64, what: &str) -> Check {
    finite(path.clone(), v)?;
    if v > 0.0 { Ok(()) } else { fail(path, format!("{what} must be > 0, got {v}")) }
}

fn non_negative(path: KeyPath, v: f64, what: &str) -> Check {
    finite(path.clone(), v)?;
    if v >= 0.0 { Ok(()) } else { fail(path, format!("{what} must be >= 0, got {v}")) }
}

fn finite_point(path: KeyPath, p: &[f64; 2]) -> Check {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        fail(path, format!("must be finite numbers, got [{}, {}]", p[0], p[1]))
    }
}

fn polyline(path: KeyPath, points: &[[f64; 2]], what: &str) -> Check {
    if points.len() < 2 {
        return fail(path, format!("{what} needs at least 2 points, got {}", points.len()));
    }
    for (i, p) in points.iter().enumerate() {
        finite_point(path.i(i), p)?;
    }
    Ok(())
}

fn mover(path: &KeyPath, m: &Mover) -> Check {
    positive(path.k("radius"), m.radius, "a mover's radius")?;
    non_negative(path.k("speed"), m.speed, "a mover's speed")?;
    polyline(path.k("path"), &m.path, "a mover's path")?;
    positive(path.k("yield_distance"), m.yield_distance, "a mover's yield_distance")?;
    non_negative(path.k("start_delay"), m.start_delay, "a mover's start_delay")?;
    match m.patience {
        Some(p) => positive(path.k("patience"), p, "a mover's patience"),
        None => Ok(()),
    }
}

/// Whether `name` is a place's name: letters, digits, `-` and `_`, at least one.
fn place_name(path: KeyPath, name: &str) -> Check {
    if name.is_empty() {
        return fail(path, "a place's name must not be empty");
    }
    match name.chars().find(|c| !(c.is_ascii_alphanumeric() || *c == '-' || *c == '_')) {
        None => Ok(()),
        Some(c) => fail(
            path,
            format!("a place's name may hold letters, digits, '-' and '_' only, got {name:?} (with {c:?})"),
        ),
    }
}

fn place(path: &KeyPath, p: &Place) -> Check {
    place_name(path.k("name"), &p.name)?;
    finite(path.k("x"), p.x)?;
    finite(path.k("y"), p.y)?;
    if let Some(h) = p.heading_deg {
        finite(path.k("heading_deg"), h)?;
    }
    Ok(())
}

/// Every static obstacle (walls, boxes, discs) with the key path that declares it.
fn labelled_statics(w: &World) -> Vec<(String, Shape)> {
    let mut out = Vec::new();
    for (i, wall) in w.walls.iter().enumerate() {
        for (j, s) in wall.segments().enumerate() {
            let label = format!(
                "walls[{i}] (segment {j}, from {:?} to {:?})",
                s.a.coords.as_slice(),
                s.b.coords.as_slice()
            );
            out.push((label, Shape::Segment(s)));
        }
    }
    out.extend(w.boxes.iter().enumerate().map(|(i, b)| (format!("boxes[{i}]"), Shape::Aabb(b.aabb()))));
    out.extend(w.discs.iter().enumerate().map(|(i, d)| (format!("discs[{i}]"), Shape::Circle(d.circle()))));
    out
}

/// Every static obstacle and mover start with the key path that declares it.
fn labelled_obstacles(w: &World) -> Vec<(String, Shape)> {
    let mut out = labelled_statics(w);
    out.extend(
        w.movers
            .iter()
            .enumerate()
            .map(|(i, m)| (format!("movers[{i}] (its start)"), Shape::Circle(m.start_circle()))),
    );
    out
}

/// Checks every rule; the first broken one is the error.
pub(crate) fn check(w: &World, robot_radius_m: f64) -> Check {
    let robot = KeyPath::key("robot");
    finite(robot.k("x"), w.robot.x)?;
    finite(robot.k("y"), w.robot.y)?;
    finite(robot.k("heading_deg"), w.robot.heading_deg)?;
    for (i, wall) in w.walls.iter().enumerate() {
        polyline(KeyPath::key("walls").i(i).k("points"), &wall.points, "a wall")?;
    }
    for (i, b) in w.boxes.iter().enumerate() {
        let path = KeyPath::key("boxes").i(i);
        finite_point(path.k("min"), &b.min)?;
        finite_point(path.k("max"), &b.max)?;
        if !(b.min[0] < b.max[0] && b.min[1] < b.max[1]) {
            return fail(
                path.k("max"),
                format!(
                    "a box needs min < max on both axes, got min = [{}, {}], max = [{}, {}]",
                    b.min[0], b.min[1], b.max[0], b.max[1]
                ),
            );
        }
    }
    for (i, d) in w.discs.iter().enumerate() {
        let path = KeyPath::key("discs").i(i);
        finite_point(path.k("center"), &d.center)?;
        positive(path.k("radius"), d.radius, "a disc's radius")?;
    }
    for (i, m) in w.movers.iter().enumerate() {
        mover(&KeyPath::key("movers").i(i), m)?;
    }
    let mut names = std::collections::HashMap::new();
    for (i, p) in w.places.iter().enumerate() {
        let path = KeyPath::key("places").i(i);
        place(&path, p)?;
        if let Some(first) = names.insert(p.name.as_str(), i) {
            return fail(path.k("name"), format!("the place name {:?} is taken by places[{first}]", p.name));
        }
    }
    let start = Point::new(w.robot.x, w.robot.y);
    for (label, shape) in labelled_obstacles(w) {
        let gap = shape.distance(&start);
        if gap < robot_radius_m {
            return fail(
                robot,
                format!(
                    "the robot's start ({}, {}) overlaps {label}: its centre is {gap:.3} m from it, \
                     less than the body's radius {robot_radius_m} m",
                    w.robot.x, w.robot.y
                ),
            );
        }
    }
    let statics = labelled_statics(w);
    for (i, p) in w.places.iter().enumerate() {
        let at = Point::new(p.x, p.y);
        for (label, shape) in &statics {
            let gap = shape.distance(&at);
            if gap < robot_radius_m {
                return fail(
                    KeyPath::key("places").i(i),
                    format!(
                        "the robot's body does not fit at place {:?} ({}, {}): it would overlap {label}, \
                         {gap:.3} m from its centre, less than the body's radius {robot_radius_m} m",
                        p.name, p.x, p.y
                    ),
                );
            }
        }
    }
    Ok(())
}
