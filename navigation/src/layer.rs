//! The map's live obstacle layer: what the range sensors see that the known map does not hold
//! (a person standing, a box moved in), marked where a beam echoes and cleared again where a
//! later beam passes through.
//!
//! Each beam is traced from its sensor along its axis over the grid's cells (Amanatides and
//! Woo's traversal, "A Fast Voxel Traversal Algorithm", 1987): the cells it crosses before its
//! echo are seen free, the cell of the echo is seen occupied. An echo marks its cell only within
//! `mark_range_m` (a far echo of a wide sonar beam says little about where along its arc the
//! thing is), and a beam clears only up to `clear_margin_m` short of its echo. What the known
//! map holds is never marked nor cleared: the layer holds only what differs from it. The
//! layered grid ([`ObstacleLayer::grid`]) is the known map with the marks on it.

use crate::mcl::{Beam, Pose2};
use orsa_interfaces::map::{GridError, OCCUPIED, OccupancyGrid};

/// The live obstacle layer over a known map (see the module docs).
#[derive(Debug, Clone)]
pub struct ObstacleLayer {
    known: OccupancyGrid,
    /// Per cell: whether a sensor saw something there that the known map does not hold.
    marked: Vec<bool>,
    mark_range_m: f64,
    clear_margin_m: f64,
    /// Bumped at every change of a mark.
    version: u64,
    /// Echoes within this distance of what the known map holds are the map's, m.
    explain_m: f64,
    /// The distance to the known map's nearest obstacle (when `explain_m` > 0).
    field: Option<crate::field::DistanceField>,
}

impl ObstacleLayer {
    /// An empty layer over `known`, marking echoes within `mark_range_m` and clearing up to
    /// `clear_margin_m` short of an echo.
    pub fn new(known: OccupancyGrid, mark_range_m: f64, clear_margin_m: f64) -> Result<Self, GridError> {
        known.validate()?;
        let marked = vec![false; known.cells.len()];
        Ok(ObstacleLayer {
            known,
            marked,
            mark_range_m,
            clear_margin_m,
            version: 0,
            explain_m: 0.0,
            field: None,
        })
    }

    /// Leaves unmarked the echoes within `explain_m` of what the known map holds: they are the
    /// known walls seen with a sensor's noise, or a cell's width off (an echo a centimetre in
    /// front of a wall falls in the free cell beside it). Without it, every such echo is a mark
    /// along the walls.
    pub fn explaining(mut self, explain_m: f64) -> Self {
        if explain_m.is_finite() && explain_m > 0.0 {
            self.field =
                Some(crate::field::DistanceField::of(&self.known, 2.0 * explain_m + self.known.resolution_m));
            self.explain_m = explain_m;
        }
        self
    }

    /// Takes the readings `beams` taken from `pose` (map frame); returns whether a mark changed.
    pub fn observe(&mut self, pose: Pose2, beams: &[Beam]) -> bool {
        let before = self.version;
        for b in beams {
            let (ox, oy) = pose.apply(b.origin.0, b.origin.1);
            let a = pose.theta + b.angle_rad;
            let (dx, dy) = (a.cos(), a.sin());
            let echo = b.range_m.filter(|r| r.is_finite() && *r >= 0.0 && *r < b.max_range_m);
            let free_to = match echo {
                Some(r) => (r - self.clear_margin_m).max(0.0),
                None => b.max_range_m,
            };
            let explained = |r: &f64| {
                self.field.as_ref().is_some_and(|f| f.at(ox + r * dx, oy + r * dy) <= self.explain_m)
            };
            let mark = echo
                .filter(|r| *r <= self.mark_range_m && !explained(r))
                .and_then(|r| self.known.cell_of(ox + r * dx, oy + r * dy))
                .map(|(ix, iy)| self.known.index(ix, iy));
            let mut cleared = Vec::new();
            self.traverse((ox, oy), (dx, dy), free_to, |i| cleared.push(i));
            // The echo's own cell is not cleared on the way to marking it again.
            for i in cleared.into_iter().filter(|i| Some(*i) != mark) {
                self.set(i, false);
            }
            if let Some(i) = mark {
                self.set(i, true);
            }
        }
        self.version != before
    }

    /// Marks or clears cell `i`, unless the known map holds it.
    fn set(&mut self, i: usize, mark: bool) {
        if self.known.cells[i] == OCCUPIED || self.marked[i] == mark {
            return;
        }
        self.marked[i] = mark;
        self.version += 1;
    }

    /// Calls `visit` with every cell the ray from `from` along the unit `dir` crosses within
    /// `length` m, in order, while it is on the grid.
    fn traverse(&self, from: (f64, f64), dir: (f64, f64), length: f64, mut visit: impl FnMut(usize)) {
        let g = &self.known;
        let r = g.resolution_m;
        let Some((mut ix, mut iy)) = g.cell_of(from.0, from.1) else { return };
        let step = |d: f64| if d > 0.0 { 1i64 } else { -1 };
        let (sx, sy) = (step(dir.0), step(dir.1));
        // The distance along the ray to the next cell boundary in x and y, and between them.
        let boundary =
            |p: f64, o: f64, i: u32, s: i64| o + (f64::from(i) + if s > 0 { 1.0 } else { 0.0 }) * r - p;
        let next = |b: f64, d: f64| if d == 0.0 { f64::INFINITY } else { b / d };
        let mut tx = next(boundary(from.0, g.origin_x_m, ix, sx), dir.0);
        let mut ty = next(boundary(from.1, g.origin_y_m, iy, sy), dir.1);
        let (dtx, dty) = (next(r, dir.0.abs()), next(r, dir.1.abs()));
        let mut t = 0.0;
        while t <= length {
            visit(g.index(ix, iy));
            if tx < ty {
                t = tx;
                tx += dtx;
                let n = i64::from(ix) + sx;
                if n < 0 || n >= i64::from(g.width) {
                    return;
                }
                ix = n as u32;
            } else {
                t = ty;
                ty += dty;
                let n = i64::from(iy) + sy;
                if n < 0 || n >= i64::from(g.height) {
                    return;
                }
                iy = n as u32;
            }
        }
    }

    /// Whether a sensor saw something at the point `(x, y)` that the known map does not hold.
    pub fn is_marked(&self, x: f64, y: f64) -> bool {
        self.known.cell_of(x, y).is_some_and(|(ix, iy)| self.marked[self.known.index(ix, iy)])
    }

    /// Clears every mark within `radius_m` of `(x, y)` (the robot's own footprint, which cannot
    /// hold an obstacle: what a sensor saw there has moved); returns whether a mark changed.
    pub fn clear_near(&mut self, x: f64, y: f64, radius_m: f64) -> bool {
        let before = self.version;
        self.for_cells_near(x, y, radius_m, |layer, i| layer.set(i, false));
        self.version != before
    }

    /// Clears every mark (a recovery: what was seen may have gone); returns whether one was.
    pub fn clear_all(&mut self) -> bool {
        let any = self.marked.iter().any(|m| *m);
        if any {
            self.marked.iter_mut().for_each(|m| *m = false);
            self.version += 1;
        }
        any
    }

    /// Whether any cell within `radius_m` of `(x, y)` is marked.
    pub fn marked_near(&mut self, x: f64, y: f64, radius_m: f64) -> bool {
        let mut any = false;
        self.for_cells_near(x, y, radius_m, |layer, i| any |= layer.marked[i]);
        any
    }

    /// The centre of the marked cell nearest `(x, y)` within `radius_m`, if there is one.
    pub fn nearest_mark(&mut self, x: f64, y: f64, radius_m: f64) -> Option<(f64, f64)> {
        self.nearest_mark_where(x, y, radius_m, |_| true)
    }

    /// The centre of the nearest marked cell within `radius_m` of `(x, y)` whose centre `keep`
    /// accepts (say, one ahead of the robot), if any.
    pub fn nearest_mark_where(
        &mut self,
        x: f64,
        y: f64,
        radius_m: f64,
        keep: impl Fn((f64, f64)) -> bool,
    ) -> Option<(f64, f64)> {
        let mut best: Option<(f64, usize)> = None;
        self.for_cells_near(x, y, radius_m, |layer, i| {
            if layer.marked[i] {
                let (px, py) = layer.centre(i);
                let d = (px - x).hypot(py - y);
                if best.is_none_or(|(b, _)| d < b) && keep((px, py)) {
                    best = Some((d, i));
                }
            }
        });
        best.map(|(_, i)| self.centre(i))
    }

    /// The centre of cell `i`.
    fn centre(&self, i: usize) -> (f64, f64) {
        let g = &self.known;
        let (ix, iy) = (i % g.width as usize, i / g.width as usize);
        (g.origin_x_m + (ix as f64 + 0.5) * g.resolution_m, g.origin_y_m + (iy as f64 + 0.5) * g.resolution_m)
    }

    /// Calls `visit` with the index of every cell whose centre is within `radius_m` of `(x, y)`.
    fn for_cells_near(&mut self, x: f64, y: f64, radius_m: f64, mut visit: impl FnMut(&mut Self, usize)) {
        let g = &self.known;
        let r = g.resolution_m;
        if !(x.is_finite() && y.is_finite() && radius_m.is_finite() && radius_m >= 0.0) {
            return;
        }
        let span = (radius_m / r).ceil() as i64 + 1;
        let cx = ((x - g.origin_x_m) / r).floor() as i64;
        let cy = ((y - g.origin_y_m) / r).floor() as i64;
        let (w, h) = (i64::from(g.width), i64::from(g.height));
        let mut cells = Vec::new();
        for iy in (cy - span).max(0)..=(cy + span).min(h - 1) {
            for ix in (cx - span).max(0)..=(cx + span).min(w - 1) {
                let px = g.origin_x_m + (ix as f64 + 0.5) * r;
                let py = g.origin_y_m + (iy as f64 + 0.5) * r;
                if (px - x).hypot(py - y) <= radius_m {
                    cells.push(g.index(ix as u32, iy as u32));
                }
            }
        }
        for i in cells {
            visit(self, i);
        }
    }

    /// How many cells are marked.
    pub fn marks(&self) -> usize {
        self.marked.iter().filter(|m| **m).count()
    }

    /// Bumped at every change of a mark.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The known map with the marks on it (marked cells occupied).
    pub fn grid(&self) -> OccupancyGrid {
        let mut g = self.known.clone();
        for (c, m) in g.cells.iter_mut().zip(&self.marked) {
            if *m {
                *c = OCCUPIED;
            }
        }
        g.version = self.version;
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::map::FREE;

    /// A 4 m x 2 m floor with a wall along its right end (x = 3.95).
    fn known() -> OccupancyGrid {
        let mut g = OccupancyGrid::filled(0.05, 80, 40, (0.0, 0.0), FREE);
        for iy in 0..40 {
            let i = g.index(79, iy);
            g.cells[i] = OCCUPIED;
        }
        g
    }

    fn ahead(range_m: Option<f64>) -> Beam {
        Beam { origin: (0.0, 0.0), angle_rad: 0.0, half_width_rad: 0.0, range_m, max_range_m: 3.0 }
    }

    #[test]
    fn the_nearest_mark_is_found_among_those_kept() {
        let mut layer = ObstacleLayer::new(known(), 2.0, 0.1).expect("valid");
        let robot = Pose2::new(1.5, 1.0, 0.0);
        let behind = Beam { angle_rad: std::f64::consts::PI, ..ahead(Some(0.3)) };
        assert!(layer.observe(robot, &[ahead(Some(0.8)), behind]));
        let near = layer.nearest_mark(1.5, 1.0, 1.0).expect("marks");
        assert!((near.0 - 1.2).abs() < 0.05, "the one behind is nearest: {near:?}");
        let ahead_only = layer.nearest_mark_where(1.5, 1.0, 1.0, |(x, _)| x > 1.5).expect("ahead");
        assert!((ahead_only.0 - 2.3).abs() < 0.05, "{ahead_only:?}");
        assert_eq!(layer.nearest_mark_where(1.5, 1.0, 0.5, |(x, _)| x > 1.5), None, "beyond the radius");
    }

    #[test]
    fn an_echo_the_map_does_not_explain_is_marked_and_cleared_when_a_beam_passes_through() {
        let mut layer = ObstacleLayer::new(known(), 2.0, 0.1).expect("valid");
        let robot = Pose2::new(0.5, 1.0, 0.0);
        // A box 1.2 m ahead: marked where the echo ends.
        assert!(layer.observe(robot, &[ahead(Some(1.2))]));
        assert!(layer.is_marked(1.72, 1.0) && layer.marks() == 1);
        assert_eq!(layer.grid().at(1.72, 1.0), OCCUPIED);
        assert_eq!(known().at(1.72, 1.0), FREE, "the known map is not touched");
        // The same again changes nothing.
        assert!(!layer.observe(robot, &[ahead(Some(1.2))]));
        // Moved away: the beam now reads past it (no echo within range), and clears it.
        assert!(layer.observe(robot, &[ahead(None)]));
        assert_eq!(layer.marks(), 0);
        assert_eq!(layer.grid().at(1.72, 1.0), FREE);
    }

    #[test]
    fn far_echoes_do_not_mark_and_known_walls_are_neither_marked_nor_cleared() {
        let mut layer = ObstacleLayer::new(known(), 1.0, 0.1).expect("valid");
        let robot = Pose2::new(0.5, 1.0, 0.0);
        assert!(!layer.observe(robot, &[ahead(Some(1.5))]), "beyond mark_range_m");
        // The wall at x = 3.95 echoes at 3.45 m: within range 3.5 m, it is known: nothing marked.
        let far = Beam { max_range_m: 5.0, ..ahead(Some(3.46)) };
        let mut near = ObstacleLayer::new(known(), 5.0, 0.1).expect("valid");
        assert!(!near.observe(robot, &[far]));
        assert_eq!(near.marks(), 0);
        // A beam passing along the wall's cells does not clear them.
        let along = Pose2::new(3.97, 0.1, std::f64::consts::FRAC_PI_2);
        near.observe(along, &[Beam { max_range_m: 1.5, ..ahead(None) }]);
        assert_eq!(near.grid().at(3.97, 1.0), OCCUPIED);
    }

    #[test]
    fn the_same_reading_again_changes_nothing_and_a_bad_grid_is_refused() {
        let mut layer = ObstacleLayer::new(known(), 2.0, 0.0).expect("valid");
        let robot = Pose2::new(1.01, 1.02, 0.4);
        assert!(layer.observe(robot, &[ahead(Some(0.5))]));
        assert!(
            !layer.observe(robot, &[ahead(Some(0.5))]),
            "the echo's own cell was cleared and marked again"
        );
        assert_eq!(layer.marks(), 1);
        let mut short = known();
        short.cells.pop();
        assert!(ObstacleLayer::new(short, 2.0, 0.1).is_err());
    }

    #[test]
    fn a_diagonal_beam_clears_every_cell_it_crosses() {
        let mut layer = ObstacleLayer::new(known(), 3.0, 0.0).expect("valid");
        // Mark a row of cells across the floor (y 1.2-1.25), then cross it with a diagonal beam.
        for k in 0..20 {
            let x = 1.025 + 0.05 * f64::from(k);
            layer.observe(Pose2::new(x, 0.2, std::f64::consts::FRAC_PI_2), &[ahead(Some(1.025))]);
        }
        assert_eq!(layer.marks(), 20);
        let diagonal = Pose2::new(0.21, 0.2, 1.0f64.atan2(1.0));
        layer.observe(diagonal, &[ahead(None)]);
        // y = x - 0.01 crosses the row (y 1.2-1.25) at x 1.21-1.26: cells 24 and 25.
        assert_eq!(layer.marks(), 18, "the diagonal clears the two cells of the row it crosses");
        assert!(!layer.is_marked(1.22, 1.22) && !layer.is_marked(1.27, 1.24));
        assert!(layer.is_marked(1.17, 1.22) && layer.is_marked(1.32, 1.22), "and no others");
    }
}
