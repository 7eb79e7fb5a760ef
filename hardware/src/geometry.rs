//! Plane geometry for the simulator: segments, circles and axis-aligned boxes.
//!
//! Each primitive answers three questions, all in metres:
//! - where its closest point to a given point is, and how far that is ([`Shape::distance`];
//!   circles and boxes are solid, so a point inside is at distance 0);
//! - where a ray first meets it ([`Shape::ray_hit`], a distance along the ray; a ray starting
//!   inside a solid meets it at 0);
//! - how much of a displacement a circle of radius `r` can travel before it touches it
//!   ([`max_travel_fraction`], in `sweep`).
//!
//! All three primitives are convex. The swept-circle test relies on that: the distance from a
//! point moving on a straight line to a convex set is a convex function of time.

use nalgebra::{Point2, Unit, Vector2};

mod sweep;

pub use sweep::{entry_time, max_travel_fraction};

/// The length of `(x, y)`. Plain `sqrt(x² + y²)`: `f64::hypot` guards against overflow that
/// cannot happen at the scale of rooms and is several times slower.
#[inline]
pub(crate) fn norm2(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}

/// A point in the plane, metres.
pub type Point = Point2<f64>;
/// A vector in the plane, metres.
pub type Vector = Vector2<f64>;

/// The unit vector at `angle_rad` counter-clockwise from +x.
pub fn unit_at(angle_rad: f64) -> Unit<Vector> {
    let (s, c) = angle_rad.sin_cos();
    Unit::new_unchecked(Vector::new(c, s))
}

/// A half-line: an origin and a unit direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Point,
    /// Which way it points.
    pub dir: Unit<Vector>,
}

impl Ray {
    /// The ray from `origin` at `angle_rad` counter-clockwise from +x.
    pub fn at_angle(origin: Point, angle_rad: f64) -> Self {
        Ray { origin, dir: unit_at(angle_rad) }
    }

    /// The point at distance `t` along the ray.
    pub fn point_at(&self, t: f64) -> Point {
        self.origin + self.dir.into_inner() * t
    }
}

/// A straight wall segment from `a` to `b` (it may be degenerate: `a == b` is a point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// One end.
    pub a: Point,
    /// The other end.
    pub b: Point,
}

impl Segment {
    /// The segment from `a` to `b`.
    pub fn new(a: Point, b: Point) -> Self {
        Segment { a, b }
    }

    /// Its length.
    pub fn length(&self) -> f64 {
        (self.b - self.a).norm()
    }

    /// The point of the segment closest to `p`.
    pub fn closest_point(&self, p: &Point) -> Point {
        // Scalar arithmetic throughout this module: it is the simulator's inner loop, and
        // nalgebra's generic operators are slow in unoptimised builds.
        let (ex, ey) = (self.b.x - self.a.x, self.b.y - self.a.y);
        let len2 = ex * ex + ey * ey;
        if len2 == 0.0 {
            return self.a;
        }
        let t = (((p.x - self.a.x) * ex + (p.y - self.a.y) * ey) / len2).clamp(0.0, 1.0);
        Point::new(self.a.x + ex * t, self.a.y + ey * t)
    }

    /// The distance from `p` to the segment.
    pub fn distance(&self, p: &Point) -> f64 {
        let q = self.closest_point(p);
        norm2(p.x - q.x, p.y - q.y)
    }

    /// The distance along `ray` to the first point of the segment, if the ray meets it.
    ///
    /// A ray running along the segment meets it at its nearest point ahead (or at 0 if it starts
    /// on it).
    pub fn ray_hit(&self, ray: &Ray) -> Option<f64> {
        let (ux, uy) = (ray.dir.x, ray.dir.y);
        let (ex, ey) = (self.b.x - self.a.x, self.b.y - self.a.y);
        let (wx, wy) = (self.a.x - ray.origin.x, self.a.y - ray.origin.y);
        let denom = ux * ey - uy * ex;
        let len = norm2(ex, ey);
        if denom.abs() <= 1e-12 * len.max(f64::MIN_POSITIVE) {
            // Parallel (or degenerate): only a collinear segment can be met.
            let scale = 1.0 + norm2(wx, wy) + len;
            if (wx * uy - wy * ux).abs() > 1e-12 * scale {
                return None;
            }
            let ta = wx * ux + wy * uy;
            let tb = (self.b.x - ray.origin.x) * ux + (self.b.y - ray.origin.y) * uy;
            let (lo, hi) = if ta <= tb { (ta, tb) } else { (tb, ta) };
            return if hi < 0.0 { None } else { Some(lo.max(0.0)) };
        }
        let t = (wx * ey - wy * ex) / denom;
        let s = (wx * uy - wy * ux) / denom;
        if t >= 0.0 && (0.0..=1.0).contains(&s) { Some(t) } else { None }
    }

    /// The smallest axis-aligned box holding the segment.
    pub fn bounds(&self) -> Aabb {
        Aabb::new(
            Point::new(self.a.x.min(self.b.x), self.a.y.min(self.b.y)),
            Point::new(self.a.x.max(self.b.x), self.a.y.max(self.b.y)),
        )
    }
}

/// A solid disc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Its centre.
    pub center: Point,
    /// Its radius, metres (> 0).
    pub radius: f64,
}

impl Circle {
    /// The disc of `radius` around `center`.
    pub fn new(center: Point, radius: f64) -> Self {
        Circle { center, radius }
    }

    /// The point of the disc closest to `p` (`p` itself when inside).
    pub fn closest_point(&self, p: &Point) -> Point {
        let (dx, dy) = (p.x - self.center.x, p.y - self.center.y);
        let n = norm2(dx, dy);
        if n <= self.radius {
            *p
        } else {
            let k = self.radius / n;
            Point::new(self.center.x + dx * k, self.center.y + dy * k)
        }
    }

    /// The distance from `p` to the disc (0 inside).
    pub fn distance(&self, p: &Point) -> f64 {
        (norm2(p.x - self.center.x, p.y - self.center.y) - self.radius).max(0.0)
    }

    /// The distance along `ray` to the disc, if the ray meets it (0 from inside).
    pub fn ray_hit(&self, ray: &Ray) -> Option<f64> {
        let (ox, oy) = (ray.origin.x - self.center.x, ray.origin.y - self.center.y);
        let c = ox * ox + oy * oy - self.radius * self.radius;
        if c <= 0.0 {
            return Some(0.0);
        }
        let b = ox * ray.dir.x + oy * ray.dir.y;
        if b >= 0.0 {
            return None;
        }
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        // -b - sqrt(disc) == c / (-b + sqrt(disc)), which keeps its precision at grazing angles.
        Some((c / (-b + disc.sqrt())).max(0.0))
    }

    /// The smallest axis-aligned box holding the disc.
    pub fn bounds(&self) -> Aabb {
        let r = self.radius;
        Aabb::new(
            Point::new(self.center.x - r, self.center.y - r),
            Point::new(self.center.x + r, self.center.y + r),
        )
    }
}

/// A solid axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: Point,
    /// The corner with the largest coordinates.
    pub max: Point,
}

impl Aabb {
    /// The box between `min` and `max` (the caller guarantees `min < max` on both axes).
    pub fn new(min: Point, max: Point) -> Self {
        Aabb { min, max }
    }

    /// Whether `p` is inside or on the boundary.
    pub fn contains(&self, p: &Point) -> bool {
        p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y
    }

    /// The point of the box closest to `p` (`p` itself when inside).
    pub fn closest_point(&self, p: &Point) -> Point {
        // max/min rather than clamp: a box built in code with min > max must not panic.
        Point::new(p.x.max(self.min.x).min(self.max.x), p.y.max(self.min.y).min(self.max.y))
    }

    /// The distance from `p` to the box (0 inside).
    pub fn distance(&self, p: &Point) -> f64 {
        let dx = (self.min.x - p.x).max(p.x - self.max.x).max(0.0);
        let dy = (self.min.y - p.y).max(p.y - self.max.y).max(0.0);
        (dx * dx + dy * dy).sqrt()
    }

    /// The four edges, counter-clockwise from the bottom one.
    pub fn edges(&self) -> [Segment; 4] {
        let (a, c) = (self.min, self.max);
        let b = Point::new(c.x, a.y);
        let d = Point::new(a.x, c.y);
        [Segment::new(a, b), Segment::new(b, c), Segment::new(c, d), Segment::new(d, a)]
    }

    /// The distance along `ray` to the box, if the ray meets it (0 from inside).
    pub fn ray_hit(&self, ray: &Ray) -> Option<f64> {
        if self.contains(&ray.origin) {
            return Some(0.0);
        }
        let (mut t_in, mut t_out) = (0.0_f64, f64::INFINITY);
        let axes = [
            (ray.origin.x, ray.dir.x, self.min.x, self.max.x),
            (ray.origin.y, ray.dir.y, self.min.y, self.max.y),
        ];
        for (o, u, lo, hi) in axes {
            if u == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
                continue;
            }
            let (t1, t2) = ((lo - o) / u, (hi - o) / u);
            let (near, far) = if t1 <= t2 { (t1, t2) } else { (t2, t1) };
            t_in = t_in.max(near);
            t_out = t_out.min(far);
            if t_in > t_out {
                return None;
            }
        }
        Some(t_in)
    }
}

/// Any of the three primitives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A wall segment.
    Segment(Segment),
    /// A solid disc.
    Circle(Circle),
    /// A solid axis-aligned box.
    Aabb(Aabb),
}

impl Shape {
    /// The point of the shape closest to `p`.
    pub fn closest_point(&self, p: &Point) -> Point {
        match self {
            Shape::Segment(s) => s.closest_point(p),
            Shape::Circle(c) => c.closest_point(p),
            Shape::Aabb(b) => b.closest_point(p),
        }
    }

    /// The distance from `p` to the shape (0 inside a solid).
    pub fn distance(&self, p: &Point) -> f64 {
        match self {
            Shape::Segment(s) => s.distance(p),
            Shape::Circle(c) => c.distance(p),
            Shape::Aabb(b) => b.distance(p),
        }
    }

    /// The distance along `ray` to the shape, if the ray meets it.
    pub fn ray_hit(&self, ray: &Ray) -> Option<f64> {
        match self {
            Shape::Segment(s) => s.ray_hit(ray),
            Shape::Circle(c) => c.ray_hit(ray),
            Shape::Aabb(b) => b.ray_hit(ray),
        }
    }

    /// The smallest axis-aligned box holding the shape.
    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Segment(s) => s.bounds(),
            Shape::Circle(c) => c.bounds(),
            Shape::Aabb(b) => *b,
        }
    }
}

#[cfg(test)]
mod tests;
