//! The distance from every cell of an occupancy grid to the nearest occupied cell.
//!
//! Computed exactly (Felzenszwalb and Huttenlocher's linear-time Euclidean distance transform,
//! "Distance Transforms of Sampled Functions", 2012: a lower envelope of parabolas per column,
//! then per row), between cell centres. It is what scores a range reading against the map: the
//! end of a beam that falls far from anything occupied is unlikely (the likelihood field of
//! Thrun, Burgard and Fox, *Probabilistic Robotics*, 6.4).

use orsa_interfaces::map::{OCCUPIED, OccupancyGrid};

/// A cell at or above this occupancy counts as occupied.
pub const OCCUPIED_AT: i8 = 65;

/// Distances to the nearest occupied cell, per cell of a grid, m.
#[derive(Debug, Clone)]
pub struct DistanceField {
    /// Cells per metre (lookups multiply: they are the inner loop of localization).
    per_m: f64,
    origin: (f64, f64),
    width: u32,
    height: u32,
    /// Row-major as the grid; capped at `max_m`.
    metres: Vec<f32>,
    max_m: f64,
}

impl DistanceField {
    /// The field of `grid`, each distance capped at `max_m` (farther is as good as far).
    pub fn of(grid: &OccupancyGrid, max_m: f64) -> Self {
        let (w, h) = (grid.width as usize, grid.height as usize);
        // Squared distances in cells; "infinite" where nothing is occupied (far beyond any cap,
        // and finite, so that the envelope's arithmetic stays finite).
        let inf = 1e30;
        // (A grid short of cells, one never validated, counts the missing ones as unknown.)
        let mut d2: Vec<f64> = (0..w * h)
            .map(|i| if grid.cells.get(i).is_some_and(|&c| c >= OCCUPIED_AT) { 0.0 } else { inf })
            .collect();
        let mut f = Vec::new();
        let mut out = Vec::new();
        // Columns, then rows.
        for x in 0..w {
            f.clear();
            f.extend((0..h).map(|y| d2[y * w + x]));
            transform_1d(&f, &mut out);
            for y in 0..h {
                d2[y * w + x] = out[y];
            }
        }
        for y in 0..h {
            f.clear();
            f.extend_from_slice(&d2[y * w..(y + 1) * w]);
            transform_1d(&f, &mut out);
            d2[y * w..(y + 1) * w].copy_from_slice(&out);
        }
        let metres = d2.iter().map(|&c| (c.sqrt() * grid.resolution_m).min(max_m) as f32).collect();
        DistanceField {
            per_m: 1.0 / grid.resolution_m,
            origin: (grid.origin_x_m, grid.origin_y_m),
            width: grid.width,
            height: grid.height,
            metres,
            max_m,
        }
    }

    /// The distance from the centre of the cell holding the point `(x, y)` (map frame) to the
    /// nearest occupied cell's centre, m: the cap where the grid does not reach.
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let (fx, fy) = ((x - self.origin.0) * self.per_m, (y - self.origin.1) * self.per_m);
        if !(fx >= 0.0 && fy >= 0.0 && fx < f64::from(self.width) && fy < f64::from(self.height)) {
            return self.max_m;
        }
        f64::from(self.metres[fy as usize * self.width as usize + fx as usize])
    }

    /// The field with every distance `d` turned into `f(d)` (the cap too), looked up by
    /// [`Self::at`] as before: a score per cell computed once, where a search would compute it
    /// at every lookup.
    pub fn mapped(&self, f: impl Fn(f64) -> f64) -> DistanceField {
        DistanceField {
            metres: self.metres.iter().map(|&d| f(f64::from(d)) as f32).collect(),
            max_m: f(self.max_m),
            ..self.clone()
        }
    }

    /// The cap on distances, m.
    pub fn max_m(&self) -> f64 {
        self.max_m
    }
}

/// The squared-distance transform of one line of samples `f` (0 where occupied, large
/// elsewhere) into `out`: `out[q] = min_p (q - p)^2 + f[p]`.
fn transform_1d(f: &[f64], out: &mut Vec<f64>) {
    let n = f.len();
    out.clear();
    out.resize(n, 0.0);
    if n == 0 {
        return;
    }
    // The parabolas of the lower envelope (their vertices) and where each starts to be lowest.
    let mut v = vec![0usize; n];
    let mut z = vec![0f64; n + 1];
    let mut k = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    let meet = |q: usize, p: usize| {
        let (q, p) = (q as f64, p as f64);
        ((f[q as usize] + q * q) - (f[p as usize] + p * p)) / (2.0 * q - 2.0 * p)
    };
    for q in 1..n {
        let mut s = meet(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = meet(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = d * d + f[v[k]];
    }
}

/// Whether `occupancy` counts as occupied (for callers that test cells as the field does).
pub fn is_occupied(occupancy: i8) -> bool {
    (OCCUPIED_AT..=OCCUPIED).contains(&occupancy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::map::FREE;

    #[test]
    fn distances_are_exact_euclidean_ones_between_cell_centres() {
        let mut g = OccupancyGrid::filled(0.1, 30, 20, (0.0, 0.0), FREE);
        let occupied = [(3u32, 4u32), (20, 15), (29, 0), (10, 10)];
        for &(x, y) in &occupied {
            let i = g.index(x, y);
            g.cells[i] = OCCUPIED;
        }
        let field = DistanceField::of(&g, 100.0);
        for y in 0..20u32 {
            for x in 0..30u32 {
                let want = occupied
                    .iter()
                    .map(|&(ox, oy)| f64::from(ox.abs_diff(x)).hypot(f64::from(oy.abs_diff(y))) * 0.1)
                    .fold(f64::INFINITY, f64::min);
                let (cx, cy) = g.centre(x, y);
                let got = field.at(cx, cy);
                assert!((got - want).abs() < 1e-5, "cell ({x}, {y}): {got} against {want}");
            }
        }
        let capped = DistanceField::of(&g, 0.25);
        assert_eq!(capped.at(1.55, 0.05), 0.25_f32 as f64, "capped");
        assert_eq!(capped.at(-1.0, 0.5), 0.25, "off the grid: the cap");
    }

    #[test]
    fn a_grid_with_nothing_occupied_is_far_everywhere() {
        let g = OccupancyGrid::filled(0.05, 7, 3, (0.0, 0.0), FREE);
        let field = DistanceField::of(&g, 2.0);
        assert_eq!(field.at(0.1, 0.1), 2.0);
        assert!(is_occupied(OCCUPIED) && !is_occupied(FREE) && !is_occupied(-1));
    }
}
