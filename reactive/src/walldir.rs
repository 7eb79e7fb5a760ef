//! The walls' direction, held through odometry while no wall is seen flat.
//!
//! A behaviour's inner loop turns the robot by the wall angle `alpha` (see [`crate::ring`]).
//! The ring gives a good angle only where it sees a flat wall: the line through the echoes of
//! the nearest sensor's neighbours. Beside a person, a door recess or a corner it gives the
//! coarse `pi/8 (m - c)` of whatever is nearest, or a line fitted to a round person, and the
//! robot turns by an angle that is not the wall's. On the reference corridor that was 30% of
//! center following's time with the angle more than 20 degrees off (EXPERIMENTS.md).
//!
//! Walls do not turn when the robot does, so [`WallDirection`] keeps the direction of the
//! last flat wall in the odometry frame (heading plus `alpha`, folded to a line's direction)
//! and gives `alpha` from it and the current heading while no flat wall agrees with it:
//! - A fitted angle within `agree_deg` of the held direction confirms and updates it.
//! - Fitted angles on both sides that agree with each other but not with the held direction
//!   mean the walls really turned (a corner, a wrong earlier fit): they replace it.
//! - A held direction unconfirmed for `hold_s` is dropped, and the next fit is taken as is.
//! - With anything nearer than `near_m` on the sides, the ring's own angle decides: close to
//!   a person, keeping parallel to what is near is what keeps the robot off it (with the held
//!   direction alone the reference corridor had bumps and deadlocks; EXPERIMENTS.md).
//! - Without odometry (or with it stale), or with `enabled = false`, nothing is
//!   held and the behaviour uses the ring's angle alone, exactly as without this module.

use orsa_actors::param::Invalid;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// How the walls' direction is held (`[...walls]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WallDirParams {
    /// Hold the walls' direction through odometry at all.
    pub enabled: bool,
    /// A fitted wall angle within this of the held direction confirms it, degrees.
    pub agree_deg: f64,
    /// A direction not confirmed for this long is dropped, s.
    pub hold_s: f64,
    /// With anything nearer than this on the sides, the ring's own angle decides, m (0: never).
    pub near_m: f64,
}

impl Default for WallDirParams {
    fn default() -> Self {
        WallDirParams { enabled: true, agree_deg: 8.0, hold_s: 3.0, near_m: 0.45 }
    }
}

impl WallDirParams {
    /// Checks every value; the message names the offending key under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<(), Invalid> {
        if !(self.agree_deg > 0.0 && self.agree_deg < 90.0) {
            return Err(Invalid::new("walls.agree_deg", "must be in (0, 90)").under(prefix));
        }
        if !(self.hold_s.is_finite() && self.hold_s > 0.0) {
            return Err(Invalid::new("walls.hold_s", "must be a positive number").under(prefix));
        }
        if !(self.near_m.is_finite() && self.near_m >= 0.0) {
            return Err(Invalid::new("walls.near_m", "must be a number >= 0").under(prefix));
        }
        Ok(())
    }
}

/// Odometry older than this is not extrapolated to a scan's time, ns.
const ODOMETRY_FRESH_NS: u64 = 500_000_000;

/// A line's direction folded into [-pi/2, pi/2).
fn fold(a: f64) -> f64 {
    (a + PI / 2.0).rem_euclid(PI) - PI / 2.0
}

/// The state of the tracker that [`WallDirParams`] configures.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WallDirection {
    /// The latest odometry: heading (rad), turn rate (rad/s), stamp (ns).
    odometry: Option<(f64, f64, u64)>,
    /// The walls' direction in the odometry frame (rad, folded) and when it was last
    /// confirmed (ns).
    held: Option<(f64, u64)>,
}

impl WallDirection {
    /// Odometry: the robot heads `heading` (rad) turning at `omega` (rad/s) at `now` (ns).
    pub fn note_heading(&mut self, heading: f64, omega: f64, now: u64) {
        if heading.is_finite() && omega.is_finite() {
            self.odometry = Some((heading, omega, now));
        }
    }

    /// The heading at `now`, extrapolated from fresh odometry.
    fn heading_at(&self, now: u64) -> Option<f64> {
        let (h, w, t) = self.odometry?;
        let ahead = now.saturating_sub(t);
        (ahead <= ODOMETRY_FRESH_NS).then_some(h + w * ahead as f64 * 1e-9)
    }

    /// The wall angle to steer by at `now` (ns), given the ring's fitted angles `fits` (flat
    /// walls only, nearest first), `ring`, the angle the ring alone would give (the nearer
    /// side's, fitted or coarse), and `nearest_m`, the nearest side reading. `None`: nothing
    /// at all to go by.
    pub fn alpha(
        &mut self,
        p: &WallDirParams,
        fits: &[f64],
        ring: Option<f64>,
        nearest_m: Option<f64>,
        now: u64,
    ) -> Option<f64> {
        let Some(h) = self.heading_at(now).filter(|_| p.enabled) else { return ring };
        let held = self.held.filter(|(_, t)| (now.saturating_sub(*t) as f64) * 1e-9 <= p.hold_s);
        let agree = p.agree_deg.to_radians();
        let chosen = match held {
            None => fits.first().copied(),
            Some((dir, _)) => {
                let predicted = fold(dir - h);
                let near = |a: f64| fold(a - predicted).abs() <= agree;
                let turned = fits.len() >= 2 && fold(fits[0] - fits[1]).abs() <= agree;
                fits.iter().copied().find(|&a| near(a)).or(if turned { Some(fits[0]) } else { None })
            }
        };
        let alpha = match (chosen, held) {
            (Some(a), _) => {
                self.held = Some((fold(h + a), now));
                Some(a)
            }
            (None, Some((dir, _))) => Some(fold(dir - h)),
            (None, None) => ring,
        };
        // Still tracked while something is close, so the direction is there when it has gone.
        if nearest_m.is_some_and(|d| d < p.near_m) { ring } else { alpha }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: u64 = 1_000_000_000;

    fn deg(d: f64) -> f64 {
        d.to_radians()
    }

    fn on() -> WallDirParams {
        WallDirParams { enabled: true, ..Default::default() }
    }

    #[test]
    fn without_odometry_or_disabled_the_ring_decides() {
        let p = on();
        let mut w = WallDirection::default();
        assert_eq!(w.alpha(&p, &[0.1, 0.3], Some(0.5), None, 0), Some(0.5));
        assert_eq!(w.alpha(&p, &[], None, None, 2 * S), None);
        // Stale odometry is no odometry.
        w.note_heading(0.0, 0.0, 0);
        assert_eq!(w.alpha(&p, &[0.2], Some(0.2), None, 0), Some(0.2));
        assert_eq!(w.alpha(&p, &[], Some(0.7), None, S), Some(0.7), "odometry a second old is not used");
        // Disabled: the ring's angle even when a held direction would differ.
        let off = WallDirParams { enabled: false, ..Default::default() };
        let mut w = WallDirection::default();
        w.note_heading(0.0, 0.0, 0);
        assert_eq!(w.alpha(&off, &[0.0], Some(0.0), None, 0), Some(0.0));
        assert_eq!(w.alpha(&off, &[deg(60.0)], Some(0.5), None, 1), Some(0.5));
    }

    #[test]
    fn the_direction_is_held_while_the_robot_turns_past_a_person() {
        let p = on();
        let mut w = WallDirection::default();
        // Parallel to the walls, heading 0.3 rad in the odometry frame: walls along 0.3.
        w.note_heading(0.3, 0.0, 0);
        assert_eq!(w.alpha(&p, &[0.0], Some(0.0), None, 0), Some(0.0));
        // The robot has turned 20 degrees left; the ring sees only a person 0.6 m away
        // (coarse 45 degrees) and a bad fit on it (60 degrees).
        w.note_heading(0.3 + deg(20.0), 0.0, S / 2);
        let a = w.alpha(&p, &[deg(60.0)], Some(deg(45.0)), Some(0.6), S / 2).expect("held");
        assert!((a - deg(-20.0)).abs() < 1e-9, "the walls are 20 degrees right of the heading: {a}");
        // Turning at 10 deg/s since the last odometry, 0.2 s ago: 2 degrees more.
        w.note_heading(0.3 + deg(20.0), deg(10.0), S);
        let a = w.alpha(&p, &[], Some(deg(45.0)), Some(0.6), S + S / 5).expect("held");
        assert!((a - deg(-22.0)).abs() < 1e-9, "extrapolated: {}", a.to_degrees());
        // Closer than near_m, the ring's angle decides, but the direction is still held.
        assert_eq!(w.alpha(&p, &[], Some(deg(45.0)), Some(0.3), S + S / 5), Some(deg(45.0)));
        let a = w.alpha(&p, &[], Some(deg(45.0)), Some(0.6), S + S / 5).expect("held");
        assert!((a - deg(-22.0)).abs() < 1e-9);
        // A fit that agrees confirms and refines it.
        let a = w.alpha(&p, &[deg(-21.0)], Some(deg(45.0)), Some(0.6), S + S / 5).expect("fit");
        assert!((a - deg(-21.0)).abs() < 1e-9);
    }

    #[test]
    fn two_sides_agreeing_replace_the_held_direction_and_it_expires() {
        let p = on();
        let mut w = WallDirection::default();
        w.note_heading(0.0, 0.0, 0);
        assert_eq!(w.alpha(&p, &[0.0], Some(0.0), None, 0), Some(0.0));
        // Both sides fit a wall 40 degrees off: the walls turned.
        assert_eq!(w.alpha(&p, &[deg(40.0), deg(41.0)], Some(0.0), None, S / 10), Some(deg(40.0)));
        // One side alone 40 degrees off the new direction is not believed.
        let a = w.alpha(&p, &[deg(80.0)], Some(deg(80.0)), None, S / 5).expect("held");
        assert!((a - deg(40.0)).abs() < 1e-9);
        // After hold_s without confirmation a new fit is taken as it is.
        w.note_heading(0.0, 0.0, 4 * S);
        assert_eq!(w.alpha(&p, &[deg(88.0)], None, None, 4 * S), Some(deg(88.0)));
        // A line's direction folds: -87 degrees is 5 degrees from 88, and confirms it.
        assert_eq!(w.alpha(&p, &[deg(-87.0)], None, None, 4 * S + 1), Some(deg(-87.0)));
        assert_eq!(w.alpha(&p, &[deg(70.0)], None, None, 4 * S + 2), Some(deg(-87.0)), "held");
    }

    #[test]
    fn bad_values_name_the_key() {
        assert!(on().validate("centerfollow").is_ok());
        let bad = WallDirParams { agree_deg: 90.0, ..on() };
        assert_eq!(
            bad.validate("centerfollow").expect_err("refused").to_string(),
            "centerfollow.walls.agree_deg: must be in (0, 90)"
        );
        let bad = WallDirParams { hold_s: 0.0, ..on() };
        assert_eq!(
            bad.validate("centerfollow").expect_err("refused").to_string(),
            "centerfollow.walls.hold_s: must be a positive number"
        );
        let bad = WallDirParams { near_m: f64::NAN, ..on() };
        assert_eq!(
            bad.validate("centerfollow").expect_err("refused").to_string(),
            "centerfollow.walls.near_m: must be a number >= 0"
        );
    }
}
