//! Sensor health: how the robot judges each of its sensors, live, and what it tells about it.
//!
//! | service | pattern | object |
//! |---|---|---|
//! | [`HEALTH`] | Push newest, on every change and every second | [`Health`] of every sensor |
//! | [`HEALTH_CHANGES`] | Event, on every change | [`Empty`] -> [`Health`] |
//!
//! Both are services of the robot server (`HEALTH.on(robot_name)`). The sensors are named as
//! fault plans name them: `infrared` (the near view, `distanceir`), `sonar` (the far view,
//! `distanceson`) and `bumpers`. A sensor judged anything but [`Verdict::Healthy`] is not
//! trusted: the safety monitor under the motors caps the speed while it is not, and behaviours
//! that read it slow and stop.

use orsa_actors::service::{EventService, PushNewestService};
use orsa_actors::{Empty, Timestamp, comm_object};
use serde::{Deserialize, Serialize};

/// The health of every sensor, pushed whenever a verdict changes and once a second otherwise
/// (a subscriber that comes late has it within a second).
pub const HEALTH: PushNewestService<Health> = PushNewestService::new("health");
/// Fires to every activation whenever a verdict changes.
pub const HEALTH_CHANGES: EventService<Empty, Health> = EventService::new("healthchanges");

/// The sensors judged, in the order [`Health::sensors`] lists them.
pub const SENSORS: [&str; 3] = ["infrared", "sonar", "bumpers"];

/// What a sensor is judged to be.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Fresh readings that agree with the robot's motion and the other sensors.
    #[default]
    Healthy,
    /// No fresh reading within a few of its periods.
    Stale,
    /// Readings that do not change while the robot's motion says they must.
    Stuck,
    /// No valid reading where another sensor, or what it saw itself a moment ago, shows
    /// something within its range.
    Dead,
    /// Readings that scatter more than the sensor does.
    Noisy,
}

impl Verdict {
    /// Its name, as reports and the live view show it.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Healthy => "healthy",
            Verdict::Stale => "stale",
            Verdict::Stuck => "stuck",
            Verdict::Dead => "dead",
            Verdict::Noisy => "noisy",
        }
    }
}

/// How one sensor is judged.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorHealth {
    /// The sensor (see [`SENSORS`]).
    pub sensor: String,
    /// Its verdict.
    pub verdict: Verdict,
    /// Since when.
    pub since: Timestamp,
    /// Why, in words (empty when healthy).
    pub why: String,
}

/// The health of every sensor of the robot.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Health {
    /// When it was judged.
    pub stamp: Timestamp,
    /// Each sensor, in the order of [`SENSORS`].
    pub sensors: Vec<SensorHealth>,
}
comm_object!(Health, "orsa.health.Health/1");

impl Health {
    /// The verdict on `sensor` (healthy if it is not judged).
    pub fn verdict(&self, sensor: &str) -> Verdict {
        self.sensors.iter().find(|s| s.sensor == sensor).map_or(Verdict::Healthy, |s| s.verdict)
    }

    /// Whether `sensor` is trusted (judged healthy, or not judged).
    pub fn trusted(&self, sensor: &str) -> bool {
        self.verdict(sensor) == Verdict::Healthy
    }

    /// The sensors not trusted, with their verdicts, as one line (`infrared stuck, sonar dead`).
    pub fn summary(&self) -> String {
        let bad: Vec<String> = self
            .sensors
            .iter()
            .filter(|s| s.verdict != Verdict::Healthy)
            .map(|s| format!("{} {}", s.sensor, s.verdict.name()))
            .collect();
        if bad.is_empty() { "all healthy".into() } else { bad.join(", ") }
    }
}

/// How long one sensor was judged unhealthy over a run, by verdict.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct HealthTimes {
    /// Times it went from healthy to not.
    pub episodes: u64,
    /// Time judged stale, s.
    pub stale_s: f64,
    /// Time judged stuck, s.
    pub stuck_s: f64,
    /// Time judged dead, s.
    pub dead_s: f64,
    /// Time judged noisy, s.
    pub noisy_s: f64,
}

impl HealthTimes {
    /// Time judged anything but healthy, s.
    pub fn unhealthy_s(&self) -> f64 {
        self.stale_s + self.stuck_s + self.dead_s + self.noisy_s
    }
}

/// How every sensor was judged over a run (in the robot's `safety` counters).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct HealthCounters {
    /// The near view.
    pub infrared: HealthTimes,
    /// The far view.
    pub sonar: HealthTimes,
    /// The bumpers.
    pub bumpers: HealthTimes,
}

impl HealthCounters {
    /// The times of `sensor` (see [`SENSORS`]).
    pub fn of(&self, sensor: &str) -> Option<&HealthTimes> {
        match sensor {
            "infrared" => Some(&self.infrared),
            "sonar" => Some(&self.sonar),
            "bumpers" => Some(&self.bumpers),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sensor_not_judged_is_trusted_and_the_summary_names_the_others() {
        let h = Health {
            stamp: Timestamp(5),
            sensors: vec![
                SensorHealth { sensor: "infrared".into(), verdict: Verdict::Stuck, ..Default::default() },
                SensorHealth { sensor: "sonar".into(), verdict: Verdict::Healthy, ..Default::default() },
            ],
        };
        assert!(!h.trusted("infrared"));
        assert!(h.trusted("sonar"));
        assert!(h.trusted("bumpers"));
        assert_eq!(h.summary(), "infrared stuck");
        let json = serde_json::to_string(&h).expect("serialise");
        assert!(json.contains("\"stuck\""), "{json}");
        assert_eq!(serde_json::from_str::<Health>(&json).expect("deserialise"), h);
    }
}
