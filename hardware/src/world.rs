//! World files: the flat indoor space a simulated Nomad 200 drives in.
//!
//! A world is a TOML file (format: `shared/worlds/SCHEMA.md`) deserialised into the typed,
//! checked [`World`]. Lengths are metres, speeds metres per second, angles degrees, times
//! seconds; x points right, y up, headings are counter-clockwise from +x. The Rust structs
//! mirror the file's keys one to one, so their field names carry no unit suffixes.
//!
//! Loading never panics and never fixes a value: any mistake is a [`WorldError`] naming the
//! file, the key path (`movers[1].speed`), the line and column, and what is wrong.
//!
//! The reference world, a 40 m department corridor, ships inside the crate: [`World::palazzina`].

use crate::geometry::{Aabb, Circle, Point, Segment, Shape};
use serde::{Deserialize, Serialize};
use std::path::Path;

mod error;
mod grid;
mod locate;
mod validate;
mod xy;

pub use error::{LineCol, WorldError};
pub use grid::{GridError, MAX_CELLS};

/// The radius of a Nomad 200's body (0.50 m across), used to check the robot's start pose.
pub const NOMAD200_RADIUS_M: f64 = 0.25;

/// The text of the reference world, `worlds/palazzina.toml`.
pub const PALAZZINA_TOML: &str = include_str!("../worlds/palazzina.toml");

/// A world: static walls, boxes and discs, moving people, and where the robot starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// Free text naming the world.
    pub name: String,
    /// The robot's start pose.
    pub robot: RobotStart,
    /// Wall polylines.
    #[serde(default)]
    pub walls: Vec<Wall>,
    /// Static axis-aligned boxes (cabinets, desks).
    #[serde(default)]
    pub boxes: Vec<BoxObstacle>,
    /// Static round obstacles (bins, pillars, plants).
    #[serde(default)]
    pub discs: Vec<Disc>,
    /// Moving round obstacles (people).
    #[serde(default)]
    pub movers: Vec<Mover>,
    /// Named places a mission can send the robot to.
    #[serde(default)]
    pub places: Vec<Place>,
}

/// A named place a mission can send the robot to: where its body's centre is to arrive, and
/// with which heading if one is given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Place {
    /// Unique in the world; letters, digits, `-` and `_`.
    pub name: String,
    /// x of the body's centre, m.
    pub x: f64,
    /// y of the body's centre, m.
    pub y: f64,
    /// The heading to arrive with, degrees counter-clockwise from +x (absent: any).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heading_deg: Option<f64>,
}

/// Where the robot starts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotStart {
    /// x of the body's centre, m.
    pub x: f64,
    /// y of the body's centre, m.
    pub y: f64,
    /// Heading, degrees counter-clockwise from +x.
    pub heading_deg: f64,
}

/// A polyline of wall segments.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    /// The corners, `[x, y]` in metres; at least 2.
    #[serde(deserialize_with = "xy::many")]
    pub points: Vec<[f64; 2]>,
    /// Whether the last point joins the first.
    #[serde(default)]
    pub closed: bool,
}

/// A static axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxObstacle {
    /// The corner with the smallest coordinates, m.
    #[serde(deserialize_with = "xy::one")]
    pub min: [f64; 2],
    /// The corner with the largest coordinates, m.
    #[serde(deserialize_with = "xy::one")]
    pub max: [f64; 2],
}

/// A static round obstacle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disc {
    /// Its centre, m.
    #[serde(deserialize_with = "xy::one")]
    pub center: [f64; 2],
    /// Its radius, m (> 0).
    pub radius: f64,
}

/// A moving round obstacle: a person walking a polyline forth and back for ever.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mover {
    /// Its radius, m (> 0).
    pub radius: f64,
    /// Walking speed along the path, m/s (0 for one who stands).
    pub speed: f64,
    /// The path, `[x, y]` in metres; at least 2 points. It starts at the first.
    #[serde(deserialize_with = "xy::many")]
    pub path: Vec<[f64; 2]>,
    /// The mover pauses while the gap between its edge and the robot's edge is below this, m.
    #[serde(default = "default_yield_distance")]
    pub yield_distance: f64,
    /// Seconds before it starts walking.
    #[serde(default)]
    pub start_delay: f64,
    /// Seconds it waits for the robot before it gives up and turns back the way it came (an
    /// orsa extension of the shared schema). Absent: it waits for as long as the robot is there,
    /// so a head-on meeting in a passage too narrow for both lasts until the robot leaves.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub patience: Option<f64>,
}

fn default_yield_distance() -> f64 {
    0.6
}

fn point(p: &[f64; 2]) -> Point {
    Point::new(p[0], p[1])
}

impl Wall {
    /// Its segments, in order, including the closing one when `closed`.
    pub fn segments(&self) -> impl Iterator<Item = Segment> + '_ {
        let open = self.points.windows(2).map(|w| Segment::new(point(&w[0]), point(&w[1])));
        let closing = match (self.closed, self.points.first(), self.points.last()) {
            (true, Some(first), Some(last)) if self.points.len() > 1 => {
                Some(Segment::new(point(last), point(first)))
            }
            _ => None,
        };
        open.chain(closing)
    }
}

impl BoxObstacle {
    /// The box as a geometric primitive.
    pub fn aabb(&self) -> Aabb {
        Aabb::new(point(&self.min), point(&self.max))
    }
}

impl Disc {
    /// The disc as a geometric primitive.
    pub fn circle(&self) -> Circle {
        Circle::new(point(&self.center), self.radius)
    }
}

impl Mover {
    /// The path's corners as points.
    pub fn path_points(&self) -> Vec<Point> {
        self.path.iter().map(point).collect()
    }

    /// The mover where it starts: at the first point of its path.
    pub fn start_circle(&self) -> Circle {
        Circle::new(self.path.first().map_or(Point::origin(), point), self.radius)
    }
}

impl Place {
    /// Where the body's centre is to arrive.
    pub fn position(&self) -> Point {
        Point::new(self.x, self.y)
    }

    /// The heading to arrive with, in radians (absent: any).
    pub fn heading_rad(&self) -> Option<f64> {
        self.heading_deg.map(f64::to_radians)
    }
}

impl RobotStart {
    /// The body's centre.
    pub fn position(&self) -> Point {
        Point::new(self.x, self.y)
    }

    /// The heading in radians.
    pub fn heading_rad(&self) -> f64 {
        self.heading_deg.to_radians()
    }
}

impl World {
    /// The reference world: the Palazzina 1 corridor, 40 m x 2.4 m, closed at both ends, with
    /// door recesses, three static obstacles and three people walking.
    pub fn palazzina() -> Result<World, WorldError> {
        World::from_str(PALAZZINA_TOML, "palazzina.toml (built in)")
    }

    /// The place named `name`, if the world has one.
    pub fn place(&self, name: &str) -> Option<&Place> {
        self.places.iter().find(|p| p.name == name)
    }

    /// Reads and checks the world file at `path`.
    pub fn from_path(path: impl AsRef<Path>) -> Result<World, WorldError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|source| WorldError::Read { path: path.to_path_buf(), error: source })?;
        World::from_str(&text, &path.display().to_string())
    }

    /// Parses and checks a world from its TOML `text`; `origin` names it in errors (usually the
    /// file's path).
    pub fn from_str(text: &str, origin: &str) -> Result<World, WorldError> {
        let doc = toml::de::DeTable::parse(text).map_err(|e| {
            let at = e.span().map(|s| LineCol::of(text, s.start));
            WorldError::Syntax { origin: origin.to_owned(), at, problem: e.message().to_owned() }
        })?;
        let world = World::deserialize(toml::de::Deserializer::from(doc.clone())).map_err(|e| {
            let (key, problem) = locate::describe_serde_error(doc.get_ref(), &e);
            let at = locate::error_span(&e).map(|s| LineCol::of(text, s.start));
            WorldError::Invalid { origin: origin.to_owned(), key, at, problem }
        })?;
        if let Err(p) = validate::check(&world, NOMAD200_RADIUS_M) {
            let at = locate::span_of(doc.get_ref(), &p.path).map(|s| LineCol::of(text, s.start));
            return Err(WorldError::Invalid {
                origin: origin.to_owned(),
                key: p.path.to_string(),
                at,
                problem: p.problem,
            });
        }
        Ok(world)
    }

    /// Checks the rules of the world format on a world built in code (`origin` names it in the
    /// error; there is no line and column to report).
    pub fn check(&self, origin: &str) -> Result<(), WorldError> {
        validate::check(self, NOMAD200_RADIUS_M).map_err(|p| WorldError::Invalid {
            origin: origin.to_owned(),
            key: p.path.to_string(),
            at: None,
            problem: p.problem,
        })
    }

    /// Every static obstacle (wall segments, boxes, discs) as geometric primitives.
    pub fn static_shapes(&self) -> Vec<Shape> {
        let walls = self.walls.iter().flat_map(Wall::segments).map(Shape::Segment);
        let boxes = self.boxes.iter().map(|b| Shape::Aabb(b.aabb()));
        let discs = self.discs.iter().map(|d| Shape::Circle(d.circle()));
        walls.chain(boxes).chain(discs).collect()
    }
}

#[cfg(test)]
mod tests;
