//! Worlds and helpers shared by the integration tests.
#![allow(dead_code, unreachable_pub)]

use orsa_hardware::sim::{SimConfig, SimNomad200};
use orsa_hardware::world::{BoxObstacle, Disc, Mover, RobotStart, Wall, World};
use std::time::Duration;

/// An empty world with the robot at `(x, y)` facing `heading_deg`.
pub fn empty(x: f64, y: f64, heading_deg: f64) -> World {
    World {
        name: "test".into(),
        robot: RobotStart { x, y, heading_deg },
        walls: vec![],
        boxes: vec![],
        discs: vec![],
        movers: vec![],
        places: vec![],
    }
}

/// The robot at the origin facing `heading_deg`, with a long wall along x = `wall_x`.
pub fn facing_wall(wall_x: f64, heading_deg: f64) -> World {
    let mut w = empty(0.0, 0.0, heading_deg);
    w.walls.push(wall(&[[wall_x, -50.0], [wall_x, 50.0]]));
    w
}

/// A closed room from (0, 0) to (`w`, `h`) with the robot at `(x, y)`.
pub fn room(w: f64, h: f64, x: f64, y: f64, heading_deg: f64) -> World {
    let mut world = empty(x, y, heading_deg);
    world.walls.push(Wall { points: vec![[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]], closed: true });
    world
}

pub fn wall(points: &[[f64; 2]]) -> Wall {
    Wall { points: points.to_vec(), closed: false }
}

pub fn boxed(min: [f64; 2], max: [f64; 2]) -> BoxObstacle {
    BoxObstacle { min, max }
}

pub fn disc(center: [f64; 2], radius: f64) -> Disc {
    Disc { center, radius }
}

pub fn standing_person(at: [f64; 2], radius: f64) -> Mover {
    Mover { radius, speed: 0.0, path: vec![at, at], yield_distance: 0.6, start_delay: 0.0, patience: None }
}

/// A noiseless simulator of `world`.
pub fn exact(world: World) -> SimNomad200 {
    SimNomad200::new(world, SimConfig::noiseless(), 1).expect("valid test world")
}

pub fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}
