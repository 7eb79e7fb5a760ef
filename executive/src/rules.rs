//! Arbitration rules: which behaviour drives, decided from sensor values, subsumption style.
//!
//! A [`Mode`] is a set of behaviours and a priority list of [`Rule`]s. The first rule whose
//! conditions all hold names the behaviour to wire to the motors; a rule without conditions
//! always holds, so it makes a good last (default) rule. A mode with no rule that holds wires
//! nothing. In the config file:
//!
//! ```toml
//! [executive.modes.patrol]
//! behaviours = ["wallfollow", "centerfollow"]
//! rules = [
//!   # the thesis' rule: something within 0.50 m in front -> wall following
//!   { drive = "wallfollow", when = [{ ring = "infrared", sensors = [0], below_m = 0.50 }] },
//!   { drive = "centerfollow" },
//! ]
//! ```
//!
//! A condition looks at some sensors of one ring: `below_m` holds when **any** of them reads a
//! valid distance under it; `above_m` holds when **all** of them read over it or nothing at all
//! (an invalid reading means nothing within range, which is "far").

use orsa_interfaces::nomad200::RING_SIZE;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which ring a condition reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RingName {
    /// The infrared ring (`distanceir`).
    Infrared,
    /// The sonar ring (`distanceson`).
    Sonar,
}

/// A test on some sensors of one ring.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Condition {
    /// The ring.
    pub ring: RingName,
    /// Sensor indices, 0..16 (0 front, 4 left, 8 back, 12 right).
    pub sensors: Vec<usize>,
    /// Holds when any listed sensor reads under this, m.
    pub below_m: Option<f64>,
    /// Holds when every listed sensor reads over this (or nothing), m.
    pub above_m: Option<f64>,
}

/// One line of a mode's priority list.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rule {
    /// The behaviour this rule wires to the motors.
    pub drive: String,
    /// Conditions that must all hold (none: always).
    #[serde(default)]
    pub when: Vec<Condition>,
}

/// A set of behaviours and the rules that arbitrate between them.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mode {
    /// Behaviours activated (State `active`) in this mode; all others are deactivated.
    #[serde(default)]
    pub behaviours: Vec<String>,
    /// Priority list: the first rule that holds drives.
    #[serde(default)]
    pub rules: Vec<Rule>,
}

/// Valid distances per sensor of both rings (`None`: invalid or not yet seen).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Readings {
    /// Infrared ring.
    pub infrared: [Option<f64>; RING_SIZE],
    /// Sonar ring.
    pub sonar: [Option<f64>; RING_SIZE],
}

impl Condition {
    fn holds(&self, r: &Readings) -> bool {
        let ring = match self.ring {
            RingName::Infrared => &r.infrared,
            RingName::Sonar => &r.sonar,
        };
        let values = self.sensors.iter().map(|&i| ring.get(i).copied().flatten());
        let below = self.below_m.is_none_or(|lim| values.clone().any(|v| v.is_some_and(|d| d < lim)));
        let above = self.above_m.is_none_or(|lim| values.clone().all(|v| v.is_none_or(|d| d > lim)));
        below && above
    }

    fn validate(&self, at: &str) -> Result<(), String> {
        if self.sensors.is_empty() {
            return Err(format!("{at}.sensors: list at least one sensor"));
        }
        if let Some(bad) = self.sensors.iter().find(|&&i| i >= RING_SIZE) {
            return Err(format!("{at}.sensors: sensor {bad} does not exist (0..{})", RING_SIZE - 1));
        }
        if self.below_m.is_none() && self.above_m.is_none() {
            return Err(format!("{at}: give below_m, above_m or both"));
        }
        for (key, v) in [("below_m", self.below_m), ("above_m", self.above_m)] {
            if let Some(v) = v
                && !(v.is_finite() && v >= 0.0)
            {
                return Err(format!("{at}.{key}: must be a non-negative number, not {v}"));
            }
        }
        Ok(())
    }
}

impl Mode {
    /// The behaviour the rules pick for these readings.
    pub fn select(&self, r: &Readings) -> Option<&str> {
        self.rules.iter().find(|rule| rule.when.iter().all(|c| c.holds(r))).map(|rule| rule.drive.as_str())
    }

    /// Whether any rule reads the sonar ring (the master subscribes to it only then).
    pub fn uses_sonar(&self) -> bool {
        self.rules.iter().flat_map(|r| &r.when).any(|c| c.ring == RingName::Sonar)
    }

    /// Checks the mode; messages name the key, e.g. `executive.modes.patrol.rules[0].drive`.
    pub fn validate(&self, at: &str) -> Result<(), String> {
        for (i, rule) in self.rules.iter().enumerate() {
            if !self.behaviours.contains(&rule.drive) {
                return Err(format!(
                    "{at}.rules[{i}].drive: '{}' is not one of this mode's behaviours {:?}",
                    rule.drive, self.behaviours
                ));
            }
            for (j, c) in rule.when.iter().enumerate() {
                c.validate(&format!("{at}.rules[{i}].when[{j}]"))?;
            }
        }
        Ok(())
    }
}

/// Validates every mode of a table of modes.
pub fn validate_modes(modes: &BTreeMap<String, Mode>) -> Result<(), String> {
    for (name, mode) in modes {
        mode.validate(&format!("executive.modes.{name}"))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn patrol() -> Mode {
        toml::from_str(
            r#"
            behaviours = ["wallfollow", "centerfollow"]
            rules = [
              { drive = "wallfollow", when = [{ ring = "infrared", sensors = [0], below_m = 0.50 }] },
              { drive = "centerfollow" },
            ]"#,
        )
        .expect("parses")
    }

    #[test]
    fn the_original_rule_picks_wallfollow_only_with_something_close_in_front() {
        let mode = patrol();
        let mut r = Readings::default();
        assert_eq!(mode.select(&r), Some("centerfollow"), "nothing seen in front");
        r.infrared[0] = Some(0.55);
        assert_eq!(mode.select(&r), Some("centerfollow"));
        r.infrared[0] = Some(0.49);
        assert_eq!(mode.select(&r), Some("wallfollow"));
        r.infrared[0] = None;
        r.infrared[1] = Some(0.1);
        assert_eq!(mode.select(&r), Some("centerfollow"), "only sensor 0 counts");
    }

    #[test]
    fn above_treats_nothing_seen_as_far_and_needs_all() {
        let c = Condition { ring: RingName::Sonar, sensors: vec![3, 4], below_m: None, above_m: Some(1.0) };
        let mut r = Readings::default();
        assert!(c.holds(&r));
        r.sonar[3] = Some(2.0);
        r.sonar[4] = Some(0.5);
        assert!(!c.holds(&r));
    }

    #[test]
    fn validation_names_the_offending_key() {
        let mut m = patrol();
        m.rules[0].drive = "teleop".into();
        let e = m.validate("executive.modes.patrol").expect_err("invalid");
        assert!(e.starts_with("executive.modes.patrol.rules[0].drive: 'teleop'"), "{e}");
        let mut m = patrol();
        m.rules[0].when[0].sensors = vec![16];
        let e = m.validate("executive.modes.patrol").expect_err("invalid");
        assert_eq!(e, "executive.modes.patrol.rules[0].when[0].sensors: sensor 16 does not exist (0..15)");
        let unknown: Result<Mode, _> = toml::from_str("behaviours = []\nrulez = []");
        assert!(unknown.expect_err("unknown key").to_string().contains("rulez"));
    }
}
