//! The map: an occupancy grid of the robot's world, and the service that pushes it.
//!
//! | service | pattern | object |
//! |---|---|---|
//! | [`MAP`] | Push newest | [`OccupancyGrid`]: the map, at every change |
//! | [`KNOWN`] | Query | [`Empty`] -> [`KnownMap`]: the map as it stands and the places it names, for whoever joins late |
//!
//! The grid is laid out as ROS 2's `nav_msgs/msg/OccupancyGrid` lays one out, so that it
//! crosses to ROS 2 and to Foxglove's `foxglove.Grid` cell for cell: row-major from the cell at
//! the origin, x along a row, each cell `-1` (unknown) or an occupancy from `0` (free) to `100`
//! (occupied). The map component is called [`NAME`] in the default configuration.

use orsa_actors::comm_object;
use orsa_actors::service::{PushNewestService, QueryService};
use orsa_actors::{Empty, Timestamp};
use serde::{Deserialize, Serialize};

/// The map component's name in the default configuration.
pub const NAME: &str = "map";

/// The map, pushed at every change.
pub const MAP: PushNewestService<OccupancyGrid> = PushNewestService::new("map");

/// The map as it stands and its places: what a planner needs to send the robot to places,
/// wherever it runs (a Push newest subscriber only gets the next change; this is the map now).
pub const KNOWN: QueryService<Empty, KnownMap> = QueryService::new("known");

/// The frame the map is drawn in: the world file's coordinates.
pub const MAP_FRAME: &str = "map";

/// A cell no one has seen.
pub const UNKNOWN: i8 = -1;
/// A cell known to be free.
pub const FREE: i8 = 0;
/// A cell known to be occupied.
pub const OCCUPIED: i8 = 100;

/// An occupancy grid (service [`MAP`]): `width` x `height` square cells of `resolution_m`,
/// the corner of cell (0, 0) at `origin` in [`MAP_FRAME`], rows along +x.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// When the grid last changed.
    pub stamp: Timestamp,
    /// Bumped at every change, so that a subscriber can tell a new grid from the same one again.
    pub version: u64,
    /// The side of a cell, m.
    pub resolution_m: f64,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// The outer corner of cell (0, 0), in the map frame, m.
    pub origin_x_m: f64,
    /// See `origin_x_m`.
    pub origin_y_m: f64,
    /// `width * height` cells, row by row from `y = 0`: [`UNKNOWN`], or `0` ([`FREE`]) to
    /// `100` ([`OCCUPIED`]).
    pub cells: Vec<i8>,
}
comm_object!(OccupancyGrid, "orsa.map.OccupancyGrid/1");

/// What is wrong with a grid from outside (a peer's message, a file).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// The resolution is not a positive finite number.
    #[error("resolution_m must be a positive finite number, got {0}")]
    Resolution(f64),
    /// The origin is not finite.
    #[error("origin must be finite, got ({0}, {1})")]
    Origin(f64, f64),
    /// The cells do not fill the grid.
    #[error("a {width} x {height} grid needs {} cells, got {cells}", u64::from(*width) * u64::from(*height))]
    Cells {
        /// Cells along x.
        width: u32,
        /// Cells along y.
        height: u32,
        /// How many came.
        cells: usize,
    },
    /// A cell holds something else than -1 or 0 to 100.
    #[error("cell {index} holds {value}: a cell is -1 (unknown) or 0 to 100")]
    Value {
        /// Its index.
        index: usize,
        /// What it holds.
        value: i8,
    },
}

impl OccupancyGrid {
    /// A grid of `width` x `height` cells of `resolution_m`, every cell `fill`, the corner of
    /// cell (0, 0) at `origin`.
    pub fn filled(resolution_m: f64, width: u32, height: u32, origin: (f64, f64), fill: i8) -> Self {
        OccupancyGrid {
            stamp: Timestamp::ZERO,
            version: 0,
            resolution_m,
            width,
            height,
            origin_x_m: origin.0,
            origin_y_m: origin.1,
            cells: vec![fill; width as usize * height as usize],
        }
    }

    /// Checks a grid that came from outside.
    pub fn validate(&self) -> Result<(), GridError> {
        if !(self.resolution_m.is_finite() && self.resolution_m > 0.0) {
            return Err(GridError::Resolution(self.resolution_m));
        }
        if !(self.origin_x_m.is_finite() && self.origin_y_m.is_finite()) {
            return Err(GridError::Origin(self.origin_x_m, self.origin_y_m));
        }
        if self.cells.len() as u64 != u64::from(self.width) * u64::from(self.height) {
            return Err(GridError::Cells { width: self.width, height: self.height, cells: self.cells.len() });
        }
        match self.cells.iter().position(|c| !(UNKNOWN..=OCCUPIED).contains(c)) {
            Some(index) => Err(GridError::Value { index, value: self.cells[index] }),
            None => Ok(()),
        }
    }

    /// The cell holding the point `(x, y)` (map frame, m), if the grid covers it.
    pub fn cell_of(&self, x: f64, y: f64) -> Option<(u32, u32)> {
        let (fx, fy) = ((x - self.origin_x_m) / self.resolution_m, (y - self.origin_y_m) / self.resolution_m);
        let inside = fx >= 0.0 && fy >= 0.0 && fx < f64::from(self.width) && fy < f64::from(self.height);
        // In range: the truncation is the floor.
        inside.then_some((fx as u32, fy as u32))
    }

    /// The centre of cell `(ix, iy)`, map frame, m.
    pub fn centre(&self, ix: u32, iy: u32) -> (f64, f64) {
        (
            self.origin_x_m + (f64::from(ix) + 0.5) * self.resolution_m,
            self.origin_y_m + (f64::from(iy) + 0.5) * self.resolution_m,
        )
    }

    /// The index of cell `(ix, iy)` in `cells`.
    pub fn index(&self, ix: u32, iy: u32) -> usize {
        iy as usize * self.width as usize + ix as usize
    }

    /// Cell `(ix, iy)`, if the grid has it.
    pub fn get(&self, ix: u32, iy: u32) -> Option<i8> {
        (ix < self.width && iy < self.height).then(|| self.cells[self.index(ix, iy)])
    }

    /// The cell holding the point `(x, y)` (map frame, m): [`UNKNOWN`] off the grid.
    pub fn at(&self, x: f64, y: f64) -> i8 {
        self.cell_of(x, y).and_then(|(ix, iy)| self.get(ix, iy)).unwrap_or(UNKNOWN)
    }
}

/// A place the map names (the world file's `[[places]]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapPlace {
    /// Its name.
    pub name: String,
    /// x in the map, m.
    pub x_m: f64,
    /// y in the map, m.
    pub y_m: f64,
    /// The heading to end with there, degrees counter-clockwise from +x, if any.
    pub heading_deg: Option<f64>,
}

/// The map as it stands and the places it names (service [`KNOWN`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnownMap {
    /// The grid.
    pub grid: OccupancyGrid,
    /// The places, in the world file's order.
    pub places: Vec<MapPlace>,
}
comm_object!(KnownMap, "orsa.map.KnownMap/1");

impl KnownMap {
    /// Checks a map that came from outside: the grid, and places with names, unique, at finite
    /// coordinates.
    pub fn validate(&self) -> Result<(), String> {
        self.grid.validate().map_err(|e| format!("the grid: {e}"))?;
        for (i, p) in self.places.iter().enumerate() {
            if p.name.is_empty() {
                return Err(format!("places[{i}] has no name"));
            }
            if self.places[..i].iter().any(|q| q.name == p.name) {
                return Err(format!("places[{i}]: '{}' is named twice", p.name));
            }
            if !(p.x_m.is_finite() && p.y_m.is_finite() && p.heading_deg.is_none_or(f64::is_finite)) {
                return Err(format!("places[{i}] ('{}'): its coordinates are not finite numbers", p.name));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> OccupancyGrid {
        let mut g = OccupancyGrid::filled(0.05, 4, 3, (-0.1, 1.0), FREE);
        let i = g.index(3, 2);
        g.cells[i] = OCCUPIED;
        g.cells[0] = UNKNOWN;
        g
    }

    #[test]
    fn grid_round_trips() {
        let mut g = grid();
        g.stamp = Timestamp(1_500_000_000);
        g.version = 3;
        let json = serde_json::to_string(&g).expect("serialise");
        assert_eq!(serde_json::from_str::<OccupancyGrid>(&json).expect("deserialise"), g);
    }

    #[test]
    fn points_fall_in_the_cell_that_holds_them_and_off_the_grid_is_unknown() {
        let g = grid();
        assert_eq!(g.cell_of(-0.1, 1.0), Some((0, 0)), "the origin is cell (0, 0)'s corner");
        assert_eq!(g.cell_of(0.0999, 1.1499), Some((3, 2)));
        assert_eq!(g.at(0.0999, 1.1499), OCCUPIED);
        assert_eq!(g.cell_of(0.1, 1.0), None, "x past the last column");
        assert_eq!(g.cell_of(-0.1001, 1.0), None);
        assert_eq!(g.cell_of(f64::NAN, 1.0), None);
        assert_eq!(g.at(5.0, 5.0), UNKNOWN);
        assert_eq!(g.at(-0.09, 1.01), UNKNOWN, "cell 0 is unknown");
        assert_eq!(g.at(-0.04, 1.01), FREE);
        let (x, y) = g.centre(3, 2);
        assert!((x - 0.075).abs() < 1e-12 && (y - 1.125).abs() < 1e-12, "({x}, {y})");
        assert_eq!(g.get(4, 0), None);
    }

    #[test]
    fn grids_from_outside_are_checked() {
        assert_eq!(grid().validate(), Ok(()));
        let mut g = grid();
        g.cells.pop();
        assert_eq!(
            g.validate().map_err(|e| e.to_string()),
            Err("a 4 x 3 grid needs 12 cells, got 11".into())
        );
        let mut g = grid();
        g.cells[5] = 101;
        assert_eq!(g.validate(), Err(GridError::Value { index: 5, value: 101 }));
        let mut g = grid();
        g.resolution_m = 0.0;
        assert_eq!(g.validate(), Err(GridError::Resolution(0.0)));
        let mut g = grid();
        g.origin_y_m = f64::INFINITY;
        assert!(matches!(g.validate(), Err(GridError::Origin(..))));
    }

    #[test]
    fn known_maps_from_outside_are_checked() {
        let place = |name: &str, x_m: f64| MapPlace { name: name.into(), x_m, y_m: 1.0, heading_deg: None };
        let ok = KnownMap { grid: grid(), places: vec![place("a", 0.0), place("b", 0.0)] };
        assert_eq!(ok.validate(), Ok(()));
        let json = serde_json::to_string(&ok).expect("serialise");
        assert_eq!(serde_json::from_str::<KnownMap>(&json).expect("deserialise"), ok);
        let twice = KnownMap { places: vec![place("a", 0.0), place("a", 1.0)], ..ok.clone() };
        assert_eq!(twice.validate(), Err("places[1]: 'a' is named twice".into()));
        let nan = KnownMap { places: vec![place("a", f64::NAN)], ..ok.clone() };
        assert!(nan.validate().expect_err("NaN").contains("not finite"));
        let unnamed = KnownMap { places: vec![place("", 0.0)], ..ok.clone() };
        assert_eq!(unnamed.validate(), Err("places[0] has no name".into()));
        let mut bad = ok;
        bad.grid.cells.pop();
        assert!(bad.validate().expect_err("short").starts_with("the grid: "));
    }
}
