//! The figure's layout and drawing: title, map, legend, behaviour strip, two time series.

use super::axis::{self, Scale};
use super::canvas::{Anchor, Canvas, Font, TextMode, polyline_data};
use super::headline::{self, NONE_LABEL};
use super::navigation;
use super::series::{PANEL_HEIGHT, Panel, STRIP_HEIGHT, TimeAxis, strip};
use super::{PlotData, WIDTH_PX, decimate};
use std::fmt::Write;

const LEFT: f64 = 130.0;
const RIGHT: f64 = 50.0;
/// The tallest the map may be, px; wide worlds are limited by the width instead.
const MAX_MAP_HEIGHT: f64 = 700.0;
/// Margin around the world's contents on the map, m.
const MAP_PAD_M: f64 = 0.3;
/// Trajectory points closer than this to the last kept one are not drawn, m (at least half a
/// px is dropped anyway).
const MIN_STEP_M: f64 = 0.01;
pub(crate) const BUMP_COLOUR: &str = "#d62728";

pub(crate) const TICK: Font = Font::new(16.0).colour("#333");
pub(crate) const LABEL: Font = Font::new(18.0).colour("#222");

/// Draws the whole figure.
pub(crate) fn draw(data: &PlotData<'_>, mode: TextMode) -> String {
    let width = f64::from(WIDTH_PX);
    let plot_width = width - LEFT - RIGHT;
    let map = MapFrame::fit(data, plot_width, 110.0);
    let legend_y = map.bottom() + 90.0;
    // A navigation run's entries take a second legend row.
    let legend_rows = if data.navigation.is_some() { 2.0 } else { 1.0 };
    let strip_top = legend_y + 34.0 * legend_rows;

    let behaviours = headline::behaviours(data);
    let others = headline::other_names(data, &behaviours);
    let colour = |b: Option<&str>| headline::colour(data, b, &others);
    // The time series, stacked under the strip. A navigation run leaves out a behaviour's
    // panel when that behaviour never drove, and adds the localization error's.
    let navigating = data.navigation.is_some();
    let mut panels = Vec::new();
    if !navigating || !data.offset.is_empty() {
        panels.push((
            "offset",
            Panel {
                top: 0.0,
                caption: "Centre following: offset from the corridor centre",
                y_label: "offset (m)",
                points: &data.offset,
                target: data.targets.offset_m,
                symmetric: true,
                colour: colour(Some("centerfollow")),
                empty: "no samples: centre following never drove",
            },
        ));
    }
    if !navigating || !data.clearance.is_empty() {
        panels.push((
            "clearance",
            Panel {
                top: 0.0,
                caption: "Wall following: clearance to the followed wall",
                y_label: "clearance (m)",
                points: &data.clearance,
                target: data.targets.clearance_m,
                symmetric: false,
                colour: colour(Some("wallfollow")),
                empty: "no samples: wall following never drove",
            },
        ));
    }
    if let Some(nav) = &data.navigation {
        panels.push((
            "localization",
            Panel {
                top: 0.0,
                caption: "Localization: the estimate's distance from the true pose",
                y_label: "error (m)",
                points: &nav.error,
                target: nav.error_target_m,
                symmetric: false,
                colour: navigation::ESTIMATE_COLOUR,
                empty: "no estimates: the localizer published none it vouched for",
            },
        ));
    }
    let mut top = strip_top + STRIP_HEIGHT + 56.0;
    for (_, panel) in &mut panels {
        panel.top = top;
        top += PANEL_HEIGHT + 78.0;
    }
    let last_bottom = top - 78.0;
    let height = (last_bottom + 76.0).ceil();

    let mut c = Canvas::new(width, height, mode);
    let title = if data.title.is_empty() { &data.world.name } else { &data.title };
    c.text(LEFT, 46.0, Font::new(28.0).bold(), title);
    c.text(LEFT, 80.0, Font::new(19.0).colour("#444"), &headline::line(data));

    map.draw(&mut c, data, &colour);
    legend(&mut c, legend_y, &behaviours, &colour);
    if navigating {
        navigation_legend(&mut c, legend_y + 34.0);
    }

    let time = TimeAxis::of(data, LEFT, LEFT + plot_width);
    strip(&mut c, data, &time, strip_top, &behaviours, &colour);
    for (id, panel) in &panels {
        panel.draw(&mut c, data, &time, id);
    }
    let unit = if time.minutes { "time (min)" } else { "time (s)" };
    c.text(LEFT + plot_width / 2.0, last_bottom + 56.0, LABEL.anchor(Anchor::Middle), unit);
    c.finish()
}

/// Where the map goes and its metres-to-px transform (equal scale on both axes).
struct MapFrame {
    /// World bounds shown, m: x0, y0, x1, y1.
    bounds: [f64; 4],
    left: f64,
    top: f64,
    /// px per m, on both axes.
    scale: f64,
}

impl MapFrame {
    fn fit(data: &PlotData<'_>, plot_width: f64, top: f64) -> MapFrame {
        let w = data.world;
        let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
        let mut add = |x: f64, y: f64, r: f64| {
            if x.is_finite() && y.is_finite() {
                b = [b[0].min(x - r), b[1].min(y - r), b[2].max(x + r), b[3].max(y + r)];
            }
        };
        w.walls.iter().flat_map(|wall| &wall.points).for_each(|p| add(p[0], p[1], 0.0));
        w.boxes.iter().flat_map(|bx| [bx.min, bx.max]).for_each(|p| add(p[0], p[1], 0.0));
        w.discs.iter().for_each(|d| add(d.center[0], d.center[1], d.radius));
        w.movers
            .iter()
            .flat_map(|m| m.path.iter().map(move |p| (p, m.radius)))
            .for_each(|(p, r)| add(p[0], p[1], r));
        data.trajectory.iter().for_each(|s| add(s.x_m, s.y_m, 0.0));
        w.places.iter().for_each(|p| add(p.x, p.y, 0.0));
        if !b[0].is_finite() {
            b = [0.0, 0.0, 1.0, 1.0];
        }
        let bounds = [b[0] - MAP_PAD_M, b[1] - MAP_PAD_M, b[2] + MAP_PAD_M, b[3] + MAP_PAD_M];
        let (w_m, h_m) = (bounds[2] - bounds[0], bounds[3] - bounds[1]);
        let scale = (plot_width / w_m).min(MAX_MAP_HEIGHT / h_m);
        let left = LEFT + (plot_width - w_m * scale) / 2.0;
        MapFrame { bounds, left, top, scale }
    }

    fn bottom(&self) -> f64 {
        self.top + (self.bounds[3] - self.bounds[1]) * self.scale
    }

    fn right(&self) -> f64 {
        self.left + (self.bounds[2] - self.bounds[0]) * self.scale
    }

    /// Metres for `px` pixels, for stroke widths inside the map group.
    fn m(&self, px: f64) -> f64 {
        px / self.scale
    }

    fn draw(&self, c: &mut Canvas, data: &PlotData<'_>, colour: &dyn Fn(Option<&str>) -> &'static str) {
        let [x0, _, _, y1] = self.bounds;
        let (bottom, right) = (self.bottom(), self.right());
        let _ = writeln!(
            c.out(),
            r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#fbfbfb" stroke="#bbb"/>"##,
            self.left,
            self.top,
            right - self.left,
            bottom - self.top
        );
        self.axes(c);

        // World coordinates from here on: x right, y up, metres.
        let (s, tx, ty) = (self.scale, self.left - x0 * self.scale, self.top + y1 * self.scale);
        let _ = writeln!(c.out(), r#"<g id="map" transform="matrix({s:.6} 0 0 {:.6} {tx:.3} {ty:.3})">"#, -s);
        let w = data.world;
        for m in &w.movers {
            let mut d = String::new();
            polyline_data(&mut d, m.path.iter().map(|p| (p[0], p[1])), 3);
            let _ = writeln!(
                c.out(),
                r##"<path d="{d}" fill="none" stroke="#a8a8a8" stroke-width="{:.4}" stroke-dasharray="{:.3} {:.3}"/>"##,
                self.m(1.5),
                self.m(9.0),
                self.m(6.0)
            );
        }
        for bx in &w.boxes {
            let _ = writeln!(
                c.out(),
                r##"<rect x="{:.3}" y="{:.3}" width="{:.3}" height="{:.3}" fill="#d9d9d9" stroke="#555" stroke-width="{:.4}"/>"##,
                bx.min[0],
                bx.min[1],
                bx.max[0] - bx.min[0],
                bx.max[1] - bx.min[1],
                self.m(1.0)
            );
        }
        for d in &w.discs {
            let _ = writeln!(
                c.out(),
                r##"<circle cx="{:.3}" cy="{:.3}" r="{:.3}" fill="#d9d9d9" stroke="#555" stroke-width="{:.4}"/>"##,
                d.center[0],
                d.center[1],
                d.radius,
                self.m(1.0)
            );
        }
        for wall in &w.walls {
            let mut d = String::new();
            polyline_data(&mut d, wall.points.iter().map(|p| (p[0], p[1])), 3);
            if wall.closed {
                d.push('Z');
            }
            let _ = writeln!(
                c.out(),
                r##"<path d="{d}" fill="none" stroke="#222" stroke-width="{:.4}" stroke-linejoin="round"/>"##,
                self.m(2.5)
            );
        }
        let min_step = MIN_STEP_M.max(self.m(0.5));
        for run in decimate::trajectory(&data.trajectory, min_step) {
            let mut d = String::new();
            polyline_data(&mut d, run.points.iter().map(|p| (p[0], p[1])), 3);
            let _ = writeln!(
                c.out(),
                r#"<path class="trajectory" d="{d}" fill="none" stroke="{}" stroke-width="{:.4}" stroke-linejoin="round" stroke-linecap="round" stroke-opacity="0.85"/>"#,
                colour(run.behaviour),
                self.m(1.6)
            );
        }
        if let Some(nav) = &data.navigation {
            navigation::draw_on_map(c, nav, &|px| self.m(px), min_step);
        }
        let mut d = String::new();
        let r = self.m(6.0);
        for b in data.bumps.iter().filter(|b| b.x_m.is_finite() && b.y_m.is_finite()) {
            let (x, y) = (b.x_m, b.y_m);
            let _ = write!(
                d,
                "M{:.3} {:.3}L{:.3} {:.3}M{:.3} {:.3}L{:.3} {:.3}",
                x - r,
                y - r,
                x + r,
                y + r,
                x - r,
                y + r,
                x + r,
                y - r
            );
        }
        if !d.is_empty() {
            let _ = writeln!(
                c.out(),
                r#"<path class="bumps" d="{d}" stroke="{BUMP_COLOUR}" stroke-width="{:.4}"/>"#,
                self.m(2.5)
            );
        }
        c.raw("</g>\n");
        // Names are drawn upright, outside the flipped group.
        for p in &w.places {
            let (x, y) = (self.left + (p.x - x0) * s, self.top + (y1 - p.y) * s);
            navigation::place(c, x, y, &p.name);
        }
    }

    /// Ticks and labels in metres on the bottom and left edges.
    fn axes(&self, c: &mut Canvas) {
        let [x0, y0, x1, y1] = self.bounds;
        let bottom = self.bottom();
        let target = |px: f64| ((px / 120.0).round() as usize).max(2);
        let xs = Scale::new(x0, x1, self.left, self.right());
        let ys = Scale::new(y0, y1, bottom, self.top);
        let step = axis::nice_step(x1 - x0, target(self.right() - self.left));
        let mut d = String::new();
        for x in axis::ticks(x0, x1, step) {
            let px = xs.map(x);
            let _ = write!(d, "M{px:.1} {bottom:.1}v6");
            c.text(px, bottom + 24.0, TICK.anchor(Anchor::Middle), &axis::label(x, step));
        }
        let step_y = axis::nice_step(y1 - y0, target(bottom - self.top).max(3));
        for y in axis::ticks(y0, y1, step_y) {
            let py = ys.map(y);
            let _ = write!(d, "M{:.1} {py:.1}h-6", self.left);
            c.text(self.left - 10.0, py + 5.5, TICK.anchor(Anchor::End), &axis::label(y, step_y));
        }
        let _ = writeln!(c.out(), r##"<path d="{d}" stroke="#555" stroke-width="1"/>"##);
        c.text((self.left + self.right()) / 2.0, bottom + 50.0, LABEL.anchor(Anchor::Middle), "x (m)");
        c.text(self.left - 52.0, (self.top + bottom) / 2.0, LABEL.anchor(Anchor::Middle).vertical(), "y (m)");
    }
}

/// The second legend row of a navigation run.
fn navigation_legend(c: &mut Canvas, y: f64) {
    use navigation::{ESTIMATE_COLOUR, PATH_COLOUR, PLACE_COLOUR, REACHED_COLOUR};
    let font = Font::new(17.0);
    let mid = y - 6.0;
    let goal = |x: f64, fill: &str| {
        format!(
            r#"<circle cx="{:.1}" cy="{mid:.1}" r="8" fill="{fill}" fill-opacity="0.35" stroke="{fill}" stroke-width="1.5"/>"#,
            x + 14.0
        )
    };
    let mut x = LEFT;
    for label in ["path planned", "estimated pose", "goal reached", "goal missed", "place"] {
        let swatch = match label {
            "path planned" => format!(
                r#"<path d="M{x:.1} {mid:.1}h28" stroke="{PATH_COLOUR}" stroke-width="1.4" stroke-dasharray="7 4"/>"#
            ),
            "estimated pose" => {
                format!(r#"<path d="M{x:.1} {mid:.1}h28" stroke="{ESTIMATE_COLOUR}" stroke-width="1.2"/>"#)
            }
            "goal reached" => goal(x, REACHED_COLOUR),
            "goal missed" => goal(x, BUMP_COLOUR),
            _ => format!(
                r#"<path d="M{:.1} {:.1}l5 5l-5 5l-5 -5z" fill="{PLACE_COLOUR}"/>"#,
                x + 14.0,
                mid - 5.0
            ),
        };
        let _ = writeln!(c.out(), r#"<g class="legend">{swatch}</g>"#);
        c.text(x + 38.0, y, font, label);
        x += 38.0 + font.width(label) + 34.0;
    }
}

/// One row of legend entries below the map.
fn legend(
    c: &mut Canvas,
    y: f64,
    behaviours: &[Option<&str>],
    colour: &dyn Fn(Option<&str>) -> &'static str,
) {
    let font = Font::new(17.0);
    let mid = y - 6.0;
    // Each entry: its swatch drawn at a left edge, and its label.
    type Swatch<'s> = Box<dyn Fn(f64) -> String + 's>;
    let mut entries: Vec<(Swatch<'_>, &str)> = Vec::new();
    for b in behaviours {
        let stroke = colour(*b);
        let swatch = move |x: f64| {
            format!(
                r#"<path d="M{x:.1} {mid:.1}h28" stroke="{stroke}" stroke-width="4" stroke-linecap="round"/>"#
            )
        };
        entries.push((Box::new(swatch), b.unwrap_or(NONE_LABEL)));
    }
    let bump = move |x: f64| {
        format!(
            r#"<path d="M{:.1} {:.1}l12 12m0 -12l-12 12" stroke="{BUMP_COLOUR}" stroke-width="2.5"/>"#,
            x + 8.0,
            mid - 6.0
        )
    };
    entries.push((Box::new(bump), "bump"));
    let wall = move |x: f64| format!(r##"<path d="M{x:.1} {mid:.1}h28" stroke="#222" stroke-width="2.5"/>"##);
    entries.push((Box::new(wall), "wall"));
    let obstacle = move |x: f64| {
        format!(
            r##"<rect x="{:.1}" y="{:.1}" width="20" height="14" fill="#d9d9d9" stroke="#555"/>"##,
            x + 4.0,
            mid - 7.0
        )
    };
    entries.push((Box::new(obstacle), "obstacle"));
    let person = move |x: f64| {
        format!(
            r##"<path d="M{x:.1} {mid:.1}h28" stroke="#a8a8a8" stroke-width="1.5" stroke-dasharray="9 6"/>"##
        )
    };
    entries.push((Box::new(person), "person's path"));

    let mut x = LEFT;
    for (swatch, label) in entries {
        let _ = writeln!(c.out(), r#"<g class="legend">{}</g>"#, swatch(x));
        c.text(x + 38.0, y, font, label);
        x += 38.0 + font.width(label) + 34.0;
    }
}
