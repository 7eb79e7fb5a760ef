//! People in the palazzina walk their paths after their start delay, and yield to the robot.

mod common;

use common::ms;
use orsa_hardware::board::AxisVelocities;
use orsa_hardware::sim::{SimConfig, SimNomad200};
use orsa_hardware::world::World;

fn palazzina(edit: impl FnOnce(&mut World)) -> SimNomad200 {
    let mut w = World::palazzina().expect("world");
    edit(&mut w);
    SimNomad200::new(w, SimConfig::noiseless(), 1).expect("sim")
}

fn close(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).hypot(a.1 - b.1) < 1e-6
}

#[test]
fn people_walk_their_paths_after_their_start_delay() {
    let mut sim = palazzina(|_| {});
    sim.run_for(ms(10_000));
    let m = sim.truth_movers();
    // 7 m along [3, 0.6] -> [11, 0.6] at 0.7 m/s.
    assert!(close((m[0].x_m, m[0].y_m), (10.0, 0.6)), "{:?}", m[0]);
    assert!(close((m[1].x_m, m[1].y_m), (36.0, 1.8)), "still waiting: {:?}", m[1]);
    sim.run_for(ms(11_000));
    let m = sim.truth_movers();
    assert!(close((m[1].x_m, m[1].y_m), (35.1, 1.8)), "1 s at 0.9 m/s: {:?}", m[1]);
    assert!(close((m[2].x_m, m[2].y_m), (14.5, 0.1)), "waits 45 s: {:?}", m[2]);
    sim.run_for(ms(28_000));
    let m = sim.truth_movers();
    // Crossing the corridor at 0.5 m/s for 4 s.
    assert!(close((m[2].x_m, m[2].y_m), (14.5, 2.1)), "{:?}", m[2]);
    sim.run_for(ms(2_000));
    let m = sim.truth_movers();
    assert!(close((m[2].x_m, m[2].y_m), (14.5, 1.1)), "turned back at the end: {:?}", m[2]);
    assert!(m.iter().all(|m| !m.yielding));
    assert_eq!(sim.truth().contact_onsets, 0);
}

#[test]
fn people_yield_to_the_robot_and_never_touch_it() {
    // The robot stands in the first person's way.
    let mut sim = palazzina(|w| {
        w.robot.x = 6.0;
        w.robot.y = 0.6;
        w.robot.heading_deg = 90.0;
    });
    sim.run_for(ms(30_000));
    let m = sim.truth_movers()[0];
    let gap = (m.x_m - 6.0).hypot(m.y_m - 0.6) - 0.5;
    assert!(m.yielding, "{m:?}");
    assert!(gap < 0.6 && gap > 0.6 - 0.7 * 0.01 - 1e-9, "paused just inside its yield distance: {gap}");
    assert_eq!(sim.truth().contact_onsets, 0, "people never push the robot");
    // The robot steps out of the way (up the corridor): the person walks on past it.
    sim.move_velocity(AxisVelocities::synchro(0.5, 0.0)).expect("cmd");
    sim.run_for(ms(3_000));
    sim.stop();
    sim.run_for(ms(20_000));
    let y = sim.truth().y_m;
    assert!(y > 1.75, "{y}");
    let m = sim.truth_movers()[0];
    assert!(m.x_m > 11.0, "walked on: {m:?}");
    assert_eq!(sim.truth().contact_onsets, 0);
}

#[test]
fn sensors_see_people_pass() {
    // The robot faces down the corridor; the first person walks away ahead and to its right.
    let mut sim = palazzina(|_| {});
    sim.run_for(ms(2_000));
    let person = sim.truth_movers()[0];
    let t = sim.truth();
    // Sonar 15 (beam -35 to -10 deg) and 0 (-12.5 to 12.5) look towards the person, who is
    // much closer than anything else that way.
    let bearing = (person.y_m - t.y_m).atan2(person.x_m - t.x_m).to_degrees();
    assert!((-20.0..-8.0).contains(&bearing), "{bearing}");
    let scan = sim.sonar();
    let seen = [15usize, 0].iter().filter_map(|&i| scan.valid_distance_m(i)).fold(f64::INFINITY, f64::min);
    let gap = (person.x_m - t.x_m).hypot(person.y_m - t.y_m) - 0.5;
    assert!(seen < gap + 0.3 && seen > gap - 0.05, "seen at {seen}, edge to edge {gap}");
}
