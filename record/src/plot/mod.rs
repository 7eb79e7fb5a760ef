//! The figure a person looks at after a run, as SVG or PNG.
//!
//! One figure, laid out like the thesis' corridor figures:
//! - a title line (given by the caller: world, seed, duration) and a headline line computed from
//!   the data (distance, time per behaviour, bumps, offset and clearance errors);
//! - the world map at equal x/y scale in metres (walls, boxes, discs, people's paths dashed) with
//!   the robot's trajectory coloured by the behaviour driving it and bumps marked with a red x;
//!   the world's places; in a navigation run also the paths planned, the localizer's estimate
//!   and the goals, reached or missed (module `navigation`);
//! - a strip showing which behaviour drove when;
//! - the offset from the corridor centre over time while centre following, and the clearance to
//!   the followed wall over time while wall following, each with its target line; in a
//!   navigation run a third: the estimate's distance from the true pose.
//!
//! Long runs are decimated for drawing (module `decimate`) so that an hour at 10 Hz stays well under a
//! few MB of SVG. PNGs are rasterised with resvg at [`WIDTH_PX`] px wide; resvg is built without
//! fonts, so a PNG's labels are drawn with a small built-in stroke font (module `font`) instead.

mod axis;
mod canvas;
mod decimate;
mod figure;
mod font;
mod headline;
mod navigation;
mod series;
mod whatif;

pub use navigation::{GoalMark, NavigationTrace};
pub use whatif::{WhatIfPlot, render_what_if_svg, write_what_if};

#[cfg(test)]
mod tests;

use orsa_hardware::world::World;
use std::path::{Path, PathBuf};

/// The figure's width in px (SVG user units, and PNG pixels).
pub const WIDTH_PX: u32 = 2000;

/// Where the robot was at one instant and what drove it.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectorySample {
    /// Robot time, s.
    pub t_s: f64,
    /// Position of the body's centre, m.
    pub x_m: f64,
    /// Position of the body's centre, m.
    pub y_m: f64,
    /// The behaviour wired to the drive (`centerfollow`, `wallfollow`, ...), `None` if none.
    pub behaviour: Option<String>,
}

/// A bump: when and where the robot touched something.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bump {
    /// Robot time, s.
    pub t_s: f64,
    /// Position of the body's centre, m.
    pub x_m: f64,
    /// Position of the body's centre, m.
    pub y_m: f64,
}

/// The values the controllers aim for, drawn as target lines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Targets {
    /// Offset from the corridor centre while centre following, m.
    pub offset_m: f64,
    /// Clearance to the followed wall while wall following, m.
    pub clearance_m: f64,
}

impl Default for Targets {
    fn default() -> Self {
        Targets { offset_m: 0.0, clearance_m: 0.20 }
    }
}

/// Everything the figure shows.
#[derive(Debug, Clone)]
pub struct PlotData<'a> {
    /// The title line, e.g. `Palazzina 1 corridor · seed 42 · 60 min` (the world's name if empty).
    pub title: String,
    /// The world the robot drove in.
    pub world: &'a World,
    /// The robot's positions, in time order.
    pub trajectory: Vec<TrajectorySample>,
    /// `(t_s, offset_m)` from the corridor centre (positive to the left), while centre following.
    pub offset: Vec<(f64, f64)>,
    /// `(t_s, clearance_m)` to the followed wall, while wall following.
    pub clearance: Vec<(f64, f64)>,
    /// The bumps.
    pub bumps: Vec<Bump>,
    /// The target lines.
    pub targets: Targets,
    /// Each behaviour's kind by its name (a name not here is its own kind): colours and the
    /// legend's order follow the kind, so a `wallfollow` named otherwise is still orange.
    pub kinds: std::collections::BTreeMap<String, String>,
    /// What navigation adds (places are drawn from the world whether or not there is any).
    pub navigation: Option<NavigationTrace>,
}

/// What went wrong while writing a plot; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The file name does not say which format to write.
    #[error("cannot plot to {path}: unknown extension {extension:?}; use .svg or .png")]
    Extension {
        /// The plot's path.
        path: PathBuf,
        /// The extension found (empty if none).
        extension: String,
    },
    /// The file could not be written.
    #[error("cannot write the plot {path}: {source}")]
    Write {
        /// The plot's path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Rasterising the figure failed (a bug in the figure, or out of memory).
    #[error("cannot render the plot {path} as PNG: {problem}")]
    Render {
        /// The plot's path.
        path: PathBuf,
        /// What failed.
        problem: String,
    },
}

/// The figure as an SVG document, labels as `<text>`.
pub fn render_svg(data: &PlotData<'_>) -> String {
    figure::draw(data, canvas::TextMode::Native)
}

/// The figure as a PNG image [`WIDTH_PX`] wide; `path` only names the file in errors.
pub fn render_png(data: &PlotData<'_>, path: &Path) -> Result<Vec<u8>, PlotError> {
    rasterise(&figure::draw(data, canvas::TextMode::Outlined), path)
}

/// An SVG document (labels outlined) as a PNG image; `path` only names the file in errors.
fn rasterise(svg: &str, path: &Path) -> Result<Vec<u8>, PlotError> {
    use resvg::{tiny_skia, usvg};
    let error = |problem: String| PlotError::Render { path: path.to_path_buf(), problem };
    let tree = usvg::Tree::from_str(svg, &usvg::Options::default())
        .map_err(|e| error(format!("the figure's SVG does not parse: {e}")))?;
    let size = tree.size().to_int_size();
    let mut pixmap = tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| error(format!("no {}x{} px image", size.width(), size.height())))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(&tree, tiny_skia::Transform::identity(), &mut pixmap.as_mut());
    pixmap.encode_png().map_err(|e| error(format!("PNG encoding failed: {e}")))
}

/// Writes the figure to `path` as SVG or PNG, chosen by the extension (`.svg` or `.png`).
pub fn write_plot(path: &Path, data: &PlotData<'_>) -> Result<(), PlotError> {
    write_svg_or_png(path, |mode| figure::draw(data, mode))
}

/// Writes the figure `draw` makes to `path`, as SVG (labels as text) or PNG (labels outlined)
/// by the extension.
fn write_svg_or_png(path: &Path, draw: impl Fn(canvas::TextMode) -> String) -> Result<(), PlotError> {
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let bytes = match extension.as_str() {
        "svg" => draw(canvas::TextMode::Native).into_bytes(),
        "png" => rasterise(&draw(canvas::TextMode::Outlined), path)?,
        _ => {
            let extension = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
            return Err(PlotError::Extension { path: path.to_path_buf(), extension });
        }
    };
    std::fs::write(path, bytes).map_err(|source| PlotError::Write { path: path.to_path_buf(), source })
}
