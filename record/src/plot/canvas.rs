//! A minimal SVG writer: elements appended to a string, and text drawn either as `<text>` or as
//! outlines from the built-in stroke font (for rasterising without fonts).

use super::font;
use std::fmt::Write;

/// How labels are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TextMode {
    /// `<text>` elements, for SVG files: small, selectable, drawn by the viewer's fonts.
    Native,
    /// Stroked paths from [`font`], for PNGs rendered by resvg without a font database.
    Outlined,
}

/// Horizontal alignment of a label at its anchor point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Anchor {
    Start,
    Middle,
    End,
}

/// How a label looks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Font {
    /// Size in px (the em).
    pub(crate) size: f64,
    pub(crate) colour: &'static str,
    pub(crate) bold: bool,
    pub(crate) anchor: Anchor,
    /// Rotated 90 degrees counter-clockwise about the anchor (for y-axis labels).
    pub(crate) vertical: bool,
}

impl Font {
    pub(crate) const fn new(size: f64) -> Font {
        Font { size, colour: "#222", bold: false, anchor: Anchor::Start, vertical: false }
    }

    pub(crate) const fn anchor(self, anchor: Anchor) -> Font {
        Font { anchor, ..self }
    }

    pub(crate) const fn colour(self, colour: &'static str) -> Font {
        Font { colour, ..self }
    }

    pub(crate) const fn bold(self) -> Font {
        Font { bold: true, ..self }
    }

    pub(crate) const fn vertical(self) -> Font {
        Font { vertical: true, ..self }
    }

    /// Grid units of the stroke font per px: its cap height is 0.72 em, like DejaVu Sans.
    fn scale(&self) -> f64 {
        0.72 * self.size / font::CAP_HEIGHT
    }

    /// The drawn width of `text` in px (exact when outlined, close to a sans font otherwise).
    pub(crate) fn width(&self, text: &str) -> f64 {
        font::width(text) * self.scale()
    }
}

/// An SVG document being written.
#[derive(Debug)]
pub(crate) struct Canvas {
    out: String,
    mode: TextMode,
}

impl Canvas {
    /// A white `width` x `height` px document.
    pub(crate) fn new(width: f64, height: f64, mode: TextMode) -> Canvas {
        let mut out = String::with_capacity(1 << 20);
        let _ = write!(
            out,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}">"#
        );
        out.push('\n');
        let _ = writeln!(out, r#"<rect width="{width}" height="{height}" fill="white"/>"#);
        Canvas { out, mode }
    }

    /// Appends markup as is.
    pub(crate) fn raw(&mut self, markup: &str) {
        self.out.push_str(markup);
    }

    /// The string to `write!` into.
    pub(crate) fn out(&mut self) -> &mut String {
        &mut self.out
    }

    /// Draws `text` with its baseline at `y` and its anchor at `x`.
    pub(crate) fn text(&mut self, x: f64, y: f64, font: Font, text: &str) {
        if text.is_empty() {
            return;
        }
        let rotate =
            if font.vertical { format!(r#" transform="rotate(-90 {x:.1} {y:.1})""#) } else { String::new() };
        match self.mode {
            TextMode::Native => {
                let anchor = match font.anchor {
                    Anchor::Start => "start",
                    Anchor::Middle => "middle",
                    Anchor::End => "end",
                };
                let weight = if font.bold { r#" font-weight="bold""# } else { "" };
                let _ = writeln!(
                    self.out,
                    r#"<text x="{x:.1}" y="{y:.1}" font-family="DejaVu Sans, Helvetica, Arial, sans-serif" font-size="{:.1}" text-anchor="{anchor}" fill="{}"{weight}{rotate}>{}</text>"#,
                    font.size,
                    font.colour,
                    escape(text)
                );
            }
            TextMode::Outlined => self.outlined(x, y, font, text, &rotate),
        }
    }

    fn outlined(&mut self, x: f64, y: f64, font: Font, text: &str, rotate: &str) {
        let k = font.scale();
        let left = match font.anchor {
            Anchor::Start => x,
            Anchor::Middle => x - font.width(text) / 2.0,
            Anchor::End => x - font.width(text),
        };
        let stroke_px = font.size * if font.bold { 0.115 } else { 0.08 };
        let _ = write!(
            self.out,
            r#"<g{rotate}><g transform="translate({left:.2} {:.2}) scale({k:.4})" fill="none" stroke="{}" stroke-width="{:.3}" stroke-linecap="round" stroke-linejoin="round">"#,
            y - font::CAP_HEIGHT * k,
            font.colour,
            stroke_px / k
        );
        let mut pen = 0.0;
        for c in text.chars() {
            let glyph = font::glyph(c);
            for d in glyph.strokes.iter().filter(|d| !d.is_empty()) {
                let _ = write!(self.out, r#"<path transform="translate({pen:.2} 0)" d="{d}"/>"#);
            }
            pen += glyph.width + font::GAP;
        }
        self.out.push_str("</g></g>\n");
    }

    /// The finished document.
    pub(crate) fn finish(mut self) -> String {
        self.out.push_str("</svg>\n");
        self.out
    }
}

/// `text` with XML's special characters escaped.
pub(crate) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// Appends `points` as the path data of a polyline (`M x y L x y ...`), with `decimals` digits.
pub(crate) fn polyline_data(out: &mut String, points: impl IntoIterator<Item = (f64, f64)>, decimals: usize) {
    for (i, (x, y)) in points.into_iter().enumerate() {
        let _ = write!(out, "{}{x:.decimals$} {y:.decimals$}", if i == 0 { "M" } else { "L" });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_and_outlines_are_paths() {
        let mut native = Canvas::new(100.0, 50.0, TextMode::Native);
        native.text(10.0, 20.0, Font::new(12.0), "a<b & c");
        let svg = native.finish();
        assert!(svg.contains(">a&lt;b &amp; c</text>"), "{svg}");

        let mut outlined = Canvas::new(100.0, 50.0, TextMode::Outlined);
        outlined.text(10.0, 20.0, Font::new(12.0), "Hi");
        let svg = outlined.finish();
        assert!(!svg.contains("<text"));
        assert_eq!(svg.matches("<path").count(), 2, "{svg}");
    }

    #[test]
    fn polylines_start_with_a_move() {
        let mut d = String::new();
        polyline_data(&mut d, [(0.0, 1.0), (2.5, 3.25)], 1);
        assert_eq!(d, "M0.0 1.0L2.5 3.2");
    }
}
