//! The sonar and infrared rings and the compass: when they fire and what they read.
//!
//! A ring fires one sensor at a time, in its fire order, one every fire period, like the real
//! board; the first firing comes one period after start (or after a reset). Firings inside a
//! step see the robot and the movers where they were at that instant (interpolated over the
//! step), and each reading keeps its own stamp. The reading model (beam of rays, noise,
//! validity) is documented on [`RingConfig`]. Every firing draws exactly one noise sample from
//! its ring's own random stream, whatever it saw, so one ring's readings never shift another's
//! noise.

use super::movers::MoverState;
use super::scene::Scene;
use crate::board::CompassReading;
use crate::geometry::{Circle, Point};
use crate::sim::config::{RingConfig, nanos};
use crate::sim::odometry::wrap_angle;
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{DistanceReading, DistanceScan, RING_SIZE, Ring, ring_angle_rad};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The motion of the robot and the movers over one step, for sensors firing inside it.
pub(crate) struct StepMotion<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) radius: f64,
    pub(crate) t0_ns: u64,
    pub(crate) t1_ns: u64,
    pub(crate) p0: Point,
    pub(crate) p1: Point,
    /// Turret angles in the world (unwrapped) at the start and the end of the step.
    pub(crate) turret0: f64,
    pub(crate) turret1: f64,
    pub(crate) movers0: &'a [Point],
    pub(crate) movers1: &'a [MoverState],
}

impl StepMotion<'_> {
    fn alpha(&self, t_ns: u64) -> f64 {
        let span = self.t1_ns.saturating_sub(self.t0_ns);
        if span == 0 { 1.0 } else { t_ns.saturating_sub(self.t0_ns) as f64 / span as f64 }
    }

    /// The turret's world angle at `t_ns`.
    pub(crate) fn turret_at(&self, t_ns: u64) -> f64 {
        let a = self.alpha(t_ns);
        self.turret0 + a * (self.turret1 - self.turret0)
    }

    /// Where the body's centre and the turret's front are at `t_ns`; fills `scratch` with the
    /// movers' circles at that instant.
    pub(crate) fn pose_at(&self, t_ns: u64, scratch: &mut Vec<Circle>) -> (Point, f64) {
        let a = self.alpha(t_ns);
        let lerp = |p0: &Point, p1: &Point| Point::new(p0.x + (p1.x - p0.x) * a, p0.y + (p1.y - p0.y) * a);
        scratch.clear();
        scratch.extend(self.movers0.iter().zip(self.movers1).map(|(p0, m)| {
            let c = m.circle();
            Circle::new(lerp(p0, &c.center), c.radius)
        }));
        (lerp(&self.p0, &self.p1), self.turret_at(t_ns))
    }

    /// What a sensor facing `sensor_angle` from the turret's front sees at `t_ns`: the distance
    /// from its face to the nearest surface met by any ray at `offsets` from its axis, if one is
    /// met within `max`. `scratch` holds the movers' circles at that instant.
    pub(crate) fn range(
        &self,
        t_ns: u64,
        sensor_angle: f64,
        offsets: &[f64],
        max: f64,
        scratch: &mut Vec<Circle>,
    ) -> Option<f64> {
        let (center, turret) = self.pose_at(t_ns, scratch);
        let axis = turret + sensor_angle;
        let (s, c) = axis.sin_cos();
        let face = Point::new(center.x + c * self.radius, center.y + s * self.radius);
        self.scene.ray_fan(scratch, face, axis, offsets, max)
    }
}

/// One sensor's latest reading (never fired: not valid, at time 0).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Stored {
    fired_ns: u64,
    valid: bool,
    distance_m: f64,
}

/// A ring of 16 range sensors firing in turn.
#[derive(Debug, Clone)]
pub(crate) struct RangeRing {
    ring: Ring,
    defaults: RingConfig,
    ray_offsets: Vec<f64>,
    min: f64,
    max: f64,
    sd: f64,
    fraction: f64,
    order: Vec<u8>,
    cursor: usize,
    period_ns: u64,
    next_ns: u64,
    readings: [Stored; RING_SIZE],
    rng: ChaCha8Rng,
}

impl RangeRing {
    /// A ring as configured, reset at `now_ns`. The configuration must be valid.
    pub(crate) fn new(ring: Ring, cfg: &RingConfig, rng: ChaCha8Rng, now_ns: u64) -> Self {
        let n = cfg.rays.max(1);
        let width = cfg.beam_width_deg.to_radians();
        let ray_offsets = if n == 1 {
            vec![0.0]
        } else {
            (0..n).map(|k| -width / 2.0 + width * f64::from(k) / f64::from(n - 1)).collect()
        };
        let mut r = RangeRing {
            ring,
            defaults: cfg.clone(),
            ray_offsets,
            min: cfg.min_range_m,
            max: cfg.max_range_m,
            sd: cfg.noise_sd_m,
            fraction: cfg.noise_fraction,
            order: Vec::new(),
            cursor: 0,
            period_ns: 0,
            next_ns: 0,
            readings: [Stored::default(); RING_SIZE],
            rng,
        };
        r.reset(now_ns);
        r
    }

    /// Back to the configured fire order and period; every reading invalid.
    pub(crate) fn reset(&mut self, now_ns: u64) {
        self.order = self.defaults.fire_order.clone();
        self.cursor = 0;
        self.period_ns = nanos(self.defaults.fire_period_s).max(1);
        self.next_ns = now_ns.saturating_add(self.period_ns);
        self.readings = [Stored::default(); RING_SIZE];
    }

    /// A new fire order (checked), starting from its first sensor at the next firing.
    pub(crate) fn set_order(&mut self, order: &[u8]) -> Result<(), String> {
        super::config::check_fire_order(order)?;
        self.order = order.to_vec();
        self.cursor = 0;
        Ok(())
    }

    /// A new fire period (at least 1 ns); the next firing is one period from `now_ns`.
    pub(crate) fn set_period(&mut self, period_ns: u64, now_ns: u64) {
        self.period_ns = period_ns.max(1);
        self.next_ns = now_ns.saturating_add(self.period_ns);
    }

    /// The next firing, `(time, sensor)`, if it is due by `until_ns`.
    fn due(&self, until_ns: u64) -> Option<(u64, usize)> {
        let sensor = usize::from(*self.order.get(self.cursor)?);
        (self.next_ns <= until_ns).then_some((self.next_ns, sensor))
    }

    /// Records the firing due now, given what its beam met (`None`: nothing within range).
    fn record(&mut self, sensor: usize, at_ns: u64, true_range: Option<f64>) {
        let z: f64 = self.rng.sample(StandardNormal);
        let (valid, distance_m) = match true_range {
            None => (false, self.max),
            Some(d) => {
                let measured = (d + z * (self.sd + self.fraction * d)).max(0.0);
                if measured < self.min {
                    (false, self.min)
                } else if measured > self.max {
                    (false, self.max)
                } else {
                    (true, measured)
                }
            }
        };
        if let Some(slot) = self.readings.get_mut(sensor) {
            *slot = Stored { fired_ns: at_ns, valid, distance_m };
        }
        self.cursor = (self.cursor + 1) % self.order.len().max(1);
        self.next_ns = self.next_ns.saturating_add(self.period_ns);
    }

    /// Fires every sensor due by the end of `motion`'s step.
    pub(crate) fn fire(&mut self, motion: &StepMotion<'_>, scratch: &mut Vec<Circle>) {
        while let Some((t, sensor)) = self.due(motion.t1_ns) {
            let range = motion.range(t, ring_angle_rad(sensor), &self.ray_offsets, self.max, scratch);
            self.record(sensor, t, range);
        }
    }

    /// The latest reading of every sensor, stamped relative to `origin`.
    pub(crate) fn scan(&self, origin: Timestamp) -> DistanceScan {
        let stamp = |ns: u64| Timestamp(origin.0.saturating_add(ns));
        let readings: Vec<DistanceReading> = self
            .readings
            .iter()
            .enumerate()
            .map(|(i, r)| DistanceReading {
                sensor_id: i as u8,
                stamp: stamp(r.fired_ns),
                valid: r.valid,
                distance_m: r.distance_m,
            })
            .collect();
        let newest = self.readings.iter().map(|r| r.fired_ns).max().unwrap_or(0);
        DistanceScan { stamp: stamp(newest), ring: self.ring, readings }
    }
}

/// The compass: the turret's true heading plus Gaussian noise, sampled periodically.
#[derive(Debug, Clone)]
pub(crate) struct Compass {
    period_ns: u64,
    next_ns: u64,
    sd_rad: f64,
    rng: ChaCha8Rng,
    last: Option<(u64, f64)>,
}

impl Compass {
    pub(crate) fn new(period_s: f64, sd_deg: f64, rng: ChaCha8Rng, now_ns: u64) -> Self {
        let period_ns = nanos(period_s).max(1);
        Compass {
            period_ns,
            next_ns: now_ns.saturating_add(period_ns),
            sd_rad: sd_deg.to_radians(),
            rng,
            last: None,
        }
    }

    /// Forgets the last sample; the next is one period from `now_ns`.
    pub(crate) fn reset(&mut self, now_ns: u64) {
        self.last = None;
        self.next_ns = now_ns.saturating_add(self.period_ns);
    }

    /// Samples every reading due by the end of `motion`'s step.
    pub(crate) fn fire(&mut self, motion: &StepMotion<'_>) {
        while self.next_ns <= motion.t1_ns {
            let z: f64 = self.rng.sample(StandardNormal);
            let heading = wrap_angle(motion.turret_at(self.next_ns) + z * self.sd_rad);
            self.last = Some((self.next_ns, heading));
            self.next_ns = self.next_ns.saturating_add(self.period_ns);
        }
    }

    /// The latest sample, stamped relative to `origin`.
    pub(crate) fn reading(&self, origin: Timestamp) -> CompassReading {
        match self.last {
            Some((ns, heading_rad)) => {
                CompassReading { stamp: Timestamp(origin.0.saturating_add(ns)), heading_rad, valid: true }
            }
            None => CompassReading { stamp: origin, heading_rad: 0.0, valid: false },
        }
    }
}
