//! Navigation on orsa's own robot and worlds: the simulated Nomad 200's odometry, sonar and
//! infrared rings fed to `orsa_navigation::mcl` against the map of the world it drives in (the
//! estimate compared with the simulator's truth, which localization never sees), and paths
//! planned on the office floor's map checked against the world file's own geometry.

use orsa_hardware::board::AxisVelocities;
use orsa_hardware::geometry::Point;
use orsa_hardware::sim::{SimConfig, SimNomad200};
use orsa_hardware::world::World;
use orsa_interfaces::nomad200::PushPeriods;
use orsa_navigation::localizer::ring_beams as beams;
use orsa_navigation::mcl::{Localizer, MclParams, Pose2};
use orsa_navigation::plan::{PlanParams, plan};
use std::time::Duration;

/// Wanders `world` for `secs` simulated seconds (ahead at 0.3 m/s, turning away from what the
/// front sonars see within 0.9 m), localizing every 0.1 s from the start pose; returns the RMS
/// and largest error of the estimate, and odometry's error at the end, m.
fn wander(world: World, secs: u64, seed: u64) -> (f64, f64, f64) {
    wander_with(world, secs, seed, MclParams::default())
}

fn wander_with(world: World, secs: u64, seed: u64, params: MclParams) -> (f64, f64, f64) {
    let start = Pose2::new(world.robot.x, world.robot.y, world.robot.heading_rad());
    let grid = world.occupancy_grid(0.05).expect("a map");
    let mut sim = SimNomad200::new(world, SimConfig::default(), seed).expect("sim");
    let robot = sim.robot_params(PushPeriods::default());
    let mut loc = Localizer::new(&grid, params, seed).expect("localizer");
    loc.reset_at(start, 0.1, 0.05).expect("a pose");
    let (mut sum2, mut worst, mut n) = (0.0, 0.0f64, 0);
    let mut turning = 0;
    let mut buf = Vec::new();
    for _ in 0..secs * 10 {
        let sonar = sim.sonar();
        let ahead =
            [15usize, 0, 1].iter().filter_map(|&i| sonar.valid_distance_m(i)).fold(f64::INFINITY, f64::min);
        if ahead < 0.9 && turning == 0 {
            turning = 15;
        }
        let (v, w) = if turning > 0 {
            turning -= 1;
            (0.0, 0.7)
        } else {
            (0.3, 0.0)
        };
        sim.move_velocity(AxisVelocities::synchro(v, w)).expect("command");
        sim.run_for(Duration::from_millis(100));
        let m = sim.motor_state();
        buf.clear();
        beams(&sim.sonar(), &robot.sonar, &mut buf);
        beams(&sim.infrared(), &robot.infrared, &mut buf);
        if loc.update(Pose2::new(m.x_m, m.y_m, m.heading_rad), &buf) {
            let (e, t) = (loc.estimate().pose, sim.truth());
            let err = (e.x - t.x_m).hypot(e.y - t.y_m);
            sum2 += err * err;
            worst = worst.max(err);
            n += 1;
        }
    }
    assert!(n > 100, "only {n} updates: the robot hardly moved");
    let (m, t) = (sim.motor_state(), sim.truth());
    let odom = start.apply(m.x_m, m.y_m);
    ((sum2 / n as f64).sqrt(), worst, (odom.0 - t.x_m).hypot(odom.1 - t.y_m))
}

#[test]
fn the_nomad_is_localized_on_the_corridor_and_the_office_floor() {
    let office =
        World::from_path(concat!(env!("CARGO_MANIFEST_DIR"), "/worlds/office.toml")).expect("office");
    for (name, world) in [("corridor", World::palazzina().expect("corridor")), ("office", office)] {
        for seed in 1..=2 {
            let (rms, worst, odom) = wander(world.clone(), 300, seed);
            println!(
                "{name} seed {seed}: rms {rms:.3} m, max {worst:.3} m, odometry {odom:.3} m off at the end"
            );
            assert!(rms < 0.1 && worst < 0.3, "{name} seed {seed}: rms {rms} m, max {worst} m");
            assert!(
                rms < odom / 2.0,
                "{name} seed {seed}: rms {rms} m, no better than odometry ({odom} m off)"
            );
        }
    }
}

#[test]
fn paths_from_the_start_reach_every_place_of_every_shipped_world_clear_of_everything() {
    for file in ["office", "suite", "loop", "lshape", "narrow", "hall"] {
        let path = format!("{}/worlds/{file}.toml", env!("CARGO_MANIFEST_DIR"));
        let world = World::from_path(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(world.places.len() >= 3, "{file}: {} places", world.places.len());
        let grid = world.occupancy_grid(0.05).expect("a map");
        let shapes = world.static_shapes();
        let start = (world.robot.x, world.robot.y);
        let params = PlanParams::default();
        for place in &world.places {
            let path = plan(&grid, start, (place.x, place.y), &params)
                .unwrap_or_else(|e| panic!("{file}: to {}: {e}", place.name));
            let straight = (place.x - start.0).hypot(place.y - start.1);
            assert!(
                path.length_m >= straight - 1e-9,
                "{file}: {}: {} m, under the straight line",
                place.name,
                path.length_m
            );
            // Every step of the path, every 2 cm, keeps the body off every wall, box and disc.
            for w in path.points.windows(2) {
                let n = ((w[1].0 - w[0].0).hypot(w[1].1 - w[0].1) / 0.02).ceil().max(1.0) as usize;
                for k in 0..=n {
                    let t = k as f64 / n as f64;
                    let at = Point::new(w[0].0 + t * (w[1].0 - w[0].0), w[0].1 + t * (w[1].1 - w[0].1));
                    let gap = shapes.iter().map(|s| s.distance(&at)).fold(f64::INFINITY, f64::min);
                    assert!(
                        gap > params.robot_radius_m,
                        "{file}: {}: the body touches something at {at:?}",
                        place.name
                    );
                }
            }
            println!(
                "{file}: start to {}: {:.2} m (straight line {straight:.2} m)",
                place.name, path.length_m
            );
        }
    }
}

/// Runs `orsa run --world worlds/FILE.toml --goto ...` on the paused clock: its report.
async fn goto_mission(file: &str, targets: &[&str], seed: u64) -> orsa::mission::report::Report {
    goto_mission_of(orsa::config::Config::default(), file, targets, seed).await
}

/// [`goto_mission`] on the robot and system of `config` (`orsa run --config ...`).
async fn goto_mission_of(
    config: orsa::config::Config,
    file: &str,
    targets: &[&str],
    seed: u64,
) -> orsa::mission::report::Report {
    let path = format!("{}/worlds/{file}.toml", env!("CARGO_MANIFEST_DIR"));
    let world = World::from_path(&path).unwrap_or_else(|e| panic!("{e}"));
    let targets: Vec<String> = targets.iter().map(|t| t.to_string()).collect();
    let config = config.with_goto(&targets).expect("a config with the places");
    let mut o = orsa::mission::RunOptions::new(world, file, config, seed, 900.0);
    o.keep_series = false;
    o.until_mission_ends = true;
    orsa::mission::run(o).await.expect("a report").report
}

/// [`goto_mission`] to `n` places drawn at random from `seed` where the body reaches on the
/// world `file` (`orsa run --tour`).
async fn tour_mission(file: &str, n: usize, seed: u64) -> orsa::mission::report::Report {
    tour_mission_of(orsa::config::Config::default(), file, n, seed).await
}

/// [`tour_mission`] on the robot and system of `config`, the places drawn for its body.
async fn tour_mission_of(
    config: orsa::config::Config,
    file: &str,
    n: usize,
    seed: u64,
) -> orsa::mission::report::Report {
    let path = format!("{}/worlds/{file}.toml", env!("CARGO_MANIFEST_DIR"));
    let world = World::from_path(&path).unwrap_or_else(|e| panic!("{e}"));
    let radius_m = config.sim.robot_params(config.robot().push_periods()).body_radius_m;
    let places = orsa::mission::tour::tour(&world, orsa::mission::tour::TourSpec::new(n, radius_m), seed)
        .expect("a tour");
    let targets: Vec<String> = places.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
    let targets: Vec<&str> = targets.iter().map(String::as_str).collect();
    goto_mission_of(config, file, &targets, seed).await
}

#[tokio::test(start_paused = true)]
async fn the_office_mission_reaches_every_place_and_reports_it() {
    let r = goto_mission("office", &["room-3", "room-5", "dock"], 1).await;
    let nav = r.navigation.as_ref().expect("a navigation section");
    println!("{}", nav.table());
    assert!(
        matches!(&r.ended, orsa::mission::report::Ended::MissionEnded { result, .. } if result == "completed"),
        "{:?}",
        r.ended
    );
    let targets: Vec<&str> = nav.goals.iter().map(|g| g.target.as_str()).collect();
    assert_eq!(targets, ["room-3", "room-5", "dock"]);
    for g in &nav.goals {
        assert_eq!(g.status, "succeeded", "{g:?}");
        // Reached: the true pose within 0.25 m of the place.
        assert!(g.final_error_m.is_some_and(|e| e < 0.25), "{g:?}");
        let shortest = g.shortest_m.expect("a shortest path");
        assert!(g.path_m >= shortest - 0.05, "{g:?}: drove less than the shortest path");
    }
    assert_eq!(nav.success_rate, 1.0);
    assert!(nav.spl >= 0.85, "SPL {}", nav.spl);
    assert!(nav.localization.samples > 500 && nav.localization.rms_m <= 0.10, "{:?}", nav.localization);
    assert_eq!(r.bumps, 0, "{:?}", r.bumps_at);
    // The same seed, the same run.
    let again = goto_mission("office", &["room-3", "room-5", "dock"], 1).await;
    assert_eq!(again.navigation, r.navigation);
}

/// The differential-drive robot with a planar laser (config/diffbot.toml) is sent to places by
/// the same navigation code, which reads its laser through the sensor geometry it describes:
/// a tour drawn for its 0.70 m body on the office floor, every place truly reached, localized
/// within the 0.10 m RMS, without a bump.
#[tokio::test(start_paused = true)]
async fn the_laser_robot_is_sent_to_places_by_the_same_navigation() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/config/diffbot.toml");
    let config = orsa::config::Config::load(std::path::Path::new(file)).unwrap_or_else(|e| panic!("{e}"));
    let radius_m = config.sim.robot_params(config.robot().push_periods()).body_radius_m;
    assert_eq!(radius_m, 0.35, "the diffbot's body");
    let r = tour_mission_of(config, "office", 5, 1).await;
    let nav = r.navigation.as_ref().expect("a navigation section");
    println!("{}", nav.table());
    assert_eq!(nav.goals.len(), 5);
    for g in &nav.goals {
        assert_eq!(g.status, "succeeded", "{g:?}");
        assert!(g.final_error_m.is_some_and(|e| e < 0.25), "{g:?}");
    }
    assert!(nav.spl >= 0.85, "SPL {}", nav.spl);
    assert!(nav.localization.samples > 500 && nav.localization.rms_m <= 0.10, "{:?}", nav.localization);
    assert_eq!(r.bumps, 0, "{:?}", r.bumps_at);
    // It was the laser robot that drove: its server, under its own name, took the velocities
    // and pushed the laser's two views.
    let services: Vec<&String> = r.delivery.services.keys().collect();
    assert!(services.iter().any(|s| s.starts_with("diffbot/")), "no diffbot service: {services:?}");
    assert!(!services.iter().any(|s| s.starts_with("nomad200/")), "a Nomad 200 in the run: {services:?}");
}

/// A random tour (`orsa run --tour`): places drawn where the body reaches on the true world,
/// not where the world's author put them, reached one after another.
#[tokio::test(start_paused = true)]
async fn random_tours_of_the_office_floor_reach_every_place() {
    for seed in 1..=2 {
        let r = tour_mission("office", 6, seed).await;
        let nav = r.navigation.as_ref().expect("a navigation section");
        println!("seed {seed}:\n{}", nav.table());
        assert_eq!(nav.goals.len(), 6);
        for g in &nav.goals {
            assert_eq!(g.status, "succeeded", "seed {seed}: {g:?}");
            assert!(g.final_error_m.is_some_and(|e| e < 0.25), "seed {seed}: {g:?}");
        }
        assert!(nav.spl >= 0.85, "seed {seed}: SPL {}", nav.spl);
        assert!(nav.localization.rms_m <= 0.10, "seed {seed}: {:?}", nav.localization);
        assert_eq!(r.bumps, 0, "seed {seed}: {:?}", r.bumps_at);
    }
}

/// People close to the robot in the office's room 5 make the filter's fit dip (a false alarm):
/// the robot turns on the spot and the relocalizer searches. Its echoes, a person among them,
/// then fit the truth (0.86 of score) less well than two alike places 8 m off in rooms 1 and 2
/// (0.93 each). Taking the better of those as a guess put the estimate 8.3 m off for 20 s
/// (RMS 0.47 m over the tour). Beaten only by places unsure of themselves, the track is kept.
#[tokio::test(start_paused = true)]
async fn a_false_alarm_among_people_keeps_the_track_rather_than_guess_a_twin_room() {
    let r = tour_mission("office", 20, 1).await;
    let nav = r.navigation.as_ref().expect("a navigation section");
    println!("{}", nav.table());
    let l = &nav.localization;
    assert!(!l.lost.is_empty(), "no false alarm on this tour any more: the test needs another seed ({l:?})");
    for spell in &l.lost {
        assert!(spell.error_after_m.is_some_and(|e| e < 0.25), "{spell:?}");
    }
    assert!(l.rms_m <= 0.10, "{l:?}");
    assert_eq!(nav.success_rate, 1.0, "{}", nav.table());
    assert_eq!(r.bumps, 0, "{:?}", r.bumps_at);
}

/// The hall looks nearly the same turned half round about its middle. People walking close
/// once made the filter's fit dip, and particles redrawn at random on the mirror image won: on
/// seeds 5 and 9 the estimate settled 10 m off and two goals in six were truly reached (the
/// planner said all six). Now a dip starts the relocalizer's search, which keeps the track.
#[tokio::test(start_paused = true)]
async fn random_tours_of_the_hall_keep_the_robot_off_its_mirror_image() {
    for seed in [5, 9] {
        let r = tour_mission("hall", 6, seed).await;
        let nav = r.navigation.as_ref().expect("a navigation section");
        println!("seed {seed}:\n{}", nav.table());
        assert_eq!(nav.goals.len(), 6);
        assert_eq!(nav.success_rate, 1.0, "seed {seed}: {:?}", nav.goals);
        assert!(nav.localization.rms_m <= 0.10, "seed {seed}: {:?}", nav.localization);
        assert_eq!(r.bumps, 0, "seed {seed}: {:?}", r.bumps_at);
    }
}

#[tokio::test(start_paused = true)]
async fn goals_to_no_place_are_rejected_at_once_naming_why_and_the_mission_goes_on() {
    let r = goto_mission("office", &["kitchen", "100,100", "0.02,3", "room-1"], 2).await;
    let nav = r.navigation.as_ref().expect("a navigation section");
    println!("{}", nav.table());
    let got: Vec<(&str, &str)> = nav.goals.iter().map(|g| (g.target.as_str(), g.status.as_str())).collect();
    assert_eq!(
        got,
        [
            ("kitchen", "rejected"),
            ("100.00,100.00", "rejected"),
            ("0.02,3.00", "rejected"),
            ("room-1", "succeeded")
        ]
    );
    let reasons: Vec<&str> = nav.goals.iter().map(|g| g.reason.as_str()).collect();
    assert!(reasons[0].contains("no place 'kitchen'") && reasons[0].contains("room-3"), "{}", reasons[0]);
    assert!(reasons[1].contains("outside the map"), "{}", reasons[1]);
    assert!(reasons[2].contains("inside a wall"), "{}", reasons[2]);
    for g in &nav.goals[..3] {
        assert_eq!(g.time_s, 0.0, "{g:?}: not rejected at once");
    }
    // The mission's end says which steps were skipped, and why.
    let orsa::mission::report::Ended::MissionEnded { result, .. } = &r.ended else { panic!("{:?}", r.ended) };
    assert!(result.starts_with("completed with 3 of 4 steps skipped: step 0 rejected: "), "{result}");
    assert!(result.contains("step 2 rejected: ") && result.contains("inside a wall"), "{result}");
}

/// A mission none of whose steps could be done did not complete: its end says it failed.
#[tokio::test(start_paused = true)]
async fn a_mission_whose_every_step_is_rejected_ends_failed() {
    let r = goto_mission("office", &["kitchen", "100,100"], 2).await;
    let orsa::mission::report::Ended::MissionEnded { result, .. } = &r.ended else { panic!("{:?}", r.ended) };
    assert!(result.starts_with("failed: all 2 steps skipped: step 0 rejected: "), "{result}");
    assert!(result.contains("outside the map"), "{result}");
}

#[test]
fn a_mission_of_places_needs_the_navigation_components_and_names_the_key() {
    let c = orsa::config::Config::from_toml(
        "[params.planner]\nmission = [{ goto = \"room-3\" }]\n",
        "places.toml",
    );
    let e = c.expect_err("no navigate mode").to_string();
    assert!(e.contains("params.planner.mission[0].goto") && e.contains("navigation"), "{e}");
    let shipped = orsa::config::Config::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/navigation.toml"
    )))
    .expect("the shipped navigation config");
    let modes: Vec<String> = shipped.executive().modes.keys().cloned().collect();
    for m in ["navigate", "patrol", "stop"] {
        assert!(modes.iter().any(|k| k == m), "{m} missing from {modes:?}");
    }
    let bad = "[params.planner]\nmission = [{ goto = \"room-3\", patrol = 5 }]\n";
    let e = orsa::config::Config::from_toml(bad, "both.toml").expect_err("two kinds in a step").to_string();
    assert!(e.contains("params.planner.mission[0]") && e.contains("exactly one"), "{e}");
}

/// A goal from outside (as `orsa goto` gives one) on the shipped `config/goals.toml`, given as
/// the system comes up, before the localizer's first estimate: accepted, it waits for the
/// estimate, then drives there and ends `succeeded` with the true pose at the place.
#[tokio::test(start_paused = true)]
async fn a_goal_given_before_the_first_estimate_waits_for_it_and_is_reached() {
    use orsa::interfaces::navigation::{NAVIGATE, NAVIGATION, NavGoal, NavReply, NavState, NavTarget};
    use orsa_actors::push_newest::PushNewestClient;
    use orsa_actors::query::QueryClient;
    let root = env!("CARGO_MANIFEST_DIR");
    let world = World::from_path(format!("{root}/worlds/office.toml")).unwrap_or_else(|e| panic!("{e}"));
    let config = orsa::config::Config::load(std::path::Path::new(&format!("{root}/config/goals.toml")))
        .expect("config/goals.toml");
    let stack =
        orsa::mission::stack::Stack::builder(&config, world).seed(3).start().await.expect("the stack");
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let feedback = PushNewestClient::connect_to(
        &stack.registry,
        NAVIGATION.on("planner"),
        orsa_actors::Sink::channel(tx),
    )
    .expect("navigation");
    feedback.subscribe().expect("subscribe");
    let goal = NavGoal { target: NavTarget::Place { name: "room-1".into() } };
    let reply = QueryClient::connect(&stack.registry, NAVIGATE.on("planner"))
        .expect("navigate")
        .query(goal, Some(Duration::from_secs(5)))
        .await
        .expect("an answer");
    let NavReply::Accepted { id } = reply else { panic!("{reply:?}") };
    let first = rx.recv().await.expect("feedback").value.clone();
    assert_eq!((first.id, first.state), (id, NavState::Active), "{first:?}");
    assert_eq!(first.reason, "waiting for the first estimate of the robot's pose", "{first:?}");
    let end = tokio::time::timeout(Duration::from_secs(120), async {
        loop {
            let f = rx.recv().await.expect("feedback").value.clone();
            if f.state.is_final() {
                return f;
            }
        }
    })
    .await
    .expect("the goal ends within 120 s");
    assert_eq!((end.id, end.state), (id, NavState::Succeeded), "{end:?}");
    let t = stack.truth().expect("simulated").truth();
    // room-1 is at (5.0, 2.5).
    let off = (t.x_m - 5.0).hypot(t.y_m - 2.5);
    assert!(off < 0.25, "the true pose is {off:.2} m from room-1");
    stack.shutdown().await;
}

/// Room 3's corridor door, x 19.5-20.5 in the wall at y 5, and a box that fills it.
const DOOR_BOX: ([f64; 2], [f64; 2]) = ([19.45, 4.75], [20.55, 5.25]);

/// Runs a mission of places on `worlds/FILE.toml` under the fault plan `plan` (TOML), to the
/// mission's end (at most 600 s).
async fn mission_under(file: &str, targets: &[&str], seed: u64, plan: &str) -> orsa::mission::RunOutcome {
    let path = format!("{}/worlds/{file}.toml", env!("CARGO_MANIFEST_DIR"));
    let world = World::from_path(&path).unwrap_or_else(|e| panic!("{e}"));
    let targets: Vec<String> = targets.iter().map(|t| t.to_string()).collect();
    let config = orsa::config::Config::default().with_goto(&targets).expect("a config with the places");
    let plan =
        orsa::faults::FaultPlan::parse(plan, "plan.toml", &orsa::faults::PlanTargets::for_stack(&config))
            .expect("the plan");
    let mut o = orsa::mission::RunOptions::new(world, file, config, seed, 600.0);
    o.until_mission_ends = true;
    o.faults = Some(plan);
    orsa::mission::run(o).await.expect("a report")
}

/// Runs a mission of places on `worlds/FILE.toml` with a box put down in room 3's corridor door
/// as the run starts (it is not on the map): the report, and when the robot's body first came
/// within its infrared's reach of the box (s, from the true trajectory).
async fn mission_with_door_box(
    file: &str,
    targets: &[&str],
    seed: u64,
) -> (orsa::mission::report::Report, f64) {
    let (min, max) = DOOR_BOX;
    let plan = format!(
        "[[fault]]\nat = 0.5\nkind = \"box_placed\"\ntarget = \"world\"\nmin = {min:?}\nmax = {max:?}\n"
    );
    let out = mission_under(file, targets, seed, &plan).await;
    let reach = SimConfig::default().infrared.max_range_m;
    let near = |x: f64, y: f64| {
        let dx = (min[0] - x).max(x - max[0]).max(0.0);
        let dy = (min[1] - y).max(y - max[1]).max(0.0);
        dx.hypot(dy) <= 0.25 + reach
    };
    let seen = out.metrics.trajectory.iter().find(|(_, x, y, _)| near(*x, *y)).map(|s| s.0);
    (out.report, seen.expect("the robot came within reach of the box"))
}

/// With room 3's only door blocked, the goal there is aborted with "no path" within 30 s of
/// the robot first coming within its sensors' reach of the box, and the mission goes on.
#[tokio::test(start_paused = true)]
async fn a_goal_behind_a_blocked_door_with_no_other_way_is_aborted_no_path() {
    let (r, seen_s) = mission_with_door_box("office", &["room-3", "room-2"], 1).await;
    let nav = r.navigation.as_ref().expect("a navigation section");
    println!("{}\nbox within reach at {seen_s:.1} s", nav.table());
    let g = &nav.goals[0];
    assert_eq!((g.target.as_str(), g.status.as_str()), ("room-3", "aborted"), "{g:?}");
    assert!(g.reason.starts_with("no path"), "{g:?}");
    // The goal started as the run did (the first estimate comes within a second).
    assert!(g.time_s - seen_s <= 30.0, "aborted {:.1} s after the box came within reach", g.time_s - seen_s);
    assert_eq!(nav.goals[1].status, "succeeded", "{:?}", nav.goals[1]);
    assert_eq!(r.bumps, 0, "{:?}", r.bumps_at);
    // The box was put down (not refused), once.
    let faults = r.faults.as_ref().expect("a faults section");
    let placed: Vec<&str> = faults
        .log
        .iter()
        .filter(|(_, _, what)| what.contains("box_placed"))
        .map(|(_, _, w)| w.as_str())
        .collect();
    assert_eq!(placed, ["injected box_placed: box [19.45, 4.75]-[20.55, 5.25]"], "{faults:?}");
}

/// With room 3's corridor door blocked and a second way in through room 2, the goal is reached
/// that way: from room 5 the corridor door is the short way (about 9 m, through room 2 about
/// 14 m), and the robot drove farther than the shortest way on the map without the box.
#[tokio::test(start_paused = true)]
async fn a_goal_behind_a_blocked_door_is_reached_by_another_way() {
    let (r, seen_s) = mission_with_door_box("suite", &["room-5", "room-3"], 1).await;
    let nav = r.navigation.as_ref().expect("a navigation section");
    println!("{}\nbox within reach at {seen_s:.1} s", nav.table());
    assert_eq!(nav.goals[0].status, "succeeded", "{:?}", nav.goals[0]);
    let g = &nav.goals[1];
    assert_eq!(g.status, "succeeded", "{g:?}");
    assert!(g.final_error_m.is_some_and(|e| e < 0.25), "{g:?}");
    let shortest = g.shortest_m.expect("a shortest path");
    assert!(g.path_m > shortest + 3.0, "{g:?}: went through room 2, not the blocked door");
    assert_eq!(r.bumps, 0, "{:?}", r.bumps_at);
    let faults = r.faults.as_ref().expect("a faults section");
    assert!(faults.log.iter().any(|(_, _, w)| w.starts_with("injected box_placed: box")), "{faults:?}");
}

/// A robot carried from the corridor into room 4 on its way to room 3 (its odometry unaware)
/// notices within seconds (its readings fit the map less than half as well as they did), turns
/// on the spot, is found again or placed at its best guess, and reaches room 3, then room 5.
/// From room 4's middle the pillar, the desk and two walls look alike turned about the pillar:
/// the search cannot tell the two apart from one spot, so it places the robot at the better of
/// the two (a guess) and confirms or corrects it as the robot drives out. On seed 3 the better
/// is the wrong one, by 0.001 of score, and driving out corrects it; reaching room 3 truly
/// (within 0.25 m of the truth) shows it was. A later spell (people close making the readings fit
/// badly for a moment) must end where the robot truly is.
#[tokio::test(start_paused = true)]
async fn a_kidnapped_robot_is_found_again_and_reaches_its_goals() {
    const KIDNAP_S: f64 = 20.0;
    let plan = format!(
        "[[fault]]\nat = {KIDNAP_S}\nkind = \"kidnap\"\ntarget = \"robot\"\nto = [6.0, 10.0, 90.0]\n"
    );
    for seed in 1..=3 {
        let out = mission_under("office", &["room-3", "room-5"], seed, &plan).await;
        let r = &out.report;
        let nav = r.navigation.as_ref().expect("a navigation section");
        println!("seed {seed}:\n{}", nav.table());
        let faults = r.faults.as_ref().expect("a faults section");
        assert!(
            faults.log.iter().any(|(_, _, w)| w.starts_with("injected kidnap")),
            "seed {seed}: {faults:?}"
        );
        let l = &nav.localization;
        let first =
            l.lost.first().unwrap_or_else(|| panic!("seed {seed}: the kidnapping went unnoticed: {l:?}"));
        assert!(
            (KIDNAP_S..KIDNAP_S + 5.0).contains(&first.from_s),
            "seed {seed}: noticed at {:.1} s",
            first.from_s
        );
        let found = first.found_s.unwrap_or_else(|| panic!("seed {seed}: never found again: {l:?}"));
        assert!(
            found - KIDNAP_S <= 30.0,
            "seed {seed}: found {:.1} s after the kidnapping",
            found - KIDNAP_S
        );
        // Found where it is, or placed at the twin and corrected on the way to room 3.
        let room_3 = &nav.goals[0];
        assert!(
            first.error_after_m.is_some_and(|e| e < 0.25) || room_3.final_error_m.is_some_and(|e| e < 0.25),
            "seed {seed}: {first:?}, {room_3:?}"
        );
        for later in &l.lost[1..] {
            assert!(later.error_after_m.is_some_and(|e| e < 0.25), "seed {seed}: {later:?}");
        }
        assert_eq!(nav.success_rate, 1.0, "seed {seed}: truly reached both: {:?}", nav.goals);
        assert_eq!(r.bumps, 0, "seed {seed}: {:?}", r.bumps_at);
    }
}
