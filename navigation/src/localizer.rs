//! The localizer component: Monte Carlo localization ([`crate::mcl`]) on the robot's odometry
//! and range sensors against the known map, publishing the pose in the map on `pose`.
//!
//! It reads the robot by its interface alone: its geometry from `robotparams` (where each range
//! sensor sits, which way it looks, how wide and how far), odometry from `basestate`, the near
//! and far range views from `distanceir` and `distanceson`, so the same component localizes
//! any robot that describes its sensors (a Nomad 200's two rings, a laser's two views). Every
//! odometry update is published as a [`PoseEstimate`]: the newest filter estimate carried
//! forward by odometry through `map -> odom`, with the filter's covariance. What it last knew
//! (`map -> odom`) outlives a restart of the component, so a restarted localizer starts where
//! the robot is.

use crate::mcl::{Beam, Localizer, MclParams, Pose2, wrap};
use crate::relocalize::{RelocParams, Relocalizer, Search};
use orsa_actors::param::Invalid;
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::{Component, ComponentError, Ctx, Empty, Timestamp, Update};
use orsa_interfaces::map::OccupancyGrid;
use orsa_interfaces::navigation::{POSE, PoseEstimate};
use orsa_interfaces::nomad200::{self, BaseState, DistanceScan, RingParams, RobotParams};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The localizer's parameters (`[params.localizer]`), read when it starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LocalizerParams {
    /// How many particles.
    pub particles: usize,
    /// The spread of the first particles about the start pose, m.
    pub initial_sigma_m: f64,
    /// Their spread in heading, degrees.
    pub initial_sigma_deg: f64,
    /// The seed of its random draws (a run with the same seed localizes the same way).
    pub seed: u64,
    /// The travel between two corrections by the range readings, m (AMCL's `update_min_d`).
    pub update_min_m: f64,
    /// The turn between two corrections, degrees (AMCL's `update_min_a`).
    pub update_min_deg: f64,
    /// Whether each reading is placed where odometry says the robot was when it was taken
    /// ([`ring_beams_at`]) rather than where it is at the correction. Off by default for now:
    /// on random tours it keeps the estimate on the hall and the loop (docs/navigation.md),
    /// but after a kidnapping the filter then holds a wrong pose well enough that the
    /// relocalizer's judge, whose thresholds were chosen without it, notices it 40 s late.
    pub timed_readings: bool,
    /// The filter redraws particles at random free places while its short-term fit is below
    /// this share of its long-term one (augmented MCL's recovery, [`MclParams::recovery_ratio`]).
    /// 0 by default: a lost robot is found by the relocalizer's search, which looks at the whole
    /// map at once and takes a pose only when it is sure. Particles redrawn at random let the
    /// filter jump by itself: in the hall, which looks nearly the same turned round, a dip of the
    /// fit (people close) drew particles onto its mirror image, which fit as well and won
    /// (random tours: the hall 80.5 % of goals truly reached at 0.5, 98.5 % at 0).
    pub recovery_ratio: f64,
    /// The robot is taken to be lost (and looked for) when the filter's short-term fit falls
    /// below this share of its long-term one: the dip that used to redraw particles at random
    /// now starts the relocalizer's search, which keeps the track if it still fits (people
    /// close) and finds the robot elsewhere if it does not (kidnapped). 0: never (the
    /// relocalizer's judge alone).
    pub lost_fit_ratio: f64,
}

impl Default for LocalizerParams {
    fn default() -> Self {
        LocalizerParams {
            particles: 500,
            initial_sigma_m: 0.1,
            initial_sigma_deg: 3.0,
            seed: 1,
            update_min_m: 0.05,
            update_min_deg: 10.0,
            timed_readings: false,
            recovery_ratio: 0.0,
            lost_fit_ratio: 0.5,
        }
    }
}

impl LocalizerParams {
    /// Checks every value; messages name the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        if !(10..=100_000).contains(&self.particles) {
            return Err(Invalid::new(
                "localizer.particles",
                format!("must be from 10 to 100000, not {}", self.particles),
            ));
        }
        if !(self.initial_sigma_m.is_finite() && (0.0..=10.0).contains(&self.initial_sigma_m)) {
            return Err(Invalid::new("localizer.initial_sigma_m", "must be from 0 to 10 m"));
        }
        if !(self.initial_sigma_deg.is_finite() && (0.0..=180.0).contains(&self.initial_sigma_deg)) {
            return Err(Invalid::new("localizer.initial_sigma_deg", "must be from 0 to 180 degrees"));
        }
        if !(self.update_min_m.is_finite() && (0.0..=5.0).contains(&self.update_min_m)) {
            return Err(Invalid::new("localizer.update_min_m", "must be from 0 to 5 m"));
        }
        if !(self.update_min_deg.is_finite() && (0.0..=180.0).contains(&self.update_min_deg)) {
            return Err(Invalid::new("localizer.update_min_deg", "must be from 0 to 180 degrees"));
        }
        if !(self.recovery_ratio.is_finite() && (0.0..=1.0).contains(&self.recovery_ratio)) {
            return Err(Invalid::new("localizer.recovery_ratio", "must be from 0 to 1"));
        }
        if !(self.lost_fit_ratio.is_finite() && (0.0..=1.0).contains(&self.lost_fit_ratio)) {
            return Err(Invalid::new("localizer.lost_fit_ratio", "must be from 0 to 1"));
        }
        Ok(())
    }
}

/// The localizer component.
#[derive(Debug, Clone)]
pub struct Localization {
    /// Its parameters.
    pub params: LocalizerParams,
    /// The robot server's name.
    pub robot: String,
    /// The known map.
    pub map: Arc<OccupancyGrid>,
    /// Where the robot starts, in the map (its odometry starts at zero there).
    pub start: Pose2,
}

/// Messages of [`Localization`].
#[derive(Debug)]
pub enum LocalizationMsg {
    /// Odometry.
    Base(Update<BaseState>),
    /// The near range view.
    Ir(Update<DistanceScan>),
    /// The far range view.
    Sonar(Update<DistanceScan>),
}

/// The running state of [`Localization`].
pub struct LocalizationState {
    filter: Localizer,
    robot: RobotParams,
    pose: PushNewestServer<PoseEstimate>,
    ir: Option<DistanceScan>,
    sonar: Option<DistanceScan>,
    /// `map -> odom`, kept across restarts.
    map_odom: Arc<Mutex<Option<Pose2>>>,
    /// Whether the filter has been placed (at the first odometry).
    placed: bool,
    beams: Vec<Beam>,
    /// Where odometry put the robot lately, for placing each reading where it was taken.
    trail: OdometryTrail,
    covariance: [f64; 9],
    /// Judges the estimate, and finds the robot when it is lost.
    reloc: Relocalizer,
}

/// A ring's readings as beams (no echo within its range: `None`), in the body's frame where
/// each was taken.
pub fn ring_beams(scan: &DistanceScan, ring: &RingParams, out: &mut Vec<Beam>) {
    beams_moved(scan, ring, None, out);
}

/// A ring's readings as beams in the body's frame at the odometry pose `now`: each moved by
/// what the robot drove and turned between the reading's own stamp and `now`, as `trail`
/// tells. A ring fires its sensors one after another (a Nomad 200's sonar over 64 ms) and
/// odometry comes every 100 ms, so a reading can be 0.15 s old when it is used: turning at
/// 1 rad/s, that is 9 degrees, and 0.45 m across at 3 m.
pub fn ring_beams_at(
    scan: &DistanceScan,
    ring: &RingParams,
    trail: &OdometryTrail,
    now: Pose2,
    out: &mut Vec<Beam>,
) {
    beams_moved(scan, ring, Some((trail, now)), out);
}

fn beams_moved(
    scan: &DistanceScan,
    ring: &RingParams,
    moved: Option<(&OdometryTrail, Pose2)>,
    out: &mut Vec<Beam>,
) {
    for r in &scan.readings {
        let Some(&a) = ring.angles_rad.get(usize::from(r.sensor_id)) else { continue };
        let echo = r.valid && r.distance_m.is_finite() && r.distance_m < ring.max_range_m;
        let mut origin = (ring.mount_radius_m * a.cos(), ring.mount_radius_m * a.sin());
        let mut angle_rad = a;
        let then = moved.map(|(trail, _)| (trail.poses.is_empty(), trail.at(r.stamp)));
        // A reading older than the whole trail cannot be placed: it is left out (with no trail
        // yet, every reading is taken where the robot is).
        if let Some((false, None)) = then {
            continue;
        }
        if let Some((trail, now)) = moved
            && let Some(then) = trail.at(r.stamp)
            && then != now
        {
            // From the body then to the odometry frame, and back into the body now.
            let (x, y) = then.apply(origin.0, origin.1);
            let (dx, dy) = (x - now.x, y - now.y);
            let (sin, cos) = now.theta.sin_cos();
            origin = (cos * dx + sin * dy, -sin * dx + cos * dy);
            angle_rad = wrap(a + then.theta - now.theta);
        }
        out.push(Beam {
            origin,
            angle_rad,
            half_width_rad: ring.beam_width_rad / 2.0,
            range_m: echo.then_some(r.distance_m),
            max_range_m: ring.max_range_m,
        });
    }
}

/// The odometry poses of the last moments (the last 16 `basestate`s), to tell where the
/// robot was when a reading was taken.
#[derive(Debug, Clone, Default)]
pub struct OdometryTrail {
    poses: VecDeque<(Timestamp, Pose2)>,
}

impl OdometryTrail {
    const KEEP: usize = 16;

    /// The odometry pose at `stamp` (one not newer than the last is ignored).
    pub fn push(&mut self, stamp: Timestamp, pose: Pose2) {
        if self.poses.back().is_some_and(|(t, _)| *t >= stamp) {
            return;
        }
        if self.poses.len() == Self::KEEP {
            self.poses.pop_front();
        }
        self.poses.push_back((stamp, pose));
    }

    /// The odometry pose at `t`: interpolated between the two around it (the turn the short
    /// way), the newest after the last; `None` before the first (older than the trail: where
    /// the robot was then is not known) or with none.
    pub fn at(&self, t: Timestamp) -> Option<Pose2> {
        let (first, last) = (self.poses.front()?, self.poses.back()?);
        if t < first.0 {
            return None;
        }
        if t == first.0 {
            return Some(first.1);
        }
        if t >= last.0 {
            return Some(last.1);
        }
        let k = self.poses.partition_point(|(s, _)| *s <= t);
        let ((t0, a), (t1, b)) = (self.poses[k - 1], self.poses[k]);
        let f = (t.0 - t0.0) as f64 / (t1.0 - t0.0) as f64;
        Some(Pose2::new(
            a.x + f * (b.x - a.x),
            a.y + f * (b.y - a.y),
            wrap(a.theta + f * wrap(b.theta - a.theta)),
        ))
    }
}

/// `map -> odom` from the pose in the map and the odometry pose it was made from.
pub fn map_to_odom(map: Pose2, odom: Pose2) -> Pose2 {
    let theta = wrap(map.theta - odom.theta);
    let (s, c) = theta.sin_cos();
    Pose2::new(map.x - (c * odom.x - s * odom.y), map.y - (s * odom.x + c * odom.y), theta)
}

impl Component for Localization {
    type Msg = LocalizationMsg;
    type State = LocalizationState;

    async fn setup(&self, ctx: &Ctx<LocalizationMsg>) -> Result<LocalizationState, ComponentError> {
        self.params.validate().map_err(|e| e.to_string())?;
        let robot: RobotParams = ctx
            .query_client(nomad200::ROBOTPARAMS.on(&self.robot))?
            .query(Empty {}, Some(Duration::from_secs(2)))
            .await
            .map_err(|e| format!("{}: cannot get {}/robotparams: {e}", ctx.name(), self.robot))?;
        let mcl = MclParams {
            particles: self.params.particles,
            update_min_m: self.params.update_min_m,
            update_min_rad: self.params.update_min_deg.to_radians(),
            recovery_ratio: self.params.recovery_ratio,
            ..MclParams::default()
        };
        let filter =
            Localizer::new(&self.map, mcl, self.params.seed).map_err(|e| format!("{}: {e}", ctx.name()))?;
        let g = &self.map;
        let bounds = [
            g.origin_x_m,
            g.origin_y_m,
            g.origin_x_m + f64::from(g.width) * g.resolution_m,
            g.origin_y_m + f64::from(g.height) * g.resolution_m,
        ];
        let reloc = Relocalizer::new(RelocParams::default(), filter.field(), bounds, robot.body_radius_m);
        let pose = ctx.push_newest_server(POSE)?;
        let map_odom = ctx.keep("map_odom", || Arc::new(Mutex::new(None::<Pose2>)))?;
        ctx.subscribe_timed(nomad200::BASESTATE.on(&self.robot), 1, LocalizationMsg::Base)?;
        ctx.subscribe_timed(nomad200::DISTANCEIR.on(&self.robot), 1, LocalizationMsg::Ir)?;
        ctx.subscribe_timed(nomad200::DISTANCESON.on(&self.robot), 1, LocalizationMsg::Sonar)?;
        Ok(LocalizationState {
            filter,
            robot,
            pose,
            ir: None,
            sonar: None,
            map_odom,
            placed: false,
            beams: Vec::new(),
            trail: OdometryTrail::default(),
            covariance: [0.0; 9],
            reloc,
        })
    }

    async fn handle(
        &self,
        _ctx: &Ctx<LocalizationMsg>,
        st: &mut LocalizationState,
        msg: LocalizationMsg,
    ) -> Result<(), ComponentError> {
        let b = match msg {
            LocalizationMsg::Ir(s) => {
                st.ir = Some(s.value.clone());
                return Ok(());
            }
            LocalizationMsg::Sonar(s) => {
                st.sonar = Some(s.value.clone());
                return Ok(());
            }
            LocalizationMsg::Base(b) => b.value,
        };
        let odom = Pose2::new(b.x_m, b.y_m, b.heading_rad);
        if !(odom.x.is_finite() && odom.y.is_finite() && odom.theta.is_finite()) {
            return Ok(());
        }
        let kept = *st.map_odom.lock().map_err(|_| "localizer: its kept pose is poisoned")?;
        if !st.placed {
            // The start pose, or where a restarted instance last knew the robot to be.
            let at = match kept {
                Some(t) => {
                    let (x, y) = t.apply(odom.x, odom.y);
                    Pose2::new(x, y, wrap(t.theta + odom.theta))
                }
                None => {
                    let (x, y) = self.start.apply(odom.x, odom.y);
                    Pose2::new(x, y, wrap(self.start.theta + odom.theta))
                }
            };
            let sigma_rad = self.params.initial_sigma_deg.to_radians();
            st.filter.reset_at(at, self.params.initial_sigma_m, sigma_rad).map_err(|e| e.to_string())?;
            st.placed = true;
        }
        st.trail.push(b.stamp, odom);
        st.beams.clear();
        for (scan, ring) in [(&st.sonar, &st.robot.sonar), (&st.ir, &st.robot.infrared)] {
            match scan {
                Some(s) if self.params.timed_readings => {
                    ring_beams_at(s, ring, &st.trail, odom, &mut st.beams)
                }
                Some(s) => ring_beams(s, ring, &mut st.beams),
                None => {}
            }
        }
        let updated = st.filter.update(odom, &st.beams);
        if updated {
            st.reloc.gather(odom, &st.beams);
            if st.reloc.search_due() {
                self.search(st, odom)?;
            }
            let (fast, slow) = st.filter.fit();
            if !st.reloc.lost() && !st.reloc.guessing() && fast < self.params.lost_fit_ratio * slow {
                let e = st.filter.estimate();
                st.reloc.set_lost_from(map_to_odom(e.pose, odom));
                tracing::warn!(
                    "{}: lost: the readings fit the map from ({:.2}, {:.2}) less than {:.0} % as well as they have \
                     been; looking for the robot among {} places where it fits",
                    self.name(),
                    e.pose.x,
                    e.pose.y,
                    100.0 * self.params.lost_fit_ratio,
                    st.reloc.candidates()
                );
            }
            if !st.reloc.lost() {
                let e = st.filter.estimate();
                if st.reloc.judge(st.filter.field(), map_to_odom(e.pose, odom)).is_some() && st.reloc.lost() {
                    // (Lost anew, or a guess that stopped fitting.)
                    tracing::warn!(
                        "{}: lost: what the sensors see does not fit the map from ({:.2}, {:.2}); looking for the robot \
                         among {} places where it fits",
                        self.name(),
                        e.pose.x,
                        e.pose.y,
                        st.reloc.candidates()
                    );
                }
            }
        }
        let t = if updated || kept.is_none() {
            let e = st.filter.estimate();
            st.covariance = [
                e.covariance[0][0],
                e.covariance[0][1],
                e.covariance[0][2],
                e.covariance[1][0],
                e.covariance[1][1],
                e.covariance[1][2],
                e.covariance[2][0],
                e.covariance[2][1],
                e.covariance[2][2],
            ];
            let t = map_to_odom(e.pose, odom);
            *st.map_odom.lock().map_err(|_| "localizer: its kept pose is poisoned")? = Some(t);
            t
        } else {
            kept.unwrap_or(self.start)
        };
        let (x, y) = t.apply(odom.x, odom.y);
        st.pose.put(PoseEstimate {
            stamp: b.stamp,
            x_m: x,
            y_m: y,
            heading_rad: wrap(t.theta + odom.theta),
            covariance: st.covariance,
            odom_x_m: t.x,
            odom_y_m: t.y,
            odom_heading_rad: t.theta,
            lost: st.reloc.lost(),
        });
        Ok(())
    }
}

impl Localization {
    fn name(&self) -> &'static str {
        "localizer"
    }

    /// Searches the map for the lost robot, `odom` its odometry now; places the filter there
    /// if the search is sure.
    fn search(&self, st: &mut LocalizationState, odom: Pose2) -> Result<(), ComponentError> {
        match st.reloc.search(st.filter.field(), odom) {
            Some(found @ (Search::Found(f) | Search::Kept(f))) => {
                let (where_, why) = match found {
                    Search::Kept(_) => ("where it was tracked, at", ", and nowhere else surely better"),
                    _ => ("at", ""),
                };
                tracing::info!(
                    "{}: found the robot {where_} ({:.2}, {:.2}, {:.0} deg): {:.0} % of the echoes fit there{why}",
                    self.name(),
                    f.pose.x,
                    f.pose.y,
                    f.pose.theta.to_degrees(),
                    100.0 * f.agreement
                );
                st.filter.reset_at(f.pose, 0.1, 3f64.to_radians()).map_err(|e| e.to_string())?;
            }
            Some(Search::Guess(best, rival)) => {
                tracing::info!(
                    "{}: taking ({:.2}, {:.2}, {:.0} deg) for now: {:.0} % of the echoes fit there (score {:.3}), \
                     and ({:.2}, {:.2}) nearly as well (score {:.3}): it must move to tell them apart",
                    self.name(),
                    best.pose.x,
                    best.pose.y,
                    best.pose.theta.to_degrees(),
                    100.0 * best.agreement,
                    best.score,
                    rival.pose.x,
                    rival.pose.y,
                    rival.score
                );
                st.filter.reset_at(best.pose, 0.1, 3f64.to_radians()).map_err(|e| e.to_string())?;
            }
            Some(Search::Unsure(best, rival)) => {
                tracing::info!(
                    "{}: still looking: best ({:.2}, {:.2}) fits {:.0} % (score {:.3}), {}",
                    self.name(),
                    best.pose.x,
                    best.pose.y,
                    100.0 * best.agreement,
                    best.score,
                    rival.map_or("too few fit".to_string(), |r| format!(
                        "and ({:.2}, {:.2}) nearly as well (score {:.3})",
                        r.pose.x, r.pose.y, r.score
                    ))
                );
            }
            None => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn map_to_odom_carries_the_odometry_pose_onto_the_estimate() {
        let map = Pose2::new(3.0, -1.0, 0.7);
        let odom = Pose2::new(1.2, 0.4, -0.3);
        let t = map_to_odom(map, odom);
        let (x, y) = t.apply(odom.x, odom.y);
        assert!((x - map.x).abs() < 1e-12 && (y - map.y).abs() < 1e-12, "{x} {y}");
        assert!((wrap(t.theta + odom.theta) - map.theta).abs() < 1e-12);
        let bad = LocalizerParams { particles: 5, ..LocalizerParams::default() };
        assert_eq!(bad.validate().expect_err("too few").key, "localizer.particles");
    }

    #[test]
    fn a_reading_taken_before_the_robot_turned_is_placed_where_the_robot_was() {
        const MS: u64 = 1_000_000;
        let then = Pose2::new(1.0, 2.0, 3.0);
        let now = Pose2::new(1.5, 2.2, -3.0); // 0.28 rad further on, across the wrap
        let mut trail = OdometryTrail::default();
        trail.push(Timestamp(100 * MS), then);
        trail.push(Timestamp(200 * MS), now);
        trail.push(Timestamp(150 * MS), Pose2::default()); // older than the last: ignored
        let mid = trail.at(Timestamp(150 * MS)).expect("a pose");
        assert!((mid.x - 1.25).abs() < 1e-12 && (mid.y - 2.1).abs() < 1e-12, "{mid:?}");
        assert!((mid.theta - wrap(3.0 + (TAU - 6.0) / 2.0)).abs() < 1e-12, "the short way round: {mid:?}");
        assert_eq!(trail.at(Timestamp(100 * MS)), Some(then));
        assert_eq!(trail.at(Timestamp(99 * MS)), None, "older than the trail");
        assert_eq!(trail.at(Timestamp(900 * MS)), Some(now));
        assert_eq!(OdometryTrail::default().at(Timestamp(0)), None);

        let ring = RingParams {
            angles_rad: vec![0.0, 0.5],
            mount_radius_m: 0.2,
            beam_width_rad: 0.0,
            min_range_m: 0.0,
            max_range_m: 5.0,
            fire_period_s: 0.05,
        };
        let reading = |sensor_id: u8, t: u64| orsa_interfaces::nomad200::DistanceReading {
            sensor_id,
            stamp: Timestamp(t * MS),
            valid: true,
            distance_m: 1.0,
        };
        let scan = DistanceScan {
            stamp: Timestamp(200 * MS),
            ring: orsa_interfaces::nomad200::Ring::Sonar,
            readings: vec![reading(0, 200), reading(1, 100)],
        };
        let end = |pose: Pose2, b: &Beam| {
            let r = b.range_m.expect("an echo");
            pose.apply(b.origin.0 + r * b.angle_rad.cos(), b.origin.1 + r * b.angle_rad.sin())
        };
        let (mut taken, mut moved) = (Vec::new(), Vec::new());
        ring_beams(&scan, &ring, &mut taken);
        ring_beams_at(&scan, &ring, &trail, now, &mut moved);
        // The reading taken now is where it was; the one taken before the turn, seen from the
        // body now, ends where it ended seen from the body then.
        assert_eq!(taken[0], moved[0]);
        let (want, got) = (end(then, &taken[1]), end(now, &moved[1]));
        assert!((want.0 - got.0).abs() < 1e-12 && (want.1 - got.1).abs() < 1e-12, "{want:?} {got:?}");
        // Without the trail it would be a quarter of a metre off.
        let naive = end(now, &taken[1]);
        assert!((naive.0 - want.0).hypot(naive.1 - want.1) > 0.25, "{naive:?} {want:?}");
        // A reading older than the trail is left out; with no trail yet, every reading is
        // taken where the robot is.
        let old = DistanceScan { readings: vec![reading(0, 200), reading(1, 50)], ..scan.clone() };
        moved.clear();
        ring_beams_at(&old, &ring, &trail, now, &mut moved);
        assert_eq!(moved, taken[..1], "the reading from before the trail is left out");
        moved.clear();
        ring_beams_at(&old, &ring, &OdometryTrail::default(), now, &mut moved);
        assert_eq!(moved.len(), 2);
    }
}
