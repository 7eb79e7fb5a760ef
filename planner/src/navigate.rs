//! Driving to places: what the planner does with a navigation goal, as pure code.
//!
//! [`NavMap`] is what the planner knows of the world (the known grid and its named places);
//! [`NavMap::resolve`] turns a target into a pose, or says why it cannot be one, and
//! [`NavMap::route`] plans the body's path to it on the grid (`orsa_navigation::plan`).
//! [`Progress`] follows a goal while it runs: the distance left along its path, whether the
//! robot has come closer lately (or needs a recovery), and whether it has arrived.

use orsa_interfaces::map::{KnownMap, OccupancyGrid};
use orsa_interfaces::navigation::NavTarget;
use orsa_navigation::layer::ObstacleLayer;
use orsa_navigation::plan::{PlanError, PlanParams, plan};
use std::sync::Arc;

/// A place named in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedPlace {
    /// Its name.
    pub name: String,
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// The heading to end with there, degrees, if any.
    pub heading_deg: Option<f64>,
}

/// What the planner knows of the world.
#[derive(Debug, Clone)]
pub struct NavMap {
    /// The known map.
    pub grid: Arc<OccupancyGrid>,
    /// The places named in it.
    pub places: Vec<NamedPlace>,
}

impl From<KnownMap> for NavMap {
    /// The map the map component serves.
    fn from(known: KnownMap) -> Self {
        NavMap {
            grid: Arc::new(known.grid),
            places: known
                .places
                .into_iter()
                .map(|p| NamedPlace { name: p.name, x_m: p.x_m, y_m: p.y_m, heading_deg: p.heading_deg })
                .collect(),
        }
    }
}

/// Where a goal goes: a position in the map and, maybe, a heading there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GoalPose {
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// The heading to end with, rad.
    pub heading_rad: Option<f64>,
}

impl NavMap {
    /// The pose `target` names, or why it names none.
    pub fn resolve(&self, target: &NavTarget) -> Result<GoalPose, String> {
        match target {
            NavTarget::Place { name } => self
                .places
                .iter()
                .find(|p| &p.name == name)
                .map(|p| GoalPose { x_m: p.x_m, y_m: p.y_m, heading_rad: p.heading_deg.map(f64::to_radians) })
                .ok_or_else(|| {
                    let known: Vec<&str> = self.places.iter().map(|p| p.name.as_str()).collect();
                    if known.is_empty() {
                        format!("no place '{name}': the map names no places")
                    } else {
                        format!("no place '{name}' in the map (places: {})", known.join(", "))
                    }
                }),
            NavTarget::Pose { x_m, y_m, heading_deg } => {
                if !(x_m.is_finite() && y_m.is_finite() && heading_deg.is_none_or(f64::is_finite)) {
                    return Err("the goal's coordinates are not finite numbers".into());
                }
                let g = &self.grid;
                let (x0, y0) = (g.origin_x_m, g.origin_y_m);
                let (x1, y1) = (x0 + g.width as f64 * g.resolution_m, y0 + g.height as f64 * g.resolution_m);
                if !(x0..x1).contains(x_m) || !(y0..y1).contains(y_m) {
                    return Err(format!(
                        "the goal ({x_m:.2}, {y_m:.2}) is outside the map ({x0:.2}..{x1:.2}, {y0:.2}..{y1:.2})"
                    ));
                }
                Ok(GoalPose { x_m: *x_m, y_m: *y_m, heading_rad: heading_deg.map(f64::to_radians) })
            }
        }
    }

    /// The body's path from `from` to `goal` on the known map (see [`route`]).
    pub fn route(
        &self,
        from: (f64, f64),
        goal: GoalPose,
        params: &PlanParams,
    ) -> Result<Vec<[f64; 2]>, String> {
        route(&self.grid, from, goal, params)
    }
}

/// Whether anything `layer` marks lies within `radius_m` of `path` over its next `ahead_m`
/// from the point nearest `(x, y)`.
pub fn blocked(
    layer: &mut ObstacleLayer,
    path: &[[f64; 2]],
    x: f64,
    y: f64,
    radius_m: f64,
    ahead_m: f64,
) -> bool {
    if path.is_empty() {
        return false;
    }
    let start = path
        .iter()
        .enumerate()
        .min_by(|a, b| {
            let da = (a.1[0] - x).hypot(a.1[1] - y);
            let db = (b.1[0] - x).hypot(b.1[1] - y);
            da.total_cmp(&db)
        })
        .map_or(0, |(i, _)| i);
    let mut along = 0.0;
    for i in start..path.len() {
        if i > start {
            along += (path[i][0] - path[i - 1][0]).hypot(path[i][1] - path[i - 1][1]);
        }
        if along > ahead_m {
            break;
        }
        if layer.marked_near(path[i][0], path[i][1], radius_m) {
            return true;
        }
    }
    false
}

/// The body's path from `from` to `goal` on `grid`, or why there is none (a goal inside a
/// wall or where the body does not fit reads so).
pub fn route(
    grid: &OccupancyGrid,
    from: (f64, f64),
    goal: GoalPose,
    params: &PlanParams,
) -> Result<Vec<[f64; 2]>, String> {
    {
        match plan(grid, from, (goal.x_m, goal.y_m), params) {
            Ok(p) => Ok(p.points.iter().map(|&(x, y)| [x, y]).collect()),
            Err(PlanError::Goal(x, y)) => Err(format!(
                "the goal ({x:.2}, {y:.2}) is inside a wall, unknown, or too close to something for the robot's body"
            )),
            Err(PlanError::NoPath(..)) => {
                Err("no path: nothing joins the robot to the goal wide enough for its body".into())
            }
            Err(e) => Err(e.to_string()),
        }
    }
}

/// The length of `path` from the point nearest `(x, y)` to its end, m.
pub fn distance_left(path: &[[f64; 2]], x: f64, y: f64) -> f64 {
    let Some(end) = path.last() else { return 0.0 };
    if path.len() == 1 {
        return (end[0] - x).hypot(end[1] - y);
    }
    let (mut best, mut best_d, mut best_t) = (0, f64::INFINITY, 0.0);
    for (i, w) in path.windows(2).enumerate() {
        let (dx, dy) = (w[1][0] - w[0][0], w[1][1] - w[0][1]);
        let len2 = dx * dx + dy * dy;
        let t =
            if len2 > 0.0 { (((x - w[0][0]) * dx + (y - w[0][1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
        let d = (w[0][0] + t * dx - x).hypot(w[0][1] + t * dy - y);
        if d < best_d {
            (best, best_d, best_t) = (i, d, t);
        }
    }
    let seg = |i: usize| (path[i + 1][0] - path[i][0]).hypot(path[i + 1][1] - path[i][1]);
    best_d + (1.0 - best_t) * seg(best) + (best + 1..path.len() - 1).map(seg).sum::<f64>()
}

/// How a running goal progresses.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    /// The least distance left so far, m.
    best_left_m: f64,
    /// When it last came `progress_m` closer, s.
    best_at_s: f64,
}

/// What [`Progress::check`] makes of the newest pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Going on.
    Going,
    /// There, and stopped.
    Arrived,
    /// No progress for too long: time for the next recovery.
    Stuck,
}

/// What a goal is judged by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judge {
    /// Within this distance of the goal (estimated) it has arrived, m.
    pub arrive_m: f64,
    /// Within this angle of its heading, rad.
    pub arrive_rad: f64,
    /// Coming this much closer counts as progress, m.
    pub progress_m: f64,
    /// Without progress for this long, it is stuck, s.
    pub stuck_s: f64,
    /// Lost (the localizer looking for the robot) for this long, a goal aborts, s.
    pub lost_s: f64,
}

impl Progress {
    /// A goal starting at `now_s` with `left_m` to go.
    pub fn new(left_m: f64, now_s: f64) -> Self {
        Progress { best_left_m: left_m, best_at_s: now_s }
    }

    /// Starts counting again (after a recovery).
    pub fn restart(&mut self, left_m: f64, now_s: f64) {
        *self = Progress::new(left_m, now_s);
    }

    /// Judges the pose `(x, y, heading)` at `now_s` with `left_m` to go, `stopped` or not.
    pub fn check(
        &mut self,
        judge: &Judge,
        goal: GoalPose,
        pose: (f64, f64, f64),
        left_m: f64,
        stopped: bool,
        now_s: f64,
    ) -> Verdict {
        let near = (goal.x_m - pose.0).hypot(goal.y_m - pose.1) < judge.arrive_m;
        let turned = goal.heading_rad.is_none_or(|h| {
            let e = h - pose.2;
            e.sin().atan2(e.cos()).abs() < judge.arrive_rad
        });
        if near && turned && stopped {
            return Verdict::Arrived;
        }
        if left_m < self.best_left_m - judge.progress_m || near {
            self.best_left_m = left_m.min(self.best_left_m);
            self.best_at_s = now_s;
        }
        if now_s - self.best_at_s > judge.stuck_s { Verdict::Stuck } else { Verdict::Going }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::map::{FREE, OCCUPIED};

    fn room() -> NavMap {
        // 4 m x 2 m of 5 cm cells, walled round.
        let (w, h) = (80usize, 40usize);
        let mut cells = vec![FREE; w * h];
        for i in 0..w {
            cells[i] = OCCUPIED;
            cells[(h - 1) * w + i] = OCCUPIED;
        }
        for j in 0..h {
            cells[j * w] = OCCUPIED;
            cells[j * w + w - 1] = OCCUPIED;
        }
        let grid = OccupancyGrid {
            stamp: orsa_actors::Timestamp(0),
            version: 1,
            resolution_m: 0.05,
            width: w as u32,
            height: h as u32,
            origin_x_m: 0.0,
            origin_y_m: 0.0,
            cells,
        };
        NavMap {
            grid: Arc::new(grid),
            places: vec![NamedPlace { name: "door".into(), x_m: 3.5, y_m: 1.0, heading_deg: Some(90.0) }],
        }
    }

    #[test]
    fn targets_resolve_or_say_why_not() {
        let m = room();
        let g = m.resolve(&NavTarget::Place { name: "door".into() }).expect("a place");
        assert_eq!((g.x_m, g.y_m), (3.5, 1.0));
        assert!((g.heading_rad.expect("heading") - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let e = m.resolve(&NavTarget::Place { name: "kitchen".into() }).expect_err("unknown");
        assert!(e.contains("no place 'kitchen'") && e.contains("door"), "{e}");
        let e = m.resolve(&NavTarget::Pose { x_m: 9.0, y_m: 1.0, heading_deg: None }).expect_err("outside");
        assert!(e.contains("outside the map"), "{e}");
        let inside_wall = GoalPose { x_m: 0.02, y_m: 1.0, heading_rad: None };
        let e = m.route((1.0, 1.0), inside_wall, &PlanParams::default()).expect_err("in a wall");
        assert!(e.contains("inside a wall"), "{e}");
        let path = m.route((1.0, 1.0), g, &PlanParams::default()).expect("a path");
        assert!((distance_left(&path, 1.0, 1.0) - 2.5).abs() < 0.05, "{}", distance_left(&path, 1.0, 1.0));
    }

    #[test]
    fn progress_tells_arrival_from_being_stuck() {
        let judge = Judge { arrive_m: 0.15, arrive_rad: 0.17, progress_m: 0.2, stuck_s: 10.0, lost_s: 60.0 };
        let goal = GoalPose { x_m: 2.0, y_m: 0.0, heading_rad: Some(0.0) };
        let mut p = Progress::new(2.0, 0.0);
        assert_eq!(p.check(&judge, goal, (0.5, 0.0, 0.0), 1.5, false, 5.0), Verdict::Going);
        // Stuck 1.5 m short for more than 10 s.
        assert_eq!(p.check(&judge, goal, (0.5, 0.0, 0.0), 1.5, true, 14.0), Verdict::Going);
        assert_eq!(p.check(&judge, goal, (0.5, 0.0, 0.0), 1.5, true, 15.5), Verdict::Stuck);
        p.restart(1.5, 15.5);
        // There but moving, or facing the wrong way: not yet.
        assert_eq!(p.check(&judge, goal, (1.9, 0.0, 0.0), 0.1, false, 20.0), Verdict::Going);
        assert_eq!(p.check(&judge, goal, (1.9, 0.0, 1.0), 0.1, true, 20.0), Verdict::Going);
        assert_eq!(p.check(&judge, goal, (1.9, 0.0, 0.1), 0.1, true, 20.0), Verdict::Arrived);
        assert_eq!(distance_left(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], 0.5, 0.1), 0.1 + 0.5 + 1.0);
    }
}
