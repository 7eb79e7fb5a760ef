//! Monte Carlo localization: the robot's pose in the map from its odometry and its range
//! readings, as a cloud of weighted guesses (particles).
//!
//! The textbook algorithm (Thrun, Burgard and Fox, *Probabilistic Robotics*, 2005), as Nav2's
//! AMCL runs it, with a fixed number of particles:
//! - **predict**: each particle moves as the odometry says the robot moved since the last
//!   update, with noise growing with the turn and the travel (the odometry motion model,
//!   table 5.6; `alpha` are its four noise parameters, as AMCL's `alpha1`-`alpha4`);
//! - **correct**: each particle is weighed by how well the readings fit the map from where it
//!   stands: the end of every beam that echoed is scored by its distance to the nearest
//!   occupied cell (the likelihood field, 6.4: `z_hit` of a normal of `sigma_hit_m`, plus
//!   `z_rand` spread over the range). Beams with no echo say nothing (AMCL does the same);
//! - **resample** (low variance, 4.3) when the weights have become uneven (fewer than half the
//!   particles' worth of effective samples);
//! - **recover** (augmented MCL, 8.3.5): a short-term and a long-term average of how well the
//!   readings fit (per beam, so that the number of beams does not matter) are kept; while the
//!   short one falls below the long one, a share of the particles is redrawn at random free
//!   places of the map. A robot that got lost, or was carried elsewhere (kidnapped), is found
//!   again as it drives.
//!
//! The defaults (1000 particles, `sigma_hit_m` 0.1, `alpha` 0.03, `recovery_ratio` 0.5) keep
//! track of the simulated Nomad 200 on the corridor and the office floor from its start pose
//! (`tests/localization.rs`: RMS 0.035-0.05 m where its odometry ends 0.4 m off). They are
//! made for tracking: the textbook's recovery (`recovery_ratio` 1) redraws particles at every
//! dip of a sonar ring's fit, and in a corridor the redrawn ones pull the estimate along it
//! (RMS 18-25 m). Looking for a robot that could be anywhere wants a wider score and the
//! textbook's recovery ([`MclParams::searching`]): on a synthetic 10 m x 6 m room with a 16-beam
//! ring (`mcl/tests.rs`, chosen on seeds 1-6, checked on 7-18) it was found from anywhere
//! within 30 s of driving 10 times in 12 and again after a kidnapping 12 in 12; the defaults
//! find it from anywhere 3 times in 12. One setting for both is not found yet.
//!
//! Updates happen after the robot moved `update_min_m` or turned `update_min_rad` (AMCL's
//! `update_min_d` and `update_min_a`): standing still, the same readings would only make the
//! cloud overconfident. Every random draw comes from one seeded generator: a seed gives the
//! same estimates.

use crate::field::DistanceField;
use orsa_interfaces::map::{FREE, OccupancyGrid};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::{PI, TAU};

/// A pose in the plane: position, m, and heading, rad counter-clockwise from +x.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
    /// Heading, rad.
    pub theta: f64,
}

impl Pose2 {
    /// The pose `(x, y, theta)`.
    pub fn new(x: f64, y: f64, theta: f64) -> Self {
        Pose2 { x, y, theta }
    }

    /// The point `(px, py)` given in this pose's frame, in the frame this pose is given in.
    pub fn apply(&self, px: f64, py: f64) -> (f64, f64) {
        let (s, c) = self.theta.sin_cos();
        (self.x + c * px - s * py, self.y + s * px + c * py)
    }
}

/// One range reading, as localization uses it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beam {
    /// Where the sensor sits on the body, m (x ahead, y left).
    pub origin: (f64, f64),
    /// Which way it looks, rad from the body's front.
    pub angle_rad: f64,
    /// Half its beam's width, rad: a wide beam (a sonar's) reads the nearest echo anywhere
    /// across it, so the reading is scored along the direction across the beam that fits the
    /// map best (5 directions are tried); a narrow one (below 0.02 rad) along its axis.
    pub half_width_rad: f64,
    /// What it read, m from its origin (`None`: no echo within its range).
    pub range_m: Option<f64>,
    /// The farthest it reads, m.
    pub max_range_m: f64,
}

/// Localization's parameters (AMCL's names in brackets).
#[derive(Debug, Clone, PartialEq)]
pub struct MclParams {
    /// How many particles (`max_particles`; fixed here).
    pub particles: usize,
    /// Odometry noise: turn from turn, turn from travel (rad/m), travel from travel, travel
    /// from turn (m/rad) (`alpha1`-`alpha4`).
    pub alpha: [f64; 4],
    /// The spread of a beam's end about the map's nearest obstacle, m (`sigma_hit`).
    pub sigma_hit_m: f64,
    /// The weight of a reading that fits the map (`z_hit`).
    pub z_hit: f64,
    /// The weight of a reading that fits nothing (`z_rand`).
    pub z_rand: f64,
    /// How fast the long-term fit follows (`recovery_alpha_slow`).
    pub alpha_slow: f64,
    /// How fast the short-term fit follows (`recovery_alpha_fast`).
    pub alpha_fast: f64,
    /// Particles are redrawn at random only while the short-term fit is below this share of
    /// the long-term one (1: whenever it is below, as the textbook has it). A real ring's fit
    /// wavers (a sonar's cone, a person passing): at 1, the redrawn particles that fit a
    /// corridor as well as the right ones pull the estimate along it.
    pub recovery_ratio: f64,
    /// The travel between updates, m (`update_min_d`).
    pub update_min_m: f64,
    /// The turn between updates, rad (`update_min_a`).
    pub update_min_rad: f64,
    /// Beyond this distance from an obstacle, a beam's end scores as badly as anywhere, m
    /// (`laser_likelihood_max_dist`).
    pub field_max_m: f64,
}

impl Default for MclParams {
    fn default() -> Self {
        MclParams {
            particles: 1000,
            alpha: [0.03, 0.03, 0.03, 0.015],
            sigma_hit_m: 0.1,
            z_hit: 0.9,
            z_rand: 0.1,
            alpha_slow: 0.001,
            alpha_fast: 0.1,
            recovery_ratio: 0.5,
            update_min_m: 0.05,
            update_min_rad: 0.1,
            field_max_m: 1.0,
        }
    }
}

/// Why localization cannot be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MclError {
    /// A parameter is out of range.
    #[error("{key}: {problem}")]
    Param {
        /// The parameter's key.
        key: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The map has no free cell to place the robot in.
    #[error("the map has no free cell: there is nowhere to look for the robot")]
    NoFreeCell,
    /// The map is not a valid grid.
    #[error("the map: {0}")]
    Grid(#[from] orsa_interfaces::map::GridError),
    /// A pose given by hand is not finite, or its spreads not finite and >= 0.
    #[error("a pose must be finite and its spreads finite and >= 0, got {0:?} +- {1} m, {2} rad")]
    Pose(Pose2, f64, f64),
}

impl MclParams {
    /// Parameters for looking for a robot that could be anywhere (or was carried elsewhere):
    /// readings scored with `sigma_hit_m` 0.2, odometry trusted less, and the textbook's
    /// recovery (see the module docs).
    pub fn searching() -> Self {
        MclParams {
            sigma_hit_m: 0.2,
            alpha: [0.1, 0.1, 0.1, 0.05],
            recovery_ratio: 1.0,
            ..MclParams::default()
        }
    }

    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), MclError> {
        let bad = |key, problem: String| Err(MclError::Param { key, problem });
        if !(1..=1_000_000).contains(&self.particles) {
            return bad("particles", format!("must be 1 to 1000000, got {}", self.particles));
        }
        if let Some(a) = self.alpha.iter().find(|a| !(a.is_finite() && **a >= 0.0)) {
            return bad("alpha", format!("must be finite and >= 0, got {a}"));
        }
        let positive = [
            ("sigma_hit_m", self.sigma_hit_m),
            ("field_max_m", self.field_max_m),
            ("update_min_m", self.update_min_m),
            ("update_min_rad", self.update_min_rad),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(key, format!("must be a positive finite number, got {v}"));
            }
        }
        let shares = [
            ("z_hit", self.z_hit),
            ("z_rand", self.z_rand),
            ("alpha_slow", self.alpha_slow),
            ("alpha_fast", self.alpha_fast),
            ("recovery_ratio", self.recovery_ratio),
        ];
        for (key, v) in shares {
            if !(0.0..=1.0).contains(&v) {
                return bad(key, format!("must be within 0 to 1, got {v}"));
            }
        }
        if self.z_hit + self.z_rand <= 0.0 {
            return bad("z_hit", "z_hit and z_rand cannot both be 0".into());
        }
        if self.alpha_slow >= self.alpha_fast && self.alpha_fast > 0.0 {
            return bad(
                "alpha_slow",
                format!("must be below alpha_fast ({}), got {}", self.alpha_fast, self.alpha_slow),
            );
        }
        Ok(())
    }
}

/// The estimate: the particles' weighted mean and their covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The mean pose.
    pub pose: Pose2,
    /// Covariance of (x, y, theta), m^2, m rad, rad^2.
    pub covariance: [[f64; 3]; 3],
}

#[derive(Debug, Clone, Copy)]
struct Particle {
    pose: Pose2,
    weight: f64,
}

/// Monte Carlo localization on one map (see the module docs).
#[derive(Debug, Clone)]
pub struct Localizer {
    params: MclParams,
    field: DistanceField,
    /// The centres of the map's free cells: where a lost robot may be.
    free: Vec<(f64, f64)>,
    resolution_m: f64,
    particles: Vec<Particle>,
    rng: ChaCha8Rng,
    /// The long- and short-term averages of the fit per beam (augmented MCL).
    w_slow: f64,
    w_fast: f64,
    /// The odometry at the last update.
    last_odom: Option<Pose2>,
    /// How many updates were made.
    updates: u64,
    /// Per farthest range a beam reads (its bits), the field turned into the log score of a
    /// beam's end in each cell: the score depends only on the distance there and the range, so
    /// it is computed once per cell rather than for every beam of every particle at every update
    /// (made at a range's first use).
    scores: Vec<(u64, DistanceField)>,
}

/// `a` wrapped into (-pi, pi].
pub fn wrap(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w <= -PI { w + TAU } else { w }
}

impl Localizer {
    /// Localization on `grid`, its draws seeded with `seed`, its particles spread over the
    /// free cells until [`Self::reset_at`] says where the robot starts.
    pub fn new(grid: &OccupancyGrid, params: MclParams, seed: u64) -> Result<Self, MclError> {
        params.validate()?;
        grid.validate()?;
        let free: Vec<(f64, f64)> = (0..grid.height)
            .flat_map(|iy| (0..grid.width).map(move |ix| (ix, iy)))
            .filter(|&(ix, iy)| grid.get(ix, iy) == Some(FREE))
            .map(|(ix, iy)| grid.centre(ix, iy))
            .collect();
        if free.is_empty() {
            return Err(MclError::NoFreeCell);
        }
        let field = DistanceField::of(grid, params.field_max_m);
        let mut l = Localizer {
            params,
            field,
            free,
            resolution_m: grid.resolution_m,
            particles: Vec::new(),
            rng: ChaCha8Rng::seed_from_u64(seed),
            w_slow: 0.0,
            w_fast: 0.0,
            last_odom: None,
            updates: 0,
            scores: Vec::new(),
        };
        l.reset_global();
        Ok(l)
    }

    /// Spreads the particles about `pose`: normal with `sigma_m` in x and y and `sigma_rad`
    /// in heading (a pose given by hand, as RViz's "2D Pose Estimate").
    pub fn reset_at(&mut self, pose: Pose2, sigma_m: f64, sigma_rad: f64) -> Result<(), MclError> {
        let finite = [pose.x, pose.y, pose.theta, sigma_m, sigma_rad].iter().all(|v| v.is_finite());
        if !finite || sigma_m < 0.0 || sigma_rad < 0.0 {
            return Err(MclError::Pose(pose, sigma_m, sigma_rad));
        }
        let n = self.params.particles;
        let w = 1.0 / n as f64;
        self.particles = (0..n)
            .map(|_| {
                let (dx, dy, dt) = (self.normal(sigma_m), self.normal(sigma_m), self.normal(sigma_rad));
                Particle { pose: Pose2::new(pose.x + dx, pose.y + dy, wrap(pose.theta + dt)), weight: w }
            })
            .collect();
        self.w_slow = 0.0;
        self.w_fast = 0.0;
        Ok(())
    }

    /// Spreads the particles uniformly over the free cells, every heading alike: the robot
    /// could be anywhere.
    pub fn reset_global(&mut self) {
        let n = self.params.particles;
        self.particles =
            (0..n).map(|_| Particle { pose: self.random_pose(), weight: 1.0 / n as f64 }).collect();
        self.w_slow = 0.0;
        self.w_fast = 0.0;
    }

    /// Takes the odometry pose `odom` and the readings `beams` taken there; updates the
    /// particles if the robot moved enough since the last update (returns whether it did). An
    /// odometry pose that is not finite is ignored.
    pub fn update(&mut self, odom: Pose2, beams: &[Beam]) -> bool {
        if !(odom.x.is_finite() && odom.y.is_finite() && odom.theta.is_finite()) {
            return false;
        }
        let Some(last) = self.last_odom else {
            self.last_odom = Some(odom);
            return false;
        };
        let (dx, dy) = (odom.x - last.x, odom.y - last.y);
        let dtheta = wrap(odom.theta - last.theta);
        if dx.hypot(dy) < self.params.update_min_m && dtheta.abs() < self.params.update_min_rad {
            return false;
        }
        self.predict(last, odom);
        self.last_odom = Some(odom);
        self.correct(beams);
        self.updates += 1;
        true
    }

    /// How many updates were made.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// The odometry motion model: every particle moves by the motion from `from` to `to`
    /// (odometry frame), with noise.
    fn predict(&mut self, from: Pose2, to: Pose2) {
        let (dx, dy) = (to.x - from.x, to.y - from.y);
        let mut trans = dx.hypot(dy);
        let mut rot1 = if trans < 0.01 { 0.0 } else { wrap(dy.atan2(dx) - from.theta) };
        // Driving backwards: a turn of about pi and a positive travel would mean something else.
        if rot1.abs() > PI / 2.0 {
            rot1 = wrap(rot1 - PI);
            trans = -trans;
        }
        let rot2 = wrap(to.theta - from.theta - rot1);
        let [a1, a2, a3, a4] = self.params.alpha;
        let sd_rot1 = (a1 * rot1 * rot1 + a2 * trans * trans).sqrt();
        let sd_trans = (a3 * trans * trans + a4 * (rot1 * rot1 + rot2 * rot2)).sqrt();
        let sd_rot2 = (a1 * rot2 * rot2 + a2 * trans * trans).sqrt();
        for i in 0..self.particles.len() {
            let r1 = rot1 - self.normal(sd_rot1);
            let t = trans - self.normal(sd_trans);
            let r2 = rot2 - self.normal(sd_rot2);
            let p = &mut self.particles[i].pose;
            p.x += t * (p.theta + r1).cos();
            p.y += t * (p.theta + r1).sin();
            p.theta = wrap(p.theta + r1 + r2);
        }
    }

    /// Weighs the particles by `beams`, keeps the fit's averages, resamples when due.
    fn correct(&mut self, beams: &[Beam]) {
        let hits: Vec<&Beam> = beams
            .iter()
            .filter(|b| {
                let placed = [b.origin.0, b.origin.1, b.angle_rad, b.half_width_rad, b.max_range_m]
                    .iter()
                    .all(|v| v.is_finite());
                placed && b.range_m.is_some_and(|r| r.is_finite() && r >= 0.0 && r < b.max_range_m)
            })
            .collect();
        if hits.is_empty() {
            return;
        }
        // Where each echo falls in the body's frame, along each direction across its beam:
        // the same for every particle, so the trigonometry is done once per update.
        let ends: Vec<(usize, Vec<(f64, f64)>)> = hits
            .iter()
            .map(|b| {
                let r = b.range_m.unwrap_or(b.max_range_m);
                let end = |a: f64| (b.origin.0 + r * a.cos(), b.origin.1 + r * a.sin());
                let points = if b.half_width_rad < 0.02 {
                    vec![end(b.angle_rad)]
                } else {
                    (-2..=2).map(|k| end(b.angle_rad + b.half_width_rad * f64::from(k) / 2.0)).collect()
                };
                (self.score_field(b.max_range_m), points)
            })
            .collect();
        let p = &self.params;
        let logs: Vec<f64> = self
            .particles
            .iter()
            .map(|part| {
                let pose = part.pose;
                let (sin, cos) = pose.theta.sin_cos();
                ends.iter()
                    .map(|(score, points)| self.beam_score(&self.scores[*score].1, pose, sin, cos, points))
                    .sum::<f64>()
                    + part.weight.ln()
            })
            .collect();
        let top = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !top.is_finite() {
            // Nothing to weigh by (cannot happen with the floor, but weights must never turn NaN).
            let w = 1.0 / self.particles.len() as f64;
            self.particles.iter_mut().for_each(|q| q.weight = w);
            return;
        }
        let mut total = 0.0;
        for (part, l) in self.particles.iter_mut().zip(&logs) {
            part.weight = (l - top).exp();
            total += part.weight;
        }
        for part in &mut self.particles {
            part.weight /= total;
        }
        // The readings' likelihood averaged over the particles as they were weighed (the prior
        // weights sum to 1), per beam (a geometric mean, so that it does not depend on how
        // many echoed).
        let n = self.particles.len() as f64;
        let mean_log = top + total.ln();
        let fit = (mean_log / hits.len() as f64).exp();
        // (A fit that is not a positive number would stop recovery for good: it is skipped.)
        if fit.is_finite() && fit > 0.0 {
            if self.w_slow == 0.0 {
                (self.w_slow, self.w_fast) = (fit, fit);
            } else {
                self.w_slow += p.alpha_slow * (fit - self.w_slow);
                self.w_fast += p.alpha_fast * (fit - self.w_fast);
            }
        }
        let inject = (1.0 - self.w_fast / (p.recovery_ratio * self.w_slow)).max(0.0);
        let neff = 1.0 / self.particles.iter().map(|q| q.weight * q.weight).sum::<f64>();
        if neff < n / 2.0 || inject > 0.0 {
            self.resample(inject);
        }
    }

    /// Low-variance resampling, each new particle drawn at a random free place instead with
    /// probability `inject`.
    fn resample(&mut self, inject: f64) {
        let n = self.particles.len();
        let step = 1.0 / n as f64;
        let mut u = self.rng.random::<f64>() * step;
        let mut c = self.particles[0].weight;
        let mut i = 0;
        let mut next = Vec::with_capacity(n);
        for _ in 0..n {
            while u > c && i + 1 < n {
                i += 1;
                c += self.particles[i].weight;
            }
            let pose = if inject > 0.0 && self.rng.random::<f64>() < inject {
                self.random_pose()
            } else {
                self.particles[i].pose
            };
            next.push(Particle { pose, weight: step });
            u += step;
        }
        self.particles = next;
    }

    /// The log score of an echo seen from `pose` (whose heading's sine and cosine are given),
    /// on the `score` field of its beam's range: at the one of its possible `points` (body
    /// frame) that scores best, i.e. falls nearest an obstacle. (The rotation is
    /// [`Pose2::apply`]'s, with the trigonometry done once per pose.)
    fn beam_score(
        &self,
        score: &DistanceField,
        pose: Pose2,
        sin: f64,
        cos: f64,
        points: &[(f64, f64)],
    ) -> f64 {
        points
            .iter()
            .map(|&(px, py)| score.at(pose.x + cos * px - sin * py, pose.y + sin * px + cos * py))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// The index in `scores` of the score field of beams reading up to `max_range_m`, made if
    /// it is the first: per cell, the log of `z_hit` of a normal of `sigma_hit_m` at the
    /// distance to the nearest obstacle plus `z_rand` spread over the range.
    fn score_field(&mut self, max_range_m: f64) -> usize {
        let key = max_range_m.to_bits();
        if let Some(i) = self.scores.iter().position(|(k, _)| *k == key) {
            return i;
        }
        let p = &self.params;
        let (sigma, z_hit, z_rand) = (p.sigma_hit_m, p.z_hit, p.z_rand);
        let norm = 1.0 / (sigma * (2.0 * PI).sqrt());
        let field = self.field.mapped(|d| {
            let z = d / sigma;
            // Floored: one reading no model explains must not rule a particle out for good (a
            // log of 0 would make every weight NaN).
            (z_hit * norm * (-0.5 * z * z).exp() + z_rand / max_range_m).max(f64::MIN_POSITIVE).ln()
        });
        self.scores.push((key, field));
        self.scores.len() - 1
    }

    /// The particles' weighted mean pose and covariance.
    pub fn estimate(&self) -> Estimate {
        let (mut x, mut y, mut s, mut c) = (0.0, 0.0, 0.0, 0.0);
        for p in &self.particles {
            x += p.weight * p.pose.x;
            y += p.weight * p.pose.y;
            s += p.weight * p.pose.theta.sin();
            c += p.weight * p.pose.theta.cos();
        }
        let theta = s.atan2(c);
        let mut cov = [[0.0; 3]; 3];
        for p in &self.particles {
            let d = [p.pose.x - x, p.pose.y - y, wrap(p.pose.theta - theta)];
            for (r, row) in cov.iter_mut().enumerate() {
                for (k, v) in row.iter_mut().enumerate() {
                    *v += p.weight * d[r] * d[k];
                }
            }
        }
        Estimate { pose: Pose2::new(x, y, theta), covariance: cov }
    }

    /// The distance field its readings are scored on.
    pub fn field(&self) -> &DistanceField {
        &self.field
    }

    /// The particles' poses (for drawing the cloud).
    pub fn poses(&self) -> impl Iterator<Item = Pose2> + '_ {
        self.particles.iter().map(|p| p.pose)
    }

    /// The current fit per beam, short- and long-term (how well the readings match the map).
    pub fn fit(&self) -> (f64, f64) {
        (self.w_fast, self.w_slow)
    }

    fn normal(&mut self, sd: f64) -> f64 {
        let z: f64 = StandardNormal.sample(&mut self.rng);
        z * sd
    }

    fn random_pose(&mut self) -> Pose2 {
        let (x, y) = self.free[self.rng.random_range(0..self.free.len())];
        let h = self.resolution_m / 2.0;
        let (jx, jy) = (self.rng.random_range(-h..h), self.rng.random_range(-h..h));
        Pose2::new(x + jx, y + jy, self.rng.random_range(-PI..PI))
    }
}

#[cfg(test)]
pub(crate) mod tests;
