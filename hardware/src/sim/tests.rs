//! Unit tests of the simulator: construction, time, ground-truth queries.

use super::*;

fn palazzina(heading_deg: f64) -> SimNomad200 {
    let mut w = World::palazzina().expect("world");
    w.robot.heading_deg = heading_deg;
    SimNomad200::new(w, SimConfig::noiseless(), 7).expect("sim")
}

#[test]
fn steps_are_whole_and_time_counts_them() {
    let mut sim = palazzina(0.0);
    assert_eq!(sim.step_period(), Duration::from_millis(10));
    assert_eq!(sim.run_for(Duration::from_millis(1005)), 100, "whole steps only");
    assert_eq!(sim.time(), Timestamp(1_000_000_000));
    sim.set_time_origin(Timestamp(5));
    assert_eq!(sim.time(), Timestamp(1_000_000_005));
    assert_eq!(sim.truth().stamp, sim.time());
    assert_eq!(sim.motor_state().stamp, sim.time());
}

#[test]
fn side_clearance_is_measured_from_the_body_edge_across_the_heading() {
    let sim = palazzina(0.0);
    // At (2, 1.2) in a 2.4 m corridor: 0.95 m to either wall.
    let left = sim.truth_side_clearance(Side::Left).expect("upper wall");
    let right = sim.truth_side_clearance(Side::Right).expect("lower wall");
    assert!((left - 0.95).abs() < 1e-12 && (right - 0.95).abs() < 1e-12, "{left} {right}");
    // The nearest thing is the first person, standing at (3, 0.6) with radius 0.25.
    let nearest = sim.truth_nearest_obstacle().expect("something");
    assert!((nearest - (1.36f64.sqrt() - 0.5)).abs() < 1e-12, "{nearest}");
    // Facing up the corridor's width, left is the west end wall, right the far east end.
    let sim = palazzina(90.0);
    let left = sim.truth_side_clearance(Side::Left).expect("west wall");
    let right = sim.truth_side_clearance(Side::Right).expect("east wall");
    assert!((left - 1.75).abs() < 1e-12 && (right - 37.75).abs() < 1e-9, "{left} {right}");
}

#[test]
fn construction_rejects_bad_worlds_configs_and_bodies() {
    let mut w = World::palazzina().expect("world");
    w.movers[0].path.truncate(1);
    let e = SimNomad200::new(w, SimConfig::default(), 1).expect_err("bad world").to_string();
    assert_eq!(e, "world: movers[0].path: a mover's path needs at least 2 points, got 1");

    let mut c = SimConfig::default();
    c.sonar.rays = 0;
    let e = SimNomad200::new(World::palazzina().expect("world"), c, 1).expect_err("bad config");
    assert!(e.to_string().contains("sonar.rays: must be between 1 and 64, got 0"), "{e}");

    let mut c = SimConfig::default();
    c.body.radius_m = 1.3;
    c.body.motion_margin_m = 1e-6;
    let e = SimNomad200::new(World::palazzina().expect("world"), c, 1).expect_err("too big");
    assert!(matches!(e, SimError::StartOverlap { .. }), "{e}");
    assert!(e.to_string().contains("radius 1.3 m"), "{e}");
}

#[test]
fn a_clone_continues_identically() {
    let mut a = palazzina(0.0);
    a.move_velocity(crate::board::AxisVelocities::synchro(0.3, 0.1)).expect("cmd");
    a.run_for(Duration::from_secs(3));
    let mut b = a.clone();
    a.run_for(Duration::from_secs(3));
    b.run_for(Duration::from_secs(3));
    assert_eq!(a.truth(), b.truth());
    assert_eq!(a.sonar(), b.sonar());
    assert_eq!(a.infrared(), b.infrared());
}

/// The corridor robot of config/diffbot.toml: differential drive, a 270 degree laser.
fn diffbot() -> SimNomad200 {
    let mut c = SimConfig::noiseless();
    c.body.radius_m = 0.35;
    c.drive.kind = orsa_interfaces::range::DriveKind::Differential;
    c.drive.max_translate_m_s = 1.0;
    c.drive.max_steer_deg_s = 120.0;
    c.drive.steer_accel_deg_s2 = 240.0;
    c.drive.max_steer_accel_deg_s2 = 480.0;
    c.laser = Some(LaserConfig { noise_sd_m: 0.0, ..LaserConfig::default() });
    SimNomad200::new(World::palazzina().expect("world"), c, 7).expect("sim")
}

/// A laser robot's rings are views of its scan: the walls 1.2 m either side of its centre show
/// 0.85 m from its 0.35 m body in the far view's side sectors, beyond the near view's reach, and
/// nothing behind it, which the 270 degree laser cannot see.
#[test]
fn a_laser_robot_sees_the_corridor_through_its_sector_views() {
    let mut sim = diffbot();
    assert!(sim.laser_scan().is_none(), "no scan before the first period");
    assert!(sim.sonar().readings.iter().all(|r| !r.valid), "nothing before the first scan");
    sim.run_for(Duration::from_millis(100));
    let (taken, beams) = sim.laser_scan().expect("one scan after 100 ms");
    assert_eq!(taken, Timestamp(100_000_000));
    assert_eq!(beams.len(), 271);
    let far = sim.sonar();
    assert_eq!(far.stamp, taken);
    for side in [4, 12] {
        let d = far.valid_distance_m(side).expect("a wall either side");
        assert!((d - 0.85).abs() < 0.01, "sector {side}: {d}");
    }
    assert_eq!(far.valid_distance_m(8), None, "behind the laser's field of view");
    let near = sim.infrared();
    assert_eq!(near.valid_distance_m(4), None, "0.85 m is beyond the near view's 0.6 m");
    // The params describe the laser as it is, and the views as the behaviours read them.
    let p = sim.robot_params(orsa_interfaces::nomad200::PushPeriods::default());
    assert_eq!(p.drive, orsa_interfaces::range::DriveKind::Differential);
    assert_eq!(p.range_sensors.len(), 1);
    assert_eq!(p.range_sensors[0].angles_rad.len(), 271);
    assert_eq!(p.infrared.mount_radius_m, 0.35);
    assert_eq!(p.max_turret_omega_rad_s, p.max_omega_rad_s, "no turret of its own");
}

/// A differential robot turns its sensors with its body, and the same seed gives the same scan.
#[test]
fn a_differential_robot_turns_its_sensors_with_it() {
    let mut sim = diffbot();
    sim.move_velocity(crate::board::AxisVelocities {
        translate_m_s: 0.0,
        steer_rad_s: 1.0,
        turret_rad_s: 0.0,
    })
    .expect("turn");
    sim.run_for(Duration::from_secs(1));
    let t = sim.truth();
    assert!(t.heading_rad > 0.5, "turned: {}", t.heading_rad);
    assert_eq!(t.turret_rad, t.heading_rad, "the sensors turn with the body");
    let mut again = diffbot();
    again
        .move_velocity(crate::board::AxisVelocities {
            translate_m_s: 0.0,
            steer_rad_s: 1.0,
            turret_rad_s: 0.0,
        })
        .expect("turn");
    again.run_for(Duration::from_secs(1));
    assert_eq!(sim.laser_scan(), again.laser_scan());
}
