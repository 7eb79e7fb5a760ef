//! The synchro drive: acceleration and limits, stopping at contact (never penetrating),
//! turning in place, sliding, odometry with and without drift.

mod common;

use common::*;
use orsa_hardware::board::{AxisAccelerations, AxisVelocities};
use orsa_hardware::geometry::Point;
use orsa_hardware::sim::{DriveConfig, SimConfig, SimNomad200};
use orsa_hardware::world::World;
use proptest::prelude::*;

const R: f64 = 0.25;
const MARGIN: f64 = 1e-6;

fn run_until_blocked(sim: &mut SimNomad200) {
    for _ in 0..5000 {
        sim.step();
        if sim.truth().translation_blocked {
            return;
        }
    }
    panic!("never blocked: {:?}", sim.truth());
}

fn settle(sim: &mut SimNomad200) {
    sim.stop();
    while !sim.is_stopped() {
        sim.step();
    }
}

#[test]
fn acceleration_and_velocity_limits_shape_the_motion() {
    let mut sim = exact(empty(0.0, 0.0, 0.0));
    sim.move_velocity(AxisVelocities::synchro(1.0, 0.0)).expect("cmd");
    sim.run_for(ms(500));
    assert!((sim.truth().v_m_s - 0.25).abs() < 1e-9, "0.5 m/s^2 for 0.5 s");
    sim.run_for(ms(1500));
    let t = sim.truth();
    assert!((t.v_m_s - 0.5).abs() < 1e-12, "saturated at the 0.5 m/s limit");
    assert!((t.x_m - 0.75).abs() < 1e-9, "0.25 m ramping + 0.5 m cruising: {}", t.x_m);
    sim.set_velocity_limits(AxisVelocities::synchro(0.2, 0.5)).expect("limits");
    sim.set_accelerations(AxisAccelerations { translate_m_s2: 1.0, steer_rad_s2: 1.0, turret_rad_s2: 1.0 })
        .expect("acc");
    sim.run_for(ms(300));
    assert!((sim.truth().v_m_s - 0.2).abs() < 1e-12, "down to the new limit at 1 m/s^2");
    assert!(
        sim.set_accelerations(AxisAccelerations {
            translate_m_s2: 1.5,
            steer_rad_s2: 1.0,
            turret_rad_s2: 1.0
        })
        .is_err()
    );
    // Steering is limited to 45 deg/s.
    sim.set_velocity_limits(AxisVelocities::synchro(0.5, 45f64.to_radians())).expect("limits");
    sim.move_velocity(AxisVelocities::synchro(0.0, 10.0)).expect("cmd");
    sim.run_for(ms(2000));
    assert!((sim.truth().omega_rad_s - 45f64.to_radians()).abs() < 1e-9);
    assert!((sim.truth().turret_omega_rad_s - 45f64.to_radians()).abs() < 1e-9, "the turret follows");
}

#[test]
fn blocked_translation_stops_at_contact_and_odometry_keeps_counting() {
    let mut sim = exact(facing_wall(1.0, 0.0));
    sim.move_velocity(AxisVelocities::synchro(0.3, 0.0)).expect("cmd");
    sim.run_for(ms(5000));
    let t = sim.truth();
    assert!((t.x_m - (1.0 - R - MARGIN)).abs() < 1e-9, "stopped at contact: {}", t.x_m);
    assert_eq!(t.y_m, 0.0);
    assert!(t.translation_blocked && t.v_m_s == 0.0 && t.in_contact);
    let gap = sim.truth_nearest_obstacle().expect("a wall");
    assert!(gap > 0.0 && gap < 2.0 * MARGIN, "{gap}");
    // The motors ran the whole time: 0.09 m ramping to 0.3 m/s in 0.6 s, then 4.4 s at 0.3.
    let odo = sim.motor_state();
    assert!((odo.x_m - 1.41).abs() < 1e-9, "odometry counted the slipping wheels: {}", odo.x_m);
    assert_eq!(odo.velocities.translate_m_s, 0.3);
    assert!((t.travelled_m - (0.75 - MARGIN)).abs() < 1e-9);
}

#[test]
fn turning_in_place_sliding_and_backing_off_work_at_contact() {
    let mut sim = exact(facing_wall(1.0, 0.0));
    sim.move_velocity(AxisVelocities::synchro(0.3, 0.0)).expect("cmd");
    run_until_blocked(&mut sim);
    settle(&mut sim);
    let at_wall = sim.truth();
    // Turn in place towards +y: always allowed, the body does not move.
    sim.move_velocity(AxisVelocities::synchro(0.0, 0.6)).expect("cmd");
    while sim.truth().heading_rad < std::f64::consts::FRAC_PI_2 - 0.08 {
        sim.step();
        assert_eq!((sim.truth().x_m, sim.truth().y_m), (at_wall.x_m, at_wall.y_m));
    }
    settle(&mut sim);
    let heading = sim.truth().heading_rad;
    assert!(heading > 1.4, "{heading}");
    // Translate: the part of the motion along the wall happens, the part into it does not.
    sim.move_velocity(AxisVelocities::synchro(0.3, 0.0)).expect("cmd");
    sim.run_for(ms(2000));
    let t = sim.truth();
    assert!(t.y_m > 0.3, "slid along the wall: {}", t.y_m);
    assert!(t.x_m <= at_wall.x_m + 1e-12 && t.x_m > at_wall.x_m - 0.1, "{}", t.x_m);
    let gap = sim.truth_nearest_obstacle().expect("wall");
    assert!(gap >= MARGIN * 0.5 - 1e-12, "{gap}");
    // Back off: heading stays, velocity negative.
    let y = t.y_m;
    sim.move_velocity(AxisVelocities::synchro(-0.3, 0.0)).expect("cmd");
    sim.run_for(ms(4000));
    assert!(sim.truth().y_m < y - 0.5, "backed up along the heading");
}

#[test]
fn a_concave_corner_stops_the_body_on_both_walls() {
    let mut sim = exact(room(2.0, 2.0, 1.0, 1.0, 45.0));
    sim.move_velocity(AxisVelocities::synchro(0.4, 0.0)).expect("cmd");
    sim.run_for(ms(6000));
    let t = sim.truth();
    let stop = 2.0 - R - MARGIN;
    assert!((t.x_m - stop).abs() < 1e-9 && (t.y_m - stop).abs() < 1e-9, "{t:?}");
}

#[test]
fn a_box_corner_stops_the_body_where_geometry_says() {
    let mut w = empty(0.0, 0.1, 0.0);
    w.boxes.push(boxed([1.0, 0.3], [2.0, 1.0]));
    let mut sim = exact(w);
    sim.move_velocity(AxisVelocities::synchro(0.3, 0.0)).expect("cmd");
    sim.run_for(ms(6000));
    let expected = 1.0 - ((R + MARGIN).powi(2) - 0.2f64.powi(2)).sqrt();
    assert!((sim.truth().x_m - expected).abs() < 1e-9, "{} vs {expected}", sim.truth().x_m);
    assert!(sim.truth().in_contact);
}

#[test]
fn odometry_without_drift_matches_the_truth_to_its_resolution() {
    // Start facing +y: the odometry frame is the start pose, so odometry x is world +y.
    let mut sim = exact(empty(5.0, 5.0, 90.0));
    sim.move_velocity(AxisVelocities::synchro(0.3, 0.2)).expect("cmd");
    for _ in 0..1000 {
        sim.step();
        let (t, o) = (sim.truth(), sim.motor_state());
        let (dx, dy) = (t.x_m - 5.0, t.y_m - 5.0);
        assert!((o.x_m - dy).abs() <= 0.00125 + 1e-9, "{} vs {dy}", o.x_m);
        assert!((o.y_m + dx).abs() <= 0.00125 + 1e-9, "{} vs {}", o.y_m, -dx);
        for v in [o.x_m, o.y_m] {
            assert!(((v / 0.0025) - (v / 0.0025).round()).abs() < 1e-6, "quantised to 2.5 mm: {v}");
        }
        let h = o.heading_rad.to_degrees();
        assert!((h * 10.0 - (h * 10.0).round()).abs() < 1e-6, "quantised to 0.1 deg: {h}");
        let err = (o.heading_rad - (t.heading_rad - std::f64::consts::FRAC_PI_2)).sin().abs();
        assert!(err <= 0.05f64.to_radians() + 1e-9, "heading within half a resolution step");
    }
}

#[test]
fn odometry_drifts_with_the_default_factors() {
    let mut sim = SimNomad200::new(empty(0.0, 0.0, 0.0), SimConfig::default(), 3).expect("sim");
    sim.move_velocity(AxisVelocities::synchro(0.5, 0.0)).expect("cmd");
    sim.run_for(ms(4500));
    settle(&mut sim);
    let (t, o) = (sim.truth(), sim.motor_state());
    // 0.25 m ramping up, 1.75 m cruising, 0.25 m ramping down.
    assert!((t.x_m - 2.25).abs() < 1e-9 && t.y_m == 0.0, "truth drove straight: {t:?}");
    // Odometry: 0.5 % long, curving left 0.05 deg per metre (0.1125 deg, reported as 0.1).
    let odo_len = (o.x_m.powi(2) + o.y_m.powi(2)).sqrt();
    assert!((odo_len - 2.26125).abs() < 0.002, "{odo_len}");
    assert!((o.heading_rad.to_degrees() - 0.1).abs() < 1e-9, "{}", o.heading_rad.to_degrees());
    assert!(o.y_m > 0.0, "curves left");
    sim.zero_axes();
    let z = sim.motor_state();
    assert_eq!((z.x_m, z.y_m, z.heading_rad, z.steer_rad, z.turret_rad), (0.0, 0.0, 0.0, 0.0, 0.0));
}

// ---- Never penetrating, whatever the commands -------------------------------------------

/// A command held for a number of steps: translate, steer and turret velocities.
fn command() -> impl Strategy<Value = (f64, f64, f64, u32)> {
    (-1.0f64..1.0, -2.0f64..2.0, -2.0f64..2.0, 1u32..80)
}

/// Asserts that the body is clear of every static shape and mover.
fn assert_clear(sim: &SimNomad200, shapes: &[orsa_hardware::geometry::Shape]) {
    let t = sim.truth();
    let p = Point::new(t.x_m, t.y_m);
    for s in shapes {
        let d = s.distance(&p);
        assert!(d >= R - 1e-9, "penetrated {s:?}: centre {d} from it at {t:?}");
    }
    for m in sim.truth_movers() {
        let d = (Point::new(m.x_m, m.y_m) - p).norm() - m.radius_m;
        assert!(d >= R - 1e-9, "penetrated mover {m:?} at {t:?}");
    }
}

fn drive(mut sim: SimNomad200, commands: &[(f64, f64, f64, u32)]) {
    let shapes = sim.world().static_shapes();
    let mut last = sim.truth();
    let max_step = sim.config().drive.max_translate_m_s * sim.config().step_s + 1e-12;
    for &(v, steer, turret, steps) in commands {
        sim.move_velocity(AxisVelocities { translate_m_s: v, steer_rad_s: steer, turret_rad_s: turret })
            .expect("finite");
        for _ in 0..steps {
            sim.step();
            assert_clear(&sim, &shapes);
            let t = sim.truth();
            assert!(((t.x_m - last.x_m).powi(2) + (t.y_m - last.y_m).powi(2)).sqrt() <= max_step);
            last = t;
        }
    }
}

/// A 6 m x 6 m room with random boxes, discs, wall segments and people, none of them on the
/// robot's start at the centre.
fn cluttered_room() -> impl Strategy<Value = World> {
    let item = (0.3f64..5.7, 0.3f64..5.7, 0.05f64..0.8, 0.05f64..0.8, 0u8..4);
    prop::collection::vec(item, 1..14).prop_map(|items| {
        let mut w = room(6.0, 6.0, 3.0, 3.0, 0.0);
        let start = Point::new(3.0, 3.0);
        for (x, y, a, b, kind) in items {
            let mut candidate = w.clone();
            match kind {
                0 => candidate.boxes.push(boxed([x, y], [x + a, y + b])),
                1 => candidate.discs.push(disc([x, y], a / 2.0)),
                2 => candidate.walls.push(wall(&[[x, y], [x + a, y - b], [x + a + b, y]])),
                _ => candidate.movers.push(orsa_hardware::world::Mover {
                    radius: 0.2 + a / 8.0,
                    speed: 0.3 + b,
                    path: vec![[x, y], [6.0 - x, 6.0 - y]],
                    yield_distance: 0.05 + a / 4.0,
                    start_delay: 0.0,
                    patience: None,
                }),
            }
            let shapes = candidate.static_shapes();
            let clear = shapes.iter().all(|s| s.distance(&start) > R + 0.01)
                && candidate.movers.iter().all(|m| m.start_circle().distance(&start) > R + 0.01);
            if clear {
                w = candidate;
            }
        }
        w
    })
}

/// Configurations from the default to a fast robot with a long step (0.15 m per step), to
/// give tunnelling every chance.
fn config() -> impl Strategy<Value = SimConfig> {
    prop_oneof![
        Just(SimConfig::default()),
        Just(SimConfig {
            step_s: 0.05,
            drive: DriveConfig {
                max_translate_m_s: 3.0,
                max_translate_accel_m_s2: 20.0,
                translate_accel_m_s2: 10.0,
                max_steer_deg_s: 180.0,
                max_turret_deg_s: 180.0,
                ..DriveConfig::default()
            },
            ..SimConfig::default()
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn never_penetrates_in_random_rooms(
        world in cluttered_room(),
        config in config(),
        commands in prop::collection::vec(command(), 1..12),
        seed in any::<u64>(),
    ) {
        let scale = config.drive.max_translate_m_s;
        let commands: Vec<_> = commands.into_iter().map(|(v, s, t, n)| (v * scale, s, t, n)).collect();
        drive(SimNomad200::new(world, config, seed).expect("valid"), &commands);
    }

    #[test]
    fn never_penetrates_in_the_palazzina(
        config in config(),
        commands in prop::collection::vec(command(), 1..16),
        seed in any::<u64>(),
    ) {
        let scale = config.drive.max_translate_m_s;
        let commands: Vec<_> = commands.into_iter().map(|(v, s, t, n)| (v * scale, s, t, n * 2)).collect();
        let world = World::palazzina().expect("world");
        drive(SimNomad200::new(world, config, seed).expect("valid"), &commands);
    }
}
