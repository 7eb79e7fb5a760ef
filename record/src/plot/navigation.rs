//! What a navigation run adds to the figure: on the map, the world's places, every path the
//! planner gave the path follower, the localizer's estimate beside the true trajectory and each
//! goal marked reached or missed; below it, a panel of the estimate's distance from the truth.

use super::canvas::{Canvas, Font};
use super::figure::BUMP_COLOUR;
use std::fmt::Write;

/// A goal on the map.
#[derive(Debug, Clone, PartialEq)]
pub struct GoalMark {
    /// What it was called: a place's name or `X,Y[,HEADING]`.
    pub label: String,
    /// Where it was, m.
    pub x_m: f64,
    /// Where it was, m.
    pub y_m: f64,
    /// Whether the robot truly reached it (the report's count).
    pub reached: bool,
}

/// A navigation run's traces, for the figure.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NavigationTrace {
    /// The goals that named a position, in order.
    pub goals: Vec<GoalMark>,
    /// Every path the planner gave the path follower, in order (a replan adds one).
    pub paths: Vec<Vec<[f64; 2]>>,
    /// The estimates the localizer vouched for, `(t_s, x_m, y_m)` (none while it said the robot
    /// was lost).
    pub estimate: Vec<(f64, f64, f64)>,
    /// `(t_s, m)`: each of those estimates' distance from the truth at its stamp.
    pub error: Vec<(f64, f64)>,
    /// The localization error aimed for, m: the error panel's target line.
    pub error_target_m: f64,
}

/// The planned paths' colour.
pub(crate) const PATH_COLOUR: &str = "#6a3d9a";
/// The estimate's colour.
pub(crate) const ESTIMATE_COLOUR: &str = "#111111";
/// A reached goal's fill.
pub(crate) const REACHED_COLOUR: &str = "#1a9850";
/// A place's marker colour.
pub(crate) const PLACE_COLOUR: &str = "#666666";
/// A goal's ring: the success radius, m.
const GOAL_RADIUS_M: f64 = 0.25;
/// Consecutive estimates further apart than this are not joined (a relocalization, or a
/// kidnapping noticed), m.
const JUMP_M: f64 = 0.5;

/// Draws the trace inside the map's group (metres, y up); `m(px)` gives metres for px.
pub(crate) fn draw_on_map(c: &mut Canvas, nav: &NavigationTrace, m: &dyn Fn(f64) -> f64, min_step_m: f64) {
    let mut d = String::new();
    for path in &nav.paths {
        line(&mut d, path.iter().map(|p| (p[0], p[1])), f64::INFINITY, 0.0);
    }
    if !d.is_empty() {
        let _ = writeln!(
            c.out(),
            r#"<path class="planned" d="{d}" fill="none" stroke="{PATH_COLOUR}" stroke-width="{:.4}" stroke-dasharray="{:.3} {:.3}" stroke-opacity="0.75" stroke-linejoin="round"/>"#,
            m(1.4),
            m(7.0),
            m(4.0)
        );
    }
    let mut d = String::new();
    line(&mut d, nav.estimate.iter().map(|&(_, x, y)| (x, y)), JUMP_M, min_step_m);
    if !d.is_empty() {
        let _ = writeln!(
            c.out(),
            r#"<path class="estimate" d="{d}" fill="none" stroke="{ESTIMATE_COLOUR}" stroke-width="{:.4}" stroke-opacity="0.7" stroke-linejoin="round"/>"#,
            m(0.9)
        );
    }
    for g in nav.goals.iter().filter(|g| g.x_m.is_finite() && g.y_m.is_finite()) {
        let fill = if g.reached { REACHED_COLOUR } else { BUMP_COLOUR };
        let _ = writeln!(
            c.out(),
            r##"<circle class="goal" cx="{:.3}" cy="{:.3}" r="{GOAL_RADIUS_M}" fill="{fill}" fill-opacity="0.35" stroke="{fill}" stroke-width="{:.4}"/>"##,
            g.x_m,
            g.y_m,
            m(1.5)
        );
    }
}

/// Draws a place's marker at px `(x, y)` with its name beside it.
pub(crate) fn place(c: &mut Canvas, x: f64, y: f64, name: &str) {
    let _ = writeln!(
        c.out(),
        r#"<path class="place" d="M{x:.1} {:.1}l5 5l-5 5l-5 -5z" fill="{PLACE_COLOUR}"/>"#,
        y - 5.0
    );
    c.text(x + 8.0, y - 6.0, Font::new(14.0).colour(PLACE_COLOUR), name);
}

/// Appends `points` to the SVG path data `d` as polylines, starting a new one where two points
/// are more than `jump` apart and dropping points closer than `min_step` to the last one drawn
/// (the last point of each polyline is always drawn). Non-finite points are skipped.
fn line(d: &mut String, points: impl Iterator<Item = (f64, f64)>, jump: f64, min_step: f64) {
    let mut last_drawn: Option<(f64, f64)> = None;
    let mut pending: Option<(f64, f64)> = None;
    let mut previous: Option<(f64, f64)> = None;
    for p in points.filter(|p| p.0.is_finite() && p.1.is_finite()) {
        let far = |a: (f64, f64), limit: f64| (p.0 - a.0).hypot(p.1 - a.1) > limit;
        match (last_drawn, previous) {
            (Some(_), Some(prev)) if !far(prev, jump) => {
                if last_drawn.is_some_and(|l| far(l, min_step) || min_step <= 0.0) {
                    let _ = write!(d, "L{:.3} {:.3}", p.0, p.1);
                    last_drawn = Some(p);
                    pending = None;
                } else {
                    pending = Some(p);
                }
            }
            _ => {
                if let Some(t) = pending.take() {
                    let _ = write!(d, "L{:.3} {:.3}", t.0, t.1);
                }
                let _ = write!(d, "M{:.3} {:.3}", p.0, p.1);
                last_drawn = Some(p);
            }
        }
        previous = Some(p);
    }
    if let Some(t) = pending {
        let _ = write!(d, "L{:.3} {:.3}", t.0, t.1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_breaks_at_jumps_and_thins_close_points() {
        let mut d = String::new();
        let points = [(0.0, 0.0), (0.001, 0.0), (0.1, 0.0), (5.0, 0.0), (5.1, 0.0)];
        line(&mut d, points.into_iter(), 0.5, 0.01);
        assert_eq!(d, "M0.000 0.000L0.100 0.000M5.000 0.000L5.100 0.000");
    }

    #[test]
    fn a_line_keeps_the_last_point_of_each_piece() {
        let mut d = String::new();
        let points = [(0.0, 0.0), (0.2, 0.0), (0.201, 0.0), (3.0, 0.0), (3.001, 0.0)];
        line(&mut d, points.into_iter(), 0.5, 0.01);
        assert_eq!(d, "M0.000 0.000L0.200 0.000L0.201 0.000M3.000 0.000L3.001 0.000");
    }

    #[test]
    fn a_line_skips_non_finite_points() {
        let mut d = String::new();
        line(&mut d, [(0.0, 0.0), (f64::NAN, 1.0), (0.1, 0.0)].into_iter(), 0.5, 0.0);
        assert_eq!(d, "M0.000 0.000L0.100 0.000");
    }
}
