//! The simulator's configuration: the robot's physical parameters, sensor models and noise.
//!
//! Defaults describe a Nomad 200 as the project uses it; [`SimConfig::noiseless`] turns every
//! noise and drift source off (quantisation stays: it is resolution, not noise). The struct
//! deserialises from TOML with unknown keys rejected, so it can sit in the stack's one
//! configuration file. Angles here are degrees (it is written by people); everything the
//! simulator reports is radians.
//!
//! Missing keys take their defaults, except inside `[sonar]` and `[infrared]`: the two rings
//! share a type but not their defaults, so a ring table that is given must be given whole.

use orsa_interfaces::nomad200::{
    BUMPER_COUNT, PushPeriods, RING_SIZE, RingParams, RobotParams, bumper_angle_rad, ring_angle_rad,
};
use orsa_interfaces::range::{DriveKind, RangeSensorParams};
use serde::{Deserialize, Serialize};

/// A configuration value the simulator cannot use.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("simulator configuration: {key}: {problem}")]
pub struct ConfigError {
    /// The key, like `sonar.fire_period_s`.
    pub key: String,
    /// What is wrong.
    pub problem: String,
}

/// Everything the simulator needs besides the world and the seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// The fixed simulation step, s (default 0.010).
    pub step_s: f64,
    /// The body.
    pub body: BodyConfig,
    /// The synchro drive's axes.
    pub drive: DriveConfig,
    /// The sonar ring.
    #[serde(default = "RingConfig::sonar")]
    pub sonar: RingConfig,
    /// The infrared ring.
    #[serde(default = "RingConfig::infrared")]
    pub infrared: RingConfig,
    /// The bumper ring.
    pub bumpers: BumperConfig,
    /// The compass.
    pub compass: CompassConfig,
    /// Odometry resolution and drift.
    pub odometry: OdometryConfig,
    /// A planar laser (absent on a Nomad 200). A robot with a laser has no sonar or infrared
    /// ring: `sonar` and `infrared` above are then unused, and the laser's sector views
    /// (`laser.near`, `laser.far`) take their place.
    pub laser: Option<LaserConfig>,
}

/// A planar laser scanner, facing forward from a mount point on the body's axis, and the two
/// sector views of its scan that the robot server pushes for the behaviours.
///
/// Each view is 16 sectors on the body's edge, sector `i` facing `i x 22.5` degrees as a ring
/// sensor would: it reads the nearest point of the scan whose bearing from the body's centre
/// lies within half its width, as the distance from the edge. `near` is pushed as `distanceir`
/// (a narrow, short view, like the infrared ring), `far` as `distanceson` (wide and long, like
/// the sonar).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LaserConfig {
    /// The mount point, m ahead of the body's centre (default 0.1).
    pub x_m: f64,
    /// Field of view, deg, centred on the front (default 270).
    pub fov_deg: f64,
    /// Beams, spread evenly over the field of view (default 271: one a degree).
    pub beams: u32,
    /// Shortest valid reading, m (default 0.05).
    pub min_range_m: f64,
    /// Longest valid reading, m (default 10).
    pub max_range_m: f64,
    /// Time between two scans, s (default 0.1: 10 Hz).
    pub period_s: f64,
    /// Standard deviation of each reading's Gaussian noise, m (default 0.01).
    pub noise_sd_m: f64,
    /// The view pushed as `distanceir` (default 6 deg sectors, valid to 0.6 m).
    pub near: SectorViewConfig,
    /// The view pushed as `distanceson` (default 25 deg sectors, valid to 6 m).
    #[serde(default = "SectorViewConfig::far")]
    pub far: SectorViewConfig,
}

/// One sector view of a laser scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectorViewConfig {
    /// Each sector's full width, deg.
    pub beam_width_deg: f64,
    /// Shortest valid reading, m.
    pub min_range_m: f64,
    /// Longest valid reading, m.
    pub max_range_m: f64,
}

impl Default for SectorViewConfig {
    /// The near view: 6 deg sectors, valid up to 0.6 m.
    fn default() -> Self {
        SectorViewConfig { beam_width_deg: 6.0, min_range_m: 0.0, max_range_m: 0.6 }
    }
}

impl SectorViewConfig {
    /// The far view: 25 deg sectors, valid up to 6 m.
    pub fn far() -> Self {
        SectorViewConfig { beam_width_deg: 25.0, min_range_m: 0.0, max_range_m: 6.0 }
    }

    /// The view as behaviours see it, on a body of `radius_m`, refreshed every `period_s`.
    pub fn params(&self, radius_m: f64, period_s: f64) -> RingParams {
        RingParams {
            angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
            mount_radius_m: radius_m,
            beam_width_rad: self.beam_width_deg.to_radians(),
            min_range_m: self.min_range_m,
            max_range_m: self.max_range_m,
            fire_period_s: period_s / RING_SIZE as f64,
        }
    }
}

impl Default for LaserConfig {
    fn default() -> Self {
        LaserConfig {
            x_m: 0.1,
            fov_deg: 270.0,
            beams: 271,
            min_range_m: 0.05,
            max_range_m: 10.0,
            period_s: 0.1,
            noise_sd_m: 0.01,
            near: SectorViewConfig::default(),
            far: SectorViewConfig::far(),
        }
    }
}

impl LaserConfig {
    /// The laser as the layers above know it.
    pub fn params(&self) -> RangeSensorParams {
        RangeSensorParams::laser(
            "laser",
            self.x_m,
            self.fov_deg.to_radians(),
            self.beams as usize,
            (self.min_range_m, self.max_range_m),
            self.period_s,
        )
    }
}

/// The body: a cylinder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BodyConfig {
    /// Radius, m (default 0.25: the body is 0.50 m across).
    pub radius_m: f64,
    /// Gap kept between the body and anything it stops against, m (default 1e-6), so that
    /// rounding never puts the body inside geometry.
    pub motion_margin_m: f64,
}

/// The drive's three axes (translate, steer, turret): hardware maxima and default
/// accelerations.
///
/// A `differential` drive moves as the synchro drive does (along its heading, turning at the
/// steering rate), but its sensors are fixed to the body, so the turret axis follows the
/// steering and its own settings are unused; and its two wheels share one speed limit: a
/// command whose wheel speeds `v +- omega x wheel_base_m / 2` exceed `max_translate_m_s` is
/// scaled down as a whole, keeping its curvature.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriveConfig {
    /// `synchro` (default: the Nomad 200) or `differential`.
    pub kind: DriveKind,
    /// Differential drive: the distance between the wheels, m (default 0.5).
    pub wheel_base_m: f64,
    /// Translation velocity limit, m/s (default 0.50).
    pub max_translate_m_s: f64,
    /// Steering rate limit, deg/s (default 45).
    pub max_steer_deg_s: f64,
    /// Turret rate limit, deg/s (default 45, so the turret keeps up with the steering).
    pub max_turret_deg_s: f64,
    /// Translation acceleration at start, m/s^2 (default 0.5).
    pub translate_accel_m_s2: f64,
    /// Steering acceleration at start, deg/s^2 (default 90).
    pub steer_accel_deg_s2: f64,
    /// Turret acceleration at start, deg/s^2 (default 90).
    pub turret_accel_deg_s2: f64,
    /// Highest translation acceleration the board accepts, m/s^2 (default 1.0).
    pub max_translate_accel_m_s2: f64,
    /// Highest steering acceleration the board accepts, deg/s^2 (default 180).
    pub max_steer_accel_deg_s2: f64,
    /// Highest turret acceleration the board accepts, deg/s^2 (default 180).
    pub max_turret_accel_deg_s2: f64,
}

/// A ring of 16 range sensors: beam, range, noise and firing.
///
/// A reading is the distance from the sensor face to the nearest surface met by any of `rays`
/// rays spread evenly across the beam, plus Gaussian noise with standard deviation
/// `noise_sd_m + noise_fraction x distance`. It is valid when something was met within
/// `max_range_m` and the noisy distance lies in `[min_range_m, max_range_m]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RingConfig {
    /// Full beam width, deg.
    pub beam_width_deg: f64,
    /// Rays cast across the beam (1 casts only the axis).
    pub rays: u32,
    /// Shortest valid reading, m.
    pub min_range_m: f64,
    /// Longest valid reading, m.
    pub max_range_m: f64,
    /// Constant part of the noise's standard deviation, m.
    pub noise_sd_m: f64,
    /// Part of the noise's standard deviation proportional to the distance.
    pub noise_fraction: f64,
    /// Time between two sensors firing, s.
    pub fire_period_s: f64,
    /// Which sensors fire, in order (1 to 16 entries, each 0..16).
    pub fire_order: Vec<u8>,
}

/// The bumper ring.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BumperConfig {
    /// A bumper is pressed while an obstacle is closer than this to the body's edge in its
    /// sector, m (default 0.005).
    pub contact_margin_m: f64,
}

/// The compass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompassConfig {
    /// Standard deviation of its Gaussian noise, deg (default 0.3).
    pub noise_sd_deg: f64,
    /// Time between samples, s (default 0.1).
    pub period_s: f64,
}

/// Odometry: what the encoders count, and how it goes wrong.
///
/// Each step, the motors' own motion (translation `ds`, steering `dθ`) is counted as
/// `ds x (1 + distance_error)` and `dθ x (1 + heading_error) + heading_error_deg_per_m x |ds|`:
/// a scale error on distance, one on turning, and a steady curve per metre travelled (wheels
/// not quite aligned). Reported values are rounded to the resolution.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OdometryConfig {
    /// Position resolution, m (default 0.0025; 0 reports unrounded values).
    pub resolution_m: f64,
    /// Angle resolution, deg (default 0.1; 0 reports unrounded values).
    pub resolution_deg: f64,
    /// Distance scale error, m per m (default 0.005).
    pub distance_error: f64,
    /// Heading scale error, rad per rad turned (default 0.002).
    pub heading_error: f64,
    /// Heading drift per metre travelled, deg/m (default 0.05).
    pub heading_error_deg_per_m: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            step_s: 0.010,
            body: BodyConfig::default(),
            drive: DriveConfig::default(),
            sonar: RingConfig::sonar(),
            infrared: RingConfig::infrared(),
            bumpers: BumperConfig::default(),
            compass: CompassConfig::default(),
            odometry: OdometryConfig::default(),
            laser: None,
        }
    }
}

impl Default for BodyConfig {
    fn default() -> Self {
        BodyConfig { radius_m: 0.25, motion_margin_m: 1e-6 }
    }
}

impl Default for DriveConfig {
    fn default() -> Self {
        DriveConfig {
            kind: DriveKind::Synchro,
            wheel_base_m: 0.5,
            max_translate_m_s: 0.50,
            max_steer_deg_s: 45.0,
            max_turret_deg_s: 45.0,
            translate_accel_m_s2: 0.5,
            steer_accel_deg_s2: 90.0,
            turret_accel_deg_s2: 90.0,
            max_translate_accel_m_s2: 1.0,
            max_steer_accel_deg_s2: 180.0,
            max_turret_accel_deg_s2: 180.0,
        }
    }
}

impl RingConfig {
    /// The sonar ring: 25 deg beam (9 rays), valid 0.30 to 6.00 m, 1 % noise, one transducer
    /// every 4 ms (a full ring every 64 ms), in index order.
    pub fn sonar() -> Self {
        RingConfig {
            beam_width_deg: 25.0,
            rays: 9,
            min_range_m: 0.30,
            max_range_m: 6.00,
            noise_sd_m: 0.0,
            noise_fraction: 0.01,
            fire_period_s: 0.004,
            fire_order: (0..RING_SIZE as u8).collect(),
        }
    }

    /// The infrared ring: a narrow 6 deg beam (3 rays), valid up to 0.60 m, noise 5 mm + 2 %
    /// of the distance, one sensor every 2.5 ms (a full ring every 40 ms), in index order.
    pub fn infrared() -> Self {
        RingConfig {
            beam_width_deg: 6.0,
            rays: 3,
            min_range_m: 0.0,
            max_range_m: 0.60,
            noise_sd_m: 0.005,
            noise_fraction: 0.02,
            fire_period_s: 0.0025,
            fire_order: (0..RING_SIZE as u8).collect(),
        }
    }

    fn without_noise(self) -> Self {
        RingConfig { noise_sd_m: 0.0, noise_fraction: 0.0, ..self }
    }

    /// The ring as behaviours see it.
    pub fn params(&self, mount_radius_m: f64) -> RingParams {
        RingParams {
            angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
            mount_radius_m,
            beam_width_rad: self.beam_width_deg.to_radians(),
            min_range_m: self.min_range_m,
            max_range_m: self.max_range_m,
            fire_period_s: self.fire_period_s,
        }
    }
}

impl Default for BumperConfig {
    fn default() -> Self {
        BumperConfig { contact_margin_m: 0.005 }
    }
}

impl Default for CompassConfig {
    fn default() -> Self {
        CompassConfig { noise_sd_deg: 0.3, period_s: 0.1 }
    }
}

impl Default for OdometryConfig {
    fn default() -> Self {
        OdometryConfig {
            resolution_m: 0.0025,
            resolution_deg: 0.1,
            distance_error: 0.005,
            heading_error: 0.002,
            heading_error_deg_per_m: 0.05,
        }
    }
}

/// Whole nanoseconds in `s` seconds (for periods already checked to be sane).
pub(crate) fn nanos(s: f64) -> u64 {
    (s * 1e9).round() as u64
}

struct Checker(Result<(), ConfigError>);

impl Checker {
    fn rule(&mut self, ok: bool, key: &str, value: impl std::fmt::Display, rule: &str) {
        if self.0.is_ok() && !ok {
            self.0 = Err(ConfigError { key: key.to_owned(), problem: format!("{rule}, got {value}") });
        }
    }

    fn range(&mut self, key: &str, v: f64, lo: f64, hi: f64, rule: &str) {
        self.rule(v.is_finite() && v >= lo && v <= hi, key, v, rule);
    }

    fn positive(&mut self, key: &str, v: f64) {
        self.rule(v.is_finite() && v > 0.0, key, v, "must be a finite number > 0");
    }
}

impl SimConfig {
    /// The defaults with every noise and drift source off: sensors read the exact geometry,
    /// the compass the exact heading, odometry only rounds.
    pub fn noiseless() -> Self {
        let d = SimConfig::default();
        SimConfig {
            sonar: d.sonar.clone().without_noise(),
            infrared: d.infrared.clone().without_noise(),
            compass: CompassConfig { noise_sd_deg: 0.0, ..d.compass.clone() },
            odometry: OdometryConfig {
                distance_error: 0.0,
                heading_error: 0.0,
                heading_error_deg_per_m: 0.0,
                ..d.odometry.clone()
            },
            ..d
        }
    }

    /// Checks every value; the first one out of range is the error.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let mut c = Checker(Ok(()));
        c.range("step_s", self.step_s, 1e-5, 1.0, "must be between 1e-5 and 1 s");
        c.positive("body.radius_m", self.body.radius_m);
        let margin_max = self.body.radius_m * 0.01;
        c.rule(
            self.body.motion_margin_m.is_finite()
                && self.body.motion_margin_m > 0.0
                && self.body.motion_margin_m <= margin_max,
            "body.motion_margin_m",
            self.body.motion_margin_m,
            "must be > 0 and at most 1 % of the radius",
        );
        let d = &self.drive;
        for (key, v) in [
            ("drive.max_translate_m_s", d.max_translate_m_s),
            ("drive.max_steer_deg_s", d.max_steer_deg_s),
            ("drive.max_turret_deg_s", d.max_turret_deg_s),
            ("drive.max_translate_accel_m_s2", d.max_translate_accel_m_s2),
            ("drive.max_steer_accel_deg_s2", d.max_steer_accel_deg_s2),
            ("drive.max_turret_accel_deg_s2", d.max_turret_accel_deg_s2),
        ] {
            c.positive(key, v);
        }
        let below = "must be > 0 and at most the matching max_*_accel";
        c.range(
            "drive.translate_accel_m_s2",
            d.translate_accel_m_s2,
            f64::MIN_POSITIVE,
            d.max_translate_accel_m_s2,
            below,
        );
        c.range(
            "drive.steer_accel_deg_s2",
            d.steer_accel_deg_s2,
            f64::MIN_POSITIVE,
            d.max_steer_accel_deg_s2,
            below,
        );
        c.range(
            "drive.turret_accel_deg_s2",
            d.turret_accel_deg_s2,
            f64::MIN_POSITIVE,
            d.max_turret_accel_deg_s2,
            below,
        );
        for (name, ring) in [("sonar", &self.sonar), ("infrared", &self.infrared)] {
            let key = |k: &str| format!("{name}.{k}");
            c.range(&key("beam_width_deg"), ring.beam_width_deg, 0.0, 179.0, "must be between 0 and 179 deg");
            c.rule((1..=64).contains(&ring.rays), &key("rays"), ring.rays, "must be between 1 and 64");
            c.range(&key("min_range_m"), ring.min_range_m, 0.0, f64::MAX, "must be a finite number >= 0");
            c.rule(
                ring.max_range_m.is_finite() && ring.max_range_m > ring.min_range_m,
                &key("max_range_m"),
                ring.max_range_m,
                "must be finite and greater than min_range_m",
            );
            c.range(&key("noise_sd_m"), ring.noise_sd_m, 0.0, f64::MAX, "must be a finite number >= 0");
            c.range(&key("noise_fraction"), ring.noise_fraction, 0.0, 1.0, "must be between 0 and 1");
            c.range(&key("fire_period_s"), ring.fire_period_s, 1e-4, 10.0, "must be between 1e-4 and 10 s");
            c.rule(
                check_fire_order(&ring.fire_order).is_ok(),
                &key("fire_order"),
                format!("{:?}", ring.fire_order),
                &check_fire_order(&ring.fire_order).err().unwrap_or_default(),
            );
        }
        c.range(
            "drive.wheel_base_m",
            d.wheel_base_m,
            f64::MIN_POSITIVE,
            10.0,
            "must be > 0 and at most 10 m",
        );
        if let Some(l) = &self.laser {
            c.range(
                "laser.x_m",
                l.x_m,
                -self.body.radius_m,
                self.body.radius_m,
                "must lie within the body's radius",
            );
            c.range("laser.fov_deg", l.fov_deg, 0.0, 360.0, "must be between 0 and 360 deg");
            c.rule((1..=4096).contains(&l.beams), "laser.beams", l.beams, "must be between 1 and 4096");
            c.range("laser.min_range_m", l.min_range_m, 0.0, f64::MAX, "must be a finite number >= 0");
            c.rule(
                l.max_range_m.is_finite() && l.max_range_m > l.min_range_m,
                "laser.max_range_m",
                l.max_range_m,
                "must be finite and greater than min_range_m",
            );
            c.range("laser.period_s", l.period_s, 1e-3, 10.0, "must be between 1e-3 and 10 s");
            c.range("laser.noise_sd_m", l.noise_sd_m, 0.0, f64::MAX, "must be a finite number >= 0");
            for (name, v) in [("near", &l.near), ("far", &l.far)] {
                let key = |k: &str| format!("laser.{name}.{k}");
                c.range(
                    &key("beam_width_deg"),
                    v.beam_width_deg,
                    0.0,
                    180.0,
                    "must be between 0 and 180 deg",
                );
                c.range(&key("min_range_m"), v.min_range_m, 0.0, f64::MAX, "must be a finite number >= 0");
                c.rule(
                    v.max_range_m.is_finite() && v.max_range_m > v.min_range_m,
                    &key("max_range_m"),
                    v.max_range_m,
                    "must be finite and greater than min_range_m",
                );
            }
        }
        c.range(
            "bumpers.contact_margin_m",
            self.bumpers.contact_margin_m,
            f64::MIN_POSITIVE,
            0.05,
            "must be > 0 and at most 0.05 m",
        );
        c.range(
            "compass.noise_sd_deg",
            self.compass.noise_sd_deg,
            0.0,
            180.0,
            "must be between 0 and 180 deg",
        );
        c.range("compass.period_s", self.compass.period_s, 1e-4, 10.0, "must be between 1e-4 and 10 s");
        let o = &self.odometry;
        c.range("odometry.resolution_m", o.resolution_m, 0.0, 1.0, "must be between 0 and 1 m");
        c.range("odometry.resolution_deg", o.resolution_deg, 0.0, 10.0, "must be between 0 and 10 deg");
        c.range("odometry.distance_error", o.distance_error, -0.5, 0.5, "must be between -0.5 and 0.5");
        c.range("odometry.heading_error", o.heading_error, -0.5, 0.5, "must be between -0.5 and 0.5");
        c.range(
            "odometry.heading_error_deg_per_m",
            o.heading_error_deg_per_m,
            -90.0,
            90.0,
            "must be between -90 and 90 deg/m",
        );
        c.0
    }

    /// The robot as behaviours should know it, with the component's push periods.
    pub fn robot_params(&self, push: PushPeriods) -> RobotParams {
        let d = &self.drive;
        let r = self.body.radius_m;
        let (sonar, infrared, range_sensors) = match &self.laser {
            Some(l) => (l.far.params(r, l.period_s), l.near.params(r, l.period_s), vec![l.params()]),
            None => {
                let (sonar, infrared) = (self.sonar.params(r), self.infrared.params(r));
                let sensors = vec![
                    RangeSensorParams::ring("sonar", &sonar),
                    RangeSensorParams::ring("infrared", &infrared),
                ];
                (sonar, infrared, sensors)
            }
        };
        let turret = match d.kind {
            DriveKind::Synchro => d.max_turret_deg_s,
            DriveKind::Differential => d.max_steer_deg_s,
        };
        RobotParams {
            body_radius_m: self.body.radius_m,
            max_v_m_s: d.max_translate_m_s,
            max_omega_rad_s: d.max_steer_deg_s.to_radians(),
            max_turret_omega_rad_s: turret.to_radians(),
            accel_m_s2: d.translate_accel_m_s2,
            steer_accel_rad_s2: d.steer_accel_deg_s2.to_radians(),
            turret_accel_rad_s2: d.turret_accel_deg_s2.to_radians(),
            sonar: sonar.clone(),
            infrared: infrared.clone(),
            bumper_angles_rad: (0..BUMPER_COUNT).map(bumper_angle_rad).collect(),
            odometry_resolution_m: self.odometry.resolution_m,
            odometry_resolution_rad: self.odometry.resolution_deg.to_radians(),
            push,
            drive: d.kind,
            range_sensors,
        }
    }
}

/// Checks a fire order: 1 to 16 entries, each a sensor index 0..16. The problem, if any.
pub(crate) fn check_fire_order(order: &[u8]) -> Result<(), String> {
    if order.is_empty() || order.len() > RING_SIZE {
        return Err(format!("must list 1 to {RING_SIZE} sensors"));
    }
    if let Some(bad) = order.iter().find(|&&i| usize::from(i) >= RING_SIZE) {
        return Err(format!("sensor {bad} does not exist (sensors are 0 to {})", RING_SIZE - 1));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_match_the_robot() {
        let c = SimConfig::default();
        c.validate().expect("defaults valid");
        SimConfig::noiseless().validate().expect("noiseless valid");
        let p = c.robot_params(PushPeriods::default());
        assert_eq!(p.body_radius_m, 0.25);
        assert_eq!(p.max_v_m_s, 0.5);
        assert!((p.max_omega_rad_s - 45f64.to_radians()).abs() < 1e-15);
        assert_eq!(p.sonar.angles_rad.len(), 16);
        assert_eq!(p.sonar.max_range_m, 6.0);
        assert_eq!(p.infrared.max_range_m, 0.6);
        assert_eq!(p.bumper_angles_rad.len(), 20);
        assert_eq!(nanos(c.sonar.fire_period_s) * 16, 64_000_000, "a full sonar ring in 64 ms");
        assert_eq!(nanos(c.infrared.fire_period_s) * 16, 40_000_000, "a full IR ring in 40 ms");
    }

    #[test]
    fn bad_values_name_their_key() {
        let mut c = SimConfig::default();
        c.sonar.fire_order = vec![0, 16];
        let e = c.validate().expect_err("sensor 16");
        assert_eq!(e.key, "sonar.fire_order");
        assert!(e.problem.contains("sensor 16 does not exist"), "{e}");
        let mut c = SimConfig::default();
        c.drive.translate_accel_m_s2 = 2.0;
        assert_eq!(c.validate().expect_err("accel").key, "drive.translate_accel_m_s2");
        let mut c = SimConfig::default();
        c.infrared.max_range_m = f64::NAN;
        assert_eq!(c.validate().expect_err("nan").key, "infrared.max_range_m");
        let c = SimConfig { step_s: 0.0, ..SimConfig::default() };
        let e = c.validate().expect_err("zero step");
        assert_eq!(e.to_string(), "simulator configuration: step_s: must be between 1e-5 and 1 s, got 0");
    }

    #[test]
    fn toml_keeps_defaults_and_rejects_unknown_keys() {
        let c: SimConfig =
            toml::from_str("step_s = 0.005\n[drive]\nmax_translate_m_s = 0.3\n").expect("parses");
        assert_eq!(c.step_s, 0.005);
        assert_eq!(c.drive.max_translate_m_s, 0.3);
        assert_eq!(c.drive.max_steer_deg_s, 45.0);
        assert_eq!(c.sonar, RingConfig::sonar());
        assert_eq!(c.infrared, RingConfig::infrared());
        assert!(toml::from_str::<SimConfig>("[drive]\nmax_speed = 1.0\n").is_err());
    }
}
