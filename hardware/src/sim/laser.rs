//! A planar laser scanner: every beam at once, once a period, from a mount point on the body.
//!
//! A scan is taken with the robot and the movers where they were at its instant (interpolated
//! within the step, as the rings' firings are). Each beam casts one ray from the mount point; a
//! reading is the distance to the first surface it meets plus Gaussian noise of
//! `noise_sd_m`, valid when something was met within `max_range_m` and the noisy distance lies
//! in `[min_range_m, max_range_m]`. Every beam draws exactly one noise sample, whatever it saw,
//! from the laser's own random stream.
//!
//! The robot server of a laser robot pushes two sector views of the newest scan on the
//! services the behaviours read (`distanceir`, `distanceson`): the scan's points, in the body
//! frame, projected onto 16 sectors by [`orsa_interfaces::range::project_onto_ring`] (see
//! [`LaserConfig`] for the two views).

use super::rings::StepMotion;
use crate::geometry::{Circle, Point};
use crate::sim::config::{LaserConfig, nanos};
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{DistanceReading, DistanceScan, Ring, RingParams};
use orsa_interfaces::range::{RangeSensorParams, project_onto_ring};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// The laser and its newest scan.
#[derive(Debug, Clone)]
pub(crate) struct Laser {
    params: RangeSensorParams,
    sd: f64,
    period_ns: u64,
    next_ns: u64,
    /// When the newest scan was taken, and each beam's reading (`None`: not valid).
    last: Option<(u64, Vec<Option<f64>>)>,
    rng: ChaCha8Rng,
    /// The sector views of the newest scan, as made (sonar, infrared): the robot server and
    /// the safety monitor read them many times a scan.
    views: ViewCache,
}

/// The views made of the newest scan; a copy starts empty.
#[derive(Debug, Default)]
struct ViewCache(parking_lot::Mutex<[Option<DistanceScan>; 2]>);

impl Clone for ViewCache {
    fn clone(&self) -> Self {
        ViewCache::default()
    }
}

impl ViewCache {
    fn clear(&self) {
        *self.0.lock() = [None, None];
    }
}

impl Laser {
    /// A laser as configured, its first scan one period after `now_ns`.
    pub(crate) fn new(cfg: &LaserConfig, rng: ChaCha8Rng, now_ns: u64) -> Self {
        let period_ns = nanos(cfg.period_s).max(1);
        Laser {
            params: cfg.params(),
            sd: cfg.noise_sd_m,
            period_ns,
            next_ns: now_ns.saturating_add(period_ns),
            last: None,
            rng,
            views: ViewCache::default(),
        }
    }

    /// Forgets the newest scan; the next is one period from `now_ns`.
    pub(crate) fn reset(&mut self, now_ns: u64) {
        self.last = None;
        self.views.clear();
        self.next_ns = now_ns.saturating_add(self.period_ns);
    }

    /// Takes every scan due by the end of `motion`'s step.
    pub(crate) fn fire(&mut self, motion: &StepMotion<'_>, scratch: &mut Vec<Circle>) {
        while self.next_ns <= motion.t1_ns {
            let t = self.next_ns;
            let (center, heading) = motion.pose_at(t, scratch);
            let (s, c) = heading.sin_cos();
            let p = &self.params;
            let mount = Point::new(center.x + c * p.x_m - s * p.y_m, center.y + s * p.x_m + c * p.y_m);
            let mut readings = match self.last.take() {
                Some((_, mut v)) => {
                    v.clear();
                    v
                }
                None => Vec::with_capacity(p.angles_rad.len()),
            };
            for a in &p.angles_rad {
                let hit = motion.scene.ray_fan(scratch, mount, heading + a, &[0.0], p.max_range_m);
                let z: f64 = self.rng.sample(StandardNormal);
                let measured = hit.map(|d| (d + z * self.sd).max(0.0));
                readings.push(measured.filter(|&d| p.in_range(d)));
            }
            self.last = Some((t, readings));
            self.views.clear();
            self.next_ns = self.next_ns.saturating_add(self.period_ns);
        }
    }

    /// The newest scan: when it was taken and each beam's reading (`None`: not valid).
    pub(crate) fn last(&self) -> Option<(u64, &[Option<f64>])> {
        self.last.as_ref().map(|(t, r)| (*t, r.as_slice()))
    }

    /// The newest scan seen as a ring of sectors described by `view`, stamped relative to
    /// `origin`; a sector is valid where a point falls in it within the view's range. Before the
    /// first scan every sector is invalid, as a ring that has not fired.
    pub(crate) fn view(&self, ring: Ring, view: &RingParams, origin: Timestamp) -> DistanceScan {
        // Each ring has one view (its parameters come from the configuration, fixed at start).
        let slot = match ring {
            Ring::Sonar => 0,
            Ring::Infrared => 1,
        };
        if let Some(made) = &self.views.0.lock()[slot] {
            return made.clone();
        }
        let made = self.make_view(ring, view, origin);
        self.views.0.lock()[slot] = Some(made.clone());
        made
    }

    fn make_view(&self, ring: Ring, view: &RingParams, origin: Timestamp) -> DistanceScan {
        let stamp = |ns: u64| Timestamp(origin.0.saturating_add(ns));
        let (taken, sectors) = match &self.last {
            Some((t, beams)) => {
                let points =
                    beams.iter().enumerate().filter_map(|(j, r)| r.and_then(|d| self.params.hit_point(j, d)));
                (*t, Some(project_onto_ring(points, view)))
            }
            None => (0, None),
        };
        let readings = (0..view.angles_rad.len())
            .map(|i| {
                let d = sectors.and_then(|s| s.get(i).copied().flatten());
                let valid = d.filter(|&d| d >= view.min_range_m && d <= view.max_range_m);
                DistanceReading {
                    sensor_id: i as u8,
                    stamp: stamp(taken),
                    valid: valid.is_some(),
                    distance_m: valid.unwrap_or(view.max_range_m),
                }
            })
            .collect();
        DistanceScan { stamp: stamp(taken), ring, readings }
    }
}
