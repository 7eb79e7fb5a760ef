//! Tests of the bench's bookkeeping and smoke runs at minimal sizes. No timing is asserted:
//! only counts, shapes and keys.

use super::*;

fn lat(p50: f64) -> Latency {
    Latency { n: 10, p50_ns: p50, p99_ns: 2.0 * p50, max_ns: 3.0 * p50, mean_ns: p50 }
}

fn sample_report() -> BenchReport {
    let row = |path: &str, baseline: Option<&str>, p50: f64, r: Option<f64>| LatencyRow {
        runtime: "current-thread".into(),
        mode: "back-to-back".into(),
        path: path.into(),
        baseline: baseline.map(str::to_string),
        latency: lat(p50),
        p50_ratio: r,
        p99_ratio: r,
    };
    let scale = |robots: usize, cost: f64| ScaleRow {
        robots,
        startup_wall_s: 0.1,
        simulated_s: 10.0,
        wall_s: 1.0,
        rtf: 10.0,
        robot_seconds_per_wall_s: 10.0 * robots as f64,
        wall_us_per_robot_sim_s: cost,
        min_steps_per_robot: 1000,
        expected_steps_per_robot: 1000,
        mean_distance_m: 1.0,
        restarts: 0,
        rss_mib_per_robot: None,
        shutdown_wall_s: 0.1,
    };
    let mut r = BenchReport {
        inproc_push_p50_ns: 1200.0,
        raw_ractor_cast_p50_ns: 1000.0,
        sense_to_act_inproc_p99_ns: 50_000.0,
        rtf_1_robot: 400.0,
        rtf_100_robots: f64::NAN,
        zenoh_push_p50_ns: None,
        raw_zenoh_p50_ns: None,
        quick: true,
        orsa_version: "0".into(),
        machine: machine(),
        command: "cargo run --release -- bench --quick".into(),
        wall_s: 1.0,
        latency: vec![
            row(inproc::ORSA_PUSH, Some(inproc::RACTOR_CAST), 1200.0, Some(1.2)),
            row(inproc::RACTOR_CAST, None, 1000.0, None),
        ],
        throughput: Vec::new(),
        fanout: Vec::new(),
        sense_to_act: SenseToAct {
            duration_s: 1.0,
            commands_received: 0,
            attributed: 0,
            unattributed: 0,
            by_behaviour: BTreeMap::new(),
            from_update: Latency::default(),
            from_sensor_firing: Latency::default(),
            stale_refused: 0,
            restarts: 0,
        },
        mission: MissionRtf { simulated_s: 1.0, wall_s: 0.0025, rtf: 400.0, distance_m: 0.1, restarts: 0 },
        scale: vec![scale(1, 2000.0), scale(10, 2500.0), scale(100, 3500.0)],
        targets: Vec::new(),
    };
    r.targets = judge(&r);
    r
}

#[test]
fn json_has_the_required_keys_and_nulls_for_zenoh() {
    let json = serde_json::to_value(sample_report()).expect("serialise");
    for key in [
        "inproc_push_p50_ns",
        "raw_ractor_cast_p50_ns",
        "sense_to_act_inproc_p99_ns",
        "rtf_1_robot",
        "rtf_100_robots",
        "zenoh_push_p50_ns",
        "raw_zenoh_p50_ns",
    ] {
        assert!(json.get(key).is_some(), "no key {key}");
    }
    assert!(json["zenoh_push_p50_ns"].is_null());
    assert!(json["raw_zenoh_p50_ns"].is_null());
    assert_eq!(json["inproc_push_p50_ns"].as_f64(), Some(1200.0));
    // A figure that could not be measured is null, not an error.
    assert!(json["rtf_100_robots"].is_null());
}

#[test]
fn targets_are_judged_from_the_figures() {
    let r = sample_report();
    let get = |prefix: &str| r.targets.iter().find(|t| t.target.starts_with(prefix)).expect(prefix).met;
    assert_eq!(get("in-process push p50"), Some(true));
    assert_eq!(get("sense to act"), None, "no command was attributed");
    assert_eq!(get("one robot"), Some(true));
    assert_eq!(get("100 robots"), None, "not measured");
    assert_eq!(get("cost per robot"), Some(false), "3500 / 2000 > 1.5");
}

#[test]
fn markdown_has_every_table_and_survives_missing_figures() {
    let text = render_markdown(&sample_report());
    for heading in ["## Targets", "## In process: latency", "## Fan-out", "## Sense to act", "## Simulation"]
    {
        assert!(text.contains(heading), "no {heading} in\n{text}");
    }
    assert!(text.contains("| current-thread | back-to-back | orsa push newest -> component |"));
    assert!(text.contains("1.20x"));
    assert!(text.contains("not measured"));
}

#[test]
fn a_tiny_inproc_run_delivers_every_message() {
    let sizes = inproc::InprocSizes { warmup: 5, back_to_back: 40, burst: 300, at_25hz: 2 };
    for kind in [inproc::RuntimeKind::CurrentThread, inproc::RuntimeKind::MultiThread] {
        let out = inproc::run(kind, sizes).expect("in-process bench");
        let b2b: Vec<_> = out.latency.iter().filter(|r| r.mode == "back-to-back").collect();
        assert_eq!(b2b.len(), 6, "three push and three query paths");
        assert!(b2b.iter().all(|r| r.latency.n == 40), "{b2b:?}");
        let hz: Vec<_> = out.latency.iter().filter(|r| r.mode == "25 Hz").collect();
        assert!(hz.len() == 6 && hz.iter().all(|r| r.latency.n == 2), "{hz:?}");
        let push = b2b.iter().find(|r| r.path == inproc::ORSA_PUSH).expect("orsa push row");
        assert_eq!(push.baseline.as_deref(), Some(inproc::RACTOR_CAST));
        assert!(push.p50_ratio.is_some());
        let bursts: Vec<_> = out.throughput.iter().filter(|t| t.how.starts_with("burst")).collect();
        assert!(bursts.len() == 3 && bursts.iter().all(|t| t.messages == 300 && t.per_s > 0.0));
    }
}

#[test]
fn a_tiny_fanout_reaches_every_subscriber() {
    let rows = fanout::run(&[1, 7], |_| 10).expect("fan-out");
    assert_eq!(rows.len(), 2);
    for r in &rows {
        assert_eq!(r.delivered, r.expected, "{r:?}");
        assert_eq!(r.handled, r.expected, "{r:?}");
        assert_eq!(r.orsa_last_handler.n, 10);
        assert_eq!(r.raw_last_handler.n, 10);
    }
    assert_eq!(rows[1].expected, (10 + 5) * 7, "ten rounds and five of warm-up");
}

#[test]
fn fanout_rounds_stay_in_bounds() {
    assert_eq!(fanout::rounds_for(1, 20_000, 100), 2000);
    assert_eq!(fanout::rounds_for(100, 20_000, 100), 200);
    assert_eq!(fanout::rounds_for(1000, 20_000, 100), 100);
    assert_eq!(fanout::rounds_for(0, 20_000, 100), 2000);
}

#[test]
fn two_robots_step_through_every_simulated_step() {
    let row = sim::scale(2, 0.5, 1.0).expect("two stacks");
    assert_eq!(row.robots, 2);
    assert_eq!(row.expected_steps_per_robot, 100);
    assert!(row.min_steps_per_robot >= 99, "{row:?}");
    assert_eq!(row.restarts, 0);
    assert!(sim::scale(0, 0.5, 1.0).is_err());
    assert!(sim::scale(1, 0.5, f64::NAN).is_err());
}

#[test]
fn sense_to_act_attributes_commands_in_a_short_real_time_run() {
    let s = sense::run(1.5).expect("sense to act");
    assert!(s.commands_received > 0, "{s:?}");
    assert!(s.attributed > 0, "{s:?}");
    assert_eq!(s.attributed + s.unattributed, s.commands_received);
    assert_eq!(s.from_update.n as u64, s.attributed);
    assert!(sense::run(-1.0).is_err());
}
