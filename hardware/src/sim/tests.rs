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
