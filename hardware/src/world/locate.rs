//! Key paths in a parsed TOML document: which key a byte offset belongs to, and where a key is.
//!
//! Serde's errors carry a byte span but no key path; the checks in `validate` produce a key
//! path but no span. The document's spanned tree (`toml::de::DeTable`) answers both ways.
//! Array indices in key paths count from 0, so `movers[1]` is the second `[[movers]]` table.

use std::fmt;
use std::ops::Range;
use toml::de::{DeTable, DeValue};

/// One step of a key path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Seg {
    /// A table key.
    Key(String),
    /// An array index, from 0.
    Index(usize),
}

/// A key path like `movers[1].path[0]`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct KeyPath(pub(crate) Vec<Seg>);

impl KeyPath {
    /// The path `key`.
    pub(crate) fn key(key: &str) -> KeyPath {
        KeyPath(vec![Seg::Key(key.to_owned())])
    }

    /// This path followed by `key`.
    pub(crate) fn k(&self, key: &str) -> KeyPath {
        let mut p = self.clone();
        p.0.push(Seg::Key(key.to_owned()));
        p
    }

    /// This path followed by index `i`.
    pub(crate) fn i(&self, i: usize) -> KeyPath {
        let mut p = self.clone();
        p.0.push(Seg::Index(i));
        p
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (n, seg) in self.0.iter().enumerate() {
            match seg {
                Seg::Key(k) if n == 0 => write!(f, "{k}")?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(i) => write!(f, "[{i}]")?,
            }
        }
        Ok(())
    }
}

/// Whether `span` covers all of `target`.
fn covers(span: &Range<usize>, target: &Range<usize>) -> bool {
    span.start <= target.start && target.end <= span.end
}

/// Keeps `path` as the best answer if its `span` covers `target` and is smaller than the best
/// so far (deeper wins a tie: a key's table and its only value can share a span).
fn consider(best: &mut Option<(usize, KeyPath)>, span: Range<usize>, target: &Range<usize>, path: &KeyPath) {
    if !covers(&span, target) {
        return;
    }
    let len = span.end.saturating_sub(span.start);
    let better = match best {
        None => true,
        Some((best_len, best_path)) => {
            len < *best_len || (len == *best_len && path.0.len() > best_path.0.len())
        }
    };
    if better {
        *best = Some((len, path.clone()));
    }
}

/// The innermost node (smallest span) under `value` covering `target`: its span length and
/// its path. Every child is searched, because an array of tables (`[[movers]]`) is spread over
/// the file and its own span need not cover its items.
fn innermost(
    value: &DeValue<'_>,
    target: &Range<usize>,
    here: &KeyPath,
    best: &mut Option<(usize, KeyPath)>,
) {
    match value {
        DeValue::Table(table) => {
            for (k, v) in table.iter() {
                let path = here.k(k.get_ref());
                consider(best, k.span(), target, &path);
                consider(best, v.span(), target, &path);
                innermost(v.get_ref(), target, &path, best);
            }
        }
        DeValue::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                let path = here.i(i);
                consider(best, item.span(), target, &path);
                innermost(item.get_ref(), target, &path, best);
            }
        }
        _ => {}
    }
}

/// The key path of the innermost key or value covering the byte range `target` (the document
/// itself, an empty path, when no key does). The TOML deserializer gives errors about the
/// document's top level (a missing `robot`) an empty span, which also means the document.
pub(crate) fn path_at(root: &DeTable<'_>, target: &Range<usize>) -> KeyPath {
    if target.is_empty() {
        return KeyPath::default();
    }
    let mut best = None;
    innermost(&DeValue::Table(root.clone()), target, &KeyPath::default(), &mut best);
    best.map(|(_, p)| p).unwrap_or_default()
}

/// The span of the value at `path`, or of its deepest ancestor present in the document (a key
/// that was left out, like an optional one with a bad default, has no span of its own).
pub(crate) fn span_of(root: &DeTable<'_>, path: &KeyPath) -> Option<Range<usize>> {
    let mut span: Option<Range<usize>> = None;
    let mut table = Some(root);
    let mut array: Option<&[toml::Spanned<DeValue<'_>>]> = None;
    for seg in &path.0 {
        let next = match (seg, table, array) {
            (Seg::Key(k), Some(t), _) => t.iter().find(|(key, _)| key.get_ref() == k).map(|(_, v)| v),
            (Seg::Index(i), _, Some(a)) => a.get(*i),
            _ => None,
        };
        let Some(next) = next else { break };
        span = Some(next.span());
        table = next.get_ref().as_table();
        array = next.get_ref().as_array().map(|a| &a[..]);
    }
    span
}

/// Where a serde error is: its span, unless that span is empty (the document as a whole).
pub(crate) fn error_span(e: &toml::de::Error) -> Option<Range<usize>> {
    e.span().filter(|s| !s.is_empty())
}

/// A serde error's key path and message, with `missing field` errors pointing at the missing
/// key rather than at the table that lacks it.
pub(crate) fn describe_serde_error(root: &DeTable<'_>, e: &toml::de::Error) -> (String, String) {
    let mut path = e.span().map(|s| path_at(root, &s)).unwrap_or_default();
    let message = e.message().trim().to_owned();
    if let Some(rest) = message.strip_prefix("missing field `")
        && let Some(field) = rest.strip_suffix('`')
    {
        path = path.k(field);
        return (path.to_string(), "missing (this key is required)".to_owned());
    }
    (path.to_string(), message)
}
