//! The what-if figure of `orsa replay --config|--set`: the commands that reached the robot,
//! recorded and replayed with the other parameters, over time, with the stretches where another
//! behaviour would have been driving shaded.

use super::axis::Scale;
use super::canvas::{Anchor, Canvas, Font, TextMode, polyline_data};
use super::figure::LABEL;
use super::series::{PANEL_HEIGHT, TimeAxis, max_gap, panel_frame, value_axis};
use super::{PlotError, WIDTH_PX, decimate};
use std::fmt::Write;
use std::path::Path;

const LEFT: f64 = 130.0;
const RIGHT: f64 = 50.0;
const RECORDED: &str = "#1f77b4";
const WHAT_IF: &str = "#ff7f0e";
const DIFFERS: &str = "#d62728";

/// What the what-if figure shows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WhatIfPlot {
    /// The title line.
    pub title: String,
    /// The second line: what was changed.
    pub subtitle: String,
    /// `(t_s, v_m_s)` of the commands that reached the robot: recorded, then what-if.
    pub v: [Vec<(f64, f64)>; 2],
    /// `(t_s, omega_rad_s)` of the same commands: recorded, then what-if.
    pub omega: [Vec<(f64, f64)>; 2],
    /// `(from_s, to_s)`: while another behaviour would have been driving.
    pub wiring_differs: Vec<(f64, f64)>,
    /// The replayed span, s.
    pub span_s: (f64, f64),
}

/// Draws the figure as SVG.
pub fn render_what_if_svg(data: &WhatIfPlot) -> String {
    draw(data, TextMode::Native)
}

/// Writes the figure to `path`, as SVG or PNG by its extension.
pub fn write_what_if(path: &Path, data: &WhatIfPlot) -> Result<(), PlotError> {
    super::write_svg_or_png(path, |mode| draw(data, mode))
}

fn draw(data: &WhatIfPlot, mode: TextMode) -> String {
    let width = f64::from(WIDTH_PX);
    let (left, right) = (LEFT, width - RIGHT);
    let legend_y = 128.0;
    let panel1 = legend_y + 70.0;
    let panel2 = panel1 + PANEL_HEIGHT + 90.0;
    let height = (panel2 + PANEL_HEIGHT + 76.0).ceil();
    let mut c = Canvas::new(width, height, mode);
    c.text(left, 46.0, Font::new(28.0).bold(), &data.title);
    c.text(left, 80.0, Font::new(19.0).colour("#444"), &data.subtitle);
    legend(&mut c, left, legend_y);

    let (t0, t1) = if data.span_s.0 < data.span_s.1 { data.span_s } else { (0.0, 1.0) };
    let time = TimeAxis { scale: Scale::new(t0, t1, left, right), minutes: t1 - t0 > 180.0 };
    let unit = if time.minutes { "min" } else { "s" };
    panel(&mut c, data, &time, panel1, "Forward speed", "v (m/s)", &data.v, "v");
    panel(&mut c, data, &time, panel2, "Turn rate", "omega (rad/s)", &data.omega, "w");
    c.text(
        (left + right) / 2.0,
        panel2 + PANEL_HEIGHT + 60.0,
        LABEL.anchor(Anchor::Middle),
        &format!("time ({unit})"),
    );
    c.finish()
}

fn legend(c: &mut Canvas, x: f64, y: f64) {
    let mut at = x;
    for (colour, label, opacity) in [
        (RECORDED, "recorded", 1.0),
        (WHAT_IF, "what-if", 1.0),
        (DIFFERS, "another behaviour would drive", 0.22),
    ] {
        let _ = writeln!(
            c.out(),
            r#"<rect x="{at:.1}" y="{:.1}" width="28" height="14" fill="{colour}" fill-opacity="{opacity}"/>"#,
            y - 12.0
        );
        c.text(at + 36.0, y, LABEL, label);
        at += 36.0 + LABEL.width(label) + 40.0;
    }
}

#[allow(clippy::too_many_arguments)]
fn panel(
    c: &mut Canvas,
    data: &WhatIfPlot,
    time: &TimeAxis,
    top: f64,
    caption: &str,
    y_label: &str,
    series: &[Vec<(f64, f64)>; 2],
    id: &str,
) {
    let (left, right) = (time.scale.r0, time.scale.r1);
    panel_frame(c, time, top, caption, id);
    for (a, b) in &data.wiring_differs {
        let (x0, x1) = (time.scale.map(a.max(time.scale.d0)), time.scale.map(b.min(time.scale.d1)));
        let _ = writeln!(
            c.out(),
            r#"<rect class="differs" x="{x0:.1}" y="{top:.1}" width="{:.1}" height="{PANEL_HEIGHT}" fill="{DIFFERS}" fill-opacity="0.22"/>"#,
            (x1 - x0).max(1.0)
        );
    }
    let values = series.iter().flatten().map(|p| p.1).filter(|v| v.is_finite());
    let (lo, hi) = values.fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let pad = ((hi - lo) * 0.08).max(0.01);
    let ys = value_axis(c, time, top, (lo - pad, hi + pad), y_label);
    let columns = (right - left).round().max(1.0) as usize;
    for (points, colour, width) in [(&series[0], RECORDED, 2.2), (&series[1], WHAT_IF, 1.3)] {
        let lines = decimate::series(points, time.scale.d0, time.scale.d1, columns, max_gap(points));
        let mut d = String::new();
        for line in &lines {
            polyline_data(&mut d, line.iter().map(|(t, v)| (time.scale.map(*t), ys.map(*v))), 1);
        }
        if !d.is_empty() {
            let _ = writeln!(
                c.out(),
                r#"<path class="series" clip-path="url(#clip-{id})" d="{d}" fill="none" stroke="{colour}" stroke-width="{width}" stroke-linejoin="round"/>"#
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_series_and_every_differing_stretch_are_drawn() {
        let line =
            |k: f64| (0..200).map(|i| (i as f64 * 0.1, k * (i as f64 * 0.1).sin())).collect::<Vec<_>>();
        let data = WhatIfPlot {
            title: "what if".into(),
            subtitle: "wallfollow.target_m = 0.3".into(),
            v: [line(0.2), line(0.25)],
            omega: [line(0.5), line(0.4)],
            wiring_differs: vec![(3.0, 4.0), (12.0, 12.5)],
            span_s: (0.0, 20.0),
        };
        let svg = render_what_if_svg(&data);
        assert_eq!(svg.matches(r#"class="series""#).count(), 4, "two series in each of two panels");
        assert_eq!(svg.matches(r#"class="differs""#).count(), 4, "two stretches in each panel");
        assert!(svg.contains("wallfollow.target_m = 0.3"));
        let empty = render_what_if_svg(&WhatIfPlot::default());
        assert_eq!(empty.matches(r#"class="series""#).count(), 0);
    }
}
