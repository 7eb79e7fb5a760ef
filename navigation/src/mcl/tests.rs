//! Localization on a synthetic room: tracking with drifting odometry, and recovery after the
//! robot is carried elsewhere.

use super::*;
use crate::field::is_occupied;
use orsa_interfaces::map::OCCUPIED;

const RES: f64 = 0.05;

/// A 10 m x 6 m room with a cabinet, a pillar and a partition: no two places look alike.
pub(crate) fn room() -> OccupancyGrid {
    let (w, h) = (200u32 + 4, 120u32 + 4);
    let mut g = OccupancyGrid::filled(RES, w, h, (-0.1, -0.1), FREE);
    let occupy = |g: &mut OccupancyGrid, f: &dyn Fn(f64, f64) -> bool| {
        for iy in 0..g.height {
            for ix in 0..g.width {
                let (x, y) = g.centre(ix, iy);
                if f(x, y) {
                    let i = g.index(ix, iy);
                    g.cells[i] = OCCUPIED;
                }
            }
        }
    };
    occupy(&mut g, &|x, y| !(0.0..=10.0).contains(&x) || !(0.0..=6.0).contains(&y));
    occupy(&mut g, &|x, y| (1.0..=2.2).contains(&x) && (4.8..=6.0).contains(&y));
    occupy(&mut g, &|x, y| (x - 7.0).hypot(y - 2.0) <= 0.3);
    occupy(&mut g, &|x, y| (4.0..=4.1).contains(&x) && (0.0..=2.5).contains(&y));
    g
}

/// 16 beams round a 0.25 m body, as a ring reads them from `truth` (ray cast on the grid,
/// with noise).
pub(crate) fn read(g: &OccupancyGrid, truth: Pose2, rng: &mut ChaCha8Rng) -> Vec<Beam> {
    (0..16)
        .map(|i| {
            let a = f64::from(i) * TAU / 16.0;
            let origin = (0.25 * a.cos(), 0.25 * a.sin());
            let (ox, oy) = truth.apply(origin.0, origin.1);
            let (dx, dy) = ((truth.theta + a).cos(), (truth.theta + a).sin());
            let max = 4.0;
            let mut r = 0.0;
            let hit = loop {
                if r > max {
                    break None;
                }
                if is_occupied(g.at(ox + r * dx, oy + r * dy)) {
                    break Some(r);
                }
                r += RES / 4.0;
            };
            let noise: f64 = StandardNormal.sample(rng);
            Beam {
                origin,
                angle_rad: a,
                half_width_rad: 0.0,
                range_m: hit.map(|r| r + 0.02 * noise),
                max_range_m: max,
            }
        })
        .collect()
}

/// The simulated robot: where it is, where its odometry thinks it is, its noise.
struct Robot {
    truth: Pose2,
    odom: Pose2,
    start: Pose2,
    rng: ChaCha8Rng,
    k: usize,
}

impl Robot {
    fn at(start: Pose2, seed: u64) -> Robot {
        Robot { truth: start, odom: Pose2::default(), start, rng: ChaCha8Rng::seed_from_u64(seed), k: 0 }
    }

    /// How far odometry, placed at the start, is from the truth, m.
    fn odom_error(&self) -> f64 {
        let (x, y) = self.start.apply(0.0, 0.0);
        let (s, c) = self.start.theta.sin_cos();
        let (ox, oy) = (x + c * self.odom.x - s * self.odom.y, y + s * self.odom.x + c * self.odom.y);
        (ox - self.truth.x).hypot(oy - self.truth.y)
    }
}

/// Drives `steps` of 0.1 s through the room (0.3 m/s, weaving, turning away from what comes
/// close), with odometry that drifts (3 % long, 2 degrees per metre to the left), updating
/// `loc`; returns the largest error of the estimate after `settle` updates of this drive.
fn drive(loc: &mut Localizer, robot: &mut Robot, steps: usize, settle: u64) -> f64 {
    let g = room();
    let mut worst: f64 = 0.0;
    let first = loc.updates();
    for _ in 0..steps {
        let ahead = read(&g, robot.truth, &mut robot.rng);
        let front = ahead[0].range_m.unwrap_or(4.0).min(ahead[1].range_m.unwrap_or(4.0));
        let (v, w) = if front < 0.8 { (0.0, 0.8) } else { (0.3, 0.25 * ((robot.k / 80) as f64 * PI).cos()) };
        robot.k += 1;
        let (d, t) = (v * 0.1, w * 0.1);
        let tr = robot.truth;
        robot.truth = Pose2::new(tr.x + d * tr.theta.cos(), tr.y + d * tr.theta.sin(), wrap(tr.theta + t));
        let (od, ot) = (d * 1.03, t + d * 2f64.to_radians());
        let o = robot.odom;
        robot.odom = Pose2::new(o.x + od * o.theta.cos(), o.y + od * o.theta.sin(), wrap(o.theta + ot));
        let beams = read(&g, robot.truth, &mut robot.rng);
        if loc.update(robot.odom, &beams) && loc.updates() - first > settle {
            let e = loc.estimate().pose;
            worst = worst.max((e.x - robot.truth.x).hypot(e.y - robot.truth.y));
        }
    }
    worst
}

fn error(loc: &Localizer, robot: &Robot) -> f64 {
    let e = loc.estimate().pose;
    (e.x - robot.truth.x).hypot(e.y - robot.truth.y)
}

#[test]
fn it_tracks_the_robot_where_odometry_drifts_away() {
    for seed in 1..=3 {
        let start = Pose2::new(2.0, 1.5, 0.3);
        let mut loc = Localizer::new(&room(), MclParams::default(), seed).expect("localizer");
        loc.reset_at(start, 0.1, 0.05).expect("a pose");
        let mut robot = Robot::at(start, seed);
        let worst = drive(&mut loc, &mut robot, 900, 0);
        assert!(
            robot.odom_error() > 0.5,
            "seed {seed}: odometry drifted only {} m: no test",
            robot.odom_error()
        );
        assert!(worst < 0.2, "seed {seed}: the estimate strayed {worst} m from the truth");
        let cov = loc.estimate().covariance;
        assert!(cov[0][0] > 0.0 && cov[0][0] < 0.05 && cov[2][2] < 0.05, "seed {seed}: covariance {cov:?}");
    }
}

#[test]
fn a_robot_anywhere_is_found_within_30_s_of_driving() {
    for seed in 1..=3 {
        let mut loc = Localizer::new(&room(), MclParams::searching(), seed).expect("localizer");
        let mut robot = Robot::at(Pose2::new(8.5, 4.5, 2.0), seed);
        drive(&mut loc, &mut robot, 300, 0);
        let worst = drive(&mut loc, &mut robot, 100, 0);
        assert!(worst < 0.3, "seed {seed}: {worst} m off in the 10 s after 30 s of driving");
    }
}

#[test]
fn a_kidnapped_robot_is_found_again_within_30_s_of_driving() {
    for seed in 1..=3 {
        let start = Pose2::new(2.0, 1.5, 0.3);
        let mut loc = Localizer::new(&room(), MclParams::searching(), seed).expect("localizer");
        loc.reset_at(start, 0.1, 0.05).expect("a pose");
        let mut robot = Robot::at(start, seed);
        assert!(drive(&mut loc, &mut robot, 200, 0) < 0.2, "seed {seed}: tracking before");
        // Carried to the other side of the partition without a word to odometry.
        robot.truth = Pose2::new(7.5, 4.5, -2.0);
        assert!(error(&loc, &robot) > 2.0);
        drive(&mut loc, &mut robot, 300, 0);
        let worst = drive(&mut loc, &mut robot, 100, 0);
        assert!(worst < 0.3, "seed {seed}: {worst} m off in the 10 s after 30 s of driving");
    }
}

#[test]
fn bad_parameters_are_refused_by_key_and_a_map_with_no_floor_too() {
    let cases: [(&str, MclParams); 4] = [
        ("particles", MclParams { particles: 0, ..MclParams::default() }),
        ("sigma_hit_m", MclParams { sigma_hit_m: f64::NAN, ..MclParams::default() }),
        ("z_rand", MclParams { z_rand: 1.5, ..MclParams::default() }),
        ("alpha", MclParams { alpha: [0.1, -0.1, 0.1, 0.1], ..MclParams::default() }),
    ];
    for (key, params) in cases {
        let e = Localizer::new(&room(), params, 1).expect_err(key);
        assert!(e.to_string().starts_with(&format!("{key}: ")), "{e}");
    }
    let walls = OccupancyGrid::filled(RES, 4, 4, (0.0, 0.0), OCCUPIED);
    assert_eq!(Localizer::new(&walls, MclParams::default(), 1).expect_err("no floor"), MclError::NoFreeCell);
}

#[test]
fn bad_input_from_outside_neither_panics_nor_poisons_the_estimate() {
    let start = Pose2::new(2.0, 1.5, 0.3);
    // A reading no model explains (z_rand 0, a beam ending far from anything) and a beam of
    // infinite range: the weights stay numbers.
    let params = MclParams { z_rand: 0.0, field_max_m: 5.0, ..MclParams::default() };
    let mut loc = Localizer::new(&room(), params, 1).expect("localizer");
    loc.reset_at(start, 0.1, 0.05).expect("a pose");
    let far = Beam {
        origin: (0.0, 0.0),
        angle_rad: 0.0,
        half_width_rad: 0.0,
        range_m: Some(3.0),
        max_range_m: 3.5,
    };
    let endless = Beam { max_range_m: f64::INFINITY, ..far };
    assert!(!loc.update(Pose2::new(0.0, 0.0, 0.0), &[far]));
    assert!(loc.update(Pose2::new(0.2, 0.0, 0.0), &[far, endless]));
    // An odometry pose that is not finite is ignored.
    assert!(!loc.update(Pose2::new(f64::NAN, 0.0, 0.0), &[far]));
    assert!(loc.update(Pose2::new(0.4, 0.0, 0.0), &[far]));
    let e = loc.estimate();
    assert!(e.pose.x.is_finite() && e.pose.y.is_finite() && e.covariance[0][0].is_finite(), "{e:?}");
    assert!((e.pose.x - 2.4).hypot(e.pose.y - 1.6) < 1.0, "{e:?}");
    // A pose given by hand that is not finite is refused, and the particles kept.
    assert!(matches!(loc.reset_at(Pose2::new(f64::NAN, 1.0, 0.0), 0.1, 0.1), Err(MclError::Pose(..))));
    assert!(matches!(loc.reset_at(start, -0.1, 0.1), Err(MclError::Pose(..))));
    assert!(loc.estimate().pose.x.is_finite());
    // A grid short of cells, or with no size to its cells, is refused, not a panic.
    let mut short = room();
    short.cells.pop();
    assert!(matches!(Localizer::new(&short, MclParams::default(), 1), Err(MclError::Grid(_))));
    let mut flat = room();
    flat.resolution_m = 0.0;
    assert!(matches!(Localizer::new(&flat, MclParams::default(), 1), Err(MclError::Grid(_))));
}

#[test]
fn a_seed_gives_the_same_estimates() {
    let run = |seed| {
        let start = Pose2::new(2.0, 1.5, 0.3);
        let mut loc = Localizer::new(&room(), MclParams::default(), seed).expect("localizer");
        loc.reset_at(start, 0.1, 0.05).expect("a pose");
        drive(&mut loc, &mut Robot::at(start, 5), 100, 0);
        loc.estimate()
    };
    assert_eq!(run(4), run(4));
    assert_ne!(run(4), run(5));
}

/// `MclParams::searching` was chosen on seeds 1-6 (against 500 particles and `sigma_hit_m`
/// 0.1, 0.3, which found the robot from anywhere 3-5 times in 6); this holds it to seeds it was
/// not chosen on. Slow-ish (a few seconds): `cargo test -p orsa-navigation -- --ignored`.
#[test]
#[ignore]
fn on_seeds_not_tuned_on_it_tracks_finds_and_refinds_the_robot() {
    let params = MclParams::searching();
    let (mut found, mut refound, mut tracked) = (0, 0, 0);
    let seeds = 7..=18;
    for seed in seeds.clone() {
        let mut loc = Localizer::new(&room(), params.clone(), seed).expect("localizer");
        let mut robot = Robot::at(Pose2::new(8.5, 4.5, 2.0), seed);
        drive(&mut loc, &mut robot, 300, 0);
        found += usize::from(drive(&mut loc, &mut robot, 100, 0) < 0.3);
        let start = Pose2::new(2.0, 1.5, 0.3);
        let mut loc = Localizer::new(&room(), params.clone(), seed).expect("localizer");
        loc.reset_at(start, 0.1, 0.05).expect("a pose");
        let mut robot = Robot::at(start, seed);
        tracked += usize::from(drive(&mut loc, &mut robot, 900, 0) < 0.2);
        robot.truth = Pose2::new(7.5, 4.5, -2.0);
        drive(&mut loc, &mut robot, 300, 0);
        refound += usize::from(drive(&mut loc, &mut robot, 100, 0) < 0.3);
    }
    let n = seeds.count();
    println!(
        "seeds 7-18: tracked {tracked}/{n}, found from anywhere {found}/{n}, found after a kidnapping {refound}/{n}"
    );
    assert_eq!(tracked, n);
    assert!(refound >= n - 1 && found >= n * 3 / 4, "found {found}, refound {refound} of {n}");
}
