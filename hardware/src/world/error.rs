//! What can be wrong with a world file, and where.

use std::fmt;
use std::path::PathBuf;

/// A position in a text file: 1-based line and column (columns count characters).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineCol {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1, in characters.
    pub column: usize,
}

impl LineCol {
    /// The line and column of byte `offset` in `text` (clamped to the text; an offset inside a
    /// multi-byte character counts as that character).
    pub fn of(text: &str, offset: usize) -> LineCol {
        let mut end = offset.min(text.len());
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let before = &text[..end];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let column = before[line_start..].chars().count() + 1;
        LineCol { line, column }
    }
}

impl fmt::Display for LineCol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.column)
    }
}

/// `:line:col` when known, nothing otherwise.
fn place(at: &Option<LineCol>) -> String {
    at.map(|lc| format!(":{lc}")).unwrap_or_default()
}

/// `key: ` when the key is known, nothing otherwise (a mistake in the document as a whole).
fn key_prefix(key: &str) -> String {
    if key.is_empty() { String::new() } else { format!("{key}: ") }
}

/// Why a world could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    /// The file could not be read.
    #[error("cannot read world file {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said (in the message, not as a chained source, so that
        /// it is printed once).
        error: std::io::Error,
    },
    /// The text is not valid TOML.
    #[error("{origin}{}: not valid TOML: {problem}", place(at))]
    Syntax {
        /// The file (or other origin) of the text.
        origin: String,
        /// Where, when known.
        at: Option<LineCol>,
        /// What the TOML parser said.
        problem: String,
    },
    /// The TOML is valid but the world is not: a missing, unknown or wrong-typed key, or a
    /// value that breaks a rule of the format.
    #[error("{origin}{}: {}{problem}", place(at), key_prefix(key))]
    Invalid {
        /// The file (or other origin) of the text.
        origin: String,
        /// The key path, like `movers[1].speed` (empty for the document as a whole).
        key: String,
        /// Where, when known.
        at: Option<LineCol>,
        /// What is wrong.
        problem: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column_count_from_one_in_characters() {
        let text = "a = 1\nbé = 2\n";
        assert_eq!(LineCol::of(text, 0), LineCol { line: 1, column: 1 });
        assert_eq!(LineCol::of(text, 6), LineCol { line: 2, column: 1 });
        // 'é' is two bytes; the '=' after "bé " is the 4th character of line 2.
        assert_eq!(LineCol::of(text, 10), LineCol { line: 2, column: 4 });
        assert_eq!(LineCol::of(text, 1000), LineCol { line: 3, column: 1 });
        // Inside the 'é': counts as the 'é'.
        assert_eq!(LineCol::of(text, 8), LineCol { line: 2, column: 2 });
    }

    #[test]
    fn messages_name_origin_place_key_and_problem() {
        let e = WorldError::Invalid {
            origin: "w.toml".into(),
            key: "movers[1].speed".into(),
            at: Some(LineCol { line: 3, column: 9 }),
            problem: "must be >= 0, got -1".into(),
        };
        assert_eq!(e.to_string(), "w.toml:3:9: movers[1].speed: must be >= 0, got -1");
        let e = WorldError::Syntax { origin: "w.toml".into(), at: None, problem: "x".into() };
        assert_eq!(e.to_string(), "w.toml: not valid TOML: x");
    }
}
