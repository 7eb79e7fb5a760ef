//! Linear scales from data to px, and tick positions at round numbers.

/// Maps the data interval `d0..d1` linearly onto the px interval `r0..r1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Scale {
    pub(crate) d0: f64,
    pub(crate) d1: f64,
    pub(crate) r0: f64,
    pub(crate) r1: f64,
}

impl Scale {
    /// A scale; a zero-width data interval is widened so the scale stays finite.
    pub(crate) fn new(d0: f64, d1: f64, r0: f64, r1: f64) -> Scale {
        let (d0, d1) = if (d1 - d0).abs() < 1e-12 { (d0 - 0.5, d0 + 0.5) } else { (d0, d1) };
        Scale { d0, d1, r0, r1 }
    }

    pub(crate) fn map(&self, v: f64) -> f64 {
        self.r0 + (v - self.d0) / (self.d1 - self.d0) * (self.r1 - self.r0)
    }
}

/// A round step (1, 2 or 5 times a power of ten) giving about `target` steps across `span`.
pub(crate) fn nice_step(span: f64, target: usize) -> f64 {
    let raw = (span.abs() / target.max(1) as f64).max(1e-9);
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = match raw / magnitude {
        n if n < 1.5 => 1.0,
        n if n < 3.0 => 2.0,
        n if n < 7.0 => 5.0,
        _ => 10.0,
    };
    step * magnitude
}

/// The multiples of `step` within `lo..=hi`.
pub(crate) fn ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    if !(step > 0.0 && lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last).take(1000).map(|i| if i == 0 { 0.0 } else { i as f64 * step }).collect()
}

/// A tick label with as many decimals as `step` needs.
pub(crate) fn label(v: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let text = format!("{v:.decimals$}");
    // "-0.00" reads as an error on an axis.
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        text.replace('-', "")
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_are_round() {
        assert_eq!(nice_step(40.0, 8), 5.0);
        assert_eq!(nice_step(2.4, 4), 0.5);
        assert_eq!(nice_step(0.3, 6), 0.05);
        assert_eq!(nice_step(60.0, 10), 5.0);
        assert_eq!(nice_step(7.0, 5), 1.0);
    }

    #[test]
    fn ticks_cover_the_interval() {
        assert_eq!(ticks(-0.3, 40.3, 5.0), [0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0]);
        assert_eq!(ticks(-0.12, 0.12, 0.05), [-0.1, -0.05, 0.0, 0.05, 0.1]);
        assert!(ticks(0.0, 1.0, 0.0).is_empty());
    }

    #[test]
    fn labels_have_the_step_decimals() {
        assert_eq!(label(5.0, 5.0), "5");
        assert_eq!(label(0.1, 0.05), "0.10");
        assert_eq!(label(-1e-17, 0.05), "0.00");
        assert_eq!(label(-0.05, 0.05), "-0.05");
    }

    #[test]
    fn scales_map_ends_to_ends() {
        let s = Scale::new(0.0, 10.0, 100.0, 200.0);
        assert_eq!((s.map(0.0), s.map(5.0), s.map(10.0)), (100.0, 150.0, 200.0));
        assert!(Scale::new(3.0, 3.0, 0.0, 1.0).map(3.0).is_finite());
    }
}
