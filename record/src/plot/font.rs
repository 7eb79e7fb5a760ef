//! A small stroke font, so that PNGs carry their labels without a font file.
//!
//! `resvg` is built without its `text` feature (no font database, no shaping), so it draws no
//! `<text>` elements. For PNG output the figure's labels are drawn instead as stroked paths from
//! the glyphs below: printable ASCII letters, digits and the punctuation plot labels use, plus
//! `°`, `·`, `×`, `±` and `–`. Any other character is drawn as a box.
//!
//! Glyphs are SVG path data in a grid with y pointing down: the cap line is y = 0, the x-height
//! y = 4, the baseline y = 10 and the descender line y = 13. A glyph is 6 units wide unless
//! stated; its advance is its width plus [`GAP`].

/// The space between two glyphs, in grid units.
pub(crate) const GAP: f64 = 2.0;
/// Grid units from the cap line to the baseline.
pub(crate) const CAP_HEIGHT: f64 = 10.0;

/// Bowls shared by several lowercase letters: a circle between the x-height and the baseline.
const BOWL: &str = "M0 7A3 3 0 1 1 6 7A3 3 0 1 1 0 7";

/// A glyph: its width in grid units and its strokes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Glyph {
    /// Width in grid units (the advance is this plus [`GAP`]).
    pub(crate) width: f64,
    /// Path data strokes (several strings are drawn together).
    pub(crate) strokes: [&'static str; 2],
}

const fn g(width: f64, a: &'static str) -> Glyph {
    Glyph { width, strokes: [a, ""] }
}

const fn g2(width: f64, a: &'static str, b: &'static str) -> Glyph {
    Glyph { width, strokes: [a, b] }
}

/// The glyph of `c`, or a box for characters the font lacks.
pub(crate) fn glyph(c: char) -> Glyph {
    match c {
        ' ' => g(3.0, ""),
        'A' => g(6.0, "M0 10L3 0L6 10M1.2 6H4.8"),
        'B' => g(6.0, "M0 10V0H3.5A2.5 2.5 0 0 1 3.5 5H0M3.5 5A2.5 2.5 0 0 1 3.5 10H0"),
        'C' => g(6.0, "M5.6 1.5A3 5 0 1 0 5.6 8.5"),
        'D' => g(6.0, "M0 0V10H2.5A3.5 5 0 0 0 2.5 0Z"),
        'E' => g(5.5, "M5.5 0H0V10H5.5M0 5H4.5"),
        'F' => g(5.5, "M5.5 0H0V10M0 5H4.5"),
        'G' => g(6.0, "M5.6 1.5A3 5 0 1 0 6 5.5H3.5"),
        'H' => g(6.0, "M0 0V10M6 0V10M0 5H6"),
        'I' => g(4.0, "M0 0H4M2 0V10M0 10H4"),
        'J' => g(5.0, "M5 0V7A2.5 3 0 0 1 0 7"),
        'K' => g(6.0, "M0 0V10M6 0L0 6.5M2.2 4.3L6 10"),
        'L' => g(5.5, "M0 0V10H5.5"),
        'M' => g(8.0, "M0 10V0L4 7L8 0V10"),
        'N' => g(6.0, "M0 10V0L6 10V0"),
        'O' => g(6.0, "M3 0A3 5 0 0 1 3 10A3 5 0 0 1 3 0"),
        'P' => g(6.0, "M0 10V0H3.5A2.5 2.5 0 0 1 3.5 5H0"),
        'Q' => g2(6.0, "M3 0A3 5 0 0 1 3 10A3 5 0 0 1 3 0", "M3.8 7L6 10.5"),
        'R' => g2(6.0, "M0 10V0H3.5A2.5 2.5 0 0 1 3.5 5H0", "M3 5L6 10"),
        'S' => g(6.0, "M5.6 1.25A3 2.5 0 1 0 3 5A3 2.5 0 1 1 0.4 8.75"),
        'T' => g(6.0, "M0 0H6M3 0V10"),
        'U' => g(6.0, "M0 0V7A3 3 0 0 0 6 7V0"),
        'V' => g(6.0, "M0 0L3 10L6 0"),
        'W' => g(8.0, "M0 0L2 10L4 3.5L6 10L8 0"),
        'X' => g(6.0, "M0 0L6 10M6 0L0 10"),
        'Y' => g(6.0, "M0 0L3 5L6 0M3 5V10"),
        'Z' => g(6.0, "M0 0H6L0 10H6"),
        'a' => g2(6.0, BOWL, "M6 4V10"),
        'b' => g2(6.0, BOWL, "M0 0V10"),
        'c' => g(5.6, "M5.6 5A3 3 0 1 0 5.6 9"),
        'd' => g2(6.0, BOWL, "M6 0V10"),
        'e' => g(6.0, "M0 7H6A3 3 0 1 0 5.2 9.1"),
        'f' => g(4.5, "M4.5 0.6A2 2 0 0 0 1.5 2.5V10M0 4H4"),
        'g' => g2(6.0, BOWL, "M6 4V11A3 2 0 0 1 0.4 12"),
        'h' => g(6.0, "M0 0V10M0 7A3 3 0 0 1 6 7V10"),
        'i' => g(1.0, "M0.5 4V10M0.5 1.6V2"),
        'j' => g(3.0, "M3 4V11A2 2 0 0 1 0 12.4M3 1.6V2"),
        'k' => g(5.0, "M0 0V10M5 4L0 8M1.8 6.6L5 10"),
        'l' => g(1.0, "M0.5 0V10"),
        'm' => g(8.0, "M0 4V10M0 6.5A2 2.5 0 0 1 4 6.5V10M4 6.5A2 2.5 0 0 1 8 6.5V10"),
        'n' => g(6.0, "M0 4V10M0 7A3 3 0 0 1 6 7V10"),
        'o' => g(6.0, BOWL),
        'p' => g2(6.0, BOWL, "M0 4V13"),
        'q' => g2(6.0, BOWL, "M6 4V13"),
        'r' => g(4.5, "M0 4V10M0 7A3.5 3 0 0 1 4.5 4.4"),
        's' => g(5.6, "M5.2 4.8A2.6 1.5 0 1 0 2.8 7A2.6 1.5 0 1 1 0.4 9.2"),
        't' => g(4.5, "M1.5 1V8.5A1.5 1.5 0 0 0 3 10H4.5M0 4H4.5"),
        'u' => g(6.0, "M0 4V7A3 3 0 0 0 6 7M6 4V10"),
        'v' => g(6.0, "M0 4L3 10L6 4"),
        'w' => g(8.0, "M0 4L2 10L4 5.5L6 10L8 4"),
        'x' => g(6.0, "M0 4L6 10M6 4L0 10"),
        'y' => g(6.0, "M0 4L3 10M6 4L1.5 13"),
        'z' => g(6.0, "M0 4H6L0 10H6"),
        '0' => g(6.0, "M3 0A3 5 0 0 1 3 10A3 5 0 0 1 3 0"),
        '1' => g(6.0, "M1 2L3.5 0V10M1 10H6"),
        '2' => g(6.0, "M0.3 2.2A3 2.6 0 0 1 5.5 4L0 10H6"),
        '3' => g(6.0, "M0.4 1.25A3 2.5 0 1 1 3 5A3 2.5 0 1 1 0.4 8.75"),
        '4' => g(6.0, "M4.5 10V0L0 7H6"),
        '5' => g(6.0, "M5.5 0H1L0.5 4.6C2.5 3.6 6 4 6 7C6 10.5 1.5 10.8 0 9"),
        '6' => g2(6.0, "M5 0.4C2 -0.5 0 3 0 7", BOWL),
        '7' => g(6.0, "M0 0H6L2 10"),
        '8' => g(6.0, "M3 5A2.5 2.5 0 1 1 3 0A2.5 2.5 0 1 1 3 5A3 2.5 0 1 1 3 10A3 2.5 0 1 1 3 5"),
        '9' => g2(6.0, "M6 3A3 3 0 1 0 0 3A3 3 0 1 0 6 3", "M6 3C6 7 4 10.5 1 9.6"),
        '.' => g(1.0, "M0.5 9.6V10"),
        ',' => g(1.0, "M1 9.4L0 12"),
        ':' => g(1.0, "M0.5 4.6V5M0.5 9.6V10"),
        ';' => g(1.0, "M1 4.6V5M1 9.4L0 12"),
        '-' => g(5.0, "M0.5 6H4.5"),
        '–' => g(7.0, "M0 6H7"),
        '+' => g(6.0, "M0 6H6M3 3V9"),
        '=' => g(6.0, "M0 4.5H6M0 7.5H6"),
        '/' => g(5.0, "M5 -0.5L0 10.5"),
        '(' => g(2.5, "M2.5 -0.5Q-0.8 5 2.5 10.5"),
        ')' => g(2.5, "M0 -0.5Q3.3 5 0 10.5"),
        '[' => g(2.5, "M2.5 -0.5H0.5V10.5H2.5"),
        ']' => g(2.5, "M0 -0.5H2V10.5H0"),
        '%' => g(
            6.0,
            "M0 10L6 0M1.2 0.3A1.2 1.2 0 1 1 1.2 2.7A1.2 1.2 0 1 1 1.2 0.3\
             M4.8 7.3A1.2 1.2 0 1 1 4.8 9.7A1.2 1.2 0 1 1 4.8 7.3",
        ),
        '|' => g(1.0, "M0.5 -0.5V12"),
        '_' => g(6.0, "M0 11.5H6"),
        '\'' => g(1.0, "M0.5 0V2.5"),
        '"' => g(2.5, "M0.5 0V2.5M2 0V2.5"),
        '!' => g(1.0, "M0.5 0V7M0.5 9.6V10"),
        '?' => g(5.6, "M0.2 2.5A2.8 2.5 0 1 1 3.8 4.9L2.8 6V7.5M2.8 9.6V10"),
        '<' => g(6.0, "M6 3.5L0 6.75L6 10"),
        '>' => g(6.0, "M0 3.5L6 6.75L0 10"),
        '#' => g(6.0, "M2 0L1 10M5 0L4 10M0 3.5H6M0 6.5H6"),
        '*' => g(6.0, "M3 1V7M0.4 2.5L5.6 5.5M0.4 5.5L5.6 2.5"),
        '°' => g(3.0, "M1.5 0A1.5 1.5 0 1 1 1.5 3A1.5 1.5 0 1 1 1.5 0"),
        '·' => g(1.0, "M0.5 6.3V6.7"),
        '×' => g(6.0, "M0.5 4L5.5 9M5.5 4L0.5 9"),
        '±' => g(6.0, "M0 5H6M3 2V8M0 10H6"),
        _ => g(6.0, "M0 0H6V10H0Z"),
    }
}

/// The advance of `text` in grid units (the trailing gap excluded).
pub(crate) fn width(text: &str) -> f64 {
    let total: f64 = text.chars().map(|c| glyph(c).width + GAP).sum();
    (total - GAP).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_printable_ascii_character_has_its_own_glyph() {
        let missing = glyph('\u{1}').strokes[0];
        for c in (' '..='~').filter(|c| !"&@$^`{}~\\".contains(*c)) {
            assert_ne!(glyph(c).strokes[0], missing, "{c:?} falls back to a box");
        }
    }

    #[test]
    fn every_glyph_parses_as_path_data() {
        for c in (' '..='~').chain("°·×±–".chars()) {
            for d in glyph(c).strokes.iter().filter(|d| !d.is_empty()) {
                let svg = format!(r#"<svg xmlns="http://www.w3.org/2000/svg"><path d="{d}"/></svg>"#);
                resvg::usvg::Tree::from_str(&svg, &resvg::usvg::Options::default())
                    .unwrap_or_else(|e| panic!("{c:?}: {e}"));
            }
        }
    }

    #[test]
    fn width_adds_advances() {
        assert_eq!(width(""), 0.0);
        assert_eq!(width("H"), 6.0);
        assert_eq!(width("Hi"), 6.0 + GAP + 1.0);
    }
}
