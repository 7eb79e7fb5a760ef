//! What the robot can meet: the world's static shapes, plus the movers where they are now.
//!
//! Movers change every step (and sensors see them where they were at the instant of firing),
//! so every query takes them as a separate slice of circles.

use crate::geometry::{self, Circle, Point, Ray, Shape, Vector};
use crate::world::World;

/// The static shapes of a world.
#[derive(Debug, Clone)]
pub(crate) struct Scene {
    statics: Vec<Shape>,
}

impl Scene {
    pub(crate) fn new(world: &World) -> Self {
        Scene { statics: world.static_shapes() }
    }

    /// Every shape: the static ones, then the movers.
    pub(crate) fn shapes<'a>(&'a self, movers: &'a [Circle]) -> impl Iterator<Item = Shape> + 'a {
        self.statics.iter().copied().chain(movers.iter().copied().map(Shape::Circle))
    }

    /// The distance along `ray` to the first shape it meets, if any is met within `max`.
    pub(crate) fn ray_cast(&self, movers: &[Circle], ray: &Ray, max: f64) -> Option<f64> {
        self.shapes(movers).filter_map(|s| s.ray_hit(ray)).filter(|&t| t <= max).reduce(f64::min)
    }

    /// The distance from `p` to the nearest shape, if there is any shape.
    pub(crate) fn nearest(&self, movers: &[Circle], p: &Point) -> Option<f64> {
        self.shapes(movers).map(|s| s.distance(p)).reduce(f64::min)
    }

    /// The largest fraction of `d` a circle of `radius` at `p` can travel touching nothing.
    pub(crate) fn max_travel_fraction(&self, movers: &[Circle], p: &Point, d: &Vector, radius: f64) -> f64 {
        self.shapes(movers).map(|s| geometry::max_travel_fraction(&s, p, d, radius)).fold(1.0, f64::min)
    }

    /// The closest point of every shape nearer than `within` to `p`.
    pub(crate) fn touching(&self, movers: &[Circle], p: &Point, within: f64) -> Vec<Point> {
        self.shapes(movers).map(|s| s.closest_point(p)).filter(|q| (q - p).norm() < within).collect()
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
