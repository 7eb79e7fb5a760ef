//! Strict `[x, y]` pairs.
//!
//! Serde's `[f64; 2]` reads two elements and stops, and the TOML deserializer does not complain
//! about what is left, so `[1.0, 2.0, 3.0]` would load as `[1.0, 2.0]`. A world file must not be
//! silently fixed, so pairs are read here and any other length is an error.

use serde::Deserialize;
use serde::de::{Deserializer, Error, SeqAccess, Visitor};
use std::fmt;

struct Pair([f64; 2]);

impl<'de> Deserialize<'de> for Pair {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct PairVisitor;
        impl<'de> Visitor<'de> for PairVisitor {
            type Value = Pair;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an [x, y] pair of numbers")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Pair, A::Error> {
                let mut xy = [0.0; 2];
                for (n, slot) in xy.iter_mut().enumerate() {
                    *slot = seq.next_element()?.ok_or_else(|| A::Error::invalid_length(n, &self))?;
                }
                let mut extra = 0;
                while seq.next_element::<toml::Value>()?.is_some() {
                    extra += 1;
                }
                if extra > 0 {
                    return Err(A::Error::invalid_length(2 + extra, &self));
                }
                Ok(Pair(xy))
            }
        }
        d.deserialize_seq(PairVisitor)
    }
}

/// Deserialises one `[x, y]` pair.
pub(super) fn one<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    Pair::deserialize(d).map(|p| p.0)
}

/// Deserialises a list of `[x, y]` pairs.
pub(super) fn many<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<[f64; 2]>, D::Error> {
    Vec::<Pair>::deserialize(d).map(|v| v.into_iter().map(|p| p.0).collect())
}
