//! Random tours: missions of places drawn at random where the robot can go, for measuring
//! navigation on any world (`orsa run --tour N`), not only at the places its author named.
//!
//! A tour's places are drawn from the seed, uniformly over the floor the body can reach from the
//! world's start on the true world (the report's own search: cells of 5 cm clear of every wall,
//! box and disc by the body's radius, joined without cutting corners), each with `margin_m` more
//! room than the body needs (a place a person would send a robot to, not one pressed against a
//! desk), and each at least `min_leg_m` in a straight line from the one before (from the start
//! for the first), so that every leg drives somewhere.

use super::navigation::Clearance;
use orsa_hardware::geometry::Point;
use orsa_hardware::world::World;
use rand::{Rng as _, SeedableRng as _};

/// How a tour is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TourSpec {
    /// How many places.
    pub places: usize,
    /// The body's radius, m.
    pub radius_m: f64,
    /// Room beyond the body's radius at each place, m.
    pub margin_m: f64,
    /// The least straight-line distance between two places in a row, m.
    pub min_leg_m: f64,
}

impl TourSpec {
    /// `places` places for a body of `radius_m`, with 0.15 m of room about each, 2 m apart.
    pub fn new(places: usize, radius_m: f64) -> Self {
        TourSpec { places, radius_m, margin_m: 0.15, min_leg_m: 2.0 }
    }
}

/// Why a tour cannot be drawn.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TourError {
    /// The body does not fit at the world's start.
    #[error("the robot's body ({radius_m} m) does not fit at the world's start")]
    StartBlocked {
        /// The body's radius.
        radius_m: f64,
    },
    /// Too little floor for the places asked.
    #[error(
        "no place with {margin_m} m of room about the body lies {min_leg_m} m or more from ({x:.2}, {y:.2}) where \
         the robot can go"
    )]
    NoRoom {
        /// The room asked about each place.
        margin_m: f64,
        /// The leg asked.
        min_leg_m: f64,
        /// The place before.
        x: f64,
        /// The place before.
        y: f64,
    },
}

/// The places of a tour of `world` drawn from `seed` (the same seed, the same places).
pub fn tour(world: &World, spec: TourSpec, seed: u64) -> Result<Vec<(f64, f64)>, TourError> {
    let clearance = Clearance::new(world, spec.radius_m, super::navigation::CELL_M);
    let start = (world.robot.x, world.robot.y);
    let reachable =
        clearance.reachable_from(start).ok_or(TourError::StartBlocked { radius_m: spec.radius_m })?;
    let shapes = world.static_shapes();
    let roomy = |p: (f64, f64)| {
        let p = Point::new(p.0, p.1);
        shapes.iter().all(|s| s.distance(&p) > spec.radius_m + spec.margin_m)
    };
    let candidates: Vec<(f64, f64)> =
        reachable.iter().map(|&i| clearance.centre(i)).filter(|&p| roomy(p)).collect();
    // A stream of its own: the same seed's run noise is not disturbed.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x746f_7572);
    let mut places = Vec::with_capacity(spec.places);
    let mut at = start;
    for _ in 0..spec.places {
        let far: Vec<(f64, f64)> =
            candidates.iter().copied().filter(|p| (p.0 - at.0).hypot(p.1 - at.1) >= spec.min_leg_m).collect();
        if far.is_empty() {
            return Err(TourError::NoRoom {
                margin_m: spec.margin_m,
                min_leg_m: spec.min_leg_m,
                x: at.0,
                y: at.1,
            });
        }
        let p = far[rng.random_range(0..far.len())];
        // To the centimetre: places are written as text (`--goto X,Y`) and read back.
        let p = ((p.0 * 100.0).round() / 100.0, (p.1 * 100.0).round() / 100.0);
        places.push(p);
        at = p;
    }
    Ok(places)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two rooms joined by a door the body passes, and a closed cupboard it cannot enter.
    fn rooms() -> World {
        World::from_str(
            r#"
            name = "two rooms"
            [robot]
            x = 1.0
            y = 1.0
            heading_deg = 0.0
            [[walls]]
            points = [[0.0, 0.0], [8.0, 0.0], [8.0, 4.0], [0.0, 4.0]]
            closed = true
            [[walls]]
            points = [[4.0, 0.0], [4.0, 1.5]]
            [[walls]]
            points = [[4.0, 2.5], [4.0, 4.0]]
            [[walls]]
            points = [[6.0, 2.5], [7.5, 2.5], [7.5, 3.5], [6.0, 3.5]]
            closed = true
            "#,
            "two rooms",
        )
        .expect("a valid world")
    }

    #[test]
    fn a_tour_is_drawn_where_the_body_can_go_with_room_and_the_same_seed_draws_the_same() {
        let world = rooms();
        let spec = TourSpec::new(40, 0.25);
        let places = tour(&world, spec, 3).expect("a tour");
        assert_eq!(places.len(), 40);
        assert_eq!(tour(&world, spec, 3).expect("a tour"), places);
        assert_ne!(tour(&world, spec, 4).expect("a tour"), places);
        let shapes = world.static_shapes();
        let mut at = (world.robot.x, world.robot.y);
        for &p in &places {
            let room = shapes.iter().map(|s| s.distance(&Point::new(p.0, p.1))).fold(f64::INFINITY, f64::min);
            assert!(room > 0.25 + 0.15 - 0.01, "{p:?}: only {room:.3} m of room");
            assert!((p.0 - at.0).hypot(p.1 - at.1) >= 2.0 - 0.01, "{p:?} too near {at:?}");
            // Inside the walls and never in the closed cupboard.
            assert!(p.0 > 0.0 && p.0 < 8.0 && p.1 > 0.0 && p.1 < 4.0, "{p:?}");
            assert!(!(p.0 > 6.0 && p.0 < 7.5 && p.1 > 2.5 && p.1 < 3.5), "{p:?} in the cupboard");
            at = p;
        }
        // Both rooms are visited.
        assert!(places.iter().any(|p| p.0 < 4.0) && places.iter().any(|p| p.0 > 4.0));
    }

    #[test]
    fn a_door_too_narrow_for_the_body_keeps_the_tour_on_its_side() {
        let world = rooms();
        // A body of 0.55 m radius does not pass the 1 m door.
        let places = tour(&world, TourSpec { margin_m: 0.05, min_leg_m: 1.0, ..TourSpec::new(30, 0.55) }, 1)
            .expect("a tour");
        assert!(places.iter().all(|p| p.0 < 4.0), "{places:?}");
        // Legs longer than the room allow no tour, and the error names where it stuck.
        let e = tour(&world, TourSpec { min_leg_m: 5.0, ..TourSpec::new(3, 0.55) }, 1).expect_err("no room");
        assert!(e.to_string().contains("5 m or more from (1.00, 1.00)"), "{e}");
        let e = tour(&world, TourSpec::new(3, 2.5), 1).expect_err("no body fits");
        assert!(matches!(e, TourError::StartBlocked { .. }), "{e}");
    }
}
