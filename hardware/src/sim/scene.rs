//! What the robot can meet: the world's static shapes, the boxes placed in it while it runs (a
//! fault plan's `box_placed`), plus the movers where they are now.
//!
//! Movers change every step (and sensors see them where they were at the instant of firing),
//! so every query takes them as a separate slice of circles.
//!
//! The static shapes never change, and every query reads all of their bounding boxes. Simulators
//! of the same world therefore share one copy: a thousand robots in one process read the same
//! few kilobytes, which stay in cache, instead of a thousand copies that evict each other. The
//! sharing is by content, bit for bit, so it can change no answer.

use crate::geometry::{self, Aabb, Circle, Point, Ray, Shape, Vector};
use crate::world::World;
use nalgebra::Unit;
use parking_lot::Mutex;
use std::sync::{Arc, Weak};

/// The most rays one fan may have (the configuration allows up to 64 per sensor).
pub(crate) const MAX_RAYS: usize = 64;

/// The static shapes of a world and the boxes placed in it since the start, each with its
/// bounding box for a cheap first test: a query skips every shape whose box is out of its reach.
#[derive(Debug, Clone)]
pub(crate) struct Scene {
    statics: Arc<Statics>,
    /// Boxes placed since the start, each with its bounds; few, so every query reads them all.
    placed: Vec<(Shape, Aabb)>,
}

/// Static shapes, each with its bounding box, and an index of them along x.
#[derive(Debug)]
struct Statics {
    shapes: Vec<(Shape, Aabb)>,
    /// `None` when there are too many shapes for a query's list of those it has seen.
    strips: Option<Strips>,
}

/// The static shapes by strips of the world along x. A ray query visits the strips in order of
/// their distance from its origin and stops at the first one beyond its nearest hit so far, so
/// in a corridor it looks at the few shapes around the robot instead of all of them.
///
/// The answer cannot change: a shape whose box is within the query's reach lies in a strip no
/// farther than its box, and every such strip is visited. Each shape is listed in the strips
/// its box overlaps and in one more on each side, so rounding in placing it cannot hide it.
#[derive(Debug)]
struct Strips {
    x0: f64,
    width: f64,
    shapes: Vec<Vec<u16>>,
}

impl Strips {
    /// The strip width aimed at, m: about a sensor's reach in a corridor.
    const WIDTH_M: f64 = 0.5;
    /// At most this many strips, however large the world.
    const MAX: usize = 4096;
    /// At most this many shapes (a query keeps a bit per shape on its stack).
    const MAX_SHAPES: usize = 64 * SEEN_WORDS;

    fn new(shapes: &[(Shape, Aabb)]) -> Option<Strips> {
        if shapes.is_empty() || shapes.len() > Self::MAX_SHAPES {
            return None;
        }
        let x0 = shapes.iter().map(|(_, b)| b.min.x).fold(f64::INFINITY, f64::min);
        let x1 = shapes.iter().map(|(_, b)| b.max.x).fold(f64::NEG_INFINITY, f64::max);
        if !(x0.is_finite() && x1.is_finite()) {
            return None;
        }
        let count = (((x1 - x0) / Self::WIDTH_M).ceil() as usize).clamp(1, Self::MAX);
        let width = ((x1 - x0) / count as f64).max(f64::MIN_POSITIVE);
        let mut strips = Strips { x0, width, shapes: vec![Vec::new(); count] };
        for (k, (_, b)) in shapes.iter().enumerate() {
            let (first, last) =
                (strips.index(b.min.x).saturating_sub(1), (strips.index(b.max.x) + 1).min(count - 1));
            for strip in &mut strips.shapes[first..=last] {
                strip.push(u16::try_from(k).ok()?);
            }
        }
        Some(strips)
    }

    /// The strip `x` falls in, clamped to the strips there are.
    fn index(&self, x: f64) -> usize {
        let i = ((x - self.x0) / self.width).floor();
        if i <= 0.0 { 0 } else { (i as usize).min(self.shapes.len() - 1) }
    }

    /// How far strip `i` lies from `x` along x (0 inside it).
    fn gap(&self, i: usize, x: f64) -> f64 {
        let left = self.x0 + i as f64 * self.width;
        (left - x).max(x - (left + self.width)).max(0.0)
    }
}

/// Words of the bit set in which a strip query marks the shapes it has looked at.
const SEEN_WORDS: usize = 16;

/// The static shapes of every scene alive in this process, for [`Scene::new`] to share.
static STATICS: Mutex<Vec<Weak<Statics>>> = Mutex::new(Vec::new());

impl Scene {
    /// The scene of `world`'s static shapes, shared with every live scene whose shapes are the
    /// same bit for bit.
    pub(crate) fn new(world: &World) -> Self {
        let statics: Vec<(Shape, Aabb)> =
            world.static_shapes().into_iter().map(|s| (s, s.bounds())).collect();
        let mut alive = STATICS.lock();
        alive.retain(|w| w.strong_count() > 0);
        if let Some(same) = alive.iter().filter_map(Weak::upgrade).find(|s| same_bits(&s.shapes, &statics)) {
            return Scene { statics: same, placed: Vec::new() };
        }
        let statics = Arc::new(Statics { strips: Strips::new(&statics), shapes: statics });
        alive.push(Arc::downgrade(&statics));
        Scene { statics, placed: Vec::new() }
    }

    /// Puts `b` in the scene: every query from now on meets it.
    pub(crate) fn place(&mut self, b: Aabb) {
        self.placed.push((Shape::Aabb(b), b));
    }

    /// Takes away a box placed as `b` (bit for bit); whether there was one.
    pub(crate) fn unplace(&mut self, b: &Aabb) -> bool {
        let key = (Shape::Aabb(*b), *b);
        match self.placed.iter().position(|p| same_bits(std::slice::from_ref(p), std::slice::from_ref(&key)))
        {
            Some(i) => {
                self.placed.remove(i);
                true
            }
            None => false,
        }
    }

    /// The boxes placed now.
    pub(crate) fn placed(&self) -> impl Iterator<Item = Aabb> + '_ {
        self.placed.iter().map(|(_, b)| *b)
    }

    /// Every shape with its bounds: the static ones, the placed ones, then the movers.
    fn shapes<'a>(&'a self, movers: &'a [Circle]) -> impl Iterator<Item = (Shape, Aabb)> + 'a {
        self.statics
            .shapes
            .iter()
            .chain(&self.placed)
            .copied()
            .chain(movers.iter().map(|c| (Shape::Circle(*c), c.bounds())))
    }

    /// The nearest distance at which any ray from `origin` at `axis + offsets[k]` meets a
    /// shape, if one is met within `max`. (At most [`MAX_RAYS`] offsets are used.)
    ///
    /// The answer is the smallest hit over every shape and ray, so skipping a shape that no ray
    /// can meet changes nothing: shapes whose box is farther than the nearest hit so far, and
    /// shapes whose box lies wholly outside the fan (a sensor's fan covers a few tens of degrees,
    /// so most shapes near the robot are beside or behind it).
    pub(crate) fn ray_fan(
        &self,
        movers: &[Circle],
        origin: Point,
        axis: f64,
        offsets: &[f64],
        max: f64,
    ) -> Option<f64> {
        let offsets = &offsets[..offsets.len().min(MAX_RAYS)];
        let mut rays = [Ray { origin, dir: Unit::new_unchecked(Vector::x()) }; MAX_RAYS];
        for (ray, o) in rays.iter_mut().zip(offsets) {
            *ray = Ray::at_angle(origin, axis + o);
        }
        let rays = &rays[..offsets.len()];
        self.first_hit(movers, &origin, rays, Fan::of(rays, offsets), max)
    }

    /// The nearest hit of any of `rays` (all from `origin`, within `fan` if given) within `max`.
    fn first_hit(
        &self,
        movers: &[Circle],
        origin: &Point,
        rays: &[Ray],
        fan: Option<Fan>,
        max: f64,
    ) -> Option<f64> {
        let mut reach = max;
        let mut best = None;
        let mut consider = |shape: &Shape, bounds: &Aabb, reach: &mut f64| {
            if bounds.distance(origin) > *reach || fan.is_some_and(|f| f.misses(origin, bounds)) {
                return;
            }
            for ray in rays {
                if let Some(t) = shape.ray_hit(ray)
                    && t <= *reach
                {
                    *reach = t;
                    best = Some(t);
                }
            }
        };
        match &self.statics.strips {
            Some(strips) if origin.x.is_finite() => {
                let mut seen = [0u64; SEEN_WORDS];
                let home = strips.index(origin.x);
                // The next strip to visit on the left (`None`: none left) and on the right.
                let (mut left, mut right) = (Some(home), home + 1);
                loop {
                    let gap_left = left.map_or(f64::INFINITY, |i| strips.gap(i, origin.x));
                    let gap_right =
                        if right < strips.shapes.len() { strips.gap(right, origin.x) } else { f64::INFINITY };
                    let (i, gap) = match left {
                        Some(i) if gap_left <= gap_right => {
                            left = i.checked_sub(1);
                            (i, gap_left)
                        }
                        _ => {
                            right += 1;
                            (right - 1, gap_right)
                        }
                    };
                    if gap > reach || gap == f64::INFINITY {
                        break;
                    }
                    for &k in &strips.shapes[i] {
                        let (word, bit) = (usize::from(k) / 64, 1u64 << (k % 64));
                        if seen[word] & bit == 0 {
                            seen[word] |= bit;
                            let (shape, bounds) = &self.statics.shapes[usize::from(k)];
                            consider(shape, bounds, &mut reach);
                        }
                    }
                }
            }
            _ => {
                for (shape, bounds) in &self.statics.shapes {
                    consider(shape, bounds, &mut reach);
                }
            }
        }
        for (shape, bounds) in &self.placed {
            consider(shape, bounds, &mut reach);
        }
        for c in movers {
            consider(&Shape::Circle(*c), &c.bounds(), &mut reach);
        }
        best
    }

    /// The distance along `ray` to the first shape it meets, if any is met within `max`.
    pub(crate) fn ray_cast(&self, movers: &[Circle], ray: &Ray, max: f64) -> Option<f64> {
        let dir = ray.dir.into_inner();
        self.first_hit(
            movers,
            &ray.origin,
            std::slice::from_ref(ray),
            Some(Fan { right: dir, left: dir }),
            max,
        )
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

/// Whether two lists of shapes are the same bit for bit (`==` would take 0.0 for -0.0).
fn same_bits(a: &[(Shape, Aabb)], b: &[(Shape, Aabb)]) -> bool {
    fn bits((shape, bounds): &(Shape, Aabb)) -> [u64; 9] {
        let (tag, f) = match *shape {
            Shape::Segment(s) => (0, [s.a.x, s.a.y, s.b.x, s.b.y]),
            Shape::Circle(c) => (1, [c.center.x, c.center.y, c.radius, 0.0]),
            Shape::Aabb(b) => (2, [b.min.x, b.min.y, b.max.x, b.max.y]),
        };
        let g = [bounds.min.x, bounds.min.y, bounds.max.x, bounds.max.y];
        let mut out = [tag; 9];
        for (o, v) in out[1..].iter_mut().zip(f.iter().chain(&g)) {
            *o = v.to_bits();
        }
        out
    }
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| bits(x) == bits(y))
}

/// The two outermost rays of a fan narrower than half a turn, for culling whole shapes.
#[derive(Debug, Clone, Copy)]
struct Fan {
    /// The most clockwise ray's direction.
    right: Vector,
    /// The most counter-clockwise ray's direction.
    left: Vector,
}

impl Fan {
    /// A shape this far (m) outside an edge ray's line is culled: far beyond the rounding of a
    /// ray hit, so culling never drops a hit the rays would report.
    const MARGIN_M: f64 = 1e-9;

    /// The fan of `rays` cast at `offsets` (None when it spans half a turn or more, or is empty).
    fn of(rays: &[Ray], offsets: &[f64]) -> Option<Fan> {
        let lo = (0..offsets.len()).min_by(|&a, &b| offsets[a].total_cmp(&offsets[b]))?;
        let hi = (0..offsets.len()).max_by(|&a, &b| offsets[a].total_cmp(&offsets[b]))?;
        (offsets[hi] - offsets[lo] < std::f64::consts::PI)
            .then(|| Fan { right: rays[lo].dir.into_inner(), left: rays[hi].dir.into_inner() })
    }

    /// Whether no ray of the fan from `origin` can meet anything inside `bounds`. Every point of
    /// every ray lies on the counter-clockwise side of the right edge's line and on the
    /// clockwise side of the left edge's line; a box with all four corners beyond one of those
    /// lines is out of reach.
    fn misses(&self, origin: &Point, bounds: &Aabb) -> bool {
        let corners = [
            (bounds.min.x, bounds.min.y),
            (bounds.max.x, bounds.min.y),
            (bounds.min.x, bounds.max.y),
            (bounds.max.x, bounds.max.y),
        ];
        let cross = |u: &Vector, (x, y): (f64, f64)| u.x * (y - origin.y) - u.y * (x - origin.x);
        corners.iter().all(|&c| cross(&self.right, c) < -Self::MARGIN_M)
            || corners.iter().all(|&c| cross(&self.left, c) > Self::MARGIN_M)
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
            places: vec![],
        }
    }

    /// The culled fan gives exactly what casting every ray at every shape gives.
    #[test]
    fn culling_by_the_fan_changes_no_answer() {
        use rand::{Rng, SeedableRng};
        let world = World::palazzina().expect("world");
        let scene = Scene::new(&world);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut hits = 0;
        for _ in 0..4000 {
            let origin = Point::new(rng.random_range(0.3..39.7), rng.random_range(0.1..2.3));
            let axis = rng.random_range(-4.0..4.0);
            let width: f64 = [0.0, 0.1, 0.44, 1.5, 3.1][rng.random_range(0..5)];
            let n = if width == 0.0 { 1 } else { rng.random_range(2..MAX_RAYS) };
            let offsets: Vec<f64> = (0..n)
                .map(|k| if n == 1 { 0.0 } else { -width / 2.0 + width * k as f64 / (n - 1) as f64 })
                .collect();
            let movers = [Circle::new(Point::new(origin.x + rng.random_range(-1.0..1.0), 1.2), 0.2)];
            let max = rng.random_range(0.3..6.0);
            let brute = scene
                .shapes(&movers)
                .flat_map(|(shape, _)| {
                    offsets.iter().filter_map(move |o| shape.ray_hit(&Ray::at_angle(origin, axis + o)))
                })
                .filter(|t| *t <= max)
                .min_by(f64::total_cmp);
            assert_eq!(
                scene.ray_fan(&movers, origin, axis, &offsets, max),
                brute,
                "at {origin:?}, axis {axis}"
            );
            hits += usize::from(brute.is_some());
        }
        assert!(hits > 1000, "the sample must hit things: {hits}");
    }

    #[test]
    fn a_fan_culls_only_boxes_wholly_outside_it() {
        let o = Point::new(0.0, 0.0);
        let rays = [Ray::at_angle(o, -0.2), Ray::at_angle(o, 0.2)];
        let fan = Fan::of(&rays, &[-0.2, 0.2]).expect("narrow fan");
        let b = |x0: f64, y0: f64, x1: f64, y1: f64| Aabb::new(Point::new(x0, y0), Point::new(x1, y1));
        assert!(!fan.misses(&o, &b(1.0, -0.1, 2.0, 0.1)), "straight ahead");
        assert!(!fan.misses(&o, &b(1.0, 0.1, 2.0, 5.0)), "straddles the left edge");
        assert!(fan.misses(&o, &b(1.0, 1.0, 2.0, 5.0)), "left of the fan");
        assert!(fan.misses(&o, &b(0.5, -3.0, 2.0, -0.5)), "right of the fan");
        assert!(!fan.misses(&o, &b(-1.0, -1.0, 1.0, 1.0)), "around the origin");
        assert!(Fan::of(&rays, &[-2.0, 2.0]).is_none(), "half a turn or more: no culling");
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

    /// Scenes of the same world share one copy of its shapes; a world that differs in any bit
    /// (a shape moved, or 0.0 written -0.0) gets its own, and the copy lives only as long as a
    /// scene uses it.
    #[test]
    fn scenes_of_the_same_world_share_their_shapes() {
        let a = Scene::new(&corridor());
        let b = Scene::new(&corridor());
        assert!(Arc::ptr_eq(&a.statics, &b.statics));
        let mut moved = corridor();
        moved.walls[0].points[1] = [10.5, 0.0];
        let c = Scene::new(&moved);
        assert!(!Arc::ptr_eq(&a.statics, &c.statics));
        assert_eq!(c.ray_cast(&[], &Ray::at_angle(Point::new(1.0, 1.0), 0.0), 20.0), Some(9.25)); // the east wall now slants through (10.25, 1)
        let mut signed = corridor();
        signed.walls[0].points[0] = [-0.0, 0.0];
        let d = Scene::new(&signed);
        assert!(!Arc::ptr_eq(&a.statics, &d.statics));
        let weak = Arc::downgrade(&c.statics);
        drop(c);
        assert!(weak.upgrade().is_none(), "the last scene of a world frees its shapes");
    }

    /// Visiting the strips nearest first gives what looking at every shape gives, bit for bit:
    /// worlds of scattered shapes, origins inside and outside them, reaches up to infinite.
    #[test]
    fn the_strips_change_no_answer() {
        use crate::world::{BoxObstacle, Disc};
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut hits = 0;
        for world_no in 0..40 {
            let mut world = corridor();
            let point = |rng: &mut rand_chacha::ChaCha8Rng| {
                [rng.random_range(-5.0..60.0), rng.random_range(-2.0..4.0)]
            };
            let walls = rng.random_range(1..6);
            world.walls = (0..walls)
                .map(|_| {
                    let n = rng.random_range(2..8);
                    Wall { points: (0..n).map(|_| point(&mut rng)).collect(), closed: false }
                })
                .collect();
            world.boxes = (0..3)
                .map(|_| {
                    let [x, y] = point(&mut rng);
                    BoxObstacle { min: [x, y], max: [x + 0.3, y + 0.2] }
                })
                .collect();
            world.discs = (0..3).map(|_| Disc { center: point(&mut rng), radius: 0.2 }).collect();
            let scene = Scene::new(&world);
            assert!(scene.statics.strips.is_some());
            let every = Scene {
                statics: Arc::new(Statics { shapes: scene.statics.shapes.clone(), strips: None }),
                placed: Vec::new(),
            };
            for _ in 0..300 {
                let origin = Point::new(rng.random_range(-15.0..75.0), rng.random_range(-4.0..6.0));
                let axis = rng.random_range(-4.0..4.0);
                let offsets = [-0.2, -0.05, 0.0, 0.1, 0.2];
                let max = [0.3, 2.0, 6.0, 100.0][rng.random_range(0..4)];
                let movers = [Circle::new(Point::new(origin.x + 0.5, origin.y), 0.25)];
                assert_eq!(
                    scene.ray_fan(&movers, origin, axis, &offsets, max),
                    every.ray_fan(&movers, origin, axis, &offsets, max),
                    "world {world_no} at {origin:?}"
                );
                let ray = Ray::at_angle(origin, axis);
                let cast = scene.ray_cast(&[], &ray, f64::INFINITY);
                assert_eq!(cast, every.ray_cast(&[], &ray, f64::INFINITY), "world {world_no} at {origin:?}");
                hits += usize::from(cast.is_some_and(|t| t > 6.0));
            }
        }
        assert!(hits > 500, "the sample must hit things far away: {hits}");
    }
}
