//! Tests of the bench's bookkeeping and smoke runs at minimal sizes. No timing is asserted:
//! only counts, shapes and keys.

use super::*;
use std::collections::BTreeMap;

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
        raw_wall_us_per_robot_sim_s: Some(cost / 10.0),
        ractor_wall_us_per_robot_sim_s: Some(cost / 5.0),
        rtf_runs: vec![9.0, 10.0, 11.0],
    };
    let mut r = BenchReport {
        inproc_push_p50_ns: 1200.0,
        raw_ractor_cast_p50_ns: 1000.0,
        sense_to_act_inproc_p99_ns: 50_000.0,
        rtf_1_robot: 400.0,
        rtf_100_robots: f64::NAN,
        zenoh_push_p50_ns: None,
        raw_zenoh_p50_ns: None,
        sense_to_act_xproc_p99_ns: None,
        quick: true,
        orsa_version: "0".into(),
        machine: machine(),
        command: "cargo run --release -p orsa-bench -- --quick".into(),
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
            legs: Vec::new(),
            stale_refused: 0,
            monitor: true,
            restarts: 0,
            live_client: None,
            ros2_calls: None,
        },
        monitor_cost: None,
        interop_cost: None,
        sense_to_act_live: SenseToAct {
            duration_s: 1.0,
            commands_received: 0,
            attributed: 0,
            unattributed: 0,
            by_behaviour: BTreeMap::new(),
            from_update: Latency::default(),
            from_sensor_firing: Latency::default(),
            legs: Vec::new(),
            stale_refused: 0,
            monitor: true,
            restarts: 0,
            live_client: None,
            ros2_calls: None,
        },
        net: None,
        net_error: Some("not run in this test".into()),
        ros2: None,
        ros2_error: Some("not run in this test".into()),
        mission: MissionRtf { simulated_s: 1.0, wall_s: 0.0025, rtf: 400.0, distance_m: 0.1, restarts: 0 },
        record_replay: RecordReplay {
            simulated_s: 60.0,
            run_wall_s: vec![1.0, 1.1, 0.9],
            record_wall_s: vec![1.1, 1.2, 1.0],
            replay_wall_s: vec![0.5, 0.6, 0.4],
            record_ratio: 1.1,
            replay_ratio: 0.5,
            live_wall_s: vec![1.0, 1.0, 1.0],
            live_ratio: 1.0,
            bit_exact: true,
            messages: 1000,
            compared: 500,
            file_bytes: 100_000,
        },
        switch: SwitchCosts {
            in_process: SwitchPair {
                rounds: 10,
                switch: Latency { n: 10, p50_ns: 6000.0, p99_ns: 9000.0, max_ns: 9000.0, mean_ns: 6000.0 },
                one_by_one: Latency {
                    n: 10,
                    p50_ns: 5000.0,
                    p99_ns: 8000.0,
                    max_ns: 8000.0,
                    mean_ns: 5000.0,
                },
                p50_ratio: 1.2,
            },
            across: None,
        },
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
        "sense_to_act_xproc_p99_ns",
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
    let cost = r.targets.iter().find(|t| t.target.starts_with("cost per robot")).expect("cost per robot");
    assert!(
        cost.measured.ends_with(
            "raw tokio skeleton 200.0 to 350.0 us (1.75x); ractor skeleton 400.0 to 700.0 us (1.75x)"
        ),
        "{cost:?}"
    );
    assert_eq!(get("zenoh push p50"), None, "the cross-process bench did not run");
    assert_eq!(get("the ROS 2 publication"), None, "the ROS 2 bench did not run");
}

/// The ROS 2 bench, small: it measures both ways, and the LaserScans reach the other session.
#[test]
fn the_ros2_publication_is_measured_against_the_plain_push() {
    let c = crate::ros2::run(100).expect("the ROS 2 bench runs");
    assert_eq!(c.plain.n + c.with_ros2.n + c.lost as usize, 200, "{c:?}");
    assert!(c.plain.n >= 90 && c.with_ros2.n >= 90, "{c:?}");
    assert!(c.p50_ratio.is_some_and(|x| x > 0.0), "{c:?}");
    assert!(c.ros2_received >= 90, "the ROS 2 subscriber got {} of 100", c.ros2_received);
    assert!(c.ros2_publish_p50_ns > 0.0, "{c:?}");
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
    assert!(text.contains("| 10.0x (runs 9.0, 10.0, 11.0) |"), "every run of a repeated row:\n{text}");
    assert!(text.contains("| ractor skeleton | ractor vs 1 robot |"), "{text}");
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
fn both_skeletons_step_and_carry_commands_like_the_stack() {
    // Two robots for 1.5 simulated s: a step every 10 ms from t = 0 (151 each), and a command
    // for every infrared scan (every 40 ms: 38) and sonar scan (every 64 ms: 24).
    for skeleton in [sim::Skeleton::Tokio, sim::Skeleton::Ractor] {
        let raw = sim::raw_scale(skeleton, 2, 0.5, 1.0).expect("two skeletons");
        assert!((300..=304).contains(&raw.steps), "{skeleton:?}: {raw:?}");
        assert!((120..=124).contains(&raw.commands), "{skeleton:?}: {raw:?}");
        assert!(raw.us_per_robot_sim_s.is_finite() && raw.us_per_robot_sim_s > 0.0, "{raw:?}");
        assert!(sim::raw_scale(skeleton, 0, 0.5, 1.0).is_err());
        assert!(sim::raw_scale(skeleton, 1, f64::INFINITY, 1.0).is_err());
    }
}

#[test]
fn sense_to_act_attributes_commands_in_a_short_real_time_run() {
    let s = sense::run(1.5, Arm::Plain).expect("sense to act");
    assert!(s.commands_received > 0, "{s:?}");
    assert!(s.attributed > 0, "{s:?}");
    assert_eq!(s.attributed + s.unattributed, s.commands_received);
    assert_eq!(s.from_update.n as u64, s.attributed);
    assert!(s.live_client.is_none());
    assert!(s.monitor, "the stack as `orsa run` starts it has its safety monitor");
    assert!(sense::run(-1.0, Arm::Plain).is_err());
    // The baseline of the monitor's cost: the same stack without it, still measured.
    let without = sense::run(1.5, Arm::NoMonitor).expect("sense to act without the monitor");
    assert!(!without.monitor && without.attributed > 0, "{without:?}");
}

#[test]
fn sense_to_act_with_a_live_client_reads_the_views_and_still_attributes_commands() {
    let s = sense::run(2.0, Arm::Live).expect("sense to act with a live client");
    assert!(s.attributed > 0, "{s:?}");
    let c = s.live_client.expect("the live client's figures");
    // The robot, driving, events, world, both scans and /tf: the process simulates the world.
    assert!(c.subscribed >= 7, "{c:?}");
    // Two seconds of scans at 25 and 15.6 Hz, and /tf at 10 Hz, at the least.
    assert!(c.messages >= 50, "{c:?}");
    assert_eq!(c.dropped, 0, "{c:?}");
}

#[test]
fn a_publishing_live_client_takes_the_whole_path_and_leaves_the_behaviours_driving() {
    let s = sense::run(2.0, Arm::LivePublishing).expect("sense to act with a publishing client");
    let c = s.live_client.clone().expect("the live client's figures");
    // 20 Hz for two seconds, less the start.
    assert!(c.published >= 20, "{c:?}");
    // Every command the server got was handed to teleop, and the robot refused each as stale:
    // none drove (the behaviours' commands are all that reached the board).
    assert!(c.taken > 0 && c.taken <= c.published, "{c:?}");
    assert!(s.stale_refused >= c.taken, "{s:?}");
    assert!(s.attributed > 0, "{s:?}");
    assert!(s.ros2_calls.is_none());
}

#[test]
fn the_ros2_services_arm_answers_calls_through_every_component() {
    let s = sense::run(2.0, Arm::Ros2Services).expect("sense to act with the services called");
    let calls = s.ros2_calls.expect("the ROS 2 client's figures");
    assert!(calls.answered > 10, "{calls:?}");
    assert_eq!(calls.incomplete, 0, "{calls:?}");
    assert!(s.attributed > 0, "{s:?}");
    assert!(s.live_client.is_none());
}

// ---- across processes ----------------------------------------------------------------------

/// The environment variable that makes [`peer_process`] serve as the peer.
const PEER_ENV: &str = "ORSA_BENCH_TEST_PEER";

/// In tests this binary is the test harness, which has no `--peer`: the peer is this
/// harness again, running only [`peer_process`].
fn test_launcher(endpoint: &str) -> anyhow::Result<std::process::Command> {
    this_harness("tests::peer_process", PEER_ENV, endpoint)
}

/// This test harness again, running only the ignored test `test`, with `env` set to `value`.
fn this_harness(test: &str, env: &str, value: &str) -> anyhow::Result<std::process::Command> {
    let mut c = std::process::Command::new(std::env::current_exe()?);
    c.args([test, "--exact", "--ignored", "--nocapture", "--test-threads=1"]).env(env, value);
    Ok(c)
}

#[test]
#[ignore = "the peer process of the cross-process tests: they start it themselves"]
fn peer_process() {
    if let Ok(endpoint) = std::env::var(PEER_ENV) {
        peer::main(&endpoint).expect("the bench peer");
    }
}

#[test]
fn peer_protocol_messages_round_trip_through_cbor() {
    let go = net::Go { path: 3, seq: u64::MAX };
    assert_eq!(net::uncbor::<net::Go>(&net::cbor(&go)), Some(go));
    let sample =
        net::Sample { seq: 7, sent_unix_ns: 1_763_700_000_123_456_789, readings: net::Sample::padding() };
    assert_eq!(sample.readings.len(), 16, "sized like a DistanceScan");
    assert_eq!(net::uncbor::<net::Sample>(&net::cbor(&sample)), Some(sample.clone()));
    // orsa's envelope carries the same sample, unchanged .
    let stamped = orsa_actors::Stamped { seq: 1, sent_at: orsa_actors::Timestamp(5), value: sample.clone() };
    let bytes = orsa_actors::wire::encode_stamped(&stamped);
    let back = orsa_actors::wire::decode_stamped::<net::Sample>(&bytes, "sample").expect("decodes");
    assert_eq!(back.value, sample);
    for req in [
        net::PeerRequest::Ping,
        net::PeerRequest::StartBehaviours { robot: "nomad200".into() },
        net::PeerRequest::StopBehaviours,
        net::PeerRequest::Stream { per_path: 3, first_seq: vec![1, 5, 9, 13], spacing_us: 10_000 },
        net::PeerRequest::TakePutCosts,
        net::PeerRequest::Quit,
    ] {
        assert_eq!(net::uncbor::<net::PeerRequest>(&net::cbor(&req)), Some(req.clone()));
    }
    let steps = vec![net::WireStep {
        behaviour: "wallfollow".into(),
        update_unix_ns: 1_763_700_000_000_000_000,
        fired_unix_ns: 1_763_699_999_990_000_000,
        handled_unix_ns: 1_763_700_000_000_050_000,
        done_unix_ns: 1_763_700_000_000_060_000,
        v: 0.25,
        w: -0.125,
    }];
    for reply in [
        net::PeerReply::Ok,
        net::PeerReply::Steps { steps, restarts: 2 },
        net::PeerReply::Failed { reason: "no".into() },
        net::PeerReply::PutCosts { per_path: vec![lat(1.0), Latency::default()] },
    ] {
        assert_eq!(net::uncbor::<net::PeerReply>(&net::cbor(&reply)), Some(reply.clone()));
    }
    assert_eq!(net::uncbor::<net::Go>(b"\xff\x00"), None, "garbage is refused, not a panic");
}

#[test]
fn run_prefixes_and_keys_follow_the_port() {
    assert_eq!(net::prefix_for("tcp/127.0.0.1:40123"), "orsabench40123");
    let k = net::RawKeys::new("orsabench40123");
    assert_eq!(k.go, "orsabench40123/bench/go");
    assert_ne!(k.callback, k.task, "each raw path has its own key");
    assert!(net::in_order(&[1, 2, 5]));
    assert!(!net::in_order(&[1, 3, 2]));
    assert!(!net::in_order(&[1, 1]));
}

#[test]
fn steps_from_the_peer_keep_their_unix_stamps() {
    const T0: u64 = 1_763_000_000_000_000_000;
    let w = net::WireStep {
        behaviour: "centerfollow".into(),
        update_unix_ns: T0 + 2_000,
        fired_unix_ns: T0 + 1_500,
        handled_unix_ns: T0 + 2_100,
        done_unix_ns: T0 + 2_200,
        v: 0.1,
        w: 0.2,
    };
    let s = sense::step_from_wire(&w);
    assert_eq!((s.behaviour, s.update.0 - T0, s.fired.0 - T0), ("centerfollow", 2_000, 1_500));
    assert_eq!((s.handled.0 - T0, s.done.0 - T0), (2_100, 2_200));
    let odd = net::WireStep { behaviour: "someone".into(), ..w };
    assert_eq!(sense::step_from_wire(&odd).behaviour, "other");
}

#[test]
fn a_tiny_cross_process_run_delivers_every_sample_in_order() {
    let sizes = net::NetSizes { warmup: 5, back_to_back: 30, at_25hz: 3, sense_s: 3.0, switch_rounds: 20 };
    let report = net::run(sizes, test_launcher).expect("cross-process bench");
    assert_eq!(report.latency.len(), 2 * net::PATHS.len(), "{:?}", report.latency);
    for row in &report.latency {
        let expected = if row.mode == "back-to-back" { 30 } else { 3 };
        assert_eq!((row.sent, row.received), (expected, expected), "{row:?}");
        assert_eq!(row.latency.n as u64, expected, "{row:?}");
        assert!(row.in_order, "{row:?}");
        assert_eq!(row.baseline.is_some(), row.path != net::RAW_CALLBACK, "{row:?}");
        assert_eq!(row.sender_put.n as u64, expected, "the peer timed every send: {row:?}");
    }
    assert!(report.codec.orsa_bytes > report.codec.raw_bytes, "{:?}", report.codec);
    let s = report.sense_to_act.expect("sense to act across processes");
    assert!(s.attributed > 0, "{s:?}");
    assert_eq!(s.attributed + s.unattributed, s.commands_received);
    assert_eq!(s.from_update.n as u64, s.attributed);
}

fn sample_net() -> NetReport {
    let row = |mode: &str, path: &str, p50: f64, base: f64| NetLatencyRow {
        mode: mode.into(),
        path: path.into(),
        baseline: net::baseline_of(path).map(str::to_string),
        latency: lat(p50),
        p50_ratio: net::baseline_of(path).map(|_| p50 / base),
        p99_ratio: None,
        sent: 10,
        received: 10,
        in_order: true,
        sender_put: lat(1000.0),
    };
    let mut latency = Vec::new();
    for (mode, [component, sink, callback, task, actor]) in
        [("back-to-back", [45.0, 32.0, 31.0, 42.0, 43.0]), ("25 Hz", [300.0, 230.0, 220.0, 260.0, 240.0])]
    {
        let base = callback * 1e3;
        latency.push(row(mode, net::ORSA_COMPONENT, component * 1e3, base));
        latency.push(row(mode, net::ORSA_SINK, sink * 1e3, base));
        latency.push(row(mode, net::RAW_CALLBACK, base, base));
        latency.push(row(mode, net::RAW_TASK, task * 1e3, base));
        latency.push(row(mode, net::RAW_ACTOR, actor * 1e3, base));
    }
    NetReport {
        runtime: "multi-thread (2 workers), in both processes".into(),
        transport: "zenoh".into(),
        startup_s: 0.5,
        latency,
        codec: CodecCosts {
            raw_bytes: 944,
            orsa_bytes: 974,
            raw_encode_ns: 800.0,
            raw_decode_ns: 3400.0,
            orsa_encode_ns: 850.0,
            orsa_decode_ns: 3600.0,
        },
        sense_to_act: Some(SenseToAct {
            duration_s: 1.0,
            commands_received: 3,
            attributed: 2,
            unattributed: 1,
            by_behaviour: BTreeMap::from([("centerfollow".to_string(), 2)]),
            from_update: lat(500_000.0),
            from_sensor_firing: lat(5_000_000.0),
            legs: vec![SenseLeg { leg: "a leg".into(), latency: lat(100_000.0) }],
            stale_refused: 0,
            monitor: true,
            restarts: 0,
            live_client: None,
            ros2_calls: None,
        }),
        switch: Some(SwitchPair {
            rounds: 5,
            switch: lat(500_000.0),
            one_by_one: lat(900_000.0),
            p50_ratio: 0.55,
        }),
    }
}

#[test]
fn the_mode_switch_targets_judge_each_place_and_say_what_was_not_measured() {
    let mut r = sample_report();
    r.targets = judge(&r);
    let find = |needle: &str| r.targets.iter().find(|t| t.target.contains(needle)).expect(needle).clone();
    let inproc = find("a mode switch in process");
    assert_eq!((inproc.met, inproc.measured.as_str()), (Some(true), "1.20x"));
    let across = find("a mode switch across processes");
    assert_eq!((across.met, across.measured.as_str()), (None, "not measured"));
    r.switch.in_process.p50_ratio = 1.6;
    r.switch.across = sample_net().switch;
    r.targets = judge(&r);
    let find = |needle: &str| r.targets.iter().find(|t| t.target.contains(needle)).expect(needle).clone();
    assert_eq!(find("a mode switch in process").met, Some(false));
    assert_eq!(find("a mode switch across processes").measured, "0.55x");
    let md = render_markdown(&r);
    assert!(
        md.contains("In process: one switch p50 6.0 µs") && md.contains("**0.55x** (5 rounds each)"),
        "{md}"
    );
}

#[test]
fn cross_process_targets_and_tables_come_from_the_net_report() {
    let mut r = sample_report();
    r.net = Some(sample_net());
    r.net_error = None;
    r.targets = judge(&r);
    let find = |needle: &str| r.targets.iter().find(|t| t.target.contains(needle)).expect(needle).clone();
    // 45 / 31 > 1.2: the headline misses; like for like (32 / 31 and 45 / 42) it is met.
    let headline = find("back-to-back; component vs subscriber callback");
    assert_eq!(headline.met, Some(false), "{headline:?}");
    assert!(headline.measured.starts_with("1.45x"), "{headline:?}");
    let like = find("back-to-back; like for like");
    assert_eq!(like.met, Some(true), "{like:?}");
    assert_eq!(like.measured, "1.03x, 1.07x");
    assert_eq!(find("25 Hz; like for like").met, Some(true));
    // Against the raw parts: 45 / 43 is met, 300 / 240 is not.
    let parts = find("back-to-back; component vs callback -> ractor cast -> actor");
    assert_eq!((parts.measured.as_str(), parts.met), ("1.05x", Some(true)), "{parts:?}");
    assert_eq!(find("25 Hz; component vs callback -> ractor cast").met, Some(false));
    let text = render_markdown(&r);
    for heading in ["## Across processes: latency", "## Sense to act, across processes"] {
        assert!(text.contains(heading), "no {heading} in\n{text}");
    }
    assert!(text.contains("| back-to-back | orsa push newest -> component | 10 | 10 | yes | 10 |"), "{text}");
    assert!(text.contains("| leg: a leg |"), "{text}");
    assert!(text.contains("raw CBOR 944 bytes"), "{text}");
    let json = serde_json::to_value(&r).expect("serialise");
    assert!(json["net"]["latency"].as_array().is_some_and(|a| a.len() == 10));
}

#[test]
fn a_failed_cross_process_bench_is_reported_not_fatal() {
    let r = sample_report();
    let text = render_markdown(&r);
    assert!(text.contains("## Across processes\n\nNot measured: not run in this test."), "{text}");
}

// ---- simulation parts in child processes ---------------------------------------------------

/// The environment variable that makes [`sim_part_process`] run a part.
const SIM_PART_ENV: &str = "ORSA_BENCH_TEST_SIM_PART";

/// In tests the child is this harness again, running only [`sim_part_process`].
fn sim_part_launcher(spec: &str) -> anyhow::Result<std::process::Command> {
    this_harness("tests::sim_part_process", SIM_PART_ENV, spec)
}

#[test]
#[ignore = "the child process of the simulation-part tests: they start it themselves"]
fn sim_part_process() {
    if let Ok(spec) = std::env::var(SIM_PART_ENV) {
        part::serve(&spec).expect("the simulation part");
    }
}

#[test]
fn sim_part_specs_read_back_and_bad_ones_name_the_field() {
    for p in [
        part::Part::Mission { duration_s: 0.1 },
        part::Part::Stack { robots: 1000, warm_s: 2.0, measure_s: 1.0 / 3.0 },
        part::Part::Raw { skeleton: sim::Skeleton::Tokio, robots: 7, warm_s: 0.0, measure_s: 1e-3 },
        part::Part::Raw { skeleton: sim::Skeleton::Ractor, robots: 3, warm_s: 0.5, measure_s: 2.0 },
    ] {
        assert_eq!(part::Part::parse(&p.spec()).expect("reads back"), p, "{}", p.spec());
    }
    for (spec, names) in [
        ("stack:0:1:1", "robots `0`"),
        ("raw:-3:1:1", "robots `-3`"),
        ("stack:2:soon:1", "warm-up `soon`"),
        ("raw:2:1:-1", "span `-1`"),
        ("ractor:x:1:1", "robots `x`"),
        ("mission:inf", "duration `inf`"),
        ("mission:NaN", "duration `NaN`"),
        ("walk:1", "expected mission:SECS"),
        ("stack:1:2", "expected mission:SECS"),
        ("", "expected mission:SECS"),
    ] {
        let e = part::Part::parse(spec).expect_err(spec).to_string();
        assert!(e.contains(&format!("`{spec}`")) && e.contains(names), "{spec}: {e}");
    }
}

#[test]
fn simulation_parts_run_in_a_child_process() {
    let row = part::stack(sim_part_launcher, 2, 0.5, 1.0).expect("two stacks in a child");
    assert_eq!(row.robots, 2);
    assert_eq!(row.expected_steps_per_robot, 100);
    assert!(row.min_steps_per_robot >= 99, "{row:?}");
    assert_eq!(row.restarts, 0);
    for skeleton in [sim::Skeleton::Tokio, sim::Skeleton::Ractor] {
        let raw = part::raw(sim_part_launcher, skeleton, 2, 0.5, 1.0).expect("two skeletons in a child");
        assert!((300..=304).contains(&raw.steps), "{skeleton:?}: {raw:?}");
    }
    let mission = part::mission(sim_part_launcher, 2.0).expect("a mission in a child");
    assert_eq!(mission.simulated_s, 2.0);
    assert!(mission.rtf > 0.0 && mission.restarts == 0, "{mission:?}");
}

#[test]
fn a_failed_simulation_part_says_which_and_why() {
    // The child refuses a part with no measured span: its own error reaches the caller.
    let e = part::stack(sim_part_launcher, 1, 0.5, 0.0).expect_err("no span").to_string();
    assert!(e.contains("`stack:1:0.5:0`") && e.contains("failed"), "{e}");
    assert!(e.contains("positive duration"), "the child's reason is lost: {e}");
    // A child that prints no result line.
    fn silent(_: &str) -> anyhow::Result<std::process::Command> {
        Ok(std::process::Command::new("true"))
    }
    let e = part::raw(silent, sim::Skeleton::Tokio, 1, 0.5, 1.0).expect_err("no result").to_string();
    assert!(e.contains("`raw:1:0.5:1`") && e.contains("no result line"), "{e}");
}
