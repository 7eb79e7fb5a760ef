//! Whole-stack scenarios on the simulator, on tokio's paused clock.

use orsa::config::Config;
use orsa::mission::stack::Stack;
use orsa::mission::{self, RunOptions};
use orsa_actors::{Clock, Registry};
use orsa_hardware::world::World;
use std::time::Duration;

/// A behaviour that knows the robot only through the patterns (pushes in, a wired Send out)
/// drives the simulated Nomad 200 down the reference corridor: ten metres in 40 s, near the
/// centre line, touching nothing.
#[tokio::test(start_paused = true)]
async fn a_pattern_only_behaviour_drives_the_robot_down_the_reference_corridor() {
    let clock = Clock::simulated();
    let registry = Registry::with_clock(clock);
    // No master: the system's own table activates center following and wires it to the motors.
    let config = Config::from_toml(
        r#"
        [[system.components]]
        name = "nomad200"
        [[system.components]]
        name = "centerfollow"
        state = "active"
        wire = { vel = "nomad200/navigationvelocity" }
        "#,
        "the test's config",
    )
    .expect("config");
    let stack = Stack::builder(&config, World::palazzina().expect("world"))
        .seed(7)
        .start_on(&registry)
        .await
        .expect("stack");
    assert_eq!(stack.components, ["nomad200", "centerfollow"]);
    let truth = stack.truth().expect("the simulator has a truth").clone();

    let start = truth.truth();
    let mut worst_offset: f64 = 0.0;
    for _ in 0..400 {
        tokio::time::sleep(Duration::from_millis(100)).await;
        let t = truth.truth();
        assert!(!t.in_contact, "touched something at ({:.2}, {:.2})", t.x_m, t.y_m);
        worst_offset = worst_offset.max((t.y_m - 1.2).abs());
    }
    let end = truth.truth();
    assert!(end.x_m - start.x_m > 8.0, "drove {:.2} m along the corridor", end.x_m - start.x_m);
    assert!(worst_offset < 0.35, "strayed {worst_offset:.2} m from the centre line");
    assert_eq!(end.contact_onsets, 0);
}

fn wf(c: &Config) -> orsa_reactive::wallfollow::WallFollowParams {
    c.params_of("wallfollow").expect("wall following's parameters")
}

fn cf(c: &Config) -> orsa_reactive::centerfollow::CenterFollowParams {
    c.params_of("centerfollow").expect("center following's parameters")
}

fn options(seed: u64, duration_s: f64) -> RunOptions {
    RunOptions::new(World::palazzina().expect("world"), "palazzina", Config::default(), seed, duration_s)
}

/// The same seed gives the same run: the whole report is identical but for wall time.
#[tokio::test(start_paused = true)]
async fn the_same_seed_gives_the_same_report() {
    let a = mission::run(options(3, 120.0)).await.expect("run");
    let b = mission::run(options(3, 120.0)).await.expect("run");
    let c = mission::run(options(4, 120.0)).await.expect("run");
    assert_eq!(a.report.of_the_run(), b.report.of_the_run(), "all but the process's memory");
    assert_eq!(a.metrics.trajectory, b.metrics.trajectory, "sample by sample");
    assert_ne!(a.metrics.trajectory, c.metrics.trajectory, "another seed, another run");
}

/// A few simulated minutes of the mission with the default rules: both behaviours drive, the
/// robot covers ground.
#[tokio::test(start_paused = true)]
async fn the_mission_uses_both_behaviours() {
    let out = mission::run(options(1, 240.0)).await.expect("run");
    let share = &out.report.behaviour_share;
    assert!(share.get("centerfollow").copied().unwrap_or(0.0) > 0.5, "{share:?}");
    assert!(share.get("wallfollow").copied().unwrap_or(0.0) > 0.0, "{share:?}");
    assert!(out.report.distance_m > 15.0, "drove {} m", out.report.distance_m);
    assert_eq!(out.report.restarts, 0);
}

/// The thesis' measures are taken by kind, not by name: the same mission with its behaviours
/// named `hug` (a `wallfollow`) and `middle` (a `centerfollow`) is the same run, and its report
/// gives the same shares, clearance and offset, the names' shares under the new names.
#[tokio::test(start_paused = true)]
async fn behaviours_named_otherwise_are_measured_by_their_kind() {
    let text = include_str!("../config/orsa.toml");
    let renamed = text
        .replace("wallfollow", "hug")
        .replace("centerfollow", "middle")
        .replace("name = \"hug\"", "name = \"hug\"\nkind = \"wallfollow\"")
        .replace("name = \"middle\"", "name = \"middle\"\nkind = \"centerfollow\"");
    let run = |config: Config| {
        mission::run(RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 1, 240.0))
    };
    let named = run(Config::from_toml(text, "config/orsa.toml").expect("config")).await.expect("run").report;
    let other =
        run(Config::from_toml(&renamed, "the renamed config").expect("config")).await.expect("run").report;
    assert!(named.kind_share.get("wallfollow").copied().unwrap_or(0.0) > 0.0, "{:?}", named.kind_share);
    assert_eq!(other.kind_share, named.kind_share);
    assert_eq!(other.behaviour_share.get("hug"), named.behaviour_share.get("wallfollow"));
    assert_eq!(other.behaviour_share.get("middle"), named.behaviour_share.get("centerfollow"));
    assert!(other.wallfollow.mean_clearance_m.is_some(), "{:?}", other.wallfollow);
    assert!(other.centerfollow.mean_abs_offset_m.is_some(), "{:?}", other.centerfollow);
    assert_eq!(other.wallfollow, named.wallfollow);
    assert_eq!(other.centerfollow, named.centerfollow);
    assert!(other.table().contains("time wall following"), "{}", other.table());
}

/// The default arbitration's hysteresis lets wall following follow walls: on seed 2's hour it
/// drives far longer than under the thesis' rule alone (`config/thesis.toml`), where it only
/// approaches and turns, and its mean clearance meets the 20 +- 2 cm target that the thesis'
/// rule misses (EXPERIMENTS.md: 33.7 % at 20.5 cm against 0.5 % at 24.3 cm).
#[tokio::test(start_paused = true)]
async fn with_hysteresis_wall_following_holds_its_clearance_and_the_thesis_rule_does_not() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let thesis = Config::load(&root.join("config/thesis.toml")).expect("the shipped thesis config");
    assert!(thesis.executive().modes["patrol"].rules.iter().all(|r| !r.holds_on()));
    assert!(Config::default().executive().modes["patrol"].rules[0].holds_on());
    let world = || World::palazzina().expect("world");
    let held = mission::run(options(2, 3600.0)).await.expect("run");
    let original = mission::run(RunOptions::new(world(), "palazzina", thesis, 2, 3600.0)).await.expect("run");
    let share = |r: &mission::report::Report| r.behaviour_share.get("wallfollow").copied().unwrap_or(0.0);
    let clearance =
        |r: &mission::report::Report| r.wallfollow.mean_clearance_m.expect("wall following drove");
    assert!(share(&held.report) > 0.08, "{}", share(&held.report));
    assert!(share(&original.report) < 0.02, "{}", share(&original.report));
    assert!((clearance(&held.report) - 0.20).abs() <= 0.02, "{}", clearance(&held.report));
    assert!(clearance(&original.report) > 0.22, "{}", clearance(&original.report));
    for r in [&held.report, &original.report] {
        assert_eq!((r.bumps, r.stalls), (0, 0), "{:?}", r.bumps_at);
        let offset = r.centerfollow.mean_abs_offset_m.expect("center following drove");
        assert!(offset <= 0.05, "{offset}");
    }
}

/// A configuration mistake is reported with the file, the line and the key.
#[test]
fn config_errors_name_file_line_and_key() {
    let e = Config::from_toml("\n[params.master]\nsubscribe_every = 0\n", "bad.toml").expect_err("invalid");
    assert_eq!(e.to_string(), "bad.toml:2:1: params.master.subscribe_every: must be at least 1");
    let e =
        Config::from_toml("[params.centerfollow]\nv_max_m_s = \"fast\"\n", "bad.toml").expect_err("invalid");
    assert!(e.to_string().starts_with("bad.toml:1:1: params.centerfollow.v_max_m_s: invalid type"), "{e}");
}

/// A deadlock is got out of. With the recovery turned off (`[*.unstick] enabled = false`), seed
/// 8 is trapped from t = 780 s to 1080 s against the lower wall near x = 13.9 m, beside the
/// crossing person who waits for it to leave, moving at most 0.55 m in any of those minutes
/// (EXPERIMENTS.md). With the behaviours' recovery (on by default) it keeps patrolling: no
/// stalled minute, and in every minute it gets at least a metre from where the minute began
/// (backing and forth on the spot would pass the stall count, not this).
#[tokio::test(start_paused = true)]
async fn a_robot_caught_between_a_wall_and_waiting_people_gets_out() {
    let config = Config::default();
    assert!(cf(&config).unstick.enabled && wf(&config).unstick.enabled);
    let opts = RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 8, 1200.0);
    let out = mission::run(opts).await.expect("run");
    assert_eq!(out.report.bumps, 0);
    assert_eq!(out.report.stalls, 0);
    let trajectory = &out.metrics.trajectory;
    for minute in trajectory.chunks(600) {
        let (t0, x0, y0, _) = &minute[0];
        let farthest = minute.iter().map(|(_, x, y, _)| (x - x0).hypot(y - y0)).fold(0.0, f64::max);
        assert!(farthest >= 1.0, "the minute from t = {t0:.0} s: at most {farthest:.2} m from its start");
    }
    assert!(out.report.distance_m > 250.0, "{} m", out.report.distance_m);
}

/// Holding the walls' direction through odometry (`[params.centerfollow.walls]`, on by default)
/// keeps the robot nearer the centre than the ring's angle alone: on seed 2, a quarter of an
/// hour, the mean offset falls from 5.1 cm to 3.7 cm (EXPERIMENTS.md has the hour on ten
/// seeds), touching nothing.
#[tokio::test(start_paused = true)]
async fn holding_the_walls_direction_keeps_the_robot_nearer_the_centre() {
    assert!(cf(&Config::default()).walls.enabled);
    let ring_only = Config::default().with_sets(&["centerfollow.walls.enabled=false".into()]).expect("set");
    assert!(!cf(&ring_only).walls.enabled);
    let opts = RunOptions::new(World::palazzina().expect("world"), "palazzina", ring_only, 2, 900.0);
    let plain = mission::run(opts).await.expect("run");
    let held = mission::run(options(2, 900.0)).await.expect("run");
    let offset =
        |r: &mission::RunOutcome| r.report.centerfollow.mean_abs_offset_m.expect("center following ran");
    assert!(
        offset(&held) < 0.8 * offset(&plain),
        "held {:.4} m against {:.4} m",
        offset(&held),
        offset(&plain)
    );
    assert_eq!((held.report.bumps, held.report.stalls), (0, 0));
}

/// Following the left wall alone (the `follow_left_wall` mode), the robot holds its 20 cm and
/// gets past the people who wait for it. Seed 1 before the bumpers were heeded and the gap
/// shared (EXPERIMENTS.md): at t = 1376 s it drove its right side into the crossing person,
/// who stood 70 cm from the wall waiting for it to pass, and pushed there, its wheels slipping
/// and its odometry counting progress, for the rest of the hour (37 stalled minutes).
#[tokio::test(start_paused = true)]
async fn following_the_wall_alone_it_holds_twenty_centimetres_and_touches_nobody() {
    let config = Config::from_toml(
        "[params.planner]\nmission = [{ mode = \"follow_left_wall\", for_s = 1560 }]\n",
        "wf.toml",
    )
    .expect("config");
    assert!(wf(&config).share_gaps && wf(&config).unstick.enabled);
    let opts = RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 1, 1560.0);
    let out = mission::run(opts).await.expect("run");
    assert_eq!(out.report.behaviour_share.get("wallfollow").copied(), Some(1.0));
    assert_eq!((out.report.bumps, out.report.stalls), (0, 0));
    let clearance = out.report.wallfollow.mean_clearance_m.expect("wall following ran");
    assert!((clearance - 0.20).abs() < 0.02, "{clearance} m");
    assert!(out.report.distance_m > 250.0, "{} m", out.report.distance_m);
}

/// The bumpers' `contact` event reaches the behaviours across the stack and they back out on
/// it. With the gap sharing off, following the wall alone on seed 1 drives the robot's right
/// side into the waiting crossing person at t = 1376 s. Odometry keeps counting there (the
/// wheels slip), so only contact can tell: with the recovery off the robot pushes on for good
/// (one contact, stalled minutes); with it on every contact backs it out, and it comes back
/// and touches again (a new contact onset each time) until the person walks on, without a
/// stalled minute. The contact is made with the safety monitor off: with it on (the last run),
/// the robot never touches the person at all.
#[tokio::test(start_paused = true)]
async fn touching_something_the_behaviour_backs_out_on_the_contact_event() {
    let run = |recovery: bool, monitor: bool| {
        let toml = format!(
            "[params.wallfollow]\nshare_gaps = false\n[params.wallfollow.unstick]\nenabled = {recovery}\n\
             [params.planner]\nmission = [{{ mode = \"follow_left_wall\", for_s = 1800 }}]\n\
             [safety]\nenabled = {monitor}\n"
        );
        let config = Config::from_toml(&toml, "contact.toml").expect("config");
        mission::run(RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 1, 1800.0))
    };
    let pushed_on = run(false, false).await.expect("run");
    assert_eq!(pushed_on.report.bumps, 1);
    assert!(pushed_on.report.stalls >= 5, "{} stalled minutes", pushed_on.report.stalls);
    let backed_out = run(true, false).await.expect("run");
    assert!(backed_out.report.bumps >= 2, "{} contacts", backed_out.report.bumps);
    assert_eq!(backed_out.report.stalls, 0);
    let guarded = run(true, true).await.expect("run");
    assert_eq!(guarded.report.bumps, 0, "the monitor stops short of the person");
    let m = guarded.report.safety.monitor.expect("the monitor's figures");
    assert!(m.obstacle_s + m.slowdown_s > 0.0, "{m:?}");
}
