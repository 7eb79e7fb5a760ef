//! The examples in `examples/` are built by the test command and run here, each checked for
//! what it shows. (The remote client is run in `tests/net/`, against a robot process.)

#[allow(dead_code, unreachable_pub)]
#[path = "../examples/new_component.rs"]
mod new_component;

#[allow(dead_code, unreachable_pub)]
#[path = "../examples/new_behaviour.rs"]
mod new_behaviour;

#[allow(dead_code, unreachable_pub)]
#[path = "../examples/new_robot.rs"]
mod new_robot;

/// The battery's five services each work, with the figures its 0.1 Wh at 36 W imply.
#[tokio::test(start_paused = true)]
async fn a_new_component_serves_each_pattern() {
    let seen = new_component::run().await.expect("the example runs");
    // 0.1 Wh at 36 W: 10 s, less the 50 ms drained before the query.
    assert!((seen.runtime_s - 9.95).abs() < 0.06, "runtime {}", seen.runtime_s);
    // Every 5th voltage sample, falling as the battery drains, 0.2 V (5 x 0.04 V) apart.
    assert_eq!(seen.voltages.len(), 4);
    for w in seen.voltages.windows(2) {
        assert!((w[0] - w[1] - 0.2).abs() < 1e-9, "{:?}", seen.voltages);
    }
    // The single-shot event fires once the charge crosses 50 %: after 5 s, just under half.
    assert!(seen.low_at.fraction < 0.5 && seen.low_at.fraction > 0.49, "{:?}", seen.low_at);
    assert!((seen.low_after_s - 5.0).abs() < 0.11, "fired after {} s", seen.low_after_s);
}

/// One file, one registration and config put `wander` in the mission: the master wires it, it
/// drives the robot along the corridor, nothing else does, the report counts it, and the harness
/// gave it a live `param` service (what `orsa param get wander` asks) that checks a set with the
/// controller's own `validate()`.
#[tokio::test(start_paused = true)]
async fn a_new_behaviour_joins_the_mission_through_config_and_one_registration() {
    let seen = new_behaviour::run(120.0).await.expect("the example runs");
    let report = seen.outcome.report;
    assert_eq!(report.behaviour_share.get("wander").copied(), Some(1.0), "{:?}", report.behaviour_share);
    assert!(report.distance_m > 5.0, "wander drove only {:.1} m", report.distance_m);
    assert_eq!(report.integrity.driven_unwired_s, 0.0);
    let params: Vec<(String, serde_json::Value)> =
        seen.params.params.iter().map(|p| (p.name.clone(), p.value.clone())).collect();
    assert_eq!(
        params,
        vec![
            ("gain_rad_s_m".to_string(), serde_json::json!(3.0)),
            ("speed_m_s".to_string(), serde_json::json!(0.2))
        ],
        "its config's params, live"
    );
    let why = seen.refused.refused.expect("5 m/s is refused");
    assert!(why.contains("speed_m_s"), "{why}");
    assert_eq!(seen.refused.params[0].value, serde_json::json!(0.2), "the old value stays");
}

/// The example's config is refused, with the key named, by a catalog that does not know it.
#[tokio::test(start_paused = true)]
async fn a_system_naming_an_unknown_kind_is_refused_with_the_key() {
    let config = orsa::config::Config::from_toml(new_behaviour::CONFIG, "example").expect("parses");
    let err = orsa::system::System::builder(&config)
        .start(&orsa::actors::Registry::new())
        .await
        .expect_err("wander is not a built-in kind");
    let text = err.to_string();
    assert!(text.contains("system.components[1].kind") && text.contains("'wander'"), "{text}");
}

/// The differential-drive robot with a laser, described in config alone, runs the corridor
/// mission: it says what it is (drive, laser, sector views on its 0.35 m body), both behaviours
/// drive it, wall following holds its 20 cm, and it touches nothing. (Seeds 1 to 10 for a
/// simulated hour each are in EXPERIMENTS.md: too long for the test command.)
#[tokio::test(start_paused = true)]
async fn a_new_robot_runs_the_corridor_mission_from_its_description() {
    use orsa::interfaces::range::{DriveKind, RangeLayout};
    let seen = new_robot::run(1, 900.0).await.expect("the example runs");
    let p = &seen.params;
    assert_eq!(p.drive, DriveKind::Differential);
    assert_eq!((p.body_radius_m, p.max_v_m_s), (0.35, 1.0));
    assert_eq!(p.range_sensors.len(), 1, "{:?}", p.range_sensors);
    let laser = &p.range_sensors[0];
    assert_eq!((laser.layout, laser.angles_rad.len(), laser.x_m), (RangeLayout::Laser, 271, 0.1));
    assert_eq!((laser.min_range_m, laser.max_range_m, laser.period_s), (0.05, 10.0, 0.1));
    assert_eq!(p.infrared.mount_radius_m, 0.35, "the views sit on the body's edge");
    let report = &seen.outcome.report;
    assert_eq!(report.bumps, 0, "{:?}", report.bumps_at);
    for b in ["wallfollow", "centerfollow"] {
        let share = report.behaviour_share.get(b).copied().unwrap_or(0.0);
        assert!(share > 0.1, "{b} drove {share} of the time: {:?}", report.behaviour_share);
    }
    assert!(report.distance_m > 150.0, "drove only {:.1} m", report.distance_m);
    let clearance = report.wallfollow.mean_clearance_m.expect("wall following held a wall");
    assert!((clearance - 0.20).abs() < 0.03, "held {clearance} m from the wall (target 0.20)");
    assert_eq!(report.integrity.driven_unwired_s, 0.0);
}
