//! The global planner: the shortest path for the robot's body over the map's grid, kept away
//! from walls where there is room.
//!
//! A cell is open to the robot's centre when it is known free and the nearest occupied cell is
//! farther than the robot's radius plus `clearance_m` (the grid inflated by the body, as Nav2's
//! costmap inflates it). A step between neighbouring cells (8-connected) costs its length,
//! more within `inflation_m` of the body's edge touching something (by `inflation_weight` at
//! the edge, falling to nothing at `inflation_m`), so that a path keeps to the middle of a
//! corridor or a door unless the detour costs more. The search is A* (the `pathfinding`
//! crate) with the straight-line distance as its heuristic, which never overestimates.

use crate::field::DistanceField;
use orsa_interfaces::map::{FREE, OccupancyGrid};

/// The planner's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanParams {
    /// The robot's radius, m.
    pub robot_radius_m: f64,
    /// The least gap a path leaves between the body and an occupied cell's centre, m.
    pub clearance_m: f64,
    /// How far from the body's edge an obstacle still makes a step dearer, m.
    pub inflation_m: f64,
    /// How much dearer a step is with the body's edge at `clearance_m` from something (0: not).
    pub inflation_weight: f64,
}

impl Default for PlanParams {
    fn default() -> Self {
        PlanParams { robot_radius_m: 0.25, clearance_m: 0.05, inflation_m: 0.5, inflation_weight: 2.0 }
    }
}

/// Why there is no path.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// A parameter is out of range.
    #[error("{key} must be a finite number >= 0 (radius > 0), got {value}")]
    Param {
        /// Its key.
        key: &'static str,
        /// Its value.
        value: f64,
    },
    /// The start is off the map or where the body does not fit.
    #[error("the start ({0:.2}, {1:.2}) is off the map or where the robot's body does not fit")]
    Start(f64, f64),
    /// The goal is off the map or where the body does not fit.
    #[error("the goal ({0:.2}, {1:.2}) is off the map, unknown, or where the robot's body does not fit")]
    Goal(f64, f64),
    /// The map is not a valid grid.
    #[error("the map: {0}")]
    Grid(#[from] orsa_interfaces::map::GridError),
    /// No path for the body joins them.
    #[error("no path wide enough for the robot joins ({0:.2}, {1:.2}) to ({2:.2}, {3:.2})")]
    NoPath(f64, f64, f64, f64),
}

/// A path: points in the map frame from the start to the goal, and its length.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    /// The points, from the start to the goal (both included, exactly).
    pub points: Vec<(f64, f64)>,
    /// Its length, m.
    pub length_m: f64,
}

/// How far from where the robot is estimated to be a path may start, when the body does not
/// fit there, m.
pub const START_SNAP_M: f64 = 0.25;

/// Cost units per metre: A* works on integers.
const UNITS_PER_M: f64 = 10_000.0;

/// What a step costs with nothing near, in cost units.
fn step_cost_free(resolution_m: f64, diagonal: bool) -> u64 {
    let len = resolution_m * if diagonal { std::f64::consts::SQRT_2 } else { 1.0 };
    (len * UNITS_PER_M).round() as u64
}

/// The shortest path for the body on `grid` from `from` to `to` (map frame), as the module
/// docs describe it.
pub fn plan(
    grid: &OccupancyGrid,
    from: (f64, f64),
    to: (f64, f64),
    p: &PlanParams,
) -> Result<Path, PlanError> {
    for (key, value) in [
        ("robot_radius_m", p.robot_radius_m),
        ("clearance_m", p.clearance_m),
        ("inflation_m", p.inflation_m),
        ("inflation_weight", p.inflation_weight),
    ] {
        if !(value.is_finite() && value >= 0.0) || (key == "robot_radius_m" && value <= 0.0) {
            return Err(PlanError::Param { key, value });
        }
    }
    grid.validate()?;
    let reach = p.robot_radius_m + p.clearance_m + p.inflation_m + grid.resolution_m;
    let field = DistanceField::of(grid, reach);
    let body = p.robot_radius_m + p.clearance_m;
    let open = |ix: u32, iy: u32| {
        let (x, y) = grid.centre(ix, iy);
        grid.get(ix, iy) == Some(FREE) && field.at(x, y) > body
    };
    let start = grid.cell_of(from.0, from.1).ok_or(PlanError::Start(from.0, from.1))?;
    // The start must hold the body (it may stand closer to something than the clearance); an
    // estimate of where the robot is can be a few centimetres into what it cannot be in (a
    // column's edge), so the nearest cell within START_SNAP_M that holds it will do.
    let holds = |(ix, iy): (u32, u32)| {
        let (x, y) = grid.centre(ix, iy);
        grid.get(ix, iy) == Some(FREE) && field.at(x, y) > p.robot_radius_m
    };
    let snapped = !holds(start);
    let start = if !snapped {
        start
    } else {
        // (No farther than the body's radius: never to the far side of a thin wall.)
        let snap_m = START_SNAP_M.min(p.robot_radius_m);
        let span = (snap_m / grid.resolution_m).ceil() as i64;
        let mut best: Option<(f64, (u32, u32))> = None;
        for dy in -span..=span {
            for dx in -span..=span {
                let (nx, ny) = (i64::from(start.0) + dx, i64::from(start.1) + dy);
                if nx < 0 || ny < 0 || nx >= i64::from(grid.width) || ny >= i64::from(grid.height) {
                    continue;
                }
                let c = (nx as u32, ny as u32);
                let (x, y) = grid.centre(c.0, c.1);
                let d = (x - from.0).hypot(y - from.1);
                if d <= snap_m && holds(c) && best.is_none_or(|(b, _)| d < b) {
                    best = Some((d, c));
                }
            }
        }
        best.ok_or(PlanError::Start(from.0, from.1))?.1
    };
    let goal =
        grid.cell_of(to.0, to.1).filter(|&(ix, iy)| open(ix, iy)).ok_or(PlanError::Goal(to.0, to.1))?;
    let step_cost = |ix: u32, iy: u32, diagonal: bool| {
        let (x, y) = grid.centre(ix, iy);
        let edge_gap = field.at(x, y) - body;
        let near = if p.inflation_m > 0.0 {
            ((p.inflation_m - edge_gap) / p.inflation_m).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let free = step_cost_free(grid.resolution_m, diagonal);
        free.max((free as f64 * (1.0 + p.inflation_weight * near)).round() as u64)
    };
    // The octile distance in the steps' own rounded units: the cost of the cheapest path with
    // no obstacle and no inflation, so never more than the true cost, and consistent.
    let (straight_u, diagonal_u) =
        (step_cost_free(grid.resolution_m, false), step_cost_free(grid.resolution_m, true));
    let heuristic = |&(ix, iy): &(u32, u32)| {
        let (dx, dy) = (u64::from(ix.abs_diff(goal.0)), u64::from(iy.abs_diff(goal.1)));
        let (lo, hi) = (dx.min(dy), dx.max(dy));
        lo * diagonal_u + (hi - lo) * straight_u
    };
    let successors = |&(ix, iy): &(u32, u32)| {
        let mut next = Vec::with_capacity(8);
        for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
            let (nx, ny) = (i64::from(ix) + dx, i64::from(iy) + dy);
            if nx < 0 || ny < 0 || nx >= i64::from(grid.width) || ny >= i64::from(grid.height) {
                continue;
            }
            let (nx, ny) = (nx as u32, ny as u32);
            let diagonal = dx != 0 && dy != 0;
            // A diagonal step must not cut a corner between two closed cells.
            if !open(nx, ny) || (diagonal && !(open(nx, iy) && open(ix, ny))) {
                continue;
            }
            next.push(((nx, ny), step_cost(nx, ny, diagonal)));
        }
        next
    };
    let (cells, _) = pathfinding::directed::astar::astar(&start, successors, heuristic, |c| *c == goal)
        .ok_or(PlanError::NoPath(from.0, from.1, to.0, to.1))?;
    let mut points = vec![from];
    // From a snapped start, first to the cell the body fits in, then on.
    let first = usize::from(!snapped);
    points.extend(
        cells
            .iter()
            .skip(first)
            .take(cells.len().saturating_sub(1 + first))
            .map(|&(ix, iy)| grid.centre(ix, iy)),
    );
    points.push(to);
    let length_m = points.windows(2).map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1)).sum();
    Ok(Path { points, length_m })
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::map::OCCUPIED;

    /// Two 4 m x 3 m rooms side by side, joined by a door `door_m` wide in the middle of the
    /// wall between them (x = 4).
    fn rooms(door_m: f64) -> OccupancyGrid {
        let mut g = OccupancyGrid::filled(0.05, 164, 64, (-0.1, -0.1), FREE);
        for iy in 0..g.height {
            for ix in 0..g.width {
                let (x, y) = g.centre(ix, iy);
                let outer = !(0.0..=8.0).contains(&x) || !(0.0..=3.0).contains(&y);
                let between = (x - 4.0).abs() < 0.05 && (y - 1.5).abs() > door_m / 2.0;
                if outer || between {
                    let i = g.index(ix, iy);
                    g.cells[i] = OCCUPIED;
                }
            }
        }
        g
    }

    #[test]
    fn a_path_goes_through_the_door_and_keeps_the_body_clear() {
        let g = rooms(1.0);
        let p = PlanParams::default();
        let path = plan(&g, (1.0, 0.6), (7.0, 2.6), &p).expect("a path");
        assert_eq!(path.points.first(), Some(&(1.0, 0.6)));
        assert_eq!(path.points.last(), Some(&(7.0, 2.6)));
        // Through the door, in its middle third.
        let at_wall = path.points.iter().find(|(x, _)| (x - 4.0).abs() < 0.03).expect("crosses x = 4");
        assert!((at_wall.1 - 1.5).abs() < 0.17, "crosses at y = {}", at_wall.1);
        // No point closer than the body to an occupied cell's centre.
        let field = DistanceField::of(&g, 5.0);
        for &(x, y) in &path.points[1..path.points.len() - 1] {
            assert!(field.at(x, y) > p.robot_radius_m + p.clearance_m, "({x}, {y})");
        }
        // Not much longer than the shortest line through the door's centre.
        let shortest = (3.0f64).hypot(0.9) + (3.0f64).hypot(1.1);
        assert!(
            path.length_m >= shortest - 0.05 && path.length_m < shortest * 1.15,
            "{} against {shortest}",
            path.length_m
        );
    }

    #[test]
    fn a_door_narrower_than_the_body_has_no_path_and_bad_ends_are_named() {
        let p = PlanParams::default();
        let narrow = rooms(0.45);
        assert!(matches!(plan(&narrow, (1.0, 0.6), (7.0, 2.6), &p), Err(PlanError::NoPath(..))));
        let g = rooms(1.0);
        assert_eq!(plan(&g, (1.0, 0.6), (20.0, 2.0), &p), Err(PlanError::Goal(20.0, 2.0)));
        assert_eq!(plan(&g, (1.0, 0.6), (4.0, 0.5), &p), Err(PlanError::Goal(4.0, 0.5)), "in the wall");
        assert_eq!(
            plan(&g, (0.02, 0.02), (7.0, 2.6), &p),
            Err(PlanError::Start(0.02, 0.02)),
            "body in the corner"
        );
        // An estimate a few centimetres into where the body cannot be plans from beside it,
        // the path still starting where the robot is said to be.
        let near = plan(&g, (0.12, 0.12), (7.0, 2.6), &p).expect("a path from beside the corner");
        assert_eq!(near.points.first(), Some(&(0.12, 0.12)));
        // Its first leg goes to where the body fits, then on from there.
        let field = DistanceField::of(&g, 1.0);
        let second = near.points[1];
        assert!(field.at(second.0, second.1) > p.robot_radius_m, "{second:?}");
        assert!((second.0 - 0.12).hypot(second.1 - 0.12) <= START_SNAP_M + 1e-9, "{second:?}");
        let mut short = rooms(1.0);
        short.cells.truncate(100);
        assert!(matches!(plan(&short, (1.0, 0.6), (7.0, 2.6), &p), Err(PlanError::Grid(_))));
        let bad = PlanParams { robot_radius_m: 0.0, ..p };
        assert!(matches!(
            plan(&g, (1.0, 0.6), (7.0, 2.6), &bad),
            Err(PlanError::Param { key: "robot_radius_m", .. })
        ));
    }

    #[test]
    fn inflation_keeps_a_path_off_the_wall_it_runs_along() {
        let g = rooms(1.0);
        let hug = PlanParams { inflation_weight: 0.0, ..PlanParams::default() };
        let keep = PlanParams::default();
        let field = DistanceField::of(&g, 5.0);
        // How far from anything the path runs half way along.
        let middle = |path: &Path| {
            let &(x, y) = path
                .points
                .iter()
                .min_by(|a, b| (a.0 - 2.0).abs().total_cmp(&(b.0 - 2.0).abs()))
                .expect("points");
            field.at(x, y)
        };
        // Along the bottom wall of the left room.
        let a = plan(&g, (0.5, 0.5), (3.5, 0.5), &hug).expect("path");
        let b = plan(&g, (0.5, 0.5), (3.5, 0.5), &keep).expect("path");
        assert!(middle(&b) > middle(&a) + 0.1, "{} against {}", middle(&b), middle(&a));
        assert!(b.length_m > a.length_m, "keeping off costs a detour");
    }
}
