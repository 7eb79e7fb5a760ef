//! What the monitor decides from one look: the body swept along the commanded path, the speed
//! that stops in the free path, and the points a sensor view's readings stand for.

use super::SafetyParams;
use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{DistanceReading, DistanceScan, RING_SIZE, RingParams, RobotParams};
use orsa_interfaces::range::sector_coverage;
use std::f64::consts::{PI, TAU};

/// Why the monitor limited a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    /// Something in the stop zone: the speed it can stop from in the free path.
    Obstacle,
    /// Something in the slowdown zone.
    Slowdown,
    /// No healthy sensor sees the direction of travel.
    Blind,
    /// A bumper is pressed on the side the robot moves towards.
    Contact,
    /// A sensor is judged unhealthy (`[safety.health]`): the path is free only as far as the
    /// views still trusted reach.
    Unhealthy,
}

/// The distance the robot's centre travels along the path of `(v, omega)` before a disc of
/// radius `r` around it first touches `p` (body frame: x ahead, y left); infinite if it never
/// does, 0 if it touches `p` now and the motion brings it closer.
pub fn free_distance(p: (f64, f64), v: f64, omega: f64, r: f64) -> f64 {
    let (px, py) = p;
    if v == 0.0 {
        return f64::INFINITY;
    }
    // Straight (a turn wider than a kilometre is straight here).
    if (omega / v).abs() < 1e-3 {
        let x = px * v.signum();
        if py.abs() >= r {
            return f64::INFINITY;
        }
        let h = (r * r - py * py).sqrt();
        return if x - h > 0.0 {
            x - h
        } else if x + h <= 0.0 || x <= 0.0 {
            f64::INFINITY // behind, or inside and moving away
        } else {
            0.0
        };
    }
    // An arc about the instantaneous centre of rotation (0, rc); the robot's centre goes round
    // it at omega, from (0, -rc).
    let rc = v / omega;
    let big_r = rc.abs();
    let (qx, qy) = (px, py - rc);
    let rho = qx.hypot(qy);
    if rho < 1e-9 {
        return f64::INFINITY; // on the centre of rotation: its distance never changes
    }
    let cos_contact = (big_r * big_r + rho * rho - r * r) / (2.0 * big_r * rho);
    if cos_contact >= 1.0 {
        return f64::INFINITY; // the swept annulus misses it
    }
    let phi0 = (-rc).atan2(0.0);
    let delta = (omega.signum() * (qy.atan2(qx) - phi0)).rem_euclid(TAU);
    let contact = cos_contact.max(-1.0).acos();
    if delta > contact && delta < TAU - contact {
        return (delta - contact) * big_r;
    }
    // Touching now: closer while the angle to it shrinks towards 0 from below pi.
    if delta > 0.0 && delta < PI { 0.0 } else { f64::INFINITY }
}

/// The highest speed from which braking at `a` after a reaction time `t` stops within `d`.
pub fn stoppable_speed(d: f64, a: f64, t: f64) -> f64 {
    let d = d.max(0.0);
    if !d.is_finite() {
        return f64::INFINITY;
    }
    a * (-t + (t * t + 2.0 * d / a).sqrt())
}

/// One thing a sensor sees, in the body frame, and when it was seen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seen {
    /// Where, m (x ahead, y left).
    pub at: (f64, f64),
    /// When the reading was taken.
    pub stamp: Timestamp,
    /// How far the robot may have moved towards it that `at` does not account for, m.
    pub slack_m: f64,
}

/// A sector view's beams, as the monitor places readings on them: each sensor's origin on the
/// view's ring and the directions across its beam (every 5 degrees at most, edges included).
#[derive(Debug, Clone, Default)]
pub struct Beams {
    /// Per sensor: its origin (body frame, m) and the unit directions across its beam.
    sensors: Vec<Beam>,
    /// Per sensor: the unit direction of its axis.
    axes: Vec<(f64, f64)>,
    /// Per sensor: the sectors its beam reaches into (bit `k`: sector `k` of [`sector`], seen
    /// from the centre).
    sectors: Vec<u32>,
    /// The cosine of half a beam's width.
    cos_half: f64,
    /// The shortest range a reading vouches for, m: nothing closer is seen free.
    min_range_m: f64,
}

/// A sensor's origin (body frame, m) and the unit directions across its beam.
type Beam = ((f64, f64), Vec<(f64, f64)>);

/// How much short of a reading a remembered point must lie for the reading to see through it.
pub const CLEAR_MARGIN_M: f64 = 0.05;

impl Beams {
    /// The beams of `view`.
    pub fn of(view: &RingParams) -> Self {
        let half = view.beam_width_rad / 2.0;
        let steps = (view.beam_width_rad / 5f64.to_radians()).ceil().max(1.0) as usize;
        let sensors = view
            .angles_rad
            .iter()
            .map(|&a| {
                let origin = (view.mount_radius_m * a.cos(), view.mount_radius_m * a.sin());
                let dirs = (0..=steps)
                    .map(|k| {
                        let b = a - half + view.beam_width_rad * k as f64 / steps as f64;
                        (b.cos(), b.sin())
                    })
                    .collect();
                (origin, dirs)
            })
            .collect();
        let axes = view.angles_rad.iter().map(|a| (a.cos(), a.sin())).collect();
        // The sectors (of bearing from the centre) each beam reaches into: a point in a beam
        // lies within half the beam of its axis, seen from the centre (the beam starts on the
        // axis, outwards). Bearings are sampled across the beam and its margins closer than
        // the narrowest sector (about 7 degrees), so none it touches is missed; the margin
        // keeps a point on a sector's edge in both.
        let sectors = view
            .angles_rad
            .iter()
            .map(|a| {
                let width = view.beam_width_rad + 2.0 * SECTOR_MARGIN;
                let steps = (width / 1f64.to_radians()).ceil().max(1.0) as usize;
                let mut set = 0u32;
                for k in 0..=steps {
                    let b = a - half - SECTOR_MARGIN + width * k as f64 / steps as f64;
                    set |= 1 << sector((b.cos(), b.sin()));
                }
                set
            })
            .collect();
        Beams { sensors, axes, sectors, cos_half: half.cos(), min_range_m: view.min_range_m }
    }

    /// What `scan` sees free, set out for testing many points against it (see [`Sight`]).
    pub fn sight(&self, scan: &DistanceScan) -> Sight {
        let mut sight = Sight::default();
        self.add_to(&mut sight, scan);
        sight
    }

    /// Adds to `sight` what `scan` sees free.
    pub fn add_to(&self, sight: &mut Sight, scan: &DistanceScan) {
        for r in &scan.readings {
            let i = usize::from(r.sensor_id);
            let (Some(((ox, oy), _)), Some(&(ax, ay)), Some(&sectors)) =
                (self.sensors.get(i), self.axes.get(i), self.sectors.get(i))
            else {
                continue;
            };
            let hi = r.distance_m - CLEAR_MARGIN_M;
            if !(r.valid && r.distance_m.is_finite() && hi > self.min_range_m) {
                continue;
            }
            sight.newest = sight.newest.max(Some(r.stamp));
            for (k, of) in sight.by_sector.iter_mut().enumerate() {
                if sectors & (1 << k) != 0 {
                    of.push(sight.rays.len() as u16);
                }
            }
            sight.rays.push(Ray {
                origin: (*ox, *oy),
                axis: (ax, ay),
                hi,
                lo: self.min_range_m,
                cos_half: self.cos_half,
                stamp: r.stamp,
            });
        }
    }

    /// The points the valid `readings` stand for: each reading anywhere across its beam.
    pub fn seen<'a>(&self, readings: impl Iterator<Item = &'a DistanceReading>, out: &mut Vec<Seen>) {
        for r in readings.filter(|r| r.valid && r.distance_m.is_finite()) {
            let Some(((ox, oy), dirs)) = self.sensors.get(usize::from(r.sensor_id)) else { continue };
            for (c, s) in dirs {
                out.push(Seen {
                    at: (ox + r.distance_m * c, oy + r.distance_m * s),
                    stamp: r.stamp,
                    slack_m: 0.0,
                });
            }
        }
    }
}

/// What sector views' readings see free: per reading, its beam from [`CLEAR_MARGIN_M`] short of what it
/// read down to the shortest range its view vouches for (a reading that vouches for nothing,
/// invalid or too short, is left out).
#[derive(Debug, Clone, Default)]
pub struct Sight {
    rays: Vec<Ray>,
    /// Per sector of bearing from the centre ([`sector`]), the rays whose beams reach into it.
    by_sector: [Vec<u16>; SECTORS],
    /// The newest stamp among them.
    newest: Option<Timestamp>,
}

/// One sensor's reading as [`Sight`] tests points against it (body frame).
#[derive(Debug, Clone, Copy)]
struct Ray {
    origin: (f64, f64),
    /// The unit direction of the sensor's axis.
    axis: (f64, f64),
    /// How far out it sees free, m.
    hi: f64,
    /// The shortest range its view vouches for, m.
    lo: f64,
    /// The cosine of half its beam.
    cos_half: f64,
    stamp: Timestamp,
}

impl Sight {
    /// Whether a reading taken after `since` is among them: a test that spares the rest for a
    /// point newer than all of them.
    pub fn newer_than(&self, since: Timestamp) -> bool {
        self.newest.is_some_and(|n| n > since)
    }

    /// Forgets every reading, keeping its buffers.
    pub fn clear(&mut self) {
        self.rays.clear();
        self.by_sector.iter_mut().for_each(Vec::clear);
        self.newest = None;
    }

    /// How many readings it holds.
    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }

    /// Whether a reading taken after `since` sees through `p` (body frame): `p` lies within the
    /// reading's beam, beyond the shortest range it vouches for and more than
    /// [`CLEAR_MARGIN_M`] short of what it read there.
    pub fn clears(&self, since: Timestamp, p: (f64, f64)) -> bool {
        self.by_sector[sector(p)].iter().any(|&i| {
            let ray = &self.rays[usize::from(i)];
            if ray.stamp <= since {
                return false;
            }
            let ((ox, oy), (ax, ay)) = (ray.origin, ray.axis);
            let (vx, vy) = (p.0 - ox, p.1 - oy);
            let d2 = vx * vx + vy * vy;
            let along = vx * ax + vy * ay;
            let (lo, hi, c) = (ray.lo, ray.hi, ray.cos_half);
            d2 > lo * lo && d2 < hi * hi && along > 0.0 && along * along >= d2 * c * c
        })
    }
}

/// How far beyond a beam's edge (rad) the sectors it reaches into are counted.
const SECTOR_MARGIN: f64 = 0.01;

/// How many sectors of bearing [`Sight`] sorts its rays into: a point is tested only against
/// the rays of its own (on a ring of 16 with 25-degree sonar cones, about 5 of 32 instead of 10
/// of 32 with octants).
const SECTORS: usize = 32;

/// The sector of the bearing of `p` from the centre, counter-clockwise from the front: the
/// bearing's diamond angle (a monotonic stand-in for the angle from 0 to 4 that needs no
/// trigonometry) in `SECTORS` equal parts, each 7 to 14 degrees wide.
fn sector(p: (f64, f64)) -> usize {
    let (x, y) = p;
    let l1 = x.abs() + y.abs();
    if l1 == 0.0 || !l1.is_finite() {
        return 0;
    }
    let d = if y >= 0.0 {
        if x >= 0.0 { y / l1 } else { 1.0 - x / l1 }
    } else if x < 0.0 {
        2.0 - y / l1
    } else {
        3.0 + x / l1
    };
    ((d * (SECTORS as f64 / 4.0)) as usize).min(SECTORS - 1)
}

/// What the monitor knows of the robot, and decides from one look at its sensors.
#[derive(Debug, Clone)]
pub struct Monitor {
    pub(super) params: SafetyParams,
    pub(super) robot: RobotParams,
    /// Which sectors each view (infrared, sonar) covers at all.
    pub(super) covered: [[bool; RING_SIZE]; 2],
    /// Each view's beams (infrared, sonar).
    pub(super) beams: [Beams; 2],
}

/// One look at the sensors.
#[derive(Debug, Clone, Default)]
pub struct Look {
    /// What they see.
    pub seen: Vec<Seen>,
    /// Which views are fresh (infrared, sonar).
    pub fresh: [bool; 2],
    /// Bumpers pressed, by angle.
    pub pressed: Vec<f64>,
    /// Whether a sensor is judged unhealthy.
    pub unhealthy: bool,
    /// Now.
    pub now: Timestamp,
}

impl Monitor {
    /// A monitor of `robot` with `params` (checked by [`SafetyParams::check_against`]).
    pub fn new(params: SafetyParams, robot: RobotParams) -> Self {
        let covered = [
            sector_coverage(&robot.range_sensors, &robot.infrared),
            sector_coverage(&robot.range_sensors, &robot.sonar),
        ];
        let beams = [Beams::of(&robot.infrared), Beams::of(&robot.sonar)];
        Monitor { params, robot, covered, beams }
    }

    /// Its parameters.
    pub fn params(&self) -> &SafetyParams {
        &self.params
    }

    /// The speed the robot may translate at on the path of `(v, omega)` given `look`, and why
    /// it is lower than `|v|` if it is.
    pub fn allowed(&self, v: f64, omega: f64, look: &Look) -> (f64, Option<Reason>) {
        let want = v.abs();
        if want < 1e-9 {
            return (want, None);
        }
        let p = &self.params;
        let travel = if v > 0.0 { 0.0 } else { PI };
        // Contact on the side it moves towards.
        if look.pressed.iter().any(|b| (b - travel).cos() > 0.2) {
            return (0.0, Some(Reason::Contact));
        }
        let a = p.deceleration(&self.robot);
        let t = p.latency_s + p.period_s;
        let r = self.robot.body_radius_m + p.stop_margin_m;
        let mut allowed = want;
        let mut reason = None;
        // The path depends on the speed at a given turn rate: look again along the slower one.
        let mut speed = want;
        for _ in 0..3 {
            let sv = speed.copysign(v);
            // Nothing farther than the path it may need can limit it (a chord is no longer
            // than its arc).
            let reach = r + p.stopping_distance(&self.robot, speed) + p.slowdown_margin_m;
            let free = look
                .seen
                .iter()
                .filter(|s| {
                    let r = reach + s.slack_m;
                    s.at.0 * s.at.0 + s.at.1 * s.at.1 <= r * r
                })
                .map(|s| free_distance(s.at, sv, omega, r) - s.slack_m)
                .fold(f64::INFINITY, f64::min);
            let stop = stoppable_speed(free, a, t);
            if stop < allowed {
                (allowed, reason) = (stop, Some(Reason::Obstacle));
            }
            if free < p.slowdown_margin_m && p.slow_speed_m_s < allowed {
                (allowed, reason) = (p.slow_speed_m_s, Some(Reason::Slowdown));
            }
            if allowed >= speed {
                break;
            }
            speed = allowed;
        }
        // With a view not looked at (judged unhealthy, or stale), the path is free only as far
        // as the views still looked at reach in the direction of travel: nothing beyond was
        // looked at. (With every view looked at, the configuration was checked to stop the
        // robot from its top speed within their reach.)
        if look.fresh.iter().any(|f| !f)
            && let Some(reach) = self.reach(travel, look)
        {
            let stop = stoppable_speed(reach - p.stop_margin_m, a, t);
            if stop < allowed {
                let why = if look.unhealthy { Reason::Unhealthy } else { Reason::Blind };
                (allowed, reason) = (stop, Some(why));
            }
        }
        if p.blind_speed_m_s < allowed && !self.sees(travel, look) {
            (allowed, reason) = (p.blind_speed_m_s, Some(Reason::Blind));
        }
        if allowed < 1e-3 {
            allowed = 0.0;
        }
        (allowed, reason)
    }

    /// How far from the body's edge the views looked at see in every sector within 60 degrees
    /// of `direction`, at the least (`None` where no view looked at covers one of them: blind).
    fn reach(&self, direction: f64, look: &Look) -> Option<f64> {
        let views = [&self.robot.infrared, &self.robot.sonar];
        let mut reach = f64::INFINITY;
        for i in 0..RING_SIZE {
            let axis = views[1].angles_rad.get(i).copied().unwrap_or(0.0);
            let off = ((axis - direction + PI).rem_euclid(TAU) - PI).abs();
            if off > 60f64.to_radians() {
                continue;
            }
            let here = (0..2)
                .filter(|&v| look.fresh[v] && self.covered[v][i])
                .map(|v| views[v].mount_radius_m + views[v].max_range_m - self.robot.body_radius_m)
                .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))))?;
            reach = reach.min(here);
        }
        reach.is_finite().then_some(reach)
    }

    /// Whether a fresh view covers every sector within 60 degrees of `direction`.
    fn sees(&self, direction: f64, look: &Look) -> bool {
        let views = [&self.robot.infrared, &self.robot.sonar];
        (0..RING_SIZE).all(|i| {
            let axis = views[1].angles_rad.get(i).copied().unwrap_or(0.0);
            let off = ((axis - direction + PI).rem_euclid(TAU) - PI).abs();
            off > 60f64.to_radians() || (0..2).any(|v| look.fresh[v] && self.covered[v][i])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 0.28;

    /// Straight ahead, a point on the axis is met where the disc's front reaches it; one beside
    /// the path never is; one behind is never met going forward and is going backward.
    #[test]
    fn a_straight_path_meets_what_lies_in_its_swept_band() {
        assert!((free_distance((1.0, 0.0), 0.3, 0.0, R) - 0.72).abs() < 1e-12);
        let off_axis = free_distance((1.0, 0.2), 0.3, 0.0, R);
        assert!((off_axis - (1.0 - (R * R - 0.04f64).sqrt())).abs() < 1e-12);
        assert_eq!(free_distance((1.0, 0.3), 0.3, 0.0, R), f64::INFINITY, "beside the path");
        assert_eq!(free_distance((-1.0, 0.0), 0.3, 0.0, R), f64::INFINITY, "behind");
        assert!((free_distance((-1.0, 0.0), -0.3, 0.0, R) - 0.72).abs() < 1e-12, "backing up");
        // Touching: moving on is 0, moving away is free.
        assert_eq!(free_distance((0.2, 0.0), 0.3, 0.0, R), 0.0);
        assert_eq!(free_distance((0.2, 0.0), -0.3, 0.0, R), f64::INFINITY);
    }

    /// On an arc the distance is the arc length of the centre's path to first contact, which
    /// a fine walk along the arc finds too.
    #[test]
    fn an_arc_meets_points_where_a_walk_along_it_does() {
        let walk = |p: (f64, f64), v: f64, w: f64| -> f64 {
            let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
            let ds = 1e-4;
            let mut s = 0.0;
            while s < 6.0 {
                if (p.0 - x).hypot(p.1 - y) <= R {
                    return s;
                }
                x += ds * th.cos() * v.signum();
                y += ds * th.sin() * v.signum();
                th += ds * w / v.abs();
                s += ds;
            }
            f64::INFINITY
        };
        for (p, v, w) in [
            ((1.0, 0.3), 0.3, 0.4),
            ((1.0, -0.3), 0.3, 0.4),
            ((0.5, 0.6), 0.2, 0.6),
            ((-0.8, 0.2), -0.2, 0.3),
            ((-0.8, -0.4), -0.2, -0.5),
            ((0.0, 1.2), 0.25, 0.5),
        ] {
            let exact = free_distance(p, v, w, R);
            let walked = walk(p, v, w);
            if walked.is_finite() {
                assert!((exact - walked).abs() < 2e-3, "{p:?} v {v} w {w}: {exact} against {walked}");
            } else {
                assert!(exact > 5.9, "{p:?} v {v} w {w}: {exact} against a walk that never met it");
            }
        }
    }

    /// Testing a point only against the rays of its sector clears exactly what testing it
    /// against every ray does, on rings of 16 and of 5 (uneven) with wide and narrow beams,
    /// including points on the sectors' edges.
    #[test]
    fn a_point_is_cleared_by_the_rays_of_its_sector_as_by_all() {
        use orsa_interfaces::nomad200::{DistanceReading, Ring};
        let every = |s: &Sight, since: Timestamp, p: (f64, f64)| {
            s.rays.iter().any(|ray| {
                let (vx, vy) = (p.0 - ray.origin.0, p.1 - ray.origin.1);
                let d2 = vx * vx + vy * vy;
                let along = vx * ray.axis.0 + vy * ray.axis.1;
                let (lo, hi, c) = (ray.lo, ray.hi, ray.cos_half);
                ray.stamp > since
                    && d2 > lo * lo
                    && d2 < hi * hi
                    && along > 0.0
                    && along * along >= d2 * c * c
            })
        };
        let rings =
            [(0..16).map(|i| i as f64 * TAU / 16.0).collect::<Vec<_>>(), vec![0.0, 0.7, 1.6, 3.3, 5.0]];
        let (mut cleared, mut tried) = (0, 0);
        // One sight cleared and filled again for every ring: nothing of the last stays.
        let mut reused = Sight::default();
        for angles in rings {
            for width_deg in [22.5f64, 8.0] {
                let view = RingParams {
                    angles_rad: angles.clone(),
                    mount_radius_m: 0.25,
                    beam_width_rad: width_deg.to_radians(),
                    min_range_m: 0.05,
                    max_range_m: 2.0,
                    fire_period_s: 0.004,
                };
                let beams = Beams::of(&view);
                let readings = (0..angles.len())
                    .map(|i| DistanceReading {
                        sensor_id: i as u8,
                        stamp: Timestamp(10 + i as u64),
                        valid: true,
                        distance_m: 0.3 + 0.23 * i as f64 % 1.5,
                    })
                    .collect();
                let scan = DistanceScan { stamp: Timestamp(30), ring: Ring::Sonar, readings };
                let sight = beams.sight(&scan);
                reused.clear();
                beams.add_to(&mut reused, &scan);
                for k in 0..40_000 {
                    let th = k as f64 / 40_000.0 * TAU;
                    let r = 0.2 + (k % 53) as f64 * 0.04;
                    let mut points = vec![(r * th.cos(), r * th.sin())];
                    if k < SECTORS {
                        // The edge between sectors k - 1 and k, on the diamond.
                        let d = k as f64 * 4.0 / SECTORS as f64;
                        let t = d.fract();
                        let edge = match d as usize {
                            0 => (1.0 - t, t),
                            1 => (-t, 1.0 - t),
                            2 => (t - 1.0, -t),
                            _ => (t, t - 1.0),
                        };
                        points.extend([(r * edge.0, r * edge.1), (r, r), (-r, r), (0.0, -r), (-r, 0.0)]);
                    }
                    for p in points {
                        let want = every(&sight, Timestamp(12), p);
                        assert_eq!(
                            sight.clears(Timestamp(12), p),
                            want,
                            "{p:?} on {angles:?}, {width_deg} deg"
                        );
                        assert_eq!(reused.clears(Timestamp(12), p), want, "reused: {p:?} on {angles:?}");
                        cleared += usize::from(want);
                        tried += 1;
                    }
                }
            }
        }
        assert!(cleared > tried / 20 && cleared < tried, "{cleared} of {tried} cleared");
    }

    /// Sectors follow the bearing round, counter-clockwise from the front, each 7 to 14
    /// degrees wide.
    #[test]
    fn sectors_follow_the_bearing_round() {
        let (mut last, mut start) = (0, 0.0);
        let steps = 36_000;
        for k in 0..steps {
            let b = k as f64 / steps as f64 * TAU;
            let s = sector((b.cos(), b.sin()));
            if s != last {
                assert_eq!(s, (last + 1) % SECTORS, "at {b} rad");
                let width = (b - start).to_degrees();
                assert!(last == 0 || (7.0..14.1).contains(&width), "sector {last}: {width} degrees");
                (last, start) = (s, b);
            }
        }
        assert_eq!(last, SECTORS - 1, "round to the front again");
        assert_eq!(sector((0.0, 0.0)), 0);
        assert_eq!(sector((f64::NAN, 1.0)), 0);
    }

    /// Braking at `a` after `t` from the speed allowed covers exactly the free distance.
    #[test]
    fn the_stoppable_speed_stops_in_the_free_distance() {
        for (d, a, t) in [(1.0, 0.5, 0.14), (0.1, 0.5, 0.14), (3.0, 1.0, 0.0)] {
            let v = stoppable_speed(d, a, t);
            assert!((v * t + v * v / (2.0 * a) - d).abs() < 1e-12);
        }
        assert_eq!(stoppable_speed(-0.1, 0.5, 0.1), 0.0);
    }
}
