//! Manoeuvres a behaviour makes instead of its cascade when the ring says it must: getting out of
//! a gap barely wider than the body ([`Wedge`]), turning round at a dead end ([`DeadEnd`]) and
//! getting out of a deadlock with people who wait for the robot ([`Unstick`]). Each is a small
//! state machine fed with the fused ring readings; the behaviours in [`crate::centerfollow`] and
//! [`crate::wallfollow`] decide which they use.

use crate::ring::{Ranges, RingGeometry, Side, front_min, projected, side_min, window_min, wrap};
use orsa_interfaces::nomad200::{RING_SIZE, bumper_angle_rad, ring_angle_rad};
use serde::{Deserialize, Serialize};

/// Getting out of a gap barely wider than the body.
///
/// The robot is wedged when its nearest left and right obstacles (sensors 1..7 and 9..15) add
/// up to less than `tight_gap_m` and something is within `open_front_m` ahead (45 degrees each
/// side). Then it turns in place, always in the direction it first chose (toward the more open
/// front diagonal), until the front is open again: choosing anew at each step makes it rock back
/// and forth between the two sides of the gap and never leave.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Wedge {
    turn: Option<f64>,
}

impl Wedge {
    /// The turn rate to turn in place at, while wedged; `None` when free.
    pub fn step(
        &mut self,
        r: &Ranges,
        tight_gap_m: f64,
        open_front_m: f64,
        omega_max_rad_s: f64,
    ) -> Option<f64> {
        let front_open = front_min(r).is_none_or(|d| d > open_front_m);
        if front_open {
            self.turn = None;
            return None;
        }
        let tight = match (side_min(r, Side::Left), side_min(r, Side::Right)) {
            (Some((_, l)), Some((_, rt))) => l + rt < tight_gap_m,
            _ => false,
        };
        if !tight && self.turn.is_none() {
            return None;
        }
        let open = |i: usize| r[i].unwrap_or(f64::INFINITY);
        let left_more_open = open(2).min(open(1)) >= open(14).min(open(15));
        Some(*self.turn.get_or_insert(if left_more_open { omega_max_rad_s } else { -omega_max_rad_s }))
    }
}

/// Turning round at a dead end, an orsa addition to center following.
///
/// At the closed end of a corridor the thesis' robot drove on until the master handed it to
/// wall following (front infrared under 0.50 m), which turned it round close to the end wall
/// and off the centre line. Here the robot turns round where the end is as far away as the
/// side walls, in place: the one spot from which a turn keeps it equally far from everything.
///
/// A dead end is ahead when sensors 15, 0 and 1 all see one flat wall square to the heading
/// (their readings, projected on the heading, agree within `flat_m`) no farther than the
/// farther side wall (sensors 3-5 and 11-13) plus `margin_m`, no nearer than the side walls
/// minus `margin_m + flat_m`, with the robot about as far from both sides and nothing within a
/// metre beyond that behind it (sensor 8). A person ahead does not look like that: beside the
/// one or two sensors it fills, the others see the side walls far off. The
/// robot then turns in place, always the same way (toward the more open side), until the front
/// is open and `alpha`, the wall angle, says it runs parallel to the walls again.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DeadEnd {
    /// The turn rate while turning, and the front distance when it began.
    turn: Option<(f64, f64)>,
}

impl DeadEnd {
    /// The turn rate to turn in place at; `None` when not at a dead end.
    pub fn step(
        &mut self,
        r: &Ranges,
        ring: &RingGeometry,
        alpha: Option<f64>,
        margin_m: f64,
        flat_m: f64,
        omega_max_rad_s: f64,
    ) -> Option<f64> {
        let ahead = |i: usize| r[i].map(|d| projected(i, d, 0.0, ring) - ring.radius_m);
        if let Some((turn, front_at_start)) = self.turn {
            // Open: nothing ahead within a metre beyond where the end wall was.
            let open = ahead(0).is_none_or(|d| d > front_at_start + 1.0);
            let parallel = alpha.is_some_and(|a| a.abs() < 5f64.to_radians());
            if open && parallel {
                self.turn = None;
                return None;
            }
            return Some(turn);
        }
        let (Some(f15), Some(f0), Some(f1)) = (ahead(15), ahead(0), ahead(1)) else {
            return None;
        };
        let (Some((_, left)), Some((_, right))) = (window_min(r, 3..=5), window_min(r, 11..=13)) else {
            return None;
        };
        let flat = f15.max(f0).max(f1) - f15.min(f0).min(f1) <= flat_m;
        // The way back must be open: a dead end is the end of a passage, not a tight spot.
        let behind_open = r[8].is_none_or(|d| d > f0 + 1.0);
        let centred = (left - right).abs() <= 2.0 * margin_m + flat_m;
        // As far ahead as to the sides: nearer, it is an obstacle in a passage, not its end.
        let far = left.max(right);
        let level = f0 <= far + margin_m && f0 >= far - margin_m - flat_m;
        if !flat || !behind_open || !centred || !level {
            return None;
        }
        let turn = if left >= right { omega_max_rad_s } else { -omega_max_rad_s };
        self.turn = Some((turn, f0));
        Some(turn)
    }
}

/// Getting out of a deadlock, an orsa addition to both behaviours (`[*.unstick]` in the config).
///
/// People in orsa's worlds, like polite people, wait while the robot is close. A robot blocked
/// ahead by a waiting person, with a wall on its other side, can then turn back and forth in
/// place for ever while nobody moves (EXPERIMENTS.md). When odometry says the robot has not
/// moved `progress_m` in `after_s`, it backs straight out at `back_m_s` for `back_s` (only while
/// nothing is within `rear_clear_m` of its back, sensors 6 to 10), then turns in place toward
/// the most open direction the ring sees (the widest opening: a sensor and both its neighbours
/// far), and drives on from there: the person it was facing can walk on, and the robot goes the
/// other way.
///
/// Contact is a deadlock at once. A robot pushing against something does not move, but its
/// wheels slip and its odometry goes on counting the progress it does not make, so the window
/// above never closes (wall following alone, seed 1: pinned against a waiting person for the
/// rest of the hour). The bumpers are what tells: while they report contact ahead of or beside
/// the body ([`Unstick::note_contact`], [`contact_direction`]), the robot backs out at once;
/// contact behind it while it backs ends the backing. If it cannot back out and still touches
/// something beside it, it turns toward the widest opening on the other side: straight on would
/// push it against what it touches again.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UnstickParams {
    /// Get out of deadlocks at all.
    pub enabled: bool,
    /// Not having moved `progress_m` for this long is a deadlock, s.
    pub after_s: f64,
    /// See `after_s`, m.
    pub progress_m: f64,
    /// Back out for this long, s.
    pub back_s: f64,
    /// At this speed, m/s (positive; the robot drives backwards).
    pub back_m_s: f64,
    /// Only while nothing is this close behind (sensors 6 to 10), m.
    pub rear_clear_m: f64,
}

impl Default for UnstickParams {
    fn default() -> Self {
        UnstickParams {
            enabled: true,
            after_s: 5.0,
            progress_m: 0.05,
            back_s: 1.5,
            back_m_s: 0.10,
            rear_clear_m: 0.25,
        }
    }
}

impl UnstickParams {
    /// Checks every value; the message names the offending key under `prefix`.
    pub fn validate(&self, prefix: &str) -> Result<(), orsa_actors::param::Invalid> {
        crate::cascade::check_positive(
            &format!("{prefix}.unstick"),
            &[
                ("after_s", self.after_s),
                ("progress_m", self.progress_m),
                ("back_s", self.back_s),
                ("back_m_s", self.back_m_s),
                ("rear_clear_m", self.rear_clear_m),
            ],
        )
    }
}

/// What [`Unstick`] is doing.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
enum Recovery {
    /// Watching for a deadlock.
    #[default]
    Watching,
    /// Backing out until then (ns).
    Backing { until: u64 },
    /// Turning in place at this rate until then (ns).
    Turning { omega: f64, until: u64 },
}

/// The state of the recovery that [`UnstickParams`] configures.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Unstick {
    /// Where the robot was when the current window began, and when (ns).
    window: Option<(u64, [f64; 2])>,
    /// The latest position (odometry), m.
    position: Option<[f64; 2]>,
    /// The latest contact the bumpers reported: when (ns), and its direction from the
    /// direction of travel (rad, counter-clockwise).
    contact: Option<(u64, f64)>,
    recovery: Recovery,
    /// The sectors no sensor of the robot covers (see
    /// [`orsa_interfaces::range::sector_coverage`]): never taken for open space behind.
    blind: [bool; RING_SIZE],
}

/// How long a contact report counts: the bumpers report every 30 ms while pressed.
const CONTACT_FRESH_NS: u64 = 100_000_000;

/// Where the bumpers pressed in `pressed` touch the body: the direction of their mean, from
/// the direction of travel (rad, counter-clockwise, in (-pi, pi]), `steer_rad` being the
/// direction of travel relative to the base (the bumpers are fixed to the base, which never
/// turns, not to the wheels); `None` when none is pressed.
pub fn contact_direction(pressed: &[bool], steer_rad: f64) -> Option<f64> {
    let (mut along, mut across, mut any) = (0.0, 0.0, false);
    for (i, _) in pressed.iter().enumerate().filter(|(_, p)| **p) {
        let a = bumper_angle_rad(i) - steer_rad;
        along += a.cos();
        across += a.sin();
        any = true;
    }
    any.then(|| across.atan2(along))
}

/// Whether a contact in direction `a` (from the direction of travel) is ahead of or beside the
/// body: within 120 degrees of the direction of travel. A robot pressed sideways against a
/// wall does not move either (the simulator does not let it slide), and backing out frees it.
fn ahead_or_beside(a: f64) -> bool {
    a.cos() >= -0.5
}

impl Unstick {
    /// Marks the sectors no sensor covers: the robot backs out only where every sector behind
    /// it is covered and clear, and otherwise turns in place at once.
    pub fn set_blind(&mut self, blind: [bool; RING_SIZE]) {
        self.blind = blind;
    }

    /// The robot is at `(x, y)` (odometry, m) at `now` (ns).
    pub fn note_position(&mut self, p: &UnstickParams, x: f64, y: f64, now: u64) {
        if !(x.is_finite() && y.is_finite()) {
            return;
        }
        self.position = Some([x, y]);
        match self.window {
            Some((_, [x0, y0])) if (x - x0).hypot(y - y0) < p.progress_m => {}
            _ => self.window = Some((now, [x, y])),
        }
    }

    /// The bumpers report contact at `now` (ns) in `direction_rad` from the direction of
    /// travel (see [`contact_direction`]).
    pub fn note_contact(&mut self, direction_rad: f64, now: u64) {
        if direction_rad.is_finite() {
            self.contact = Some((now, direction_rad));
        }
    }

    /// The direction of a contact reported within [`CONTACT_FRESH_NS`] of `now`.
    fn touching_at(&self, now: u64) -> Option<f64> {
        self.contact.filter(|(t, _)| now.abs_diff(*t) <= CONTACT_FRESH_NS).map(|(_, a)| a)
    }

    /// Whether a contact reported within [`CONTACT_FRESH_NS`] of `now` is ahead or beside
    /// (`ahead`), or behind.
    fn touching(&self, ahead: bool, now: u64) -> bool {
        self.touching_at(now).is_some_and(|a| ahead_or_beside(a) == ahead)
    }

    /// The command to give instead of the behaviour's own at `now` (ns), if it is getting out of
    /// a deadlock: `(v, omega)`.
    pub fn step(
        &mut self,
        p: &UnstickParams,
        r: &Ranges,
        omega_max_rad_s: f64,
        now: u64,
    ) -> Option<(f64, f64)> {
        if !p.enabled {
            return None;
        }
        if self.recovery == Recovery::Watching {
            let stalled =
                self.window.is_some_and(|(since, _)| (now.saturating_sub(since) as f64) * 1e-9 >= p.after_s);
            if !stalled && !self.touching(true, now) {
                return None;
            }
            self.recovery = Recovery::Backing { until: now + secs_ns(p.back_s) };
        }
        if let Recovery::Backing { until } = self.recovery {
            // A sector no sensor covers is not clear: it was not looked at.
            let rear_clear = (6..=10).all(|i| !self.blind[i] && r[i].is_none_or(|d| d > p.rear_clear_m));
            if now < until && rear_clear && !self.touching(false, now) {
                return Some((-p.back_m_s, 0.0));
            }
            // Still touching something beside it (it could not back away): not straight on,
            // into it again, but to the other side.
            let away = self.touching_at(now).filter(|a| ahead_or_beside(*a) && a.sin().abs() > 0.5);
            let angle = wrap(ring_angle_rad(widest_opening(r, away.map(|a| -a.sin().signum()))));
            // Steering takes about half a second to reach full rate.
            let until = now + secs_ns(angle.abs() / omega_max_rad_s + 0.5);
            let omega = if angle >= 0.0 { omega_max_rad_s } else { -omega_max_rad_s };
            self.recovery =
                if angle == 0.0 { Recovery::Watching } else { Recovery::Turning { omega, until } };
        }
        if let Recovery::Turning { omega, until } = self.recovery
            && now < until
        {
            return Some((0.0, omega));
        }
        self.recovery = Recovery::Watching;
        self.restart(now);
        None
    }

    /// A new window from where the robot is now.
    fn restart(&mut self, now: u64) {
        self.window = self.position.map(|p| (now, p));
    }
}

fn secs_ns(s: f64) -> u64 {
    (s * 1e9) as u64
}

/// The sensor facing the widest opening: the one whose reading and both neighbours' are
/// farthest (an opening, not a gap beside a person), the smallest turn first among equals;
/// with `side` (1: left, -1: right), only among the sensors on that side (1-7 or 9-15).
fn widest_opening(r: &Ranges, side: Option<f64>) -> usize {
    let far = |i: usize| r[i % RING_SIZE].unwrap_or(f64::INFINITY);
    let mut best = (0usize, f64::NEG_INFINITY);
    let on_side = |i: usize| match side {
        Some(s) if s > 0.0 => (1..=7).contains(&i),
        Some(_) => (9..=15).contains(&i),
        None => true,
    };
    for i in [0, 1, 15, 2, 14, 3, 13, 4, 12, 5, 11, 6, 10, 7, 9, 8].into_iter().filter(|&i| on_side(i)) {
        let d = far(i + RING_SIZE - 1).min(far(i)).min(far(i + 1));
        if d > best.1 {
            best = (i, d);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ring::synthetic::{dead_end, scene};
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn a_wedged_robot_keeps_turning_one_way_until_the_front_is_open() {
        let mut w = Wedge::default();
        let mut r = [None; RING_SIZE];
        r[4] = Some(0.05);
        r[12] = Some(0.02);
        r[1] = Some(0.10);
        r[15] = Some(0.20);
        // Wedged; the right diagonal is more open: turn right.
        assert_eq!(w.step(&r, 0.15, 0.3, 0.8), Some(-0.8));
        // The diagonals swap as it turns: it keeps turning right, it does not rock back.
        r[1] = Some(0.25);
        r[15] = Some(0.05);
        assert_eq!(w.step(&r, 0.15, 0.3, 0.8), Some(-0.8));
        // Front open: free again.
        for i in [14, 15, 0, 1, 2] {
            r[i] = None;
        }
        assert_eq!(w.step(&r, 0.15, 0.3, 0.8), None);
        // Sides wide apart: not wedged, whatever is ahead.
        let mut r = [None; RING_SIZE];
        r[4] = Some(0.5);
        r[12] = Some(0.5);
        r[0] = Some(0.1);
        assert_eq!(Wedge::default().step(&r, 0.15, 0.3, 0.8), None);
    }

    #[test]
    fn a_dead_end_turns_the_robot_round_where_the_end_is_as_far_as_the_sides() {
        let w = 45f64.to_radians();
        let mut d = DeadEnd::default();
        let (far, ring) = dead_end(2.0, 0.0, &[]);
        assert_eq!(d.step(&far, &ring, Some(0.0), 0.05, 0.10, w), None, "the end is still far");
        let (near, ring) = dead_end(1.22, 0.0, &[]);
        let turn = d.step(&near, &ring, Some(0.0), 0.05, 0.10, w).expect("turns round here");
        assert_eq!(turn.abs(), w);
        // Half way round the end wall is beside it: it keeps turning the same way.
        let (side, ring) = dead_end(1.22, FRAC_PI_2, &[]);
        assert_eq!(d.step(&side, &ring, Some(0.4), 0.05, 0.10, w), Some(turn));
        // Round, but not yet parallel to the walls: still turning.
        let (round, ring) = dead_end(1.22, PI, &[]);
        assert_eq!(d.step(&round, &ring, Some(0.2), 0.05, 0.10, w), Some(turn));
        // Round and parallel: done, and the wall now behind does not start it again.
        assert_eq!(d.step(&round, &ring, Some(0.01), 0.05, 0.10, w), None);
        assert_eq!(d.step(&round, &ring, Some(0.01), 0.05, 0.10, w), None);
    }

    #[test]
    fn a_person_ahead_or_behind_is_not_a_dead_end() {
        let w = 45f64.to_radians();
        // A corridor with no end, a person straight ahead at 1.2 m from the centre.
        let (r, ring) = dead_end(40.0, 0.0, &[(1.45, 0.0, 0.25)]);
        assert!(r[0].is_some_and(|d| d < 1.0), "the person is seen: {:?}", r[0]);
        assert_eq!(DeadEnd::default().step(&r, &ring, Some(0.0), 0.05, 0.10, w), None);
        // A real dead end with somebody close behind: no room to have come from, no turn.
        let (r, ring) = dead_end(1.22, 0.0, &[(-0.9, 0.0, 0.25)]);
        assert_eq!(DeadEnd::default().step(&r, &ring, Some(0.0), 0.05, 0.10, w), None);
        // The end seen off the centre line: not the turning spot.
        let hb = 12.5f64.to_radians();
        let walls = [(FRAC_PI_2, 0.7), (-FRAC_PI_2, 1.7), (0.0, 1.22)];
        let r = scene(&walls, &[], 0.0, 0.25, 6.0, hb);
        assert_eq!(
            DeadEnd::default().step(&r, &RingGeometry::uniform(0.25, 2.0 * hb), Some(0.0), 0.05, 0.10, w),
            None
        );
    }

    const S: u64 = 1_000_000_000;

    #[test]
    fn a_robot_that_stopped_making_progress_backs_out_and_turns_to_the_open_side() {
        let p = UnstickParams::default();
        let w = 45f64.to_radians();
        let mut u = Unstick::default();
        // Blocked all round but behind (sensors 7-9), and a gap (sensor 4) beside a person.
        let mut r: Ranges = [Some(0.3); RING_SIZE];
        r[4] = None;
        r[6] = Some(2.0);
        r[7..=9].fill(Some(3.0));
        u.note_position(&p, 1.0, 1.0, 0);
        // Creeping 1 cm a second is no progress.
        for k in 0..5 {
            u.note_position(&p, 1.0 + 0.01 * k as f64, 1.0, k * S);
            assert_eq!(u.step(&p, &r, w, k * S), None, "{k} s: still its own command");
        }
        // Five seconds without 5 cm: back out, straight.
        assert_eq!(u.step(&p, &r, w, 5 * S), Some((-0.10, 0.0)));
        assert_eq!(u.step(&p, &r, w, 6 * S), Some((-0.10, 0.0)));
        // After 1.5 s, turn toward the widest opening (sensor 8, half a turn, not the farther
        // but narrow gap of sensor 4; left first among equals) for pi/w + 0.5 s.
        let (v, omega) = u.step(&p, &r, w, 6 * S + S / 2).expect("turning");
        assert_eq!((v, omega), (0.0, w));
        let turn_ns = ((PI / w + 0.5) * 1e9) as u64;
        assert_eq!(u.step(&p, &r, w, 6 * S + S / 2 + turn_ns - 1), Some((0.0, w)));
        assert_eq!(u.step(&p, &r, w, 6 * S + S / 2 + turn_ns), None, "done: drives on");
        // And watches afresh from there.
        assert_eq!(u.step(&p, &r, w, 10 * S + turn_ns), None);
    }

    #[test]
    fn progress_keeps_it_quiet_and_a_blocked_back_skips_the_backing() {
        let p = UnstickParams::default();
        let w = 45f64.to_radians();
        let mut u = Unstick::default();
        let mut r: Ranges = [None; RING_SIZE];
        for k in 0..60 {
            u.note_position(&p, 0.1 * k as f64, 0.0, k * S);
            assert_eq!(u.step(&p, &r, w, k * S), None, "moving: never");
        }
        // Stuck with somebody right behind (sensor 7) and the right side open (sensors 11-13).
        r = [Some(0.3); RING_SIZE];
        r[7] = Some(0.1);
        r[11..=13].fill(Some(2.0));
        let mut u = Unstick::default();
        u.note_position(&p, 0.0, 0.0, 0);
        assert_eq!(u.step(&p, &r, w, 5 * S), Some((0.0, -w)), "no backing into the person: turn right");
        // Disabled: nothing, ever.
        let off = UnstickParams { enabled: false, ..p };
        let mut u = Unstick::default();
        u.note_position(&off, 0.0, 0.0, 0);
        assert_eq!(u.step(&off, &r, w, 100 * S), None);
        assert!(
            UnstickParams { back_s: 0.0, ..p }
                .validate("centerfollow")
                .is_err_and(|e| e.key == "centerfollow.unstick.back_s")
        );
    }

    #[test]
    fn contact_ahead_backs_out_at_once_though_odometry_says_it_moves() {
        let p = UnstickParams::default();
        let w = 45f64.to_radians();
        let mut u = Unstick::default();
        // Open only behind (sensors 7-9).
        let mut r: Ranges = [Some(0.3); RING_SIZE];
        r[7..=9].fill(Some(3.0));
        // Wheels slipping against a person: odometry counts 25 cm a second.
        for k in 0..3 {
            u.note_position(&p, 0.25 * k as f64, 0.0, k * S);
            assert_eq!(u.step(&p, &r, w, k * S), None);
        }
        u.note_contact(0.0, 3 * S);
        u.note_position(&p, 0.75, 0.0, 3 * S);
        assert_eq!(u.step(&p, &r, w, 3 * S + 10), Some((-0.10, 0.0)), "backs out at once");
        // Contact behind while backing ends the backing: it turns instead.
        u.note_contact(PI, 3 * S + S / 2);
        assert_eq!(
            u.step(&p, &r, w, 3 * S + S / 2),
            Some((0.0, w)),
            "turns to the open side, no more backing"
        );
        // A contact report goes stale after a tenth of a second; one behind never starts a
        // recovery.
        let mut u = Unstick::default();
        u.note_position(&p, 0.0, 0.0, 0);
        u.note_contact(0.0, 0);
        assert_eq!(u.step(&p, &r, w, S / 5), None, "stale");
        u.note_contact(PI, S / 5);
        assert_eq!(u.step(&p, &r, w, S / 5), None, "behind");
        // Turned off, contact does nothing either.
        let off = UnstickParams { enabled: false, ..p };
        u.note_contact(0.0, S);
        assert_eq!(u.step(&off, &r, w, S), None);
    }

    #[test]
    fn contact_is_placed_relative_to_the_direction_of_travel() {
        use orsa_interfaces::nomad200::BUMPER_COUNT;
        let pressed = |ids: &[usize]| {
            let mut p = vec![false; BUMPER_COUNT];
            for &i in ids {
                p[i] = true;
            }
            p
        };
        let ahead = |ids: &[usize], steer: f64| contact_direction(&pressed(ids), steer).map(ahead_or_beside);
        assert_eq!(contact_direction(&pressed(&[]), 0.0), None);
        // Bumper 0 faces the base's start-up heading, bumper 5 the opposite way.
        assert_eq!(ahead(&[0, 10], 0.0), Some(true));
        assert_eq!(ahead(&[5, 15], 0.0), Some(false));
        // The wheels have turned half round: the same bumpers are now behind and ahead.
        assert_eq!(ahead(&[0, 10], PI), Some(false));
        assert_eq!(ahead(&[5, 15], PI), Some(true));
        // Beside (bumper 7 at 252 degrees, with the robot steering at -90): counts as ahead.
        let beside = contact_direction(&pressed(&[7]), -FRAC_PI_2).expect("pressed");
        assert!((beside - (-18f64).to_radians()).abs() < 1e-9, "{beside}");
        // 144 degrees off the direction of travel: behind.
        assert_eq!(ahead(&[4], 0.0), Some(false));
    }

    #[test]
    fn pressed_sideways_with_no_room_behind_it_turns_away_from_what_it_touches() {
        let p = UnstickParams::default();
        let w = 45f64.to_radians();
        // A wall close on the right and behind; open straight ahead, less so to the left.
        let mut r: Ranges = [None; RING_SIZE];
        r[7..=14].fill(Some(0.05));
        r[2..=6].fill(Some(0.4));
        let mut u = Unstick::default();
        u.note_position(&p, 0.0, 0.0, 0);
        u.note_contact(-FRAC_PI_2, S);
        // It cannot back out; straight on is the widest opening, but that pushes it into the
        // wall again: it turns left, toward the widest opening on that side (sensor 1).
        let (v, omega) = u.step(&p, &r, w, S).expect("recovering");
        assert_eq!((v, omega), (0.0, w));
        // Touching ahead (not beside), it may go straight on after all: nothing to turn away from.
        let mut u = Unstick::default();
        u.note_position(&p, 0.0, 0.0, 0);
        u.note_contact(0.2, S);
        assert_eq!(u.step(&p, &r, w, S), None, "the widest opening is straight ahead");
    }
}
