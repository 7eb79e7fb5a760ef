//! What the robot can meet: the world's static shapes, plus the movers where they are now.
//!
//! Movers change every step (and sensors see them where they were at the instant of firing),
//! so every query takes them as a separate slice of circles.

use crate::geometry::{self, Aabb, Circle, Point, Ray, Shape, Vector};
use crate::world::World;

/// The most rays one fan may have (the configuration allows up to 64 per sensor).
pub(crate) const MAX_RAYS: usize = 64;

/// The static shapes of a world, each with its bounding box for a cheap first test: a query
/// skips every shape whose box is out of its reach.
#[derive(Debug, Clone)]
pub(crate) struct Scene {
    statics: Vec<(Shape, Aabb)>,
}

impl Scene {
    pub(crate) fn new(world: &World) -> Self {
        Scene { statics: world.static_shapes().into_iter().map(|s| (s, s.bounds())).collect() }
    }

    /// Every shape with its bounds: the static ones, then the movers.
    fn shapes<'a>(&'a self, movers: &'a [Circle]) -> impl Iterator<Item = (Shape, Aabb)> + 'a {
        self.statics.iter().copied().chain(movers.iter().map(|c| (Shape::Circle(*c), c.bounds())))
    }

    /// The nearest distance at which any ray from `origin` at `axis + offsets[k]` meets a
    /// shape, if one is met within `max`. (At most [`MAX_RAYS`] offsets are used.)
    pub(crate) fn ray_fan(
        &self,
        movers: &[Circle],
        origin: Point,
        axis: f64,
        offsets: &[f64],
        max: f64,
    ) -> Option<f64> {
        let rays: Vec<Ray> = offsets.iter().take(MAX_RAYS).map(|o| Ray::at_angle(origin, axis + o)).collect();
        let mut reach = max;
        let mut best = None;
        for (shape, bounds) in self.shapes(movers) {
            if bounds.distance(&origin) > reach {
                continue;
            }
            for ray in &rays {
                if let Some(t) = shape.ray_hit(ray)
                    && t <= reach
                {
                    reach = t;
                    best = Some(t);
                }
            }
        }
        best
    }

    /// The distance along `ray` to the first shape it meets, if any is met within `max`.
    pub(crate) fn ray_cast(&self, movers: &[Circle], ray: &Ray, max: f64) -> Option<f64> {
        let axis = ray.dir.y.atan2(ray.dir.x);
        self.ray_fan(movers, ray.origin, axis, &[0.0], max)
    }

    /// The distance from `p` to the nearest shape, if there is any shape.
    pub(crate) fn nearest(&self, movers: &[Circle], p: &Point) -> Option<f64> {
        let mut best: Option<f64> = None;
        for (shape, bounds) in self.shapes(movers) {
            if best.is_some_and(|b| bounds.distance(p) >= b) {
                continue;
            }
            let d = shape.distance(p);
            best = Some(best.map_or(d, |b| b.min(d)));
        }
        best
    }

    /// The largest fraction of `d` a circle of `radius` at `p` can travel touching nothing.
    pub(crate) fn max_travel_fraction(&self, movers: &[Circle], p: &Point, d: &Vector, radius: f64) -> f64 {
        let reach = geometry::norm2(d.x, d.y) + radius;
        self.shapes(movers)
            .filter(|(_, bounds)| bounds.distance(p) <= reach)
            .map(|(s, _)| geometry::max_travel_fraction(&s, p, d, radius))
            .fold(1.0, f64::min)
    }

    /// The closest point of every shape nearer than `within` to `p`.
    pub(crate) fn touching(&self, movers: &[Circle], p: &Point, within: f64) -> Vec<Point> {
        self.shapes(movers)
            .filter(|(_, bounds)| bounds.distance(p) < within)
            .map(|(s, _)| s.closest_point(p))
            .filter(|q| geometry::norm2(q.x - p.x, q.y - p.y) < within)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{RobotStart, Wall};

    fn corridor() -> World {
        World {
            name: "c".into(),
            robot: RobotStart { x: 1.0, y: 1.0, heading_deg: 0.0 },
            walls: vec![Wall {
                points: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 2.0], [0.0, 2.0]],
                closed: true,
            }],
            boxes: vec![],
            discs: vec![],
            movers: vec![],
        }
    }

    #[test]
    fn queries_include_movers() {
        let scene = Scene::new(&corridor());
        let p = Point::new(1.0, 1.0);
        let ray = Ray::at_angle(p, 0.0);
        assert_eq!(scene.ray_cast(&[], &ray, 100.0), Some(9.0));
        assert_eq!(scene.ray_cast(&[], &ray, 8.0), None, "beyond max");
        let person = [Circle::new(Point::new(4.0, 1.0), 0.5)];
        assert_eq!(scene.ray_cast(&person, &ray, 100.0), Some(2.5));
        assert_eq!(scene.nearest(&[], &p), Some(1.0));
        assert_eq!(scene.nearest(&[Circle::new(Point::new(1.0, 1.75), 0.25)], &p), Some(0.5));
        let f = scene.max_travel_fraction(&person, &p, &Vector::new(4.0, 0.0), 0.25);
        assert!((f - 2.25 / 4.0).abs() < 1e-12, "{f}");
        assert_eq!(scene.touching(&[], &Point::new(1.0, 0.3), 0.31), vec![Point::new(1.0, 0.0)]);
    }
}
