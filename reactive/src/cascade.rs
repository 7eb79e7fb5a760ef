//! The two cascaded proportional loops both behaviours use.
//!
//! Outer loop: the lateral error `e` (how far the robot should move to its left, m) sets the
//! wall-angle set-point `alpha_ref = -k_d e`, clamped to `alpha_max`: to move left the robot
//! must head left of the wall direction, which is `alpha < 0` (see [`crate::ring`]).
//! Inner loop: `omega = k_alpha (alpha_ref - alpha)` with `k_alpha < 0`, clamped to `omega_max`.
//! Since `alpha' = -omega`, this gives `alpha' = k_alpha (alpha - alpha_ref)`: `alpha` converges to
//! its set-point with time constant `1/|k_alpha|`, and the distance with `1/(v k_d)`.
//!
//! The thesis writes the model as `alpha' = omega`, `d' = v sin(alpha)`, which cannot both hold
//! for its own `alpha` formula with the sensor ring counting counter-clockwise; orsa keeps the
//! gains' signs as the thesis gives them (`k_d > 0`, `k_alpha < 0`) and the loop structure, and
//! states the sign conventions that make it stable.

use orsa_actors::param::Invalid;
use serde::{Deserialize, Serialize};

/// Gains and limits of the cascade.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CascadeParams {
    /// Outer gain, rad of wall angle per m of lateral error (> 0).
    pub k_d: f64,
    /// Inner gain, rad/s of turn rate per rad of angle error (< 0).
    pub k_alpha: f64,
    /// Largest angle set-point, degrees.
    pub alpha_max_deg: f64,
    /// Largest turn rate commanded, degrees per second.
    pub omega_max_deg_s: f64,
}

/// Checks that each `(key, value)` is a positive finite number; the error names
/// `prefix.key`, as every behaviour's parameter checks do.
pub fn check_positive(prefix: &str, values: &[(&str, f64)]) -> Result<(), Invalid> {
    match values.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
        Some((key, _)) => Err(Invalid::new(*key, "must be a positive number").under(prefix)),
        None => Ok(()),
    }
}

impl Default for CascadeParams {
    fn default() -> Self {
        CascadeParams { k_d: 3.0, k_alpha: -2.5, alpha_max_deg: 30.0, omega_max_deg_s: 45.0 }
    }
}

impl CascadeParams {
    /// Checks signs and ranges; the message names the offending key.
    pub fn validate(&self, prefix: &str) -> Result<(), Invalid> {
        let ok = |cond: bool, key: &str, what: &str| {
            if cond { Ok(()) } else { Err(Invalid::new(key, what).under(prefix)) }
        };
        ok(self.k_d.is_finite() && self.k_d > 0.0, "k_d", "must be a positive number")?;
        ok(self.k_alpha.is_finite() && self.k_alpha < 0.0, "k_alpha", "must be a negative number")?;
        ok(self.alpha_max_deg > 0.0 && self.alpha_max_deg <= 90.0, "alpha_max_deg", "must be in (0, 90]")?;
        ok(
            self.omega_max_deg_s > 0.0 && self.omega_max_deg_s.is_finite(),
            "omega_max_deg_s",
            "must be positive",
        )
    }

    /// The turn rate that drives the lateral error `error_left_m` to zero, given the wall angle.
    pub fn omega(&self, error_left_m: f64, alpha_rad: f64) -> f64 {
        let amax = self.alpha_max_deg.to_radians();
        let alpha_ref = (-self.k_d * error_left_m).clamp(-amax, amax);
        let wmax = self.omega_max_deg_s.to_radians();
        (self.k_alpha * (alpha_ref - alpha_rad)).clamp(-wmax, wmax)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turns_toward_where_it_must_go_and_saturates() {
        let c = CascadeParams::default();
        assert!(c.omega(0.1, 0.0) > 0.0, "must move left: turn left");
        assert!(c.omega(-0.1, 0.0) < 0.0, "must move right: turn right");
        assert_eq!(c.omega(0.0, 0.0), 0.0);
        // Already heading left at the set-point angle: no turn.
        let alpha_ref = -c.k_d * 0.05;
        assert!(c.omega(0.05, alpha_ref).abs() < 1e-12);
        assert!((c.omega(100.0, 0.0) - 45f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn validation_names_the_key() {
        let bad = CascadeParams { k_alpha: 1.0, ..Default::default() };
        assert_eq!(
            bad.validate("wallfollow").err().map(|e| e.to_string()).as_deref(),
            Some("wallfollow.k_alpha: must be a negative number")
        );
    }
}
