//! The robot server `nomad200`: its services and their communication objects, in SI units.
//!
//! | service | pattern | object |
//! |---|---|---|
//! | [`DISTANCEIR`] | Push timed (40 ms) | [`DistanceScan`] of the infrared ring |
//! | [`DISTANCESON`] | Push timed (64 ms) | [`DistanceScan`] of the sonar ring |
//! | [`BUMPERS`] | Push timed (30 ms) | [`ContactScan`] |
//! | [`BASESTATE`] | Push timed (100 ms) | [`BaseState`] (odometry) |
//! | [`CONTACT`] | Event, while a bumper is pressed | [`Empty`] -> [`ContactScan`] |
//! | [`NAVIGATIONVELOCITY`] | Send | [`NavigationVelocity`] from the wired behaviour |
//! | [`TELEOP`] | Send | [`NavigationVelocity`] from teleoperation, which takes priority |
//! | [`ROBOTPARAMS`] | Query | [`Empty`] -> [`RobotParams`], so no behaviour hard-codes the robot |
//! | [`SAFETY`] | Query | [`Empty`] -> [`SafetyCounters`], what the server did with commands |
//! | [`HEALTH`](crate::health::HEALTH) | Push newest, on change and every second | [`Health`](crate::health::Health) of every sensor |
//! | [`HEALTH_CHANGES`](crate::health::HEALTH_CHANGES) | Event, on change | [`Empty`] -> [`Health`](crate::health::Health) |
//!
//! The component is called [`NAME`] in the default configuration; a system may host it under
//! another name, so clients address it as `DISTANCEIR.on(robot_name)`.
//!
//! Sensor ring layout, for sonar and infrared alike: sensor `i` faces
//! `i x 22.5` degrees counter-clockwise from the turret's front (0 front, 4 left, 8 back,
//! 12 right); see [`ring_angle_rad`]. Sensors sit on the body's edge and report the distance from
//! the body's edge (the sensor face). Bumpers are fixed to the base, which on a synchro-drive
//! robot never rotates: their angles are relative to the base's orientation at start-up.

use crate::range::{DriveKind, RangeSensorParams};
use orsa_actors::service::{EventService, PushTimedService, QueryService, SendService};
use orsa_actors::{Empty, Timestamp, comm_object};
use serde::{Deserialize, Serialize};

/// The robot server's name in the default configuration.
pub const NAME: &str = "nomad200";

/// The infrared ring, pushed every 40 ms by default.
pub const DISTANCEIR: PushTimedService<DistanceScan> = PushTimedService::new("distanceir");
/// The sonar ring, pushed every 64 ms by default.
pub const DISTANCESON: PushTimedService<DistanceScan> = PushTimedService::new("distanceson");
/// The bumper ring, pushed every 30 ms by default.
pub const BUMPERS: PushTimedService<ContactScan> = PushTimedService::new("bumpers");
/// Odometry and motion state, pushed every 100 ms by default.
pub const BASESTATE: PushTimedService<BaseState> = PushTimedService::new("basestate");
/// Fires to every activation while a bumper is pressed.
pub const CONTACT: EventService<Empty, ContactScan> = EventService::new("contact");
/// Velocity commands from the behaviour the master wired to the motors.
pub const NAVIGATIONVELOCITY: SendService<NavigationVelocity> = SendService::new("navigationvelocity");
/// Velocity commands from teleoperation: they take priority over `navigationvelocity` while
/// they keep coming.
pub const TELEOP: SendService<NavigationVelocity> = SendService::new("teleop");
/// The robot's geometry, limits, sensor layout and push periods.
pub const ROBOTPARAMS: QueryService<Empty, RobotParams> = QueryService::new("robotparams");
/// What the server did with velocity commands.
pub const SAFETY: QueryService<Empty, SafetyCounters> = QueryService::new("safety");

/// Sensors per ring (sonar and infrared).
pub const RING_SIZE: usize = 16;

/// Bumpers: two rings of ten.
pub const BUMPER_COUNT: usize = 20;

/// The direction of ring sensor `i`, radians counter-clockwise from the turret's front.
pub fn ring_angle_rad(i: usize) -> f64 {
    (i as f64 * 22.5).to_radians()
}

/// The centre of bumper `i`'s sector, radians counter-clockwise from the base's front.
///
/// Bumpers 0-9 form the lower ring, one every 36 degrees from the front; 10-19 the upper ring,
/// staggered by 18 degrees so that the two rings together resolve a contact to 18 degrees.
pub fn bumper_angle_rad(i: usize) -> f64 {
    let ring_offset = if i >= BUMPER_COUNT / 2 { 18.0 } else { 0.0 };
    ((i % (BUMPER_COUNT / 2)) as f64 * 36.0 + ring_offset).to_radians()
}

/// Which sensor ring a scan comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ring {
    /// The 16 ultrasonic transducers.
    Sonar,
    /// The 16 infrared proximity sensors.
    Infrared,
}

/// One sensor's latest reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DistanceReading {
    /// Which sensor, 0..16 (see [`ring_angle_rad`]).
    pub sensor_id: u8,
    /// When it fired.
    pub stamp: Timestamp,
    /// Whether `distance_m` means anything: false if nothing was seen within the sensor's
    /// range, if the echo was too close, or if the sensor has not fired yet.
    pub valid: bool,
    /// Distance from the sensor face to the nearest surface in its beam, m. When not `valid`,
    /// it is the range limit that was exceeded (or 0 if the sensor has not fired).
    pub distance_m: f64,
}

/// The latest reading of every sensor of a ring.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
pub struct DistanceScan {
    /// The newest reading's stamp (each reading has its own).
    pub stamp: Timestamp,
    /// Which ring.
    pub ring: Ring,
    /// One reading per sensor, indexed by `sensor_id`.
    pub readings: Vec<DistanceReading>,
}
comm_object!(DistanceScan, "orsa.nomad200.DistanceScan/1");

impl Clone for DistanceScan {
    fn clone(&self) -> Self {
        DistanceScan { stamp: self.stamp, ring: self.ring, readings: self.readings.clone() }
    }

    /// Reuses `self`'s buffer of readings (a derived `Clone` would allocate a new one).
    fn clone_from(&mut self, source: &Self) {
        self.stamp = source.stamp;
        self.ring = source.ring;
        self.readings.clone_from(&source.readings);
    }
}

impl DistanceScan {
    /// Sensor `id`'s distance, if its reading is valid.
    pub fn valid_distance_m(&self, id: usize) -> Option<f64> {
        self.readings.get(id).filter(|r| r.valid).map(|r| r.distance_m)
    }
}

/// The bumper ring's contact state.
#[derive(Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContactScan {
    /// When it was read.
    pub stamp: Timestamp,
    /// Whether bumper `i` is pressed (see [`bumper_angle_rad`]).
    pub pressed: Vec<bool>,
}
comm_object!(ContactScan, "orsa.nomad200.ContactScan/1");

impl Clone for ContactScan {
    fn clone(&self) -> Self {
        ContactScan { stamp: self.stamp, pressed: self.pressed.clone() }
    }

    /// Reuses `self`'s buffer (a derived `Clone` would allocate a new one).
    fn clone_from(&mut self, source: &Self) {
        self.stamp = source.stamp;
        self.pressed.clone_from(&source.pressed);
    }
}

impl ContactScan {
    /// Whether any bumper is pressed.
    pub fn any(&self) -> bool {
        self.pressed.iter().any(|&p| p)
    }
}

/// The base's odometry and motion state, as its encoders (and compass) tell it.
///
/// The pose is in the odometry frame: the origin and heading zero are where the axes were
/// last zeroed. It drifts from the truth; nothing here is ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BaseState {
    /// When it was read.
    pub stamp: Timestamp,
    /// Odometry x, m.
    pub x_m: f64,
    /// Odometry y, m.
    pub y_m: f64,
    /// Odometry heading (the direction of travel), radians in (-pi, pi].
    pub heading_rad: f64,
    /// Translation velocity (encoder), m/s.
    pub v_m_s: f64,
    /// Steering (heading) rate (encoder), rad/s.
    pub omega_rad_s: f64,
    /// Steering encoder angle, radians in (-pi, pi].
    pub steer_rad: f64,
    /// Turret encoder angle, radians in (-pi, pi].
    pub turret_rad: f64,
    /// Turret rate (encoder), rad/s.
    pub turret_omega_rad_s: f64,
    /// Compass heading of the turret, radians counter-clockwise from the world's +x, in
    /// (-pi, pi].
    pub compass_rad: f64,
    /// Whether `compass_rad` holds a reading.
    pub compass_valid: bool,
}
comm_object!(BaseState, "orsa.nomad200.BaseState/1");

/// A velocity command for the base: translate at `v_m_s` and turn steering and turret together
/// at `omega_rad_s`, so the sensor rings keep facing the direction of travel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NavigationVelocity {
    /// When the command was made.
    pub stamp: Timestamp,
    /// Translation velocity, m/s (negative backs up).
    pub v_m_s: f64,
    /// Turn rate, rad/s, counter-clockwise positive.
    pub omega_rad_s: f64,
}
comm_object!(NavigationVelocity, "orsa.nomad200.NavigationVelocity/1");

/// One sensor ring as behaviours need to know it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RingParams {
    /// Sensor `i` faces `angles_rad[i]` counter-clockwise from the turret's front.
    pub angles_rad: Vec<f64>,
    /// Distance from the body's centre to each sensor face, m.
    pub mount_radius_m: f64,
    /// Full width of each sensor's beam, rad.
    pub beam_width_rad: f64,
    /// Shortest valid reading, m.
    pub min_range_m: f64,
    /// Longest valid reading, m.
    pub max_range_m: f64,
    /// Time between two sensors firing, s (a full ring takes 16 times this).
    pub fire_period_s: f64,
}

/// How often the `nomad200` component pushes each service, s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PushPeriods {
    /// `distanceir`.
    pub distanceir_s: f64,
    /// `distanceson`.
    pub distanceson_s: f64,
    /// `bumpers`.
    pub bumpers_s: f64,
    /// `basestate`.
    pub basestate_s: f64,
}

impl Default for PushPeriods {
    /// 40 ms, 64 ms, 30 ms and 100 ms, as the original server pushed them.
    fn default() -> Self {
        PushPeriods { distanceir_s: 0.040, distanceson_s: 0.064, bumpers_s: 0.030, basestate_s: 0.100 }
    }
}

/// Everything a behaviour needs to know about the robot: geometry, limits, sensor layout and
/// how often data arrives.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotParams {
    /// The body's radius, m.
    pub body_radius_m: f64,
    /// Translation velocity limit, m/s.
    pub max_v_m_s: f64,
    /// Steering rate limit, rad/s.
    pub max_omega_rad_s: f64,
    /// Turret rate limit, rad/s.
    pub max_turret_omega_rad_s: f64,
    /// Translation acceleration, m/s^2.
    pub accel_m_s2: f64,
    /// Steering acceleration, rad/s^2.
    pub steer_accel_rad_s2: f64,
    /// Turret acceleration, rad/s^2.
    pub turret_accel_rad_s2: f64,
    /// The sonar ring.
    pub sonar: RingParams,
    /// The infrared ring.
    pub infrared: RingParams,
    /// Bumper `i`'s sector centre, rad counter-clockwise from the base's front.
    pub bumper_angles_rad: Vec<f64>,
    /// Odometry position resolution, m.
    pub odometry_resolution_m: f64,
    /// Odometry angle resolution, rad.
    pub odometry_resolution_rad: f64,
    /// Push periods of the component's services.
    pub push: PushPeriods,
    /// How the base moves (absent in objects from before robots were described: synchro).
    #[serde(default)]
    pub drive: DriveKind,
    /// Every range sensor the robot carries, as it is (a ring, a planar laser): what a map or a
    /// localizer reads. `sonar` and `infrared` above are the two sector views the behaviours
    /// read, the rings themselves on a Nomad 200, projections of these sensors on other robots.
    #[serde(default)]
    pub range_sensors: Vec<RangeSensorParams>,
}
comm_object!(RobotParams, "orsa.nomad200.RobotParams/1");

/// What the safety monitor under the robot server did (see `orsa_hardware::safety`): how
/// often and how long it limited or stopped the robot, by reason, and the distance that cost.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MonitorCounters {
    /// Times it began to limit a command that was running free.
    pub interventions: u64,
    /// Time a command in force was limited, s.
    pub limited_s: f64,
    /// Of that, time the robot was held from translating at all, s.
    pub stopped_s: f64,
    /// Time limited by something in the stop zone, s.
    pub obstacle_s: f64,
    /// Time limited by something in the slowdown zone, s.
    pub slowdown_s: f64,
    /// Time limited because no healthy sensor saw the direction of travel, s.
    pub blind_s: f64,
    /// Time held by a pressed bumper on the side of travel, s.
    pub contact_s: f64,
    /// Time capped because a sensor was judged unhealthy (`orsa_interfaces::health`), s.
    #[serde(default)]
    pub unhealthy_s: f64,
    /// Distance the commands asked for and the monitor did not let through, m.
    pub distance_lost_m: f64,
}

/// What the server did with velocity commands (service `safety`, for reports and tests).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SafetyCounters {
    /// Commands applied to the motors.
    pub applied: u64,
    /// Commands refused because they were older than the timeout on arrival, or older than the
    /// last command applied.
    pub stale_refused: u64,
    /// Commands refused because they were stamped in the future.
    pub future_refused: u64,
    /// Times the watchdog stopped the robot for lack of fresh commands.
    pub timeouts: u64,
    /// Commands whose values were clamped to the robot's limits.
    pub clamped: u64,
    /// Commands the motor board refused (not finite, board gone).
    pub failed: u64,
    /// `navigationvelocity` commands ignored because teleoperation held the robot.
    #[serde(default)]
    pub overridden: u64,
    /// Commands older than the timeout when the motor board took them (checked after the
    /// board answered, apart from the refusal on arrival: a slow board would show here).
    #[serde(default)]
    pub stale_applied: u64,
    /// What the safety monitor under the motors did (`None`: the robot has none, or it is off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub monitor: Option<MonitorCounters>,
    /// How the robot judged its sensors (`None`: it does not judge them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub health: Option<crate::health::HealthCounters>,
}
comm_object!(SafetyCounters, "orsa.nomad200.SafetyCounters/1");

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_actors::CommObject;

    fn round_trip<T: CommObject + PartialEq>(v: T) {
        let json = serde_json::to_string(&v).expect("serialise");
        let back: T = serde_json::from_str(&json).expect("deserialise");
        assert_eq!(v, back, "{} did not survive a round trip", T::ID);
    }

    fn ring() -> RingParams {
        RingParams {
            angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
            mount_radius_m: 0.25,
            beam_width_rad: 25f64.to_radians(),
            min_range_m: 0.3,
            max_range_m: 6.0,
            fire_period_s: 0.004,
        }
    }

    /// `clone_from` gives an equal scan in the buffer the target already had.
    #[test]
    fn scans_clone_into_the_buffer_they_have() {
        let reading = |i: u8, d: f64| DistanceReading {
            sensor_id: i,
            stamp: Timestamp(7),
            valid: i != 3,
            distance_m: d,
        };
        let mut last = DistanceScan {
            stamp: Timestamp(1),
            ring: Ring::Sonar,
            readings: (0..16).map(|i| reading(i, 1.0)).collect(),
        };
        let next = DistanceScan {
            stamp: Timestamp(2),
            ring: Ring::Infrared,
            readings: (0..16).map(|i| reading(i, 0.5)).collect(),
        };
        let buffer = last.readings.as_ptr();
        last.clone_from(&next);
        assert_eq!(last, next);
        assert_eq!(last.readings.as_ptr(), buffer);
        let mut pressed = ContactScan { stamp: Timestamp(1), pressed: vec![false; 20] };
        let contact = ContactScan { stamp: Timestamp(2), pressed: (0..20).map(|i| i == 4).collect() };
        let buffer = pressed.pressed.as_ptr();
        pressed.clone_from(&contact);
        assert_eq!(pressed, contact);
        assert_eq!(pressed.pressed.as_ptr(), buffer);
    }

    #[test]
    fn every_object_round_trips() {
        let reading = |i: u8| DistanceReading {
            sensor_id: i,
            stamp: Timestamp(4_000_000 * u64::from(i)),
            valid: !i.is_multiple_of(3),
            distance_m: 0.1 * f64::from(i) + 1e-9,
        };
        round_trip(DistanceScan {
            stamp: Timestamp(64_000_000),
            ring: Ring::Sonar,
            readings: (0..16).map(reading).collect(),
        });
        round_trip(ContactScan { stamp: Timestamp(30), pressed: (0..20).map(|i| i == 7).collect() });
        round_trip(BaseState {
            stamp: Timestamp(100),
            x_m: 1.0025,
            y_m: -0.5,
            heading_rad: 0.1,
            v_m_s: 0.25,
            omega_rad_s: -0.2,
            steer_rad: 0.1,
            turret_rad: 0.2,
            turret_omega_rad_s: -0.2,
            compass_rad: 3.0,
            compass_valid: true,
        });
        round_trip(NavigationVelocity { stamp: Timestamp(1), v_m_s: 0.25, omega_rad_s: 0.1 });
        round_trip(RobotParams {
            body_radius_m: 0.25,
            max_v_m_s: 0.5,
            max_omega_rad_s: 45f64.to_radians(),
            max_turret_omega_rad_s: 45f64.to_radians(),
            accel_m_s2: 0.5,
            steer_accel_rad_s2: 90f64.to_radians(),
            turret_accel_rad_s2: 90f64.to_radians(),
            sonar: ring(),
            infrared: RingParams { max_range_m: 0.6, ..ring() },
            bumper_angles_rad: (0..BUMPER_COUNT).map(bumper_angle_rad).collect(),
            odometry_resolution_m: 0.0025,
            odometry_resolution_rad: 0.1f64.to_radians(),
            push: PushPeriods::default(),
            drive: DriveKind::Differential,
            range_sensors: vec![
                RangeSensorParams::ring("sonar", &ring()),
                RangeSensorParams::laser("laser", 0.1, 4.7, 271, (0.05, 10.0), 0.1),
            ],
        });
    }

    #[test]
    fn ring_layout_is_counter_clockwise_from_the_front() {
        assert_eq!(ring_angle_rad(0), 0.0);
        assert!((ring_angle_rad(4) - std::f64::consts::FRAC_PI_2).abs() < 1e-15, "4 is left");
        assert!((ring_angle_rad(8) - std::f64::consts::PI).abs() < 1e-15, "8 is back");
        assert!((ring_angle_rad(12) - 1.5 * std::f64::consts::PI).abs() < 1e-15, "12 is right");
    }

    #[test]
    fn bumper_rings_are_staggered() {
        assert_eq!(bumper_angle_rad(0), 0.0);
        assert!((bumper_angle_rad(1).to_degrees() - 36.0).abs() < 1e-12);
        assert!((bumper_angle_rad(10).to_degrees() - 18.0).abs() < 1e-12);
        assert!((bumper_angle_rad(19).to_degrees() - 342.0).abs() < 1e-12);
    }

    #[test]
    fn valid_distance_ignores_invalid_readings() {
        let scan = DistanceScan {
            stamp: Timestamp(2),
            ring: Ring::Infrared,
            readings: vec![
                DistanceReading { sensor_id: 0, stamp: Timestamp(1), valid: true, distance_m: 0.4 },
                DistanceReading { sensor_id: 1, stamp: Timestamp(2), valid: false, distance_m: 0.6 },
            ],
        };
        assert_eq!(scan.valid_distance_m(0), Some(0.4));
        assert_eq!(scan.valid_distance_m(1), None);
        assert_eq!(scan.valid_distance_m(2), None);
    }
}
