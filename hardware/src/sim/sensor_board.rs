//! The simulator's sensor-board operations, synchronously (see
//! [`SensorBoard`](crate::board::SensorBoard) for the asynchronous trait these back).

use super::SimNomad200;
use crate::board::{BoardError, CompassReading};
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{ContactScan, DistanceScan, Ring};
use std::time::Duration;

/// The shortest fire period accepted: 0.1 ms.
const MIN_FIRE_PERIOD: Duration = Duration::from_micros(100);
/// The longest fire period accepted: 10 s.
const MAX_FIRE_PERIOD: Duration = Duration::from_secs(10);

fn period_ns(operation: &'static str, period: Duration) -> Result<u64, BoardError> {
    if (MIN_FIRE_PERIOD..=MAX_FIRE_PERIOD).contains(&period) {
        Ok(u64::try_from(period.as_nanos()).unwrap_or(u64::MAX))
    } else {
        Err(BoardError::InvalidArgument {
            operation,
            reason: format!(
                "period must be between {MIN_FIRE_PERIOD:?} and {MAX_FIRE_PERIOD:?}, got {period:?}"
            ),
        })
    }
}

fn order_error(operation: &'static str) -> impl FnOnce(String) -> BoardError {
    move |problem| BoardError::InvalidArgument { operation, reason: format!("fire order {problem}") }
}

impl SimNomad200 {
    /// Resets the sensor board: configured fire orders and periods, all readings invalid; the
    /// rings and compass next fire one period from now.
    pub fn sensor_init(&mut self) {
        self.sonar.reset(self.now_ns);
        self.infrared.reset(self.now_ns);
        if let Some(laser) = &mut self.laser {
            laser.reset(self.now_ns);
        }
        self.compass.reset(self.now_ns);
    }

    /// Sets the sonar fire order (1 to 16 sensor indices, each 0..16).
    pub fn set_sonar_fire_order(&mut self, order: &[u8]) -> Result<(), BoardError> {
        self.sonar.set_order(order).map_err(order_error("set_sonar_fire_order"))
    }

    /// Sets the time between two sonar transducers firing (0.1 ms to 10 s).
    pub fn set_sonar_fire_period(&mut self, period: Duration) -> Result<(), BoardError> {
        let ns = period_ns("set_sonar_fire_period", period)?;
        self.sonar.set_period(ns, self.now_ns);
        Ok(())
    }

    /// Sets the infrared fire order (1 to 16 sensor indices, each 0..16).
    pub fn set_infrared_fire_order(&mut self, order: &[u8]) -> Result<(), BoardError> {
        self.infrared.set_order(order).map_err(order_error("set_infrared_fire_order"))
    }

    /// Sets the time between two infrared sensors firing (0.1 ms to 10 s).
    pub fn set_infrared_fire_period(&mut self, period: Duration) -> Result<(), BoardError> {
        let ns = period_ns("set_infrared_fire_period", period)?;
        self.infrared.set_period(ns, self.now_ns);
        Ok(())
    }

    /// The latest reading of each sonar transducer (on a laser robot: the laser's far view).
    pub fn sonar(&self) -> DistanceScan {
        match (&self.laser, &self.config.laser) {
            (Some(laser), Some(c)) => {
                laser.view(Ring::Sonar, &c.far.params(self.radius, c.period_s), self.origin)
            }
            _ => self.sonar.scan(self.origin),
        }
    }

    /// The latest reading of each infrared sensor (on a laser robot: the laser's near view).
    pub fn infrared(&self) -> DistanceScan {
        match (&self.laser, &self.config.laser) {
            (Some(laser), Some(c)) => {
                laser.view(Ring::Infrared, &c.near.params(self.radius, c.period_s), self.origin)
            }
            _ => self.infrared.scan(self.origin),
        }
    }

    /// The laser's newest scan, if the robot has a laser: when it was taken and each beam's
    /// reading (`None`: not valid), beams as [`LaserConfig::params`](crate::sim::LaserConfig::params) describes them.
    pub fn laser_scan(&self) -> Option<(Timestamp, &[Option<f64>])> {
        let (t, beams) = self.laser.as_ref()?.last()?;
        Some((Timestamp(self.origin.0.saturating_add(t)), beams))
    }

    /// The bumpers as of the last step.
    pub fn bumpers(&self) -> ContactScan {
        self.bumpers.scan(self.origin)
    }

    /// The latest compass sample.
    pub fn compass(&self) -> CompassReading {
        self.compass.reading(self.origin)
    }
}
