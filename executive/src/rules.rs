//! Arbitration rules: which behaviour drives, decided from sensor values, subsumption style.
//!
//! A [`Mode`] is a set of behaviours and a priority list of [`Rule`]s. The first rule that
//! applies names the behaviour to wire to the motors; a rule without conditions always applies,
//! so it makes a good last (default) rule. A mode with no rule that applies wires nothing.
//!
//! A rule **engages** when its `when` conditions all hold. Without more, it applies only while
//! they hold, which is the thesis' rule: wall following drives while something is within 0.50 m
//! in front, and hands back the moment nothing is. A rule can also **hold** the robot after its
//! trigger clears (hysteresis):
//!
//! - `hold_while`: once engaged, the rule keeps applying while these conditions all hold ...
//! - `release_when`, `release_after_s`: ... until these conditions have held without a break for
//!   `release_after_s` (a dwell: the way ahead must stay clear that long);
//! - `min_dwell_s`: once engaged, it applies at least this long whatever the readings;
//! - `cooldown_s`: once it stops applying, its `when` is ignored this long.
//!
//! A rule that holds is still preempted by a rule above it in the list whose `when` holds. Rules
//! are judged on every scan the master receives, at the scan's time, so a dwell is measured in
//! sensor time and a replay decides the same. In the config file:
//!
//! ```toml
//! [params.master.modes.patrol]
//! behaviours = ["wallfollow", "centerfollow"]
//! rules = [
//!   # the thesis' trigger: something within 0.50 m in front -> wall following ...
//!   { drive = "wallfollow", when = [{ ring = "infrared", sensors = [0], below_m = 0.50 }],
//!     # ... which keeps the robot while a wall is within its reach on the left ...
//!     hold_while = [{ ring = "infrared", sensors = [3, 4, 5], below_m = 0.55 }],
//!     # ... until the way ahead has been clear for 4 s
//!     release_when = [{ ring = "sonar", sensors = [15, 0, 1], above_m = 1.0 }],
//!     release_after_s = 4.0 },
//!   { drive = "centerfollow" },
//! ]
//! ```
//!
//! A condition looks at some sensors of one ring: `below_m` holds when **any** of them reads a
//! valid distance under it; `above_m` holds when **all** of them read over it or nothing at all
//! (an invalid reading means nothing within range, which is "far"). [`Arbiter`] keeps what a
//! mode's rules need to remember between scans.

use orsa_actors::param::Invalid;
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
    /// Conditions that must all hold for the rule to engage (none: always).
    #[serde(default)]
    pub when: Vec<Condition>,
    /// Once engaged, the rule keeps applying while these all hold (until released).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hold_while: Option<Vec<Condition>>,
    /// Once engaged, the rule lets go when these have all held for `release_after_s`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub release_when: Vec<Condition>,
    /// How long `release_when` must hold without a break, s.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub release_after_s: f64,
    /// Once engaged, the rule applies at least this long, s.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub min_dwell_s: f64,
    /// Once it stops applying, the rule's `when` is ignored this long, s.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub cooldown_s: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The longest dwell, release time or cool-down a rule may ask for, s.
pub const MAX_RULE_TIME_S: f64 = 3600.0;

impl Rule {
    /// A rule that drives `drive` whenever `when` holds, and holds nothing.
    pub fn new(drive: &str, when: Vec<Condition>) -> Self {
        Rule {
            drive: drive.to_string(),
            when,
            hold_while: None,
            release_when: Vec::new(),
            release_after_s: 0.0,
            min_dwell_s: 0.0,
            cooldown_s: 0.0,
        }
    }

    /// Whether the rule can keep applying after its trigger clears.
    pub fn holds_on(&self) -> bool {
        self.hold_while.is_some() || !self.release_when.is_empty() || self.min_dwell_s > 0.0
    }

    fn conditions(&self) -> impl Iterator<Item = &Condition> {
        self.when.iter().chain(self.hold_while.iter().flatten()).chain(&self.release_when)
    }

    fn validate(&self, at: &str) -> Result<(), Invalid> {
        for (j, c) in self.when.iter().enumerate() {
            c.validate(&format!("{at}.when[{j}]"))?;
        }
        for (j, c) in self.hold_while.iter().flatten().enumerate() {
            c.validate(&format!("{at}.hold_while[{j}]"))?;
        }
        for (j, c) in self.release_when.iter().enumerate() {
            c.validate(&format!("{at}.release_when[{j}]"))?;
        }
        for (key, v) in [
            ("release_after_s", self.release_after_s),
            ("min_dwell_s", self.min_dwell_s),
            ("cooldown_s", self.cooldown_s),
        ] {
            if !(v.is_finite() && (0.0..=MAX_RULE_TIME_S).contains(&v)) {
                return Err(Invalid::new(
                    format!("{at}.{key}"),
                    format!("must be from 0 to {MAX_RULE_TIME_S} seconds, not {v}"),
                ));
            }
        }
        if self.release_after_s > 0.0 && self.release_when.is_empty() {
            return Err(Invalid::new(
                format!("{at}.release_after_s"),
                "there is no release_when to wait for",
            ));
        }
        if self.when.is_empty() && (self.holds_on() || self.cooldown_s > 0.0) {
            return Err(Invalid::new(
                at,
                "a rule without `when` always applies; hold_while, release_when, min_dwell_s \
                 and cooldown_s would change nothing",
            ));
        }
        if self.hold_while.as_ref().is_some_and(Vec::is_empty) && self.release_when.is_empty() {
            return Err(Invalid::new(
                format!("{at}.hold_while"),
                "an empty list always holds and there is no release_when, so the \
                 rule could never release the robot; list conditions or give release_when",
            ));
        }
        Ok(())
    }
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

    fn validate(&self, at: &str) -> Result<(), Invalid> {
        if self.sensors.is_empty() {
            return Err(Invalid::new(format!("{at}.sensors"), "list at least one sensor"));
        }
        if let Some(bad) = self.sensors.iter().find(|&&i| i >= RING_SIZE) {
            return Err(Invalid::new(
                format!("{at}.sensors"),
                format!("sensor {bad} does not exist (0..{})", RING_SIZE - 1),
            ));
        }
        if self.below_m.is_none() && self.above_m.is_none() {
            return Err(Invalid::new(at, "give below_m, above_m or both"));
        }
        for (key, v) in [("below_m", self.below_m), ("above_m", self.above_m)] {
            if let Some(v) = v
                && !(v.is_finite() && v >= 0.0)
            {
                return Err(Invalid::new(
                    format!("{at}.{key}"),
                    format!("must be a non-negative number, not {v}"),
                ));
            }
        }
        if self.below_m == Some(0.0) {
            return Err(Invalid::new(
                format!("{at}.below_m"),
                "no distance reads under 0, so the condition could never hold",
            ));
        }
        if let (Some(below), Some(above)) = (self.below_m, self.above_m)
            && self.sensors.len() == 1
            && below <= above
        {
            return Err(Invalid::new(
                at,
                format!(
                    "one sensor cannot read under {below} and over {above} at once, so the \
                     condition could never hold"
                ),
            ));
        }
        Ok(())
    }
}

impl Mode {
    /// The behaviour the rules pick for these readings, judging each rule by its trigger only
    /// (what a fresh [`Arbiter`] decides on its first scan).
    pub fn select(&self, r: &Readings) -> Option<&str> {
        self.rules.iter().find(|rule| all(&rule.when, r)).map(|rule| rule.drive.as_str())
    }

    /// Whether any rule reads the sonar ring (the master subscribes to it only then).
    pub fn uses_sonar(&self) -> bool {
        self.rules.iter().flat_map(Rule::conditions).any(|c| c.ring == RingName::Sonar)
    }

    /// Checks the mode; messages name the key, e.g. `executive.modes.patrol.rules[0].drive`.
    pub fn validate(&self, at: &str) -> Result<(), Invalid> {
        for (i, rule) in self.rules.iter().enumerate() {
            if !self.behaviours.contains(&rule.drive) {
                return Err(Invalid::new(
                    format!("{at}.rules[{i}].drive"),
                    format!("'{}' is not one of this mode's behaviours {:?}", rule.drive, self.behaviours),
                ));
            }
            rule.validate(&format!("{at}.rules[{i}]"))?;
        }
        Ok(())
    }
}

fn all(conditions: &[Condition], r: &Readings) -> bool {
    conditions.iter().all(|c| c.holds(r))
}

/// Times within this of a dwell's end count as its end (seconds are sums of floating point
/// numbers; a dwell of 2 s measured from 3.6 s ends at 5.6 s, not one scan later).
const TIME_SLACK_S: f64 = 1e-9;

/// What a mode's rules remember between scans: which rule is engaged since when, how long its
/// release condition has held, and which rules cool down until when. One arbiter serves one
/// mode; a new goal starts a new one.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Arbiter {
    engaged: Option<Engaged>,
    cool_until: BTreeMap<usize, f64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Engaged {
    rule: usize,
    since_s: f64,
    release_since_s: Option<f64>,
}

impl Arbiter {
    /// An arbiter with nothing engaged.
    pub fn new() -> Self {
        Self::default()
    }

    /// Judges `mode`'s rules on readings taken at `now_s` (seconds on any steady base) and
    /// returns the index of the rule that applies, if any.
    pub fn decide(&mut self, mode: &Mode, r: &Readings, now_s: f64) -> Option<usize> {
        let chosen = mode.rules.iter().enumerate().position(|(i, rule)| {
            let holds = self.still_holds(i, rule, r, now_s);
            let cooled = self.cool_until.get(&i).is_none_or(|&t| now_s >= t - TIME_SLACK_S);
            let triggered = all(&rule.when, r) && cooled;
            triggered || holds
        });
        if let Some(was) = self.engaged
            && Some(was.rule) != chosen
        {
            self.engaged = None;
            if let Some(rule) = mode.rules.get(was.rule)
                && rule.cooldown_s > 0.0
            {
                self.cool_until.insert(was.rule, now_s + rule.cooldown_s);
            }
        }
        if let Some(i) = chosen
            && self.engaged.is_none()
        {
            self.engaged = Some(Engaged { rule: i, since_s: now_s, release_since_s: None });
        }
        chosen
    }

    /// Whether the engaged rule `i` keeps the robot although its trigger may have cleared;
    /// updates the release dwell.
    fn still_holds(&mut self, i: usize, rule: &Rule, r: &Readings, now_s: f64) -> bool {
        let Some(e) = self.engaged.as_mut().filter(|e| e.rule == i) else {
            return false;
        };
        if !rule.holds_on() {
            return false;
        }
        if !rule.release_when.is_empty() {
            if all(&rule.release_when, r) {
                e.release_since_s.get_or_insert(now_s);
            } else {
                e.release_since_s = None;
            }
        }
        if now_s - e.since_s < rule.min_dwell_s - TIME_SLACK_S {
            return true;
        }
        let holding = rule.hold_while.as_deref().is_none_or(|c| all(c, r));
        let released = e.release_since_s.is_some_and(|t| now_s - t >= rule.release_after_s - TIME_SLACK_S);
        let can_hold = rule.hold_while.is_some() || !rule.release_when.is_empty();
        can_hold && holding && !released
    }

    /// The engaged rule's index, if any.
    pub fn engaged(&self) -> Option<usize> {
        self.engaged.map(|e| e.rule)
    }
}

/// Validates every mode of a table of modes.
pub fn validate_modes(modes: &BTreeMap<String, Mode>) -> Result<(), Invalid> {
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

    fn hysteresis() -> Mode {
        toml::from_str(
            r#"
            behaviours = ["wallfollow", "centerfollow"]
            rules = [
              { drive = "wallfollow", when = [{ ring = "infrared", sensors = [0], below_m = 0.5 }],
                hold_while = [{ ring = "infrared", sensors = [4], below_m = 0.4 }],
                release_when = [{ ring = "infrared", sensors = [0], above_m = 0.5 }],
                release_after_s = 2.0 },
              { drive = "centerfollow" },
            ]"#,
        )
        .expect("parses")
    }

    /// Readings with the front sensor and the left sensor at these distances (None: nothing).
    fn seen(front: Option<f64>, left: Option<f64>) -> Readings {
        let mut r = Readings::default();
        r.infrared[0] = front;
        r.infrared[4] = left;
        r
    }

    #[test]
    fn a_held_rule_keeps_the_robot_until_the_release_has_held_for_its_dwell() {
        let mode = hysteresis();
        let mut a = Arbiter::new();
        let wall = Some(0.2);
        assert_eq!(a.decide(&mode, &seen(None, wall), 0.0), Some(1), "not triggered: the default rule");
        assert_eq!(a.decide(&mode, &seen(Some(0.3), None), 1.0), Some(0), "the trigger engages it");
        assert_eq!(a.decide(&mode, &seen(None, wall), 1.4), Some(0), "held: the wall is within reach");
        assert_eq!(a.decide(&mode, &seen(None, wall), 3.0), Some(0), "the way ahead clear for 1.6 s");
        assert_eq!(a.decide(&mode, &seen(Some(0.45), wall), 3.2), Some(0), "something ahead again");
        assert_eq!(a.decide(&mode, &seen(None, wall), 3.6), Some(0), "the release's clock restarted");
        assert_eq!(a.decide(&mode, &seen(None, wall), 5.5), Some(0), "1.9 s");
        assert_eq!(a.decide(&mode, &seen(None, wall), 5.6), Some(1), "2 s clear: released");
        assert_eq!(a.engaged(), Some(1));
    }

    #[test]
    fn a_held_rule_lets_go_when_its_hold_condition_fails() {
        let mode = hysteresis();
        let mut a = Arbiter::new();
        assert_eq!(a.decide(&mode, &seen(Some(0.3), Some(0.2)), 0.0), Some(0));
        assert_eq!(a.decide(&mode, &seen(None, Some(0.39)), 0.4), Some(0));
        assert_eq!(a.decide(&mode, &seen(None, Some(0.41)), 0.8), Some(1), "the wall is out of reach");
        assert_eq!(a.decide(&mode, &seen(None, Some(0.2)), 1.2), Some(1), "a wall again does not re-engage");
    }

    #[test]
    fn the_thesis_rule_has_no_memory() {
        let mode = patrol();
        let mut a = Arbiter::new();
        for (t, front, want) in
            [(0.0, Some(0.3), 0), (0.4, None, 1), (0.8, Some(0.49), 0), (1.2, Some(0.51), 1)]
        {
            assert_eq!(a.decide(&mode, &seen(front, Some(0.2)), t), Some(want), "t = {t}");
            assert_eq!(mode.select(&seen(front, Some(0.2))), Some(mode.rules[want].drive.as_str()));
        }
    }

    #[test]
    fn min_dwell_and_cooldown() {
        let mut mode = patrol();
        mode.rules[0].min_dwell_s = 1.0;
        mode.rules[0].cooldown_s = 2.0;
        mode.validate("m").expect("valid");
        let mut a = Arbiter::new();
        assert_eq!(a.decide(&mode, &seen(Some(0.3), None), 10.0), Some(0));
        assert_eq!(a.decide(&mode, &seen(None, None), 10.9), Some(0), "within the minimum dwell");
        assert_eq!(a.decide(&mode, &seen(None, None), 11.0), Some(1), "the dwell is over");
        assert_eq!(a.decide(&mode, &seen(Some(0.3), None), 12.9), Some(1), "cooling down");
        assert_eq!(a.decide(&mode, &seen(Some(0.3), None), 13.0), Some(0), "cooled down");
    }

    #[test]
    fn a_rule_above_preempts_a_held_rule() {
        let mut mode = hysteresis();
        mode.behaviours.push("escape".into());
        let escape = Condition { ring: RingName::Sonar, sensors: vec![8], below_m: Some(0.3), above_m: None };
        mode.rules.insert(0, Rule::new("escape", vec![escape]));
        mode.validate("m").expect("valid");
        let mut a = Arbiter::new();
        assert_eq!(a.decide(&mode, &seen(Some(0.3), Some(0.2)), 0.0), Some(1));
        let mut r = seen(None, Some(0.2));
        r.sonar[8] = Some(0.1);
        assert_eq!(a.decide(&mode, &r, 0.4), Some(0), "the rule above wins");
        assert_eq!(a.decide(&mode, &seen(None, Some(0.2)), 0.8), Some(2), "the held rule was let go");
    }

    #[test]
    fn rules_that_could_never_release_or_never_hold_are_refused() {
        let refuse = |edit: &dyn Fn(&mut Rule), want: &str| {
            let mut m = hysteresis();
            edit(&mut m.rules[0]);
            let e = m.validate("executive.modes.patrol").expect_err(want).to_string();
            assert!(e.starts_with(want), "{e}");
        };
        refuse(
            &|r| {
                r.hold_while = Some(vec![]);
                r.release_when.clear();
                r.release_after_s = 0.0;
            },
            "executive.modes.patrol.rules[0].hold_while: an empty list always holds",
        );
        refuse(&|r| r.release_when.clear(), "executive.modes.patrol.rules[0].release_after_s: there is no");
        refuse(&|r| r.release_after_s = f64::NAN, "executive.modes.patrol.rules[0].release_after_s: must be");
        refuse(&|r| r.cooldown_s = -1.0, "executive.modes.patrol.rules[0].cooldown_s: must be");
        refuse(&|r| r.min_dwell_s = 1e9, "executive.modes.patrol.rules[0].min_dwell_s: must be");
        refuse(
            &|r| r.hold_while = Some(vec![cond(17)]),
            "executive.modes.patrol.rules[0].hold_while[0].sensors",
        );
        refuse(
            &|r| r.release_when[0].above_m = None,
            "executive.modes.patrol.rules[0].release_when[0]: give",
        );
        refuse(
            &|r| r.when[0].below_m = Some(0.0),
            "executive.modes.patrol.rules[0].when[0].below_m: no distance",
        );
        refuse(
            &|r| r.when[0].above_m = Some(0.6),
            "executive.modes.patrol.rules[0].when[0]: one sensor cannot read under 0.5 and over 0.6",
        );
        let mut m = hysteresis();
        m.rules[1].hold_while = Some(vec![cond(4)]);
        let e = m.validate("executive.modes.patrol").expect_err("default rule holding").to_string();
        assert!(
            e.starts_with("executive.modes.patrol.rules[1]: a rule without `when` always applies"),
            "{e}"
        );
        let unknown_ring: Result<Mode, _> = toml::from_str(
            "behaviours = [\"a\"]\nrules = [{ drive = \"a\", when = [{ ring = \"laser\", sensors = [0], below_m = 1.0 }] }]",
        );
        let e = unknown_ring.expect_err("unknown ring").to_string();
        assert!(e.contains("line 2") && e.contains("laser"), "{e}");
    }

    fn cond(sensor: usize) -> Condition {
        Condition { ring: RingName::Infrared, sensors: vec![sensor], below_m: Some(0.4), above_m: None }
    }

    #[test]
    fn validation_names_the_offending_key() {
        let mut m = patrol();
        m.rules[0].drive = "teleop".into();
        let e = m.validate("executive.modes.patrol").expect_err("invalid").to_string();
        assert!(e.starts_with("executive.modes.patrol.rules[0].drive: 'teleop'"), "{e}");
        let mut m = patrol();
        m.rules[0].when[0].sensors = vec![16];
        let e = m.validate("executive.modes.patrol").expect_err("invalid").to_string();
        assert_eq!(e, "executive.modes.patrol.rules[0].when[0].sensors: sensor 16 does not exist (0..15)");
        let unknown: Result<Mode, _> = toml::from_str("behaviours = []\nrulez = []");
        assert!(unknown.expect_err("unknown key").to_string().contains("rulez"));
    }
}
