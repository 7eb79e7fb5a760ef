//! Exact-answer tests of distances and ray casts.

use super::*;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

const EPS: f64 = 1e-12;

fn p(x: f64, y: f64) -> Point {
    Point::new(x, y)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < EPS
}

#[test]
fn segment_distance_interior_and_ends() {
    let s = Segment::new(p(0.0, 0.0), p(4.0, 0.0));
    assert!(close(s.distance(&p(2.0, 3.0)), 3.0));
    assert!(close(s.distance(&p(-3.0, 4.0)), 5.0));
    assert!(close(s.distance(&p(7.0, -4.0)), 5.0));
    assert_eq!(s.closest_point(&p(1.5, -2.0)), p(1.5, 0.0));
    let dot = Segment::new(p(1.0, 1.0), p(1.0, 1.0));
    assert!(close(dot.distance(&p(4.0, 5.0)), 5.0));
}

#[test]
fn ray_meets_segment_at_known_distance() {
    let wall = Segment::new(p(3.0, -1.0), p(3.0, 1.0));
    let t = wall.ray_hit(&Ray::at_angle(p(0.0, 0.0), 0.0)).expect("hit");
    assert!(close(t, 3.0));
    // At 45 degrees up it meets x = 3 at y = 3: beyond the wall's end, a miss.
    assert_eq!(wall.ray_hit(&Ray::at_angle(p(0.0, 0.0), FRAC_PI_4)), None);
    // At atan(1/3) it meets the top end exactly, at sqrt(10).
    let t = wall.ray_hit(&Ray::at_angle(p(0.0, 0.0), (1.0_f64 / 3.0).atan())).expect("end");
    assert!(close(t, 10.0_f64.sqrt()), "{t}");
    // Pointing away.
    assert_eq!(wall.ray_hit(&Ray::at_angle(p(0.0, 0.0), PI)), None);
}

#[test]
fn ray_along_a_collinear_segment_meets_its_near_end() {
    let wall = Segment::new(p(2.0, 0.0), p(5.0, 0.0));
    let t = wall.ray_hit(&Ray::at_angle(p(0.0, 0.0), 0.0)).expect("collinear hit");
    assert!(close(t, 2.0));
    assert_eq!(wall.ray_hit(&Ray::at_angle(p(3.0, 0.0), 0.0)), Some(0.0));
    assert_eq!(wall.ray_hit(&Ray::at_angle(p(6.0, 0.0), 0.0)), None);
    // Parallel but offset: never.
    assert_eq!(wall.ray_hit(&Ray::at_angle(p(0.0, 0.1), 0.0)), None);
}

#[test]
fn circle_distance_and_ray() {
    let c = Circle::new(p(5.0, 0.0), 1.0);
    assert!(close(c.distance(&p(0.0, 0.0)), 4.0));
    assert_eq!(c.distance(&p(5.5, 0.0)), 0.0);
    let t = c.ray_hit(&Ray::at_angle(p(0.0, 0.0), 0.0)).expect("hit");
    assert!(close(t, 4.0));
    // Tangent-ish: offset by 0.6 meets the circle at x = 5 - 0.8.
    let t = c.ray_hit(&Ray::at_angle(p(0.0, 0.6), 0.0)).expect("hit");
    assert!(close(t, 4.2), "{t}");
    assert_eq!(c.ray_hit(&Ray::at_angle(p(0.0, 1.01), 0.0)), None);
    assert_eq!(c.ray_hit(&Ray::at_angle(p(5.2, 0.1), FRAC_PI_2)), Some(0.0));
    assert_eq!(c.ray_hit(&Ray::at_angle(p(0.0, 0.0), PI)), None);
}

#[test]
fn box_distance_and_ray() {
    let b = Aabb::new(p(1.0, 1.0), p(3.0, 2.0));
    assert!(close(b.distance(&p(0.0, 1.5)), 1.0));
    assert!(close(b.distance(&p(6.0, 6.0)), 5.0));
    assert_eq!(b.distance(&p(2.0, 1.5)), 0.0);
    let t = b.ray_hit(&Ray::at_angle(p(0.0, 1.5), 0.0)).expect("face");
    assert!(close(t, 1.0));
    let t = b.ray_hit(&Ray::at_angle(p(2.0, 5.0), -FRAC_PI_2)).expect("top");
    assert!(close(t, 3.0));
    // Into the corner (1, 1) along the diagonal from (0, 0).
    let t = b.ray_hit(&Ray::at_angle(p(0.0, 0.0), FRAC_PI_4)).expect("corner");
    assert!(close(t, 2.0_f64.sqrt()), "{t}");
    assert_eq!(b.ray_hit(&Ray::at_angle(p(0.0, 3.0), 0.0)), None);
    assert_eq!(b.ray_hit(&Ray::at_angle(p(2.0, 1.5), 1.0)), Some(0.0));
}

#[test]
fn shape_dispatches_to_its_primitive() {
    let shapes = [
        Shape::Segment(Segment::new(p(2.0, -1.0), p(2.0, 1.0))),
        Shape::Circle(Circle::new(p(3.0, 0.0), 1.0)),
        Shape::Aabb(Aabb::new(p(2.0, -1.0), p(4.0, 1.0))),
    ];
    let ray = Ray::at_angle(p(0.0, 0.0), 0.0);
    for s in &shapes {
        assert!(close(s.distance(&p(0.0, 0.0)), 2.0), "{s:?}");
        assert!(close(s.ray_hit(&ray).expect("hit"), 2.0), "{s:?}");
        assert_eq!(s.closest_point(&p(0.0, 0.0)), p(2.0, 0.0), "{s:?}");
    }
}
