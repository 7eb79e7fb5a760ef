//! Fault plans against the whole stack on tokio's paused clock: the robot stays safe, every
//! failure is detected and recovered, and the report says what broke.

use orsa::config::Config;
use orsa::faults::{FaultPlan, PlanTargets};
use orsa::hardware::world::World;
use orsa::mission::{self, RunOptions};

fn plan(text: &str, config: &Config) -> FaultPlan {
    FaultPlan::parse(text, "test-plan.toml", &PlanTargets::for_stack(config)).expect("a valid plan")
}

/// The safety case: a behaviour that panics at 10 Hz for ten simulated minutes never
/// leaves the robot driving on a stale command.
#[tokio::test(start_paused = true)]
async fn a_behaviour_panicking_at_10_hz_for_ten_minutes_never_leaves_the_robot_on_a_stale_command() {
    let mut config = Config::default();
    // Ten restarts a second for ten minutes is the point of the test, not a reason for the
    // behaviours' subtree to give up.
    let behaviours = config.supervision.subtrees.get_mut("behaviours").expect("the behaviours' subtree");
    behaviours.max_restarts = 1_000;
    behaviours.period_s = 60.0;
    let plan = plan(
        "[[fault]]\nat = 10.0\nkind = \"panic\"\ntarget = \"centerfollow\"\nevery = 0.1\nuntil = 610.0\n",
        &config,
    );
    let mut opts = RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 1, 660.0);
    opts.faults = Some(plan);
    let report = mission::run(opts).await.expect("the run completes").report;
    let faults = report.faults.as_ref().expect("a faults section");
    assert_eq!(faults.injected.get("panic"), Some(&6001));
    assert_eq!(faults.detected.get("centerfollow"), Some(&6001), "every panic was seen");
    assert_eq!(faults.restarts.get("centerfollow"), Some(&6001), "and restarted");
    assert_eq!(faults.not_recovered, 0, "every restarted instance handled messages again");
    // Never a moment on a command older than the velocity timeout: the watchdog never had to
    // stop the robot, and nothing stale was applied.
    assert_eq!(report.safety.command_timeouts, 0, "{:?}", report.safety);
    assert_eq!(report.bumps, 0);
    assert_eq!(report.stalls, 0);
    assert!(report.distance_m > 100.0, "the robot kept patrolling: {} m", report.distance_m);
    held_together(&report);
}

/// Nothing that must arrive was lost, the motors never ran unwired or on a stale command, and
/// every subscription and wiring stayed as it should.
fn held_together(report: &orsa::mission::report::Report) {
    let d = &report.delivery;
    assert_eq!(d.lost_must_arrive, 0, "{:?}", d.services);
    assert!(d.total.offered > 0, "the ledger counted the run");
    for (service, s) in &d.services {
        assert!(s.in_flight <= 2, "{service}: {s:?}");
    }
    let i = &report.integrity;
    assert_eq!(i.driven_unwired_s, 0.0, "{i:?}");
    assert_eq!(i.driven_on_stale_command_s, 0.0, "{i:?}");
    assert_eq!(report.safety.stale_commands_applied, 0, "{:?}", report.safety);
    assert!(i.client_checks > 0 && i.wiring_checks > 0, "{i:?}");
    assert_eq!(i.client_mismatches, 0, "{i:?}");
    assert_eq!(i.wiring_mismatches, 0, "{i:?}");
    assert!(i.wiring_matches_master, "{i:?}");
}

/// Every kind of broken part a single process can have, repeatedly, over five simulated minutes.
#[tokio::test(start_paused = true)]
async fn the_standard_plan_is_survived_and_accounted_for() {
    let config = Config::default();
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/config/faults.example.toml"))
        .expect("the shipped plan");
    let plan = plan(&text, &config);
    let mut opts = RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 2, 300.0);
    opts.faults = Some(plan);
    let report = mission::run(opts).await.expect("the run completes").report;
    let f = report.faults.as_ref().expect("a faults section");
    // Link cuts need a second process; the world's events are the navigation tests'.
    for kind in
        orsa::faults::KINDS.iter().filter(|k| **k != "link_cut" && !orsa::faults::WORLD_EVENTS.contains(k))
    {
        assert!(f.injected.get(*kind).copied().unwrap_or(0) >= 8, "{kind} injected: {:?}", f.injected);
    }
    for component in ["nomad200", "wallfollow", "centerfollow", "master"] {
        assert!(f.restarts.get(component).copied().unwrap_or(0) >= 8, "{component}: {:?}", f.restarts);
        assert_eq!(
            f.detected.get(component),
            f.restarts.get(component),
            "{component}: each failure restarted once"
        );
    }
    assert_eq!(f.not_recovered, 0, "{:?}", f.log.iter().rev().take(10).collect::<Vec<_>>());
    let velocity = f.messages.get("nomad200/navigationvelocity").expect("velocity faults counted");
    assert!(velocity.dropped > 0 && velocity.duplicated > 0, "{velocity:?}");
    assert!(f.hardware_altered > 0);
    assert_eq!(report.bumps, 0);
    assert!(report.distance_m > 40.0, "the robot kept patrolling: {} m", report.distance_m);
    held_together(&report);
    // The receivers saw each injected copy as a duplicate, and the plan's drops are its own.
    let v = &report.delivery.services["nomad200/navigationvelocity"];
    assert_eq!(v.counts.duplicates, v.counts.copies_injected, "{v:?}");
    assert_eq!(v.counts.dropped, velocity.dropped, "{v:?}");
    assert!(v.counts.duplicates > 0);
    // The faults section says the same in short.
    let loss = f.loss.expect("loss figures");
    assert_eq!((loss.lost_must_arrive, loss.wiring_mismatches, loss.subscription_mismatches), (0, 0, 0));
    assert_eq!(loss.duplicates, report.delivery.total.duplicates);
    let safety = f.safety.expect("safety figures");
    assert_eq!((safety.bumps, safety.stale_commands_applied), (0, 0));
    assert_eq!(safety.driven_on_stale_command_s, 0.0);
}
