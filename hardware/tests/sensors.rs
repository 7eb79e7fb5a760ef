//! Sonar, infrared, compass and bumpers against walls at known distances and angles.

mod common;

use common::*;
use orsa_actors::Timestamp;
use orsa_hardware::board::AxisVelocities;
use orsa_hardware::sim::{SimConfig, SimNomad200};
use orsa_interfaces::nomad200::{DistanceScan, Ring, ring_angle_rad};

const R: f64 = 0.25;

/// Ray offsets across a beam, as configured: `n` rays spread evenly over `width_deg`.
fn offsets(width_deg: f64, n: u32) -> Vec<f64> {
    if n == 1 {
        return vec![0.0];
    }
    (0..n).map(|k| (-width_deg / 2.0 + width_deg * f64::from(k) / f64::from(n - 1)).to_radians()).collect()
}

/// The exact reading of a sensor at the body's edge, facing world angle `axis`, of an endless
/// wall along x = `wall_x` ahead: the nearest of its rays, if any is nearer than `max`.
fn expected(wall_x: f64, center_x: f64, axis: f64, offsets: &[f64], max: f64) -> Option<f64> {
    let d = wall_x - (center_x + R * axis.cos());
    offsets
        .iter()
        .map(|o| (axis + o).cos())
        .filter(|&c| c > 0.0)
        .map(|c| d / c)
        .filter(|&t| t <= max)
        .reduce(f64::min)
}

/// Steps until every sensor of the ring has fired at least once more.
fn fresh_ring(sim: &mut SimNomad200) {
    let t = sim.time();
    while sim.sonar().readings.iter().chain(&sim.infrared().readings).any(|r| r.stamp <= t) {
        sim.step();
    }
}

fn check_ring(
    scan: &DistanceScan,
    wall_x: f64,
    center_x: f64,
    turret: f64,
    offs: &[f64],
    min: f64,
    max: f64,
) {
    for r in &scan.readings {
        let axis = turret + ring_angle_rad(usize::from(r.sensor_id));
        match expected(wall_x, center_x, axis, offs, max) {
            Some(d) if d >= min => {
                assert!(r.valid, "{:?} sensor {} should see the wall at {d}", scan.ring, r.sensor_id);
                assert!(
                    (r.distance_m - d).abs() < 1e-9,
                    "{:?} sensor {}: {} vs {d}",
                    scan.ring,
                    r.sensor_id,
                    r.distance_m
                );
            }
            Some(_) => {
                assert!(!r.valid, "{:?} sensor {} is too close to be valid", scan.ring, r.sensor_id);
                assert_eq!(r.distance_m, min);
            }
            None => {
                assert!(!r.valid, "{:?} sensor {} sees nothing in range", scan.ring, r.sensor_id);
                assert_eq!(r.distance_m, max);
            }
        }
    }
}

#[test]
fn sonar_reads_a_wall_ahead_at_every_sensor_angle() {
    for heading in [0.0, 30.0, -50.0] {
        let mut sim = exact(facing_wall(2.0, heading));
        fresh_ring(&mut sim);
        let scan = sim.sonar();
        assert_eq!(scan.ring, Ring::Sonar);
        if heading == 0.0 {
            assert!((scan.readings[0].distance_m - 1.75).abs() < 1e-12, "face to wall");
        }
        check_ring(&scan, 2.0, 0.0, f64::to_radians(heading), &offsets(25.0, 9), 0.30, 6.0);
        let valid = scan.readings.iter().filter(|r| r.valid).count();
        assert!((3..=8).contains(&valid), "a wall ahead fills some of the ring, not all: {valid}");
    }
}

#[test]
fn infrared_reads_a_near_wall_and_nothing_beyond_its_range() {
    for heading in [0.0, 20.0, -35.0] {
        let mut sim = exact(facing_wall(0.6, heading));
        fresh_ring(&mut sim);
        let scan = sim.infrared();
        assert_eq!(scan.ring, Ring::Infrared);
        check_ring(&scan, 0.6, 0.0, f64::to_radians(heading), &offsets(6.0, 3), 0.0, 0.6);
        assert!(scan.readings[0].valid && scan.readings[8].distance_m == 0.6 && !scan.readings[8].valid);
    }
    let mut sim = exact(facing_wall(1.0, 0.0));
    fresh_ring(&mut sim);
    assert!(sim.infrared().readings.iter().all(|r| !r.valid), "0.75 m away: out of IR range");
}

#[test]
fn sonar_too_close_is_invalid_and_infrared_still_sees() {
    let mut sim = exact(facing_wall(0.5, 0.0));
    fresh_ring(&mut sim);
    let s = sim.sonar().readings[0];
    assert!(!s.valid && s.distance_m == 0.30, "{s:?}");
    let ir = sim.infrared().readings[0];
    assert!(ir.valid && (ir.distance_m - 0.25).abs() < 1e-12, "{ir:?}");
}

#[test]
fn rings_turn_with_the_turret() {
    let mut sim = exact(facing_wall(2.0, 0.0));
    sim.move_velocity(AxisVelocities { translate_m_s: 0.0, steer_rad_s: 0.0, turret_rad_s: 0.5 })
        .expect("cmd");
    sim.run_for(ms(1500));
    sim.stop();
    while !sim.is_stopped() {
        sim.step();
    }
    fresh_ring(&mut sim);
    let t = sim.truth();
    assert!(t.turret_rad > 0.6, "the turret turned: {}", t.turret_rad);
    assert_eq!(t.heading_rad, 0.0, "the steering did not");
    check_ring(&sim.sonar(), 2.0, 0.0, t.turret_rad, &offsets(25.0, 9), 0.30, 6.0);
    sim.run_for(ms(100)); // a compass sample (10 Hz) taken since the turret stopped
    let compass = sim.compass();
    assert!(compass.valid && (compass.heading_rad - t.turret_rad).abs() < 1e-9, "compass follows the turret");
}

#[test]
fn sensors_see_movers() {
    let mut w = empty(0.0, 0.0, 0.0);
    w.movers.push(standing_person([2.0, 0.0], 0.25));
    let mut sim = exact(w);
    fresh_ring(&mut sim);
    assert!((sim.sonar().readings[0].distance_m - 1.5).abs() < 1e-12);
    assert!(!sim.sonar().readings[8].valid, "nothing behind");
}

#[test]
fn sonar_fires_one_transducer_every_4_ms_in_order() {
    let mut sim = exact(facing_wall(2.0, 0.0));
    sim.run_for(ms(60));
    let scan = sim.sonar();
    for r in &scan.readings[..15] {
        assert_eq!(r.stamp, Timestamp(4_000_000 * (u64::from(r.sensor_id) + 1)), "sensor {}", r.sensor_id);
    }
    assert_eq!(scan.readings[15].stamp, Timestamp::ZERO, "not fired yet at 60 ms");
    assert!(!scan.readings[15].valid);
    assert_eq!(scan.stamp, Timestamp(60_000_000));
    sim.step();
    assert_eq!(sim.sonar().readings[15].stamp, Timestamp(64_000_000), "a full ring every 64 ms");
    assert_eq!(sim.sonar().readings[0].stamp, Timestamp(68_000_000), "and round again");
}

#[test]
fn fire_order_and_period_can_be_changed() {
    let mut sim = exact(facing_wall(2.0, 0.0));
    sim.set_sonar_fire_order(&[3, 1, 7]).expect("order");
    sim.set_sonar_fire_period(ms(10)).expect("period");
    sim.run_for(ms(100));
    let stamp_of = |sim: &SimNomad200, i: usize| sim.sonar().readings[i].stamp;
    // 3 @ 10, 1 @ 20, 7 @ 30, 3 @ 40, ... , 1 @ 80, 7 @ 90, 3 @ 100 ms.
    assert_eq!(stamp_of(&sim, 3), Timestamp(100_000_000));
    assert_eq!(stamp_of(&sim, 1), Timestamp(80_000_000));
    assert_eq!(stamp_of(&sim, 7), Timestamp(90_000_000));
    assert!(sim.sonar().readings.iter().enumerate().all(|(i, r)| [1, 3, 7].contains(&i) || !r.valid));
    // A period change restarts the schedule from now.
    sim.set_infrared_fire_order(&[0]).expect("order");
    sim.set_infrared_fire_period(ms(25)).expect("period");
    sim.run_for(ms(50));
    assert_eq!(sim.infrared().readings[0].stamp, Timestamp(150_000_000));
    assert!(sim.set_sonar_fire_order(&[]).is_err());
    assert!(sim.set_sonar_fire_order(&[16]).is_err());
    assert!(sim.set_sonar_fire_period(std::time::Duration::ZERO).is_err());
    // Init restores the defaults and forgets every reading.
    sim.sensor_init();
    assert!(sim.sonar().readings.iter().chain(&sim.infrared().readings).all(|r| !r.valid));
    sim.run_for(ms(40));
    assert_eq!(sim.infrared().readings[15].stamp, Timestamp(190_000_000), "IR ring every 40 ms");
}

#[test]
fn infrared_fires_every_2_5_ms() {
    let mut sim = exact(facing_wall(0.6, 0.0));
    sim.run_for(ms(40));
    for r in &sim.infrared().readings {
        assert_eq!(r.stamp, Timestamp(2_500_000 * (u64::from(r.sensor_id) + 1)));
    }
}

/// Sensor 0's successive readings over `n` fresh firings.
fn samples(sim: &mut SimNomad200, ring: Ring, n: usize) -> Vec<f64> {
    let read = |sim: &SimNomad200| if ring == Ring::Sonar { sim.sonar() } else { sim.infrared() }.readings[0];
    let mut out = Vec::with_capacity(n);
    let mut last = read(sim).stamp;
    while out.len() < n {
        sim.step();
        let r = read(sim);
        if r.stamp != last {
            assert!(r.valid, "{r:?}");
            out.push(r.distance_m);
            last = r.stamp;
        }
    }
    out
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    (mean, (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
}

#[test]
fn noise_has_the_documented_size() {
    // Sonar: 1 % of 3.0 m.
    let mut sim = SimNomad200::new(facing_wall(3.25, 0.0), SimConfig::default(), 11).expect("sim");
    let (mean, sd) = mean_sd(&samples(&mut sim, Ring::Sonar, 400));
    assert!((mean - 3.0).abs() < 4.0 * 0.03 / 20.0, "sonar mean {mean}");
    assert!((sd - 0.03).abs() < 0.2 * 0.03, "sonar sd {sd}");
    // Infrared: 5 mm + 2 % of 0.5 m.
    let mut sim = SimNomad200::new(facing_wall(0.75, 0.0), SimConfig::default(), 12).expect("sim");
    let (mean, sd) = mean_sd(&samples(&mut sim, Ring::Infrared, 400));
    assert!((mean - 0.5).abs() < 4.0 * 0.015 / 20.0, "IR mean {mean}");
    assert!((sd - 0.015).abs() < 0.2 * 0.015, "IR sd {sd}");
}

#[test]
fn compass_reads_the_heading_with_small_noise() {
    let mut sim = exact(empty(0.0, 0.0, 30.0));
    sim.run_for(ms(100));
    let c = sim.compass();
    assert!(c.valid && c.stamp == Timestamp(100_000_000));
    assert!((c.heading_rad - 30f64.to_radians()).abs() < 1e-12);
    let mut sim = SimNomad200::new(empty(0.0, 0.0, 179.9), SimConfig::default(), 5).expect("sim");
    let mut errors = Vec::new();
    for _ in 0..500 {
        sim.run_for(ms(100));
        let h = sim.compass().heading_rad;
        assert!(h > -std::f64::consts::PI && h <= std::f64::consts::PI, "wrapped: {h}");
        let e = (h - 179.9f64.to_radians() + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        errors.push(e.to_degrees());
    }
    let (mean, sd) = mean_sd(&errors);
    assert!(mean.abs() < 0.06, "{mean}");
    assert!((sd - 0.3).abs() < 0.05, "{sd}");
}

/// Drives at `heading_deg` until blocked; returns the simulator.
fn drive_until_blocked(mut sim: SimNomad200, v: f64) -> SimNomad200 {
    sim.move_velocity(AxisVelocities::synchro(v, 0.0)).expect("cmd");
    for _ in 0..2000 {
        sim.step();
        if sim.truth().translation_blocked {
            return sim;
        }
    }
    panic!("never blocked: {:?}", sim.truth());
}

#[test]
fn bumpers_press_in_the_direction_of_contact_relative_to_the_base() {
    let sim = drive_until_blocked(exact(facing_wall(1.0, 0.0)), 0.3);
    let b = sim.bumpers();
    let pressed: Vec<usize> = (0..20).filter(|&i| b.pressed[i]).collect();
    assert_eq!(pressed, vec![0, 10]);
    assert_eq!(sim.truth().contact_onsets, 1);
    assert!(sim.truth().in_contact);

    // Heading 60 degrees, base still at 0: the contact is at 60 degrees on the ring.
    let mut w = empty(0.0, 0.0, 0.0);
    let n = (60f64.to_radians().cos(), 60f64.to_radians().sin());
    let c = (1.5 * n.0, 1.5 * n.1);
    w.walls.push(wall(&[[c.0 + 5.0 * n.1, c.1 - 5.0 * n.0], [c.0 - 5.0 * n.1, c.1 + 5.0 * n.0]]));
    let mut sim = exact(w);
    sim.move_velocity(AxisVelocities::synchro(0.0, 0.5)).expect("turn");
    while sim.truth().heading_rad < 60f64.to_radians() - 0.02 {
        sim.step();
    }
    sim.stop();
    while !sim.is_stopped() {
        sim.step();
    }
    let heading = sim.truth().heading_rad;
    let sim = drive_until_blocked(sim, 0.3);
    let b = sim.bumpers();
    let pressed: Vec<usize> = (0..20).filter(|&i| b.pressed[i]).collect();
    // Whatever the exact heading (it overshoots while decelerating), the contact is where the
    // wall's normal points: 60 degrees on the base's ring.
    assert!((55.0..70.0).contains(&heading.to_degrees()), "{}", heading.to_degrees());
    assert_eq!(pressed, vec![2, 11], "60 degrees: lower bumper 2, upper 11");
}
