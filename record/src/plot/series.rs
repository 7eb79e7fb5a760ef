//! Over time: the time axis, the strip of which behaviour drove when, and the time-series
//! panels (offset, clearance) with their target lines.

use super::PlotData;
use super::axis::{self, Scale};
use super::canvas::{Anchor, Canvas, Font, polyline_data};
use super::decimate;
use super::figure::{BUMP_COLOUR, LABEL, TICK};
use std::fmt::Write;

/// Height of a time-series panel, px.
pub(crate) const PANEL_HEIGHT: f64 = 300.0;
/// Height of the behaviour strip, px.
pub(crate) const STRIP_HEIGHT: f64 = 16.0;

/// The time axis shared by the strip and both panels.
pub(crate) struct TimeAxis {
    pub(crate) scale: Scale,
    /// Labels in minutes (long runs) rather than seconds.
    pub(crate) minutes: bool,
}

impl TimeAxis {
    pub(crate) fn of(data: &PlotData<'_>, left: f64, right: f64) -> TimeAxis {
        let times = data
            .trajectory
            .iter()
            .map(|s| s.t_s)
            .chain(data.offset.iter().chain(&data.clearance).map(|p| p.0))
            .chain(data.bumps.iter().map(|b| b.t_s))
            .chain(data.navigation.iter().flat_map(|n| n.error.iter().map(|p| p.0)))
            .filter(|t| t.is_finite());
        let (t0, t1) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)));
        let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (0.0, 1.0) };
        let minutes = t1 - t0 > 180.0;
        // Ends just short of a tick (an hour's last sample at 59.998 min) reach it.
        let step = axis::nice_step((t1 - t0) / if minutes { 60.0 } else { 1.0 }, 12)
            * if minutes { 60.0 } else { 1.0 };
        let slack = 0.03 * (t1 - t0);
        let t0 = if t0 - (t0 / step).floor() * step <= slack { (t0 / step).floor() * step } else { t0 };
        let t1 = if (t1 / step).ceil() * step - t1 <= slack { (t1 / step).ceil() * step } else { t1 };
        TimeAxis { scale: Scale::new(t0, t1, left, right), minutes }
    }

    /// Tick marks and labels under a panel whose bottom edge is at `y`.
    pub(crate) fn ticks(&self, c: &mut Canvas, y: f64) {
        let unit = if self.minutes { 60.0 } else { 1.0 };
        let (t0, t1) = (self.scale.d0 / unit, self.scale.d1 / unit);
        let step = axis::nice_step(t1 - t0, 12);
        let mut d = String::new();
        for t in axis::ticks(t0, t1, step) {
            let px = self.scale.map(t * unit);
            let _ = write!(d, "M{px:.1} {y:.1}v6");
            c.text(px, y + 24.0, TICK.anchor(Anchor::Middle), &axis::label(t, step));
        }
        let _ = writeln!(c.out(), r##"<path d="{d}" stroke="#555" stroke-width="1"/>"##);
    }
}

/// Which behaviour drove when: one coloured rectangle per stretch, at most one per px column.
pub(crate) fn strip(
    c: &mut Canvas,
    data: &PlotData<'_>,
    time: &TimeAxis,
    top: f64,
    behaviours: &[Option<&str>],
    colour: &dyn Fn(Option<&str>) -> &'static str,
) {
    let (left, right) = (time.scale.r0, time.scale.r1);
    let columns = (right - left).ceil().max(1.0) as usize;
    let mut time_in: Vec<Vec<f64>> = vec![vec![0.0; behaviours.len()]; columns];
    for w in data.trajectory.windows(2) {
        let k = behaviours.iter().position(|b| *b == w[0].behaviour.as_deref()).unwrap_or(0);
        let (a, b) = (time.scale.map(w[0].t_s) - left, time.scale.map(w[1].t_s) - left);
        if !(a.is_finite() && b.is_finite() && b > a) {
            continue;
        }
        let mut x = a.max(0.0);
        while x < b.min(columns as f64) {
            let column = x.floor();
            let next = (column + 1.0).min(b);
            time_in[column as usize][k] += next - x;
            x = next;
        }
    }
    let winner = |col: &Vec<f64>| {
        col.iter().enumerate().filter(|(_, t)| **t > 0.0).max_by(|a, b| a.1.total_cmp(b.1)).map(|(k, _)| k)
    };
    let mut start = 0;
    let winners: Vec<Option<usize>> = time_in.iter().map(winner).collect();
    for i in 1..=columns {
        if i == columns || winners[i] != winners[start] {
            if let Some(k) = winners[start] {
                let _ = writeln!(
                    c.out(),
                    r#"<rect x="{:.1}" y="{top:.1}" width="{}" height="{STRIP_HEIGHT}" fill="{}"/>"#,
                    left + start as f64,
                    i - start,
                    colour(behaviours[k])
                );
            }
            start = i;
        }
    }
    let _ = writeln!(
        c.out(),
        r##"<rect x="{left:.1}" y="{top:.1}" width="{:.1}" height="{STRIP_HEIGHT}" fill="none" stroke="#bbb"/>"##,
        right - left
    );
    c.text(left - 10.0, top + 13.0, TICK.anchor(Anchor::End), "behaviour");
}

/// A panel's caption, its clip path (`clip-{id}`) and its frame, `PANEL_HEIGHT` high from `top`.
pub(crate) fn panel_frame(c: &mut Canvas, time: &TimeAxis, top: f64, caption: &str, id: &str) {
    let (left, right) = (time.scale.r0, time.scale.r1);
    c.text(left, top - 14.0, Font::new(18.0).bold(), caption);
    let _ = writeln!(
        c.out(),
        r##"<clipPath id="clip-{id}"><rect x="{left:.1}" y="{top:.1}" width="{:.1}" height="{PANEL_HEIGHT}"/></clipPath>
<rect x="{left:.1}" y="{top:.1}" width="{:.1}" height="{PANEL_HEIGHT}" fill="#fbfbfb" stroke="#bbb"/>"##,
        right - left,
        right - left
    );
}

/// A panel's value axis over `range` (grid, tick labels, `y_label`) and the time ticks under
/// it; the scale of its values.
pub(crate) fn value_axis(
    c: &mut Canvas,
    time: &TimeAxis,
    top: f64,
    range: (f64, f64),
    y_label: &str,
) -> Scale {
    let (left, right) = (time.scale.r0, time.scale.r1);
    let ((lo, hi), bottom) = (range, top + PANEL_HEIGHT);
    let ys = Scale::new(lo, hi, bottom, top);
    let step = axis::nice_step(hi - lo, 6);
    let mut grid = String::new();
    for v in axis::ticks(lo, hi, step) {
        let py = ys.map(v);
        let _ = write!(grid, "M{left:.1} {py:.1}H{right:.1}");
        c.text(left - 10.0, py + 5.5, TICK.anchor(Anchor::End), &axis::label(v, step));
    }
    let _ = writeln!(c.out(), r##"<path d="{grid}" stroke="#e3e3e3" stroke-width="1"/>"##);
    c.text(left - 78.0, (top + bottom) / 2.0, LABEL.anchor(Anchor::Middle).vertical(), y_label);
    time.ticks(c, bottom);
    ys
}

/// A time series panel with its target line.
pub(crate) struct Panel<'p> {
    pub(crate) top: f64,
    pub(crate) caption: &'p str,
    pub(crate) y_label: &'p str,
    pub(crate) points: &'p [(f64, f64)],
    pub(crate) target: f64,
    /// The value range is symmetric about the target (offsets) rather than starting at zero.
    pub(crate) symmetric: bool,
    pub(crate) colour: &'static str,
    pub(crate) empty: &'p str,
}

impl Panel<'_> {
    pub(crate) fn draw(&self, c: &mut Canvas, data: &PlotData<'_>, time: &TimeAxis, id: &str) {
        let (left, right) = (time.scale.r0, time.scale.r1);
        let (top, bottom) = (self.top, self.top + PANEL_HEIGHT);
        panel_frame(c, time, top, self.caption, id);
        let (lo, hi) = self.value_range();
        let ys = value_axis(c, time, top, (lo, hi), self.y_label);

        let mut d = String::new();
        for b in data.bumps.iter().filter(|b| b.t_s.is_finite()) {
            let _ = write!(d, "M{:.1} {top:.1}V{bottom:.1}", time.scale.map(b.t_s));
        }
        if !d.is_empty() {
            let _ = writeln!(
                c.out(),
                r#"<path d="{d}" stroke="{BUMP_COLOUR}" stroke-opacity="0.45" stroke-width="1.2"/>"#
            );
        }

        let columns = (right - left).round().max(1.0) as usize;
        let lines =
            decimate::series(self.points, time.scale.d0, time.scale.d1, columns, max_gap(self.points));
        let mut d = String::new();
        for line in &lines {
            polyline_data(&mut d, line.iter().map(|(t, v)| (time.scale.map(*t), ys.map(*v))), 1);
        }
        if d.is_empty() {
            c.text(
                (left + right) / 2.0,
                (top + bottom) / 2.0,
                LABEL.anchor(Anchor::Middle).colour("#888"),
                self.empty,
            );
        } else {
            let _ = writeln!(
                c.out(),
                r#"<path class="series" clip-path="url(#clip-{id})" d="{d}" fill="none" stroke="{}" stroke-width="1.4" stroke-linejoin="round"/>"#,
                self.colour
            );
        }
        let py = ys.map(self.target);
        let _ = writeln!(
            c.out(),
            r##"<path class="target" d="M{left:.1} {py:.1}H{right:.1}" stroke="#222" stroke-width="1.6" stroke-dasharray="10 6"/>"##
        );
        let label = format!("target {} m", axis::label(self.target, 0.01));
        c.text(right - 8.0, py - 8.0, TICK.anchor(Anchor::End).colour("#222"), &label);
    }

    /// The value range shown: the target and the data between their 0.5th and 99.5th
    /// percentiles (a lost wall's few metres would otherwise flatten everything else).
    fn value_range(&self) -> (f64, f64) {
        let mut values: Vec<f64> = self.points.iter().map(|p| p.1).filter(|v| v.is_finite()).collect();
        values.sort_by(f64::total_cmp);
        let at = |q: f64| values.get(((values.len() - 1) as f64 * q).round() as usize).copied();
        let (lo, hi) = if values.is_empty() {
            (self.target, self.target)
        } else {
            (
                at(0.005).unwrap_or(self.target).min(self.target),
                at(0.995).unwrap_or(self.target).max(self.target),
            )
        };
        if self.symmetric {
            let half = (hi - self.target).max(self.target - lo).max(0.02) * 1.15;
            (self.target - half, self.target + half)
        } else {
            let lo = lo.min(0.0);
            (lo, hi + (hi - lo).max(0.05) * 0.15)
        }
    }
}

/// Samples further apart than this belong to different stretches of driving: four times the
/// median interval, at least half a second.
pub(crate) fn max_gap(points: &[(f64, f64)]) -> f64 {
    let mut dts: Vec<f64> = points.windows(2).map(|w| w[1].0 - w[0].0).filter(|d| d.is_finite()).collect();
    if dts.is_empty() {
        return 0.5;
    }
    let mid = dts.len() / 2;
    let (_, median, _) = dts.select_nth_unstable_by(mid, f64::total_cmp);
    (*median * 4.0).max(0.5)
}
