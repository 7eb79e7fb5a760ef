//! The report's `navigation` section: every goal's outcome, measured against the simulator's
//! truth, and how well the robot knew where it was.
//!
//! A goal's `path_m` is the distance the robot's true centre drove while the goal ran;
//! `shortest_m` is the shortest path for the robot's body on the true world from where the goal
//! started to its target, found by a search of this module's own (Dijkstra over 5 cm cells
//! whose centres are clear of every wall, box and disc by the body's radius, judged on the world
//! file's exact shapes, then pulled tight where the straight line between two of its points
//! stays clear): independent of the navigation under test, which plans on its occupancy grid.
//! `spl` is success weighted by path length (Anderson et al., 2018): the mean over goals of
//! success x shortest / max(path, shortest). `localization` compares every published pose
//! estimate with the truth at the estimate's own stamp.

use super::Stack;
use super::observe::{RunObserver, Tick};
use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::{Sink, Update};
use orsa_hardware::geometry::{Point, Shape};
use orsa_hardware::world::World;
use orsa_interfaces::navigation::{self, NavFeedback, NavState, PoseEstimate};
use orsa_record::plot::{GoalMark, NavigationTrace};
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};
use tokio::sync::mpsc;

/// One goal's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GoalFigures {
    /// The goal's id.
    pub id: u64,
    /// Where it went: a place's name or `X,Y[,HEADING]`.
    pub target: String,
    /// `succeeded`, `aborted`, `canceled` or `rejected` (`active` if the run ended first).
    pub status: String,
    /// Why it ended so.
    pub reason: String,
    /// How long it ran, s.
    pub time_s: f64,
    /// What the robot drove meanwhile, m: the simulator's odometer of its true motion (being
    /// carried elsewhere is no driving).
    pub path_m: f64,
    /// The shortest path for its body on the world file's shapes, m (`None`: there is none).
    /// Boxes put down at run time (`box_placed`) are not in it.
    pub shortest_m: Option<f64>,
    /// How far from the target the robot truly stopped, m (`None`: it names no position).
    pub final_error_m: Option<f64>,
}

impl GoalFigures {
    /// Whether the goal counts as reached: the planner said `succeeded` and the robot's true
    /// position was within [`SUCCESS_RADIUS_M`] of it.
    pub fn reached(&self) -> bool {
        self.status == NavState::Succeeded.name() && self.final_error_m.is_none_or(|e| e <= SUCCESS_RADIUS_M)
    }
}

/// How well the robot knew where it was.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LocalizationFigures {
    /// RMS distance of the estimate from the truth, m, over the estimates the localizer vouched
    /// for: those it published while it said the robot was lost (looking for it, the pose not
    /// to be driven on) are left out, and counted in `lost_s`. Those between a kidnapping and
    /// its noticing it are in.
    pub rms_m: f64,
    /// The largest, m (over the same estimates).
    pub max_m: f64,
    /// How many estimates were compared.
    pub samples: u64,
    /// How long the localizer said the robot was lost, s.
    #[serde(default)]
    pub lost_s: f64,
    /// Each time it said so, in order.
    #[serde(default)]
    pub lost: Vec<LostSpell>,
}

/// A time the localizer said the robot was lost.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LostSpell {
    /// When it said so, s.
    pub from_s: f64,
    /// When it found the robot again, s (`None`: not by the end of the run).
    pub found_s: Option<f64>,
    /// How far from the truth its first estimate after that was, m.
    pub error_after_m: Option<f64>,
}

/// The report's `navigation` section.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigationReport {
    /// Every goal, in order.
    pub goals: Vec<GoalFigures>,
    /// The share of goals that succeeded and were truly reached: the planner said `succeeded`
    /// and the robot's true position was within [`SUCCESS_RADIUS_M`] of the goal (a planner
    /// fooled by a wrong estimate does not count).
    pub success_rate: f64,
    /// Success weighted by path length.
    pub spl: f64,
    /// The estimate against the truth.
    pub localization: LocalizationFigures,
}

impl NavigationReport {
    /// The section as a table for the terminal.
    pub fn table(&self) -> String {
        let mut out = String::from("goal         status      time      driven  shortest  off    reason\n");
        for g in &self.goals {
            out.push_str(&format!(
                "{:<12} {:<10} {:>6.1} s {:>7.2} m {:>7} {:>6}  {}\n",
                g.target,
                g.status,
                g.time_s,
                g.path_m,
                g.shortest_m.map_or("-".into(), |s| format!("{s:.2} m")),
                g.final_error_m.map_or("-".into(), |e| format!("{e:.2} m")),
                match g.final_error_m {
                    Some(e) if g.status == NavState::Succeeded.name() && e > SUCCESS_RADIUS_M =>
                        format!("{} (but truly {e:.2} m off: not a success)", g.reason),
                    _ => g.reason.clone(),
                }
            ));
        }
        out.push_str(&format!(
            "success {:.0} % of {} goals, SPL {:.3}, localization RMS {:.3} m (largest {:.3} m, {} estimates)",
            self.success_rate * 100.0,
            self.goals.len(),
            self.spl,
            self.localization.rms_m,
            self.localization.max_m,
            self.localization.samples
        ));
        for l in &self.localization.lost {
            out.push_str(&match (l.found_s, l.error_after_m) {
                (Some(found), e) => format!(
                    "\nlost at {:.1} s, found again at {found:.1} s ({:.1} s later){}",
                    l.from_s,
                    found - l.from_s,
                    e.map_or(String::new(), |e| format!(", {e:.2} m off"))
                ),
                (None, _) => format!("\nlost at {:.1} s, not found again by the end", l.from_s),
            });
        }
        out
    }

    fn finish(&mut self) {
        let n = self.goals.len() as f64;
        if n > 0.0 {
            let ok = GoalFigures::reached;
            self.success_rate = self.goals.iter().filter(|g| ok(g)).count() as f64 / n;
            self.spl = self
                .goals
                .iter()
                .map(|g| match (ok(g), g.shortest_m) {
                    // A goal already within the success radius at its start needs no driving: the
                    // radius stands for its shortest path, so the robot's jitter there does not
                    // count as a detour of 100 %.
                    (true, Some(s)) => {
                        let s = s.max(SUCCESS_RADIUS_M);
                        s / g.path_m.max(s)
                    }
                    _ => 0.0,
                })
                .sum::<f64>()
                / n;
        }
    }
}

/// A goal being measured.
struct Running {
    id: u64,
    target: String,
    goal: [f64; 2],
    start_s: f64,
    from: (f64, f64),
    last: (f64, f64),
    path_m: f64,
}

/// Measures a run's navigation (see the module docs).
pub(super) struct NavigationRun {
    world: World,
    radius_m: f64,
    feedback: Option<(mpsc::UnboundedReceiver<Update<NavFeedback>>, PushNewestClient<NavFeedback>)>,
    poses: Option<(mpsc::UnboundedReceiver<Update<PoseEstimate>>, PushNewestClient<PoseEstimate>)>,
    /// The truth at each recent tick, by stamp (ns).
    truth: BTreeMap<u64, (f64, f64)>,
    pending: Vec<PoseEstimate>,
    running: Option<Running>,
    report: NavigationReport,
    sum2: f64,
    clearance: Option<Clearance>,
    /// The robot's true odometer at the last tick, m (what it drove: a kidnapping adds nothing).
    travelled_m: Option<f64>,
    /// Since when the localizer says the robot is lost, s.
    lost_at: Option<f64>,
    /// What the plot draws.
    trace: NavigationTrace,
}

impl NavigationRun {
    pub(super) fn new(world: World, radius_m: f64) -> Self {
        NavigationRun {
            world,
            radius_m,
            feedback: None,
            poses: None,
            truth: BTreeMap::new(),
            pending: Vec::new(),
            running: None,
            report: NavigationReport::default(),
            sum2: 0.0,
            clearance: None,
            travelled_m: None,
            lost_at: None,
            trace: NavigationTrace { error_target_m: LOCALIZATION_TARGET_M, ..Default::default() },
        }
    }

    fn end_goal(&mut self, f: &NavFeedback, now: (f64, f64)) {
        let (target, start_s, from, path_m, goal) = match self.running.take() {
            Some(r) if r.id == f.id => (r.target, r.start_s, r.from, r.path_m, Some(r.goal)),
            other => {
                // Ended before it was seen running (rejected, or ended within a tick).
                self.running = other;
                (f.target.to_string(), f.stamp.0 as f64 * 1e-9, now, 0.0, f.goal)
            }
        };
        let shortest_m = match goal.filter(|_| f.state != NavState::Rejected) {
            Some(g) => self
                .clearance
                .get_or_insert_with(|| Clearance::new(&self.world, self.radius_m, CELL_M))
                .shortest(from, (g[0], g[1])),
            None => None,
        };
        let figures = GoalFigures {
            id: f.id,
            target,
            status: f.state.name().into(),
            reason: f.reason.clone(),
            time_s: f.stamp.0 as f64 * 1e-9 - start_s,
            path_m,
            shortest_m,
            final_error_m: goal
                .filter(|_| f.state != NavState::Rejected)
                .map(|g| (g[0] - now.0).hypot(g[1] - now.1)),
        };
        self.mark(&figures, goal);
        self.report.goals.push(figures);
    }

    /// Marks a goal that named a position on the plot.
    fn mark(&mut self, g: &GoalFigures, at: Option<[f64; 2]>) {
        if let Some(at) = at.filter(|_| g.status != NavState::Rejected.name()) {
            let label = g.target.clone();
            self.trace.goals.push(GoalMark { label, x_m: at[0], y_m: at[1], reached: g.reached() });
        }
    }

    /// Takes the goals' feedback that came, the robot being at `now`.
    fn drain(&mut self, now: (f64, f64)) {
        let mut updates = Vec::new();
        if let Some((rx, _)) = &mut self.feedback {
            while let Ok(f) = rx.try_recv() {
                updates.push(f.value.clone());
            }
        }
        for f in updates {
            if !f.path.is_empty() && self.trace.paths.last() != Some(&f.path) {
                self.trace.paths.push(f.path.clone());
            }
            if f.state == NavState::Active {
                if self.running.as_ref().is_none_or(|r| r.id != f.id)
                    && let Some(goal) = f.goal
                {
                    self.running = Some(Running {
                        id: f.id,
                        target: f.target.to_string(),
                        goal,
                        start_s: f.stamp.0 as f64 * 1e-9,
                        from: now,
                        last: now,
                        path_m: 0.0,
                    });
                }
            } else {
                self.end_goal(&f, now);
            }
        }
    }
}

impl RunObserver for NavigationRun {
    fn on_start(&mut self, stack: &Stack) {
        let planner = orsa_interfaces::planner::NAME;
        let (tx, rx) = mpsc::unbounded_channel();
        if let Ok(c) = PushNewestClient::connect_to(
            &stack.registry,
            navigation::NAVIGATION.on(planner),
            Sink::channel(tx),
        ) && c.subscribe().is_ok()
        {
            self.feedback = Some((rx, c));
        }
        let (tx, rx) = mpsc::unbounded_channel();
        if let Ok(c) = PushNewestClient::connect_to(
            &stack.registry,
            navigation::POSE.on(navigation::LOCALIZER),
            Sink::channel(tx),
        ) && c.subscribe().is_ok()
        {
            self.poses = Some((rx, c));
        }
    }

    fn on_tick(&mut self, tick: &Tick<'_>) {
        let t = tick.truth;
        let now = (t.x_m, t.y_m);
        self.truth.insert(t.stamp.0, now);
        while self.truth.len() > 100 {
            self.truth.pop_first();
        }
        if let Some((rx, _)) = &mut self.poses {
            while let Ok(p) = rx.try_recv() {
                self.pending.push(p.value);
            }
        }
        let truth = &self.truth;
        let trace = &mut self.trace;
        let (mut sum2, mut worst, mut n) = (0.0, self.report.localization.max_m, 0);
        self.pending.retain(|p| {
            if p.stamp.0 > t.stamp.0 {
                // Wait for the truth after it.
                return true;
            }
            // The truth at the estimate's stamp, between the samples either side of it.
            let after = truth.range(p.stamp.0..).next();
            let before = truth.range(..=p.stamp.0).next_back();
            let at = match (before, after) {
                (Some((&t0, &a)), Some((&t1, &b))) if t1 - t0 <= 200_000_000 => {
                    let f = if t1 > t0 { (p.stamp.0 - t0) as f64 / (t1 - t0) as f64 } else { 0.0 };
                    Some((a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1)))
                }
                _ => None,
            };
            let at_s = p.stamp.0 as f64 * 1e-9;
            let spells = &mut self.report.localization.lost;
            let was_lost = spells.last().is_some_and(|l| l.found_s.is_none());
            if p.lost {
                if !was_lost {
                    spells.push(LostSpell { from_s: at_s, found_s: None, error_after_m: None });
                }
                self.lost_at = Some(self.lost_at.unwrap_or(at_s));
                return false;
            }
            if let Some(since) = self.lost_at.take() {
                self.report.localization.lost_s += at_s - since;
                if let Some(l) = spells.last_mut() {
                    l.found_s = Some(at_s);
                    l.error_after_m = at.map(|(x, y)| (p.x_m - x).hypot(p.y_m - y));
                }
            }
            if let Some((x, y)) = at {
                let e = (p.x_m - x).hypot(p.y_m - y);
                sum2 += e * e;
                worst = worst.max(e);
                n += 1;
                trace.error.push((at_s, e));
            }
            trace.estimate.push((at_s, p.x_m, p.y_m));
            false
        });
        self.sum2 += sum2;
        self.report.localization.max_m = worst;
        self.report.localization.samples += n;
        // Driven: the simulator's odometer of the true motion, not the jumps between samples
        // (a robot carried elsewhere drove nothing).
        let moved = self.travelled_m.map_or(0.0, |before| t.travelled_m - before);
        self.travelled_m = Some(t.travelled_m);
        if let Some(r) = &mut self.running {
            r.path_m += moved;
            r.last = now;
        }
        self.drain(now);
    }

    fn on_end(&mut self, outcome: &mut super::RunOutcome) {
        if let Some(last) =
            self.running.as_ref().map(|r| r.last).or(self.truth.last_key_value().map(|(_, p)| *p))
        {
            self.drain(last);
        }
        let mut report = std::mem::take(&mut self.report);
        if let Some(r) = self.running.take() {
            let last = r.last;
            let clearance =
                self.clearance.get_or_insert_with(|| Clearance::new(&self.world, self.radius_m, CELL_M));
            let figures = GoalFigures {
                id: r.id,
                target: r.target,
                status: NavState::Active.name().into(),
                reason: "the run ended first".into(),
                time_s: outcome.report.sim_seconds - r.start_s,
                path_m: r.path_m,
                shortest_m: clearance.shortest(r.from, (r.goal[0], r.goal[1])),
                final_error_m: Some((r.goal[0] - last.0).hypot(r.goal[1] - last.1)),
            };
            self.mark(&figures, Some(r.goal));
            report.goals.push(figures);
        }
        if let Some(since) = self.lost_at.take() {
            report.localization.lost_s += (outcome.report.sim_seconds - since).max(0.0);
        }
        let n = report.localization.samples;
        report.localization.rms_m = if n > 0 { (self.sum2 / n as f64).sqrt() } else { 0.0 };
        report.finish();
        outcome.report.navigation = Some(report);
        outcome.metrics.navigation = Some(std::mem::take(&mut self.trace));
    }
}

/// A goal is reached within this distance of it (the issue's definition), m.
pub const SUCCESS_RADIUS_M: f64 = 0.25;

/// The localization RMS aimed for (the issue's target), m: the plot's target line.
pub const LOCALIZATION_TARGET_M: f64 = 0.10;

/// The cell of the independent search, m.
pub(super) const CELL_M: f64 = 0.05;

/// Where the body fits on the true world, cell by cell (see the module docs).
pub(super) struct Clearance {
    shapes: Vec<Shape>,
    radius_m: f64,
    origin: (f64, f64),
    cell_m: f64,
    width: usize,
    height: usize,
    fits: Vec<bool>,
}

impl Clearance {
    pub(super) fn new(world: &World, radius_m: f64, cell_m: f64) -> Self {
        let shapes = world.static_shapes();
        let (mut lo, mut hi) = ((f64::INFINITY, f64::INFINITY), (f64::NEG_INFINITY, f64::NEG_INFINITY));
        for s in &shapes {
            let b = s.bounds();
            lo = (lo.0.min(b.min.x), lo.1.min(b.min.y));
            hi = (hi.0.max(b.max.x), hi.1.max(b.max.y));
        }
        let origin = (lo.0 - cell_m, lo.1 - cell_m);
        let width = (((hi.0 - lo.0) / cell_m).ceil() as usize + 2).min(20_000);
        let height = (((hi.1 - lo.1) / cell_m).ceil() as usize + 2).min(20_000);
        let mut c = Clearance { shapes, radius_m, origin, cell_m, width, height, fits: Vec::new() };
        c.fits = (0..width * height)
            .map(|i| {
                let p = c.centre(i);
                c.clear(&Point::new(p.0, p.1))
            })
            .collect();
        c
    }

    pub(super) fn centre(&self, i: usize) -> (f64, f64) {
        let (ix, iy) = (i % self.width, i / self.width);
        (self.origin.0 + (ix as f64 + 0.5) * self.cell_m, self.origin.1 + (iy as f64 + 0.5) * self.cell_m)
    }

    fn clear(&self, p: &Point) -> bool {
        self.shapes.iter().all(|s| s.distance(p) > self.radius_m)
    }

    /// Whether the body fits all along the straight line from `a` to `b` (every 2 cm).
    fn line_clear(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let n = ((b.0 - a.0).hypot(b.1 - a.1) / 0.02).ceil().max(1.0) as usize;
        (0..=n).all(|k| {
            let t = k as f64 / n as f64;
            self.clear(&Point::new(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)))
        })
    }

    /// The nearest cell to `p` where the body fits, within two cells.
    fn cell_near(&self, p: (f64, f64)) -> Option<usize> {
        let cx = ((p.0 - self.origin.0) / self.cell_m).floor() as i64;
        let cy = ((p.1 - self.origin.1) / self.cell_m).floor() as i64;
        let mut best: Option<(f64, usize)> = None;
        for dy in -2..=2 {
            for dx in -2..=2 {
                let (x, y) = (cx + dx, cy + dy);
                if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
                    continue;
                }
                let i = y as usize * self.width + x as usize;
                let c = self.centre(i);
                let d = (c.0 - p.0).hypot(c.1 - p.1);
                if self.fits[i] && best.is_none_or(|(b, _)| d < b) {
                    best = Some((d, i));
                }
            }
        }
        best.map(|(_, i)| i)
    }

    /// Every cell the body reaches from `from` (by the same steps as [`Clearance::shortest`]),
    /// `None` if it does not fit there.
    pub(super) fn reachable_from(&self, from: (f64, f64)) -> Option<Vec<usize>> {
        let s = self.cell_near(from)?;
        let mut seen = vec![false; self.fits.len()];
        seen[s] = true;
        let mut todo = vec![s];
        let mut all = Vec::new();
        while let Some(i) = todo.pop() {
            all.push(i);
            for j in self.steps(i) {
                if !seen[j] {
                    seen[j] = true;
                    todo.push(j);
                }
            }
        }
        all.sort_unstable();
        Some(all)
    }

    /// The cells one step from `i` where the body fits: the eight around it, a diagonal only
    /// with both cells beside it free (no corner cutting).
    fn steps(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let (x, y) = ((i % self.width) as i64, (i / self.width) as i64);
        [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)].into_iter().filter_map(
            move |(dx, dy)| {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= self.width as i64 || ny >= self.height as i64 {
                    return None;
                }
                let j = ny as usize * self.width + nx as usize;
                let beside = |ax: i64, ay: i64| self.fits[ay as usize * self.width + ax as usize];
                (self.fits[j] && (dx == 0 || dy == 0 || (beside(nx, y) && beside(x, ny)))).then_some(j)
            },
        )
    }

    /// The shortest path for the body from `from` to `to`, m.
    fn shortest(&self, from: (f64, f64), to: (f64, f64)) -> Option<f64> {
        let (s, g) = (self.cell_near(from)?, self.cell_near(to)?);
        let mut dist = vec![u64::MAX; self.fits.len()];
        let mut prev = vec![usize::MAX; self.fits.len()];
        let mut heap = BinaryHeap::new();
        dist[s] = 0;
        heap.push(Reverse((0u64, s)));
        // Costs in micrometres: integers keep the search exact and ordered.
        let (straight, diagonal) =
            ((self.cell_m * 1e6).round() as u64, (self.cell_m * 1e6 * 2f64.sqrt()).round() as u64);
        while let Some(Reverse((d, i))) = heap.pop() {
            if i == g {
                break;
            }
            if d > dist[i] {
                continue;
            }
            for j in self.steps(i) {
                let diagonal_step = j % self.width != i % self.width && j / self.width != i / self.width;
                let nd = d + if diagonal_step { diagonal } else { straight };
                if nd < dist[j] {
                    dist[j] = nd;
                    prev[j] = i;
                    heap.push(Reverse((nd, j)));
                }
            }
        }
        if dist[g] == u64::MAX {
            return None;
        }
        let mut cells = vec![g];
        while let Some(&c) = cells.last()
            && c != s
        {
            cells.push(prev[c]);
        }
        cells.reverse();
        let mut points: Vec<(f64, f64)> = vec![from];
        points.extend(cells.iter().map(|&c| self.centre(c)));
        points.push(to);
        // Pulled tight: from each kept point, on to the farthest one in plain sight.
        let (mut length, mut at) = (0.0, 0);
        while at + 1 < points.len() {
            let mut next = at + 1;
            for k in (at + 2..points.len()).rev() {
                if self.line_clear(points[at], points[k]) {
                    next = k;
                    break;
                }
            }
            length += (points[next].0 - points[at].0).hypot(points[next].1 - points[at].1);
            at = next;
        }
        Some(length)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_independent_search_finds_the_way_round_a_wall_and_none_through_a_narrow_gap() {
        let world = World::from_str(
            r#"
            name = "two rooms"
            [robot]
            x = 1.0
            y = 1.0
            heading_deg = 0.0
            [[walls]]
            points = [[0.0, 0.0], [6.0, 0.0], [6.0, 4.0], [0.0, 4.0]]
            closed = true
            [[walls]]
            points = [[3.0, 0.0], [3.0, 3.0]]
            "#,
            "test",
        )
        .expect("world");
        let c = Clearance::new(&world, 0.25, 0.05);
        // Straight across the first room.
        let d = c.shortest((1.0, 1.0), (1.0, 3.0)).expect("a path");
        assert!((d - 2.0).abs() < 0.02, "{d}");
        // Round the wall's end at (3, 3): at least the two legs to its tip, at most a few cm
        // more (the body keeps 0.25 m off the tip).
        let d = c.shortest((1.0, 1.0), (5.0, 1.0)).expect("a path");
        let legs = 2.0 * (2.0f64.powi(2) + 2.0f64.powi(2)).sqrt();
        assert!(d > legs && d < legs + 0.5, "{d} vs {legs}");
        // No way for a body 1.4 m wide: the gap above the wall is 1 m.
        let wide = Clearance::new(&world, 0.7, 0.05);
        assert_eq!(wide.shortest((1.0, 2.0), (5.0, 2.0)), None);
    }

    #[test]
    fn spl_weighs_success_by_path_length() {
        let goal = |status: &str, path_m: f64, shortest: Option<f64>| GoalFigures {
            id: 1,
            target: "x".into(),
            status: status.into(),
            reason: String::new(),
            time_s: 1.0,
            path_m,
            shortest_m: shortest,
            final_error_m: Some(0.0),
        };
        let mut r = NavigationReport {
            goals: vec![
                goal("succeeded", 10.0, Some(8.0)),
                goal("aborted", 3.0, Some(8.0)),
                goal("succeeded", 5.0, Some(5.0)),
            ],
            ..NavigationReport::default()
        };
        r.finish();
        assert!((r.success_rate - 2.0 / 3.0).abs() < 1e-12);
        assert!((r.spl - (0.8 + 0.0 + 1.0) / 3.0).abs() < 1e-12, "{}", r.spl);
        // A goal where the robot already is: jitter of 5 cm is no detour, 1 m is.
        let mut r = NavigationReport {
            goals: vec![goal("succeeded", 0.05, Some(0.01))],
            ..NavigationReport::default()
        };
        r.finish();
        assert_eq!(r.spl, 1.0);
        let mut r = NavigationReport {
            goals: vec![goal("succeeded", 1.0, Some(0.01))],
            ..NavigationReport::default()
        };
        r.finish();
        assert!((r.spl - 0.25).abs() < 1e-12, "{}", r.spl);
        // Said succeeded, truly 1 m away (the estimate was wrong): not a success.
        let mut fooled = goal("succeeded", 10.0, Some(8.0));
        fooled.final_error_m = Some(1.0);
        let mut r =
            NavigationReport { goals: vec![fooled, goal("succeeded", 8.0, Some(8.0))], ..Default::default() };
        r.finish();
        assert_eq!((r.success_rate, r.spl), (0.5, 0.5));
    }
}
