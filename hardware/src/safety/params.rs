//! The monitor's parameters, `[safety]`, and the checks that refuse zones that cannot stop the robot.

use orsa_actors::param::Invalid;
use orsa_interfaces::nomad200::RobotParams;
use serde::{Deserialize, Serialize};

/// The monitor's parameters (`[safety]`), read at start only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetyParams {
    /// Whether the monitor guards the motors (default true; false only to measure what it
    /// costs).
    pub enabled: bool,
    /// The stop zone: the body grown by this much, m (default 0.03).
    pub stop_margin_m: f64,
    /// The slowdown zone: this much free path beyond the stop zone, m (default 0.1).
    pub slowdown_margin_m: f64,
    /// The speed cap in the slowdown zone, m/s (default 0.15).
    pub slow_speed_m_s: f64,
    /// Time from a reading to the brakes acting, s, on top of the monitor's period (default
    /// 0.1).
    pub latency_s: f64,
    /// The deceleration braking is counted at, m/s^2 (default: the robot's own, its
    /// `accel_m_s2`; never more).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub deceleration_m_s2: Option<f64>,
    /// How often the monitor looks again at the command in force, s (default 0.04).
    pub period_s: f64,
    /// The speed cap towards a direction no healthy sensor sees, m/s (default 0.05).
    pub blind_speed_m_s: f64,
    /// A sensor view with no reading this recent is not trusted, s (default 1.0).
    pub stale_after_s: f64,
    /// How long what the sensors saw stays in view at most, carried by odometry, unless a
    /// reading sees through it first, s (default 10).
    pub memory_s: f64,
    /// How the sensors' health is judged (`[safety.health]`, see [`super::health`]).
    pub health: super::health::HealthParams,
}

impl Default for SafetyParams {
    fn default() -> Self {
        SafetyParams {
            enabled: true,
            stop_margin_m: 0.03,
            slowdown_margin_m: 0.1,
            slow_speed_m_s: 0.15,
            latency_s: 0.1,
            deceleration_m_s2: None,
            period_s: 0.04,
            blind_speed_m_s: 0.05,
            stale_after_s: 1.0,
            memory_s: 10.0,
            health: Default::default(),
        }
    }
}

/// The table's keys, as errors name them.
const TABLE: &str = "safety";

impl SafetyParams {
    /// Why these parameters cannot be used on any robot, if they cannot.
    pub fn validate(&self) -> Result<(), Invalid> {
        let bad = |key: &str, reason: String| Err(Invalid::new(format!("{TABLE}.{key}"), reason));
        let checks: [(&str, f64, f64, f64); 8] = [
            ("stop_margin_m", self.stop_margin_m, 0.0, 1.0),
            ("slowdown_margin_m", self.slowdown_margin_m, 0.0, 10.0),
            ("slow_speed_m_s", self.slow_speed_m_s, 1e-3, 10.0),
            ("latency_s", self.latency_s, 0.0, 2.0),
            ("period_s", self.period_s, 1e-3, 0.5),
            ("blind_speed_m_s", self.blind_speed_m_s, 0.0, 10.0),
            ("stale_after_s", self.stale_after_s, 1e-3, 60.0),
            ("memory_s", self.memory_s, 0.0, 60.0),
        ];
        for (key, v, lo, hi) in checks {
            if !(v.is_finite() && v >= lo && v <= hi) {
                return bad(key, format!("must be between {lo} and {hi}, got {v}"));
            }
        }
        if let Some(a) = self.deceleration_m_s2
            && !(a.is_finite() && a > 0.0)
        {
            return bad("deceleration_m_s2", format!("must be above 0, got {a}"));
        }
        self.health.validate()
    }

    /// The deceleration braking is counted at on `robot`.
    pub fn deceleration(&self, robot: &RobotParams) -> f64 {
        self.deceleration_m_s2.unwrap_or(robot.accel_m_s2)
    }

    /// The free path the robot needs to stop from `v` m/s: reaction, braking and the margin.
    pub fn stopping_distance(&self, robot: &RobotParams, v: f64) -> f64 {
        let a = self.deceleration(robot);
        v * (self.latency_s + self.period_s) + v * v / (2.0 * a) + self.stop_margin_m
    }

    /// Why these parameters cannot guard `robot`, if they cannot: braking counted harder than
    /// the robot brakes, or zones that cannot stop it from its top speed within what its
    /// sensors see ahead. `robot_keys` names where the robot's own figures come from.
    pub fn check_against(&self, robot: &RobotParams, robot_keys: &str) -> Result<(), Invalid> {
        self.validate()?;
        if !self.enabled {
            return Ok(());
        }
        let a = self.deceleration(robot);
        if !(a.is_finite() && a > 0.0) {
            return Err(Invalid::new(
                format!("{TABLE}.deceleration_m_s2"),
                format!("the robot describes no deceleration ({robot_keys} gives {a} m/s^2): give one"),
            ));
        }
        if a > robot.accel_m_s2 {
            return Err(Invalid::new(
                format!("{TABLE}.deceleration_m_s2"),
                format!(
                    "{a} m/s^2 is more than the robot brakes at ({} m/s^2, {robot_keys}): the monitor \
                     would count on stopping shorter than it can",
                    robot.accel_m_s2
                ),
            ));
        }
        let need = self.stopping_distance(robot, robot.max_v_m_s);
        let sees = [&robot.sonar, &robot.infrared]
            .iter()
            .map(|r| r.mount_radius_m + r.max_range_m - robot.body_radius_m)
            .fold(0.0, f64::max);
        if need > sees {
            return Err(Invalid::new(
                format!("{TABLE}.latency_s"),
                format!(
                    "from the robot's top speed ({} m/s, {robot_keys}) the zones need {need:.2} m to stop \
                     it (with {TABLE}.period_s, {TABLE}.deceleration_m_s2 and {TABLE}.stop_margin_m), more \
                     than its sensors see ahead ({sees:.2} m): shorten the latency or the period, or lower \
                     the top speed",
                    robot.max_v_m_s
                ),
            ));
        }
        Ok(())
    }
}
