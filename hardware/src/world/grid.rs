//! A world as an occupancy grid: what a map server loads for the world the robot drives in.
//!
//! Every cell a wall, box or disc touches is occupied; so is a cell whose centre lies within
//! half a cell's diagonal of one (a cell the shape may graze: the grid errs towards occupied,
//! by less than a cell). The cells the robot can reach from its start pose without crossing an
//! occupied cell (4-connected) are free, and the rest (beyond the outer walls, inside closed
//! rooms) unknown. People are not in it: they move, and the map's live obstacle layer sees them.

use super::World;
use crate::geometry::{Point, Shape};
use orsa_interfaces::map::{FREE, OCCUPIED, OccupancyGrid, UNKNOWN};

/// The most cells a world's grid may have (a 1 km x 1 km floor at 5 cm is 400 million).
pub const MAX_CELLS: u64 = 100_000_000;

/// Why a world cannot be made a grid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// The cell size is not a positive finite number.
    #[error("a grid's resolution must be a positive finite number of metres, got {0}")]
    Resolution(f64),
    /// The grid would be too large.
    #[error(
        "a grid of {width} x {height} cells of {resolution_m} m is more than {MAX_CELLS} cells: use coarser cells"
    )]
    TooLarge {
        /// Cells along x.
        width: u64,
        /// Cells along y.
        height: u64,
        /// The cell size asked for, m.
        resolution_m: f64,
    },
}

/// Cells of margin around everything the world holds.
const MARGIN_CELLS: f64 = 2.0;

impl World {
    /// The world's walls, boxes and discs as an occupancy grid of `resolution_m` cells (see the
    /// module docs), covering all of them, the robot's start and the places with two cells to
    /// spare, the corner of cell (0, 0) on a multiple of the resolution.
    pub fn occupancy_grid(&self, resolution_m: f64) -> Result<OccupancyGrid, GridError> {
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return Err(GridError::Resolution(resolution_m));
        }
        let shapes = self.static_shapes();
        let mut points: Vec<Point> = vec![self.robot.position()];
        points.extend(self.places.iter().map(|p| p.position()));
        for s in &shapes {
            let b = s.bounds();
            points.extend([b.min, b.max]);
        }
        let lo = |f: fn(&Point) -> f64| points.iter().map(f).fold(f64::INFINITY, f64::min);
        let hi = |f: fn(&Point) -> f64| points.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
        let margin = MARGIN_CELLS * resolution_m;
        let origin_x = ((lo(|p| p.x) - margin) / resolution_m).floor() * resolution_m;
        let origin_y = ((lo(|p| p.y) - margin) / resolution_m).floor() * resolution_m;
        let width = ((hi(|p| p.x) + margin - origin_x) / resolution_m).ceil().max(1.0);
        let height = ((hi(|p| p.y) + margin - origin_y) / resolution_m).ceil().max(1.0);
        // The checked world has finite numbers: these are finite and positive.
        let (w, h) = (width as u64, height as u64);
        if w.saturating_mul(h) > MAX_CELLS {
            return Err(GridError::TooLarge { width: w, height: h, resolution_m });
        }
        let mut grid = OccupancyGrid::filled(resolution_m, w as u32, h as u32, (origin_x, origin_y), UNKNOWN);
        // A hair over half the diagonal: a cell that touches a shape at a corner only (a wall's
        // end on a cell's corner) is occupied too, whatever the rounding.
        let touch = resolution_m * std::f64::consts::FRAC_1_SQRT_2 * (1.0 + 1e-9);
        for s in &shapes {
            occupy(&mut grid, s, touch);
        }
        let start = grid.cell_of(self.robot.x, self.robot.y);
        if let Some(start) = start {
            fill_free(&mut grid, start);
        }
        Ok(grid)
    }
}

/// Marks occupied every cell of `grid` whose centre lies within `touch` of `shape`.
fn occupy(grid: &mut OccupancyGrid, shape: &Shape, touch: f64) {
    let b = shape.bounds();
    let r = grid.resolution_m;
    let col = |x: f64| ((x - grid.origin_x_m) / r).floor().clamp(0.0, f64::from(grid.width - 1)) as u32;
    let row = |y: f64| ((y - grid.origin_y_m) / r).floor().clamp(0.0, f64::from(grid.height - 1)) as u32;
    let (x0, x1) = (col(b.min.x - touch), col(b.max.x + touch));
    let (y0, y1) = (row(b.min.y - touch), row(b.max.y + touch));
    for iy in y0..=y1 {
        for ix in x0..=x1 {
            let (x, y) = grid.centre(ix, iy);
            if shape.distance(&Point::new(x, y)) <= touch {
                let i = grid.index(ix, iy);
                grid.cells[i] = OCCUPIED;
            }
        }
    }
}

/// Marks free every unknown cell reachable from `start` through unknown cells, 4-connected.
fn fill_free(grid: &mut OccupancyGrid, start: (u32, u32)) {
    let mut todo = vec![start];
    while let Some((ix, iy)) = todo.pop() {
        let i = grid.index(ix, iy);
        if grid.cells[i] != UNKNOWN {
            continue;
        }
        grid.cells[i] = FREE;
        if ix > 0 {
            todo.push((ix - 1, iy));
        }
        if iy > 0 {
            todo.push((ix, iy - 1));
        }
        if ix + 1 < grid.width {
            todo.push((ix + 1, iy));
        }
        if iy + 1 < grid.height {
            todo.push((ix, iy + 1));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{BoxObstacle, Disc, Place, RobotStart, Wall};

    /// A closed 4 m x 2 m room with a box, a disc and a closed cupboard (a room in the room the
    /// robot cannot reach).
    fn room() -> World {
        World {
            name: "room".into(),
            robot: RobotStart { x: 0.5, y: 1.0, heading_deg: 0.0 },
            walls: vec![
                Wall { points: vec![[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]], closed: true },
                Wall { points: vec![[3.0, 1.5], [3.8, 1.5], [3.8, 1.9], [3.0, 1.9]], closed: true },
            ],
            boxes: vec![BoxObstacle { min: [1.5, 0.0], max: [2.0, 0.6] }],
            discs: vec![Disc { center: [2.5, 1.4], radius: 0.15 }],
            movers: vec![],
            places: vec![Place { name: "corner".into(), x: 3.5, y: 0.4, heading_deg: None }],
        }
    }

    #[test]
    fn walls_boxes_and_discs_are_occupied_the_reachable_floor_free_and_the_rest_unknown() {
        let w = room();
        let g = w.occupancy_grid(0.05).expect("grid");
        assert_eq!(g.validate(), Ok(()));
        assert_eq!(g.resolution_m, 0.05);
        // Two cells of margin round the outer wall.
        assert!((g.origin_x_m + 0.1).abs() < 1e-9 && (g.origin_y_m + 0.1).abs() < 1e-9, "{g:?}");
        assert_eq!((g.width, g.height), (84, 44));
        for (x, y) in [(2.0, 0.0), (4.0, 1.0), (0.0, 1.99), (1.75, 0.3), (2.5, 1.4), (2.62, 1.4), (3.4, 1.5)]
        {
            assert_eq!(g.at(x, y), OCCUPIED, "({x}, {y})");
        }
        for (x, y) in [(0.5, 1.0), (1.0, 0.1), (3.5, 0.4), (2.5, 1.6), (3.9, 1.0), (2.7, 1.0)] {
            assert_eq!(g.at(x, y), FREE, "({x}, {y})");
        }
        // Beyond the walls, and inside the cupboard, nothing is known.
        for (x, y) in [(-0.07, 1.0), (2.0, 2.07), (3.4, 1.7)] {
            assert_eq!(g.at(x, y), UNKNOWN, "({x}, {y})");
        }
        // No free cell holds a piece of an obstacle.
        let shapes = w.static_shapes();
        for iy in 0..g.height {
            for ix in 0..g.width {
                if g.get(ix, iy) == Some(FREE) {
                    let (x, y) = g.centre(ix, iy);
                    let gap =
                        shapes.iter().map(|s| s.distance(&Point::new(x, y))).fold(f64::INFINITY, f64::min);
                    assert!(gap > 0.05 / 2f64.sqrt(), "free cell ({ix}, {iy}) is {gap} m from a shape");
                }
            }
        }
    }

    #[test]
    fn a_wall_along_a_diagonal_still_closes_the_room() {
        let mut w = room();
        w.walls = vec![Wall { points: vec![[0.0, 0.0], [3.0, 0.2], [1.0, 2.9]], closed: true }];
        w.boxes.clear();
        w.discs.clear();
        w.places.clear();
        w.robot = RobotStart { x: 1.3, y: 1.0, heading_deg: 0.0 };
        for res in [0.05, 0.1, 0.037] {
            let g = w.occupancy_grid(res).expect("grid");
            assert_eq!(g.at(1.3, 1.0), FREE);
            assert_eq!(g.at(3.0, 2.5), UNKNOWN, "at {res} m the flood leaked out");
        }
    }

    #[test]
    fn bad_resolutions_and_huge_grids_are_refused() {
        let w = room();
        assert_eq!(w.occupancy_grid(0.0), Err(GridError::Resolution(0.0)));
        let e = w.occupancy_grid(f64::NAN).expect_err("NaN cells");
        assert!(e.to_string().contains("got NaN"), "{e}");
        let e = w.occupancy_grid(1e-4).expect_err("too fine");
        assert!(e.to_string().contains("use coarser cells"), "{e}");
    }

    #[test]
    fn the_shipped_worlds_become_grids_with_the_start_and_places_free() {
        let office =
            World::from_path(concat!(env!("CARGO_MANIFEST_DIR"), "/../worlds/office.toml")).expect("office");
        for w in [World::palazzina().expect("palazzina"), office] {
            let g = w.occupancy_grid(0.05).expect("grid");
            assert_eq!(g.at(w.robot.x, w.robot.y), FREE, "{}", w.name);
            for p in &w.places {
                assert_eq!(g.at(p.x, p.y), FREE, "{}: {}", w.name, p.name);
            }
        }
    }
}
