//! Finding a lost robot again: judging whether the estimate still fits what the sensors see,
//! and, when it does not, searching the whole map for where the recent readings fit.
//!
//! Monte Carlo localization tracks well and finds a robot carried elsewhere (kidnapped) badly:
//! with a few hundred particles and two rings of sixteen beams, the particles it redraws at
//! random seldom land near the truth, and in a corridor the ones that fit a stretch of it pull
//! the estimate along. So orsa does what a person would do: it notices, then looks.
//!
//! - **Judging** ([`Relocalizer::judge`]): every echo of the last `judge_updates` updates is
//!   kept where it fell in the odometry frame (odometry is good over a metre or two). Through the
//!   estimate's `map -> odom`, the share of those echoes that fall within `near_m` of an obstacle
//!   on the map is the estimate's *agreement*. Tracking, it is high (people and unmapped boxes
//!   take a share); after a kidnapping, the walls are elsewhere and it drops. Below `lost_below`
//!   the robot is lost.
//! - **Looking** ([`Relocalizer::search`]): from the moment it is lost, the echoes are gathered
//!   afresh (those before the kidnapping fit another place) while the robot turns on the spot
//!   (a full turn shows every sonar's view of the room). The gathered echoes, in the robot's
//!   frame, are then matched against the whole map, as correlative scan matching does (Olson,
//!   "Real-Time Correlative Scan Matching", 2009): every pose on a coarse grid over the free
//!   space where the body fits (`step_m`, `step_deg`) is scored by the likelihood field of the
//!   echoes' ends, the best are refined on a fine grid, and the best of all is taken only if no
//!   pose elsewhere (`distinct_m` away, or turned) explains the echoes nearly as well (`misfit_ratio`, `margin`): a robot
//!   in one of two alike rooms is not placed in the wrong one, it gathers more first.
//! - **Keeping the track** ([`Search::Kept`]): where the robot was when it was judged lost,
//!   carried on by odometry, is evidence too. People walking close take a share of the echoes
//!   and can make a sound estimate look lost; in a room that looks the same turned round (a
//!   hall, point-symmetric) the search then finds the truth and its mirror image equally good
//!   and would never be sure. A pose of the search near the track that fits well
//!   (`kept_above`) is taken if no pose elsewhere surely beats it, or if the pose that does is
//!   not sure of its own place (a rival nearly as good) and the track scores nearly as well
//!   (`kept_within`): the track breaks the tie, as a filter's prior would. After a kidnapping the track is elsewhere and fits badly there, so
//!   it decides nothing.
//!
//! A wide beam (a sonar's) reads the nearest echo anywhere across it, so each of its echoes is
//! scored at the best of five directions across the beam, as [`crate::mcl`] does.

use crate::field::DistanceField;
use crate::mcl::{Beam, Pose2, wrap};
use std::collections::VecDeque;
use std::f64::consts::{PI, TAU};

/// Relocalization's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct RelocParams {
    /// The updates whose echoes judge the estimate.
    pub judge_updates: usize,
    /// Fewer echoes than this in them: no judgement (the robot sees too little).
    pub judge_min_echoes: usize,
    /// An echo within this distance of an obstacle on the map agrees with the estimate, m.
    pub near_m: f64,
    /// Below this share of agreeing echoes, the robot is lost.
    pub lost_below: f64,
    /// The updates gathered, once lost, before the first search (at 10 degrees an update, a
    /// full turn is 36).
    pub search_after: usize,
    /// The most updates gathered (the oldest are dropped: odometry drifts).
    pub gather_max: usize,
    /// The coarse search's step in position, m, and in heading, degrees.
    pub step_m: f64,
    /// The coarse search's step in heading, degrees.
    pub step_deg: f64,
    /// The spread of an echo's end about the map's nearest obstacle in the coarse score, m
    /// (blurred further by the coarse step).
    pub sigma_m: f64,
    /// The same in the fine score, which tells places apart, m.
    pub fine_sigma_m: f64,
    /// A pose is taken only if every pose `distinct_m` away explains the beams at least this
    /// many times worse (its misfit, one less its score, is this many times the best's)...
    pub misfit_ratio: f64,
    /// ... and scores at least this much less (the score is a mean over beams: 0.01 is one beam
    /// in a hundred explained worse).
    pub margin: f64,
    /// How far apart two poses must be to count as two places, m.
    pub distinct_m: f64,
    /// The best pose is taken only if at least this share of the echoes agree from it.
    pub found_above: f64,
    /// A pose near where the robot was tracked when it was lost (odometry carrying it on) is
    /// taken if at least this share of the echoes agree from it and no pose elsewhere surely
    /// beats it.
    pub kept_above: f64,
    /// ... or, when the pose that surely beats it is not sure of its own place (a rival
    /// elsewhere nearly as good), if its score is within this of that pose's.
    pub kept_within: f64,
}

impl Default for RelocParams {
    fn default() -> Self {
        RelocParams {
            judge_updates: 30,
            judge_min_echoes: 60,
            near_m: 0.25,
            lost_below: 0.45,
            search_after: 36,
            gather_max: 150,
            step_m: 0.2,
            step_deg: 5.0,
            sigma_m: 0.15,
            fine_sigma_m: 0.08,
            misfit_ratio: 2.0,
            margin: 0.01,
            distinct_m: 1.0,
            found_above: 0.7,
            kept_above: 0.6,
            kept_within: 0.15,
        }
    }
}

/// One echo's possible ends, in some frame (a narrow beam's one, a wide beam's five).
#[derive(Debug, Clone, Copy)]
struct Echo {
    ends: [(f64, f64); 5],
    n: u8,
}

impl Echo {
    /// The echo of `beam` (which echoed), seen from `pose`.
    fn of(beam: &Beam, pose: Pose2) -> Option<Echo> {
        let r = beam.range_m?;
        let mut e = Echo { ends: [(0.0, 0.0); 5], n: 0 };
        let mut put = |a: f64| {
            let p = pose.apply(beam.origin.0 + r * a.cos(), beam.origin.1 + r * a.sin());
            e.ends[usize::from(e.n)] = p;
            e.n += 1;
        };
        if beam.half_width_rad < 0.02 {
            put(beam.angle_rad);
        } else {
            for k in -2..=2 {
                put(beam.angle_rad + beam.half_width_rad * f64::from(k) / 2.0);
            }
        }
        Some(e)
    }

    fn ends(&self) -> &[(f64, f64)] {
        &self.ends[..usize::from(self.n)]
    }
}

/// A beam that echoed nothing within its range, in some frame.
#[derive(Debug, Clone, Copy)]
struct Miss {
    origin: (f64, f64),
    angle_rad: f64,
    max_range_m: f64,
}

impl Miss {
    /// The miss of `beam` (which did not echo), seen from `pose`.
    fn of(beam: &Beam, pose: Pose2) -> Option<Miss> {
        if beam.range_m.is_some() || !beam.max_range_m.is_finite() {
            return None;
        }
        Some(Miss {
            origin: pose.apply(beam.origin.0, beam.origin.1),
            angle_rad: wrap(pose.theta + beam.angle_rad),
            max_range_m: beam.max_range_m,
        })
    }

    /// Whether the map leaves its axis open to nine tenths of its range, seen from `pose`
    /// (marched along the distance field: each step as long as the way is clear).
    fn open(&self, field: &DistanceField, pose: Pose2) -> bool {
        let (ox, oy) = pose.apply(self.origin.0, self.origin.1);
        let (dy, dx) = (pose.theta + self.angle_rad).sin_cos();
        let reach = 0.9 * self.max_range_m;
        let mut t = 0.0;
        while t < reach {
            let d = field.at(ox + t * dx, oy + t * dy);
            if d < 0.03 {
                return false;
            }
            t += d.max(0.025);
        }
        true
    }
}

/// A pose found by a search, with its score (the mean likelihood of the echoes, 0 to 1) and
/// the share of the echoes that agree from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Found {
    /// The robot's pose in the map, now.
    pub pose: Pose2,
    /// The mean over the echoes of `exp(-d^2 / 2 sigma^2)`, d the distance of its end to the
    /// map's nearest obstacle.
    pub score: f64,
    /// The share of echoes within `near_m` of an obstacle.
    pub agreement: f64,
}

/// What a search concluded.
#[derive(Debug, Clone, PartialEq)]
pub enum Search {
    /// The robot is here.
    Found(Found),
    /// The best pose fits well, but a pose elsewhere nearly as well: the robot is taken to be
    /// at the best for now (it must move to tell them apart), while the echoes are still
    /// gathered and searched; the estimate is judged as usual, and one that stops fitting is
    /// lost again, with every echo since it was first lost.
    Guess(Found, Found),
    /// The robot is here, near where it was tracked when it was judged lost: nothing elsewhere
    /// surely fits better (a rival that fits as well may exist: the track breaks the tie).
    Kept(Found),
    /// Nothing fits well enough: the best pose, and its rival if any.
    Unsure(Found, Option<Found>),
}

/// Judges the estimate and finds a lost robot (see the module docs).
#[derive(Debug, Clone)]
pub struct Relocalizer {
    params: RelocParams,
    /// Where the body fits: the search's candidate positions on the coarse grid.
    candidates: Vec<(f64, f64)>,
    /// The echoes of recent updates, in the odometry frame, with their update's number.
    echoes: VecDeque<(u64, Echo)>,
    /// The beams of recent updates that echoed nothing within their range, in the odometry
    /// frame, with their update's number.
    misses: VecDeque<(u64, Miss)>,
    update: u64,
    /// Since which update the echoes are gathered for a search (the robot is lost, or placed at
    /// a guess).
    lost_since: Option<u64>,
    /// Whether the robot is placed at a guess ([`Search::Guess`]).
    guessing: bool,
    /// The update at which the guess was taken.
    guessed_at: u64,
    searched_at: u64,
    /// The estimate's `map -> odom` when the robot was judged lost (none when it was set lost
    /// by hand): where it was tracked, which odometry carries on.
    lost_from: Option<Pose2>,
}

impl Relocalizer {
    /// A relocalizer on `field`, the body fitting where `field` is at least `body_m` (the body's
    /// radius) from obstacles and inside `bounds` (min x, min y, max x, max y).
    pub fn new(params: RelocParams, field: &DistanceField, bounds: [f64; 4], body_m: f64) -> Relocalizer {
        let mut candidates = Vec::new();
        let step = params.step_m;
        let mut y = bounds[1] + step / 2.0;
        while y < bounds[3] {
            let mut x = bounds[0] + step / 2.0;
            while x < bounds[2] {
                // (The field is capped: a cap below the body's radius counts as room enough.)
                if field.at(x, y) >= body_m.min(field.max_m()) {
                    candidates.push((x, y));
                }
                x += step;
            }
            y += step;
        }
        Relocalizer {
            params,
            candidates,
            echoes: VecDeque::new(),
            misses: VecDeque::new(),
            update: 0,
            lost_since: None,
            guessing: false,
            guessed_at: 0,
            searched_at: 0,
            lost_from: None,
        }
    }

    /// How many positions a search tries (before turning each).
    pub fn candidates(&self) -> usize {
        self.candidates.len()
    }

    /// Whether the robot is lost (echoes are being gathered for a search).
    pub fn lost(&self) -> bool {
        self.lost_since.is_some() && !self.guessing
    }

    /// Whether the robot is placed at a guess that a search has not confirmed yet.
    pub fn guessing(&self) -> bool {
        self.guessing
    }

    /// Takes an update's `beams`, read at the odometry pose `odom`.
    pub fn gather(&mut self, odom: Pose2, beams: &[Beam]) {
        self.update += 1;
        // A guess judged sound for a whole window of gathering is taken as found: searching on
        // (a second of one core each time) would not tell places apart that the way driven
        // did not.
        if self.guessing && self.update - self.guessed_at >= self.params.gather_max as u64 {
            self.set_found();
        }
        let u = self.update;
        self.echoes.extend(beams.iter().filter_map(|b| Echo::of(b, odom)).map(|e| (u, e)));
        self.misses.extend(beams.iter().filter_map(|b| Miss::of(b, odom)).map(|m| (u, m)));
        let keep = if self.lost_since.is_some() { self.params.gather_max } else { self.params.judge_updates };
        let oldest = u.saturating_sub(keep as u64 - 1).max(self.lost_since.unwrap_or(0));
        while self.echoes.front().is_some_and(|(k, _)| *k < oldest) {
            self.echoes.pop_front();
        }
        while self.misses.front().is_some_and(|(k, _)| *k < oldest) {
            self.misses.pop_front();
        }
    }

    /// The share of the recent echoes that agree with `map_odom` (`map -> odom`), if there are
    /// enough to judge by; marks the robot lost when it is below `lost_below` (and starts
    /// gathering afresh). Returns the share.
    pub fn judge(&mut self, field: &DistanceField, map_odom: Pose2) -> Option<f64> {
        if self.lost() {
            return None;
        }
        let from = self.update.saturating_sub(self.params.judge_updates as u64 - 1);
        let recent = self.echoes.iter().filter(|(k, _)| *k >= from);
        let (mut n, mut near) = (0usize, 0usize);
        for (_, e) in recent {
            n += 1;
            let d = e.ends().iter().map(|&(x, y)| {
                let (mx, my) = map_odom.apply(x, y);
                field.at(mx, my)
            });
            if d.fold(f64::INFINITY, f64::min) < self.params.near_m {
                near += 1;
            }
        }
        if n < self.params.judge_min_echoes {
            return None;
        }
        let share = near as f64 / n as f64;
        if share < self.params.lost_below {
            if self.guessing {
                // The guess was wrong: lost again, with what was gathered since.
                self.guessing = false;
            } else {
                self.set_lost_from(map_odom);
            }
        }
        Some(share)
    }

    /// Marks the robot lost: echoes are gathered afresh from the next update for a search.
    pub fn set_lost(&mut self) {
        self.guessing = false;
        self.lost_from = None;
        self.lost_since = Some(self.update + 1);
        self.searched_at = self.update;
        self.echoes.clear();
        self.misses.clear();
    }

    /// Marks the robot lost while its estimate's `map -> odom` was `map_odom`: where it was
    /// tracked, which breaks a search's ties ([`Search::Kept`]).
    pub fn set_lost_from(&mut self, map_odom: Pose2) {
        self.set_lost();
        self.lost_from = Some(map_odom);
    }

    /// Marks the robot found (at a pose given by hand, or found by a search).
    pub fn set_found(&mut self) {
        self.lost_since = None;
        self.guessing = false;
        self.lost_from = None;
    }

    /// Whether a search is due: lost, with `search_after` updates gathered, and a third of that
    /// more since the last search.
    pub fn search_due(&self) -> bool {
        let Some(since) = self.lost_since else { return false };
        let gathered = self.update + 1 - since;
        gathered >= self.params.search_after as u64
            && self.update - self.searched_at >= (self.params.search_after as u64 / 3).max(1)
    }

    /// Searches the map for the robot's pose now, `odom` its odometry pose, from the echoes
    /// gathered since it was lost. Marks it found if the search is sure.
    pub fn search(&mut self, field: &DistanceField, odom: Pose2) -> Option<Search> {
        self.searched_at = self.update;
        // The echoes in the robot's frame now: odom^-1 applied to each end.
        let (s, c) = odom.theta.sin_cos();
        let to_body = |(x, y): (f64, f64)| {
            let (dx, dy) = (x - odom.x, y - odom.y);
            (c * dx + s * dy, -s * dx + c * dy)
        };
        let echoes: Vec<Echo> = self
            .echoes
            .iter()
            .map(|(_, e)| {
                let mut b = *e;
                for p in &mut b.ends[..usize::from(e.n)] {
                    *p = to_body(*p);
                }
                b
            })
            .collect();
        let misses: Vec<Miss> = self
            .misses
            .iter()
            .map(|(_, m)| Miss {
                origin: to_body(m.origin),
                angle_rad: wrap(m.angle_rad - odom.theta),
                max_range_m: m.max_range_m,
            })
            .collect();
        if echoes.len() < self.params.judge_min_echoes || self.candidates.is_empty() {
            return None;
        }
        let p = &self.params;
        let coarse_score = field.mapped(|d| likelihood(d, p.sigma_m, 2.0 * p.sigma_m));
        let fine_score = field.mapped(|d| likelihood(d, p.fine_sigma_m, p.fine_sigma_m));
        // Coarse: a sample of the echoes, every candidate, every heading step.
        let stride = (echoes.len() / 100).max(1);
        // (A wide beam's three middle directions of five: the blur of the coarse score covers
        // the rest.)
        let sample: Vec<Echo> = echoes
            .iter()
            .step_by(stride)
            .map(|e| {
                let mut c = *e;
                if e.n == 5 {
                    c.ends = [e.ends[1], e.ends[2], e.ends[3], (0.0, 0.0), (0.0, 0.0)];
                    c.n = 3;
                }
                c
            })
            .collect();
        let headings = ((360.0 / p.step_deg).round() as usize).max(1);
        let mut coarse: Vec<Found> = Vec::new();
        let mut rotated: Vec<Echo> = sample.clone();
        for k in 0..headings {
            let theta = wrap(k as f64 * TAU / headings as f64);
            let (s, c) = theta.sin_cos();
            turn_into(&mut rotated, &sample, s, c);
            for &(cx, cy) in &self.candidates {
                let score = score_at(&coarse_score, &rotated, cx, cy);
                coarse.push(Found { pose: Pose2::new(cx, cy, theta), score, agreement: 0.0 });
            }
        }
        coarse.sort_by(|a, b| b.score.total_cmp(&a.score));
        let seeds = distinct(&coarse, p.distinct_m, 12, coarse.len().min(20_000));
        // Where it was tracked when lost, now: map -> odom then, on the odometry now.
        let tracked = self.lost_from.map(|m| {
            let (x, y) = m.apply(odom.x, odom.y);
            Pose2::new(x, y, wrap(m.theta + odom.theta))
        });
        // Fine: every echo, about each seed, and about the track (which the coarse grid may
        // have ranked below the seeds: people's echoes, or a rival place alike).
        let mut refined: Vec<Found> =
            seeds.iter().map(|f| self.refine(field, &fine_score, &echoes, &misses, f.pose)).collect();
        refined.extend(tracked.map(|t| self.refine(field, &fine_score, &echoes, &misses, t)));
        refined.sort_by(|a, b| b.score.total_cmp(&a.score));
        let best = *refined.first()?;
        // Whether `a` surely explains the echoes better than `b`.
        let beats = |a: &Found, b: &Found| {
            b.score <= a.score - p.margin && 1.0 - b.score >= p.misfit_ratio * (1.0 - a.score)
        };
        // The best pose near the track (refined is best first).
        let kept = tracked.and_then(|t| refined.iter().find(|f| !apart(f.pose, t, p.distinct_m)).copied());
        let rival = refined[1..].iter().find(|f| apart(f.pose, best.pose, p.distinct_m)).copied();
        let sure = best.agreement >= p.found_above && rival.is_none_or(|r| beats(&best, &r));
        // The track is kept where it fits well and nothing surely beats it, or where what beats
        // it is itself not sure of its place (a rival elsewhere nearly as good) and the track
        // scores nearly as well: the echoes then single out no place, and where the robot was
        // tracked is the better bet than one of two alike places elsewhere (office, seed 1:
        // people close to the true pose, 0.86 of score, twin rooms 8 m off 0.93 each). A
        // kidnapped robot's track scores far less (0.48-0.59 against 0.99 in the office).
        let nearly = |k: &Found| !sure && k.score >= best.score - p.kept_within;
        if let Some(k) = kept.filter(|k| k.agreement >= p.kept_above && (!beats(&best, k) || nearly(k))) {
            self.set_found();
            return Some(Search::Kept(k));
        }
        match rival {
            _ if sure => {
                self.set_found();
                Some(Search::Found(best))
            }
            Some(r) if best.agreement >= p.found_above && !self.guessing => {
                self.guessing = true;
                self.guessed_at = self.update;
                Some(Search::Guess(best, r))
            }
            _ => Some(Search::Unsure(best, rival)),
        }
    }

    /// The best pose about `seed` on the fine grid (a quarter of the coarse steps, over one
    /// coarse step either way), scored with every echo; its score then counts the beams that
    /// echoed nothing as well (one whose way the map blocks from there scores 0, else 1), which
    /// tells apart places whose walls look alike but whose openings do not.
    fn refine(
        &self,
        field: &DistanceField,
        fine_score: &DistanceField,
        echoes: &[Echo],
        misses: &[Miss],
        seed: Pose2,
    ) -> Found {
        let p = &self.params;
        let (step, turn) = (p.step_m / 4.0, (p.step_deg / 4.0).to_radians());
        let mut best = Found { pose: seed, score: f64::NEG_INFINITY, agreement: 0.0 };
        // The grid search on at most 400 echoes, evenly taken; the best pose is then scored on
        // every one.
        let sample: Vec<Echo> = echoes.iter().step_by((echoes.len() / 400).max(1)).copied().collect();
        let mut rotated = sample.clone();
        for dk in -4..=4 {
            let theta = wrap(seed.theta + f64::from(dk) * turn);
            let (s, c) = theta.sin_cos();
            turn_into(&mut rotated, &sample, s, c);
            for dy in -4..=4 {
                for dx in -4..=4 {
                    let (x, y) = (seed.x + f64::from(dx) * step, seed.y + f64::from(dy) * step);
                    let score = score_at(fine_score, &rotated, x, y);
                    if score > best.score {
                        best = Found { pose: Pose2::new(x, y, theta), score, agreement: 0.0 };
                    }
                }
            }
        }
        let (s, c) = best.pose.theta.sin_cos();
        let near = echoes
            .iter()
            .filter(|e| {
                e.ends()
                    .iter()
                    .map(|&(x, y)| field.at(best.pose.x + c * x - s * y, best.pose.y + s * x + c * y))
                    .fold(f64::INFINITY, f64::min)
                    < p.near_m
            })
            .count();
        best.agreement = near as f64 / echoes.len().max(1) as f64;
        let mut turned = echoes.to_vec();
        turn_into(&mut turned, echoes, s, c);
        best.score = score_at(fine_score, &turned, best.pose.x, best.pose.y);
        let open = misses.iter().filter(|m| m.open(field, best.pose)).count();
        best.score =
            (best.score * echoes.len() as f64 + open as f64) / (echoes.len() + misses.len()).max(1) as f64;
        best
    }
}

/// Each of `echoes` turned by the angle whose sine and cosine are `s` and `c`, into `out` (as
/// long as `echoes`).
fn turn_into(out: &mut [Echo], echoes: &[Echo], s: f64, c: f64) {
    for (r, e) in out.iter_mut().zip(echoes) {
        for (q, &(x, y)) in r.ends[..usize::from(e.n)].iter_mut().zip(e.ends()) {
            *q = (c * x - s * y, s * x + c * y);
        }
    }
}

/// The likelihood of an echo's end `d` from the map's nearest obstacle: a normal of `sigma`,
/// with every distance below `floor` counted as on the obstacle (the coarse search is blurred by
/// its step).
fn likelihood(d: f64, sigma: f64, floor: f64) -> f64 {
    let d = (d - floor + sigma).max(0.0);
    (-0.5 * d * d / (sigma * sigma)).exp()
}

/// The mean likelihood of `echoes` (already turned to the pose's heading) from `(x, y)`, on
/// `score` (the distance field mapped through [`likelihood`]): each echo at its best end.
fn score_at(score: &DistanceField, echoes: &[Echo], x: f64, y: f64) -> f64 {
    let mut total = 0.0;
    for e in echoes {
        total += e.ends().iter().map(|&(ex, ey)| score.at(x + ex, y + ey)).fold(0.0, f64::max);
    }
    total / echoes.len().max(1) as f64
}

/// Whether two poses count as two places: `apart_m` apart, or turned more than 30 degrees.
fn apart(a: Pose2, b: Pose2, apart_m: f64) -> bool {
    (a.x - b.x).hypot(a.y - b.y) >= apart_m || wrap(a.theta - b.theta).abs() > PI / 6.0
}

/// The best of `sorted` (best first, the first `look` of them) that are pairwise `apart`, at
/// most `n`.
fn distinct(sorted: &[Found], apart_m: f64, n: usize, look: usize) -> Vec<Found> {
    let mut out: Vec<Found> = Vec::new();
    for f in &sorted[..look] {
        if out.iter().all(|o| apart(o.pose, f.pose, apart_m)) {
            out.push(*f);
            if out.len() == n {
                break;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
