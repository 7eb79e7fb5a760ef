//! Swept-circle collision: how far a circle can move along a straight displacement.
//!
//! A circle of radius `r` centred at `p` touches a shape exactly when `p` is within `r` of it,
//! that is, when `p` enters the shape grown by `r`: a disc grows into a bigger disc, a segment
//! into a capsule, a box into a rounded box (the union of the capsules around its four edges,
//! which the centre must cross before it can reach the box itself). So every question here is
//! about a moving *point* entering a disc or a capsule.

use super::{Circle, Point, Segment, Shape, Vector, norm2};

/// The first time `t >= 0` at which the point `p + t·d` is within `radius` of `center`, if ever.
/// Returns 0 when `p` already is.
/// How far inside counts as touching rather than overlapping: rounding, not geometry.
const TOUCH: f64 = 1e-9;

fn disc_entry(p: &Point, d: &Vector, center: &Point, radius: f64) -> Option<f64> {
    let (mx, my) = (p.x - center.x, p.y - center.y);
    let c = mx * mx + my * my - radius * radius;
    let b = mx * d.x + my * d.y;
    if c <= 0.0 {
        // Overlapping: entered already. Touching to within rounding: entering only when
        // moving inward, so a body can always leave what it touches.
        let depth = radius - (mx * mx + my * my).sqrt();
        return (depth > TOUCH || b < 0.0).then_some(0.0);
    }
    let a = d.x * d.x + d.y * d.y;
    if a == 0.0 || b >= 0.0 {
        return None;
    }
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    // The smaller root (-b - sqrt(disc)) / a, written as c / (-b + sqrt(disc)) for precision.
    Some(c / (-b + disc.sqrt()))
}

fn earliest(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, None) => x,
        (None, y) => y,
    }
}

/// The first time `t >= 0` at which `p + t·d` is within `radius` of `seg`, if ever.
/// Returns 0 when `p` already is.
fn capsule_entry(p: &Point, d: &Vector, seg: &Segment, radius: f64) -> Option<f64> {
    let dist = seg.distance(p);
    if dist <= radius {
        // As for a disc: touching to within rounding enters only when moving toward the
        // closest point (a segment is convex).
        let q = seg.closest_point(p);
        let inward = (q.x - p.x) * d.x + (q.y - p.y) * d.y;
        return (radius - dist > TOUCH || inward > 0.0).then_some(0.0);
    }
    let mut best = earliest(disc_entry(p, d, &seg.a, radius), disc_entry(p, d, &seg.b, radius));
    let (ex, ey) = (seg.b.x - seg.a.x, seg.b.y - seg.a.y);
    let len = norm2(ex, ey);
    if len > 0.0 {
        let (ux, uy) = (ex / len, ey / len);
        let (nx, ny) = (-uy, ux);
        let (wx, wy) = (p.x - seg.a.x, p.y - seg.a.y);
        let s0 = wx * nx + wy * ny;
        let rate = d.x * nx + d.y * ny;
        // Crossing the side of the capsule facing p, if p moves towards the segment's line.
        // No `|s0| > radius` condition: p is outside the capsule, so |s0| <= radius with its
        // projection inside the segment can only be rounding at exact contact, where the
        // answer is 0, not "never".
        if s0 * rate < 0.0 {
            let t = ((s0.abs() - radius) / rate.abs()).max(0.0);
            let along = (wx + d.x * t) * ux + (wy + d.y * t) * uy;
            if (0.0..=len).contains(&along) {
                best = earliest(best, Some(t));
            }
        }
    }
    best
}

/// The first time `t >= 0` at which a circle of `radius` centred at `center + t·displacement`
/// touches `shape`, if ever (0 if it already does). `t = 1` is the end of the displacement.
pub fn entry_time(shape: &Shape, center: &Point, displacement: &Vector, radius: f64) -> Option<f64> {
    match shape {
        Shape::Circle(Circle { center: c, radius: rc }) => disc_entry(center, displacement, c, radius + rc),
        Shape::Segment(s) => capsule_entry(center, displacement, s, radius),
        Shape::Aabb(b) => {
            if b.contains(center) {
                return Some(0.0);
            }
            b.edges()
                .iter()
                .fold(None, |acc, e| earliest(acc, capsule_entry(center, displacement, e, radius)))
        }
    }
}

/// The largest fraction `f` in `[0, 1]` of `displacement` that a circle of `radius` centred at
/// `center` can travel without coming closer than `radius` to `shape`.
///
/// When the circle already overlaps the shape (its centre is closer than `radius`, which
/// rounding can cause at exact contact), the whole displacement is allowed if it does not bring
/// the centre closer to the shape (convexity then guarantees it never does on the way) and none
/// of it otherwise: sliding along or backing away from a touched wall works, pushing into it
/// does not. A centre exactly on the shape cannot tell away from towards and never moves.
pub fn max_travel_fraction(shape: &Shape, center: &Point, displacement: &Vector, radius: f64) -> f64 {
    if displacement.x == 0.0 && displacement.y == 0.0 {
        return 1.0;
    }
    let q = shape.closest_point(center);
    let (ax, ay) = (center.x - q.x, center.y - q.y);
    let gap = norm2(ax, ay);
    // At exactly `radius` the body touches (entry_time would answer 0): moving away or along
    // must stay free, or a body stopped against a wall at the kept margin is glued to it.
    if gap <= radius {
        let away = displacement.x * ax + displacement.y * ay;
        return if gap > 0.0 && away >= 0.0 { 1.0 } else { 0.0 };
    }
    match entry_time(shape, center, displacement, radius) {
        Some(t) if t < 1.0 => t.max(0.0),
        _ => 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;

    const EPS: f64 = 1e-12;

    fn p(x: f64, y: f64) -> Point {
        Point::new(x, y)
    }
    fn v(x: f64, y: f64) -> Vector {
        Vector::new(x, y)
    }

    #[test]
    fn a_body_touching_exactly_can_leave_or_slide_but_not_push_in() {
        let wall = Shape::Segment(Segment::new(p(7.0, 0.0), p(14.0, 0.0)));
        let c = p(13.7824, 0.25 + 1e-6);
        let r = 0.25 + 1e-6;
        let h = 163.2f64.to_radians();
        assert_eq!(max_travel_fraction(&wall, &c, &v(0.0025 * h.cos(), 0.0025 * h.sin()), r), 1.0, "away");
        assert_eq!(max_travel_fraction(&wall, &c, &v(-0.0025, 0.0), r), 1.0, "along");
        assert_eq!(max_travel_fraction(&wall, &c, &v(0.0, -0.0025), r), 0.0, "into");
        let disc = Shape::Circle(Circle::new(p(0.0, 0.0), 1.0));
        assert_eq!(max_travel_fraction(&disc, &p(2.0, 0.0), &v(0.1, 0.0), 1.0), 1.0, "away from a disc");
        assert_eq!(max_travel_fraction(&disc, &p(2.0, 0.0), &v(-0.1, 0.0), 1.0), 0.0, "into a disc");
        // The case found in a run: touching a person to within rounding, moving away.
        let person = Shape::Circle(Circle::new(p(28.420168560325532, 0.6), 0.25));
        let at = p(28.8806, 0.4050);
        let gap = person.distance(&at);
        let h = 50.1f64.to_radians();
        let f = max_travel_fraction(&person, &at, &v(0.0025 * h.cos(), 0.0025 * h.sin()), gap);
        assert_eq!(f, 1.0, "moving away from a person it touches");
        assert_eq!(entry_time(&person, &at, &v(0.0025 * h.cos(), 0.0025 * h.sin()), gap + 1e-15), None);
    }

    #[test]
    fn circle_against_disc_head_on() {
        let disc = Shape::Circle(Circle::new(p(5.0, 0.0), 1.0));
        // Radii 1 + 1: contact when the centre reaches x = 3, 0.3 of the way.
        let f = max_travel_fraction(&disc, &p(0.0, 0.0), &v(10.0, 0.0), 1.0);
        assert!((f - 0.3).abs() < EPS, "{f}");
        // Passing beside it, 2.5 off axis, is free.
        let f = max_travel_fraction(&disc, &p(0.0, 2.5), &v(10.0, 0.0), 1.0);
        assert_eq!(f, 1.0);
    }

    #[test]
    fn circle_against_wall_face() {
        let wall = Shape::Segment(Segment::new(p(-10.0, 2.0), p(10.0, 2.0)));
        let f = max_travel_fraction(&wall, &p(0.0, 0.0), &v(0.0, 3.0), 0.5);
        assert!((f - 0.5).abs() < EPS, "{f}");
        // Diagonally: contact at y = 1.5 still, half of the y travel.
        let f = max_travel_fraction(&wall, &p(0.0, 0.0), &v(3.0, 3.0), 0.5);
        assert!((f - 0.5).abs() < EPS, "{f}");
        // Too short to reach it.
        assert_eq!(max_travel_fraction(&wall, &p(0.0, 0.0), &v(0.0, 1.0), 0.5), 1.0);
    }

    #[test]
    fn circle_against_wall_end() {
        // A wall from (2, -5) up to (2, 0); a circle at y = 0.5 moving +x meets its top end.
        let wall = Shape::Segment(Segment::new(p(2.0, -5.0), p(2.0, 0.0)));
        let f = max_travel_fraction(&wall, &p(0.0, 0.5), &v(4.0, 0.0), 1.0);
        let expected = (2.0 - 0.75_f64.sqrt()) / 4.0;
        assert!((f - expected).abs() < EPS, "{f} vs {expected}");
        // Above the end by more than the radius: free.
        assert_eq!(max_travel_fraction(&wall, &p(0.0, 1.01), &v(4.0, 0.0), 1.0), 1.0);
    }

    #[test]
    fn circle_against_box_corner_and_face() {
        let b = Shape::Aabb(Aabb::new(p(2.0, 2.0), p(4.0, 4.0)));
        // Along the diagonal into the corner (2, 2): contact at distance 1 from it.
        let f = max_travel_fraction(&b, &p(0.0, 0.0), &v(3.0, 3.0), 1.0);
        let expected = (2.0 - 1.0 / 2.0_f64.sqrt()) / 3.0;
        assert!((f - expected).abs() < EPS, "{f} vs {expected}");
        // Into the left face at y = 3: contact at x = 1.
        let f = max_travel_fraction(&b, &p(0.0, 3.0), &v(2.0, 0.0), 1.0);
        assert!((f - 0.5).abs() < EPS, "{f}");
    }

    #[test]
    fn touching_allows_sliding_and_backing_off_but_not_pushing() {
        let wall = Shape::Segment(Segment::new(p(-10.0, 0.0), p(10.0, 0.0)));
        let c = p(0.0, 0.5 - 1e-15); // a hair inside the contact distance
        assert_eq!(max_travel_fraction(&wall, &c, &v(1.0, 0.0), 0.5), 1.0, "slide");
        assert_eq!(max_travel_fraction(&wall, &c, &v(0.0, 1.0), 0.5), 1.0, "back off");
        assert_eq!(max_travel_fraction(&wall, &c, &v(1.0, -0.1), 0.5), 0.0, "push");
    }

    #[test]
    fn exact_contact_with_a_slanted_wall_blocks_pushing_into_it() {
        // Found by the no-penetration property test: at exact contact the closest-point
        // distance and the signed distance to the wall's line round differently.
        let wall = Shape::Segment(Segment::new(
            p(2.9343526449864656, 1.7368249086642762),
            p(3.3441585196917143, 1.3036070992980333),
        ));
        let c = p(3.3248570401473905, 1.6878054456127876);
        let d = v(-0.0740128728124758, -0.0463093767603582);
        let f = max_travel_fraction(&wall, &c, &d, 0.25 + 1e-6);
        assert!(f < 1e-6, "{f}");
    }

    #[test]
    fn entry_time_is_zero_when_already_overlapping() {
        let disc = Shape::Circle(Circle::new(p(0.0, 0.0), 1.0));
        assert_eq!(entry_time(&disc, &p(1.5, 0.0), &v(1.0, 0.0), 1.0), Some(0.0));
        let b = Shape::Aabb(Aabb::new(p(0.0, 0.0), p(1.0, 1.0)));
        assert_eq!(entry_time(&b, &p(0.5, 0.5), &v(1.0, 0.0), 0.1), Some(0.0));
    }

    #[test]
    fn perpendicular_approach_to_capsule_side_matches_closed_form() {
        let s = Segment::new(p(0.0, 0.0), p(4.0, 0.0));
        let t = capsule_entry(&p(1.0, 1.5), &v(0.0, -2.0), &s, 0.5).expect("hits");
        assert!((t - 0.5).abs() < EPS, "{t}");
    }
}
