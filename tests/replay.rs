//! Record, then replay: the replayed components make every message they made, bit for bit;
//! one altered message is found where it is; a what-if changes what the controller says it
//! would; and a recording that cannot be replayed says why, and where.

use orsa::config::Config;
use orsa::faults::{FaultPlan, PlanTargets};
use orsa::hardware::world::World;
use orsa::mission::{self, RunOptions};
use orsa::reactive::ring::{RingGeometry, ranges};
use orsa::reactive::wallfollow::WallFollower;
use orsa::replay::file::{Published, Recording};
use orsa::replay::{ReplayError, ReplayOptions, Replayed, replay};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[path = "support/rewrite.rs"]
mod rewrite;
use rewrite::rewrite;

/// A folder of this test process's own.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("orsa-replay-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Records a run of `duration_s` and reads the recording back.
async fn record(
    path: &Path,
    config: Config,
    seed: u64,
    duration_s: f64,
    faults: Option<FaultPlan>,
) -> Recording {
    let mut opts = RunOptions::new(World::palazzina().expect("world"), "palazzina", config, seed, duration_s);
    opts.record = Some(path.to_path_buf());
    opts.faults = faults;
    let out = mission::run(opts).await.expect("the run");
    out.recording.expect("a recording").expect("written");
    Recording::open(path).expect("a replayable recording")
}

async fn replay_as_recorded(rec: &Recording) -> Replayed {
    replay(rec, ReplayOptions::default()).await.expect("the replay runs")
}

fn assert_bit_exact(out: &Replayed) {
    assert!(out.bit_exact(), "first divergence: {:#?}", out.divergence);
    assert!(out.compared > 1000 && out.fed > 1000, "compared {} fed {}", out.compared, out.fed);
}

#[tokio::test(start_paused = true)]
async fn a_replay_is_bit_exact_on_several_seeds() {
    let d = dir("seeds");
    for seed in [1, 7] {
        let rec = record(&d.join(format!("{seed}.mcap")), Config::default(), seed, 60.0, None).await;
        assert_eq!(rec.meta.seed, seed);
        let out = replay_as_recorded(&rec).await;
        assert_bit_exact(&out);
        // What is compared is what the deciding components made: commands, statuses, wiring.
        for topic in
            ["nomad200/navigationvelocity", "wallfollow/status", "centerfollow/status", "master/driving"]
        {
            assert!(out.replayed.get(topic).is_some_and(|m| m.len() > 1), "{topic} was replayed");
        }
    }
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[tokio::test(start_paused = true)]
async fn a_replay_under_the_standard_fault_plan_is_bit_exact() {
    let d = dir("faults");
    let config = Config::default();
    let text = std::fs::read_to_string("config/faults.example.toml").expect("the standard plan");
    let plan =
        FaultPlan::parse(&text, "faults.example.toml", &PlanTargets::for_stack(&config)).expect("plan");
    let rec = record(&d.join("f.mcap"), config, 3, 80.0, Some(plan)).await;
    assert_eq!(rec.meta.faults_toml.as_deref(), Some(text.as_str()), "the plan travels in the recording");
    let out = replay_as_recorded(&rec).await;
    assert_bit_exact(&out);
    // The restarts were replayed too: the supervisor's events are among the compared topics.
    let restarts = &out.replayed["supervision/events"];
    assert!(restarts.len() >= 8, "{} supervisor events", restarts.len());
    std::fs::remove_dir_all(&d).expect("clean up");
}

/// The plan of one cell of the matrix below: `kind` on `target` twice, once on the instant grid
/// every periodic service shares (8 s) and once off it, each lasting 1.5 s where the kind lasts.
fn one_fault_plan(kind: &str, target: &str) -> String {
    let extra = match kind {
        "drop" | "duplicate" | "sensor_stuck" | "sensor_dropout" | "motor_stall" => "duration = 1.5\n",
        "delay" => "duration = 1.5\ndelay_s = 0.25\n",
        "sensor_noise" => "duration = 1.5\nsigma_m = 0.05\n",
        // In the corridor's middle, 3-4 m ahead of the robot, clear of the people's paths.
        "box_placed" => "duration = 1.5\nmin = [7.0, 1.0]\nmax = [7.4, 1.4]\n",
        "kidnap" => "to = [10.0, 1.2, 0.0]\n",
        _ => "",
    };
    [8.0, 13.337]
        .iter()
        .map(|at| format!("[[fault]]\nat = {at}\nkind = \"{kind}\"\ntarget = \"{target}\"\n{extra}"))
        .collect()
}

/// Every fault kind a single-process plan accepts, on every target it accepts (each component
/// killed, panicked, hung; each Send and push service dropped, delayed, duplicated; each sensor
/// ring stuck, dead, noisy; the motors stalled; a box put down, the robot carried elsewhere), at
/// an instant the periodic services share and at one they do not: every recording replays bit
/// for bit. (A kill of the master used to make
/// the replay part at the kill's instant: the restarted master's unwiring raced with the
/// behaviours' commands of that instant, and the race went the other way in the replay.)
#[tokio::test(start_paused = true)]
async fn a_replay_is_bit_exact_under_every_fault_kind_on_every_target() {
    let d = dir("matrix");
    let config = Config::default();
    let targets = PlanTargets::for_stack(&config);
    let mut cells: Vec<(&str, String)> = Vec::new();
    for c in &targets.components {
        cells.extend(["kill", "panic", "hang"].map(|k| (k, c.clone())));
    }
    for s in &targets.services {
        cells.extend(["drop", "delay", "duplicate"].map(|k| (k, s.to_string())));
    }
    for ring in ["sonar", "infrared", "bumpers"] {
        cells.extend(["sensor_stuck", "sensor_dropout", "sensor_noise"].map(|k| (k, ring.to_string())));
    }
    cells.push(("motor_stall", "motors".into()));
    cells.push(("box_placed", "world".into()));
    cells.push(("kidnap", "robot".into()));
    let kinds: std::collections::BTreeSet<&str> = cells.iter().map(|(k, _)| *k).collect();
    let single_process: Vec<&str> =
        orsa::faults::KINDS.iter().copied().filter(|k| *k != "link_cut").collect();
    assert_eq!(kinds.len(), single_process.len(), "every kind but link_cut");
    let mut failed = Vec::new();
    for (i, (kind, target)) in cells.iter().enumerate() {
        let text = one_fault_plan(kind, target);
        let plan = FaultPlan::parse(&text, "matrix", &targets).expect("a plan the language accepts");
        let rec = record(&d.join(format!("{i}.mcap")), config.clone(), 5, 20.0, Some(plan)).await;
        let out = replay_as_recorded(&rec).await;
        if let Some(div) = &out.divergence {
            failed.push(format!("{kind} on {target}: parts at {:.3} s on {}", div.at_s, div.topic));
        }
    }
    assert!(cells.len() >= 50, "{} cells", cells.len());
    assert!(
        failed.is_empty(),
        "{} of {} cells do not replay bit for bit:\n{}",
        failed.len(),
        cells.len(),
        failed.join("\n")
    );
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[tokio::test(start_paused = true)]
async fn a_replay_with_a_rewiring_mid_run_is_bit_exact() {
    let d = dir("rewire");
    // The planner switches modes mid-run, so the master rewires the motors to the other
    // behaviour and back.
    let config = Config::default()
        .with_sets(&[r#"planner.mission=[{mode="patrol",for_s=20},{mode="follow_left_wall",for_s=20},{mode="patrol",for_s=40}]"#.into()])
        .expect("a mission");
    let rec = record(&d.join("w.mcap"), config, 2, 60.0, None).await;
    let wiring = &rec.outputs["wallfollow/wiring"];
    assert!(wiring.iter().any(|m| m.log_time >= 20_000_000_000), "the motors were rewired mid-run");
    let out = replay_as_recorded(&rec).await;
    assert_bit_exact(&out);
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[tokio::test(start_paused = true)]
async fn one_altered_message_is_reported_at_exactly_that_message() {
    let d = dir("altered");
    let rec = record(&d.join("a.mcap"), Config::default(), 4, 40.0, None).await;
    let topic = "nomad200/navigationvelocity";
    let k = 321;
    let original = rec.outputs[topic][k].clone();
    let altered =
        String::from_utf8(original.data.clone()).expect("json").replace("\"v_m_s\":", "\"v_m_s\":1");
    assert_ne!(altered.as_bytes(), original.data.as_slice());
    let altered_path = d.join("altered.mcap");
    rewrite(
        &d.join("a.mcap"),
        &altered_path,
        |t, i, data| {
            if t == topic && i == k {
                *data = altered.clone().into_bytes();
            }
        },
        |_| {},
    );
    let out = replay_as_recorded(&Recording::open(&altered_path).expect("readable")).await;
    let div = out.divergence.expect("the altered message is found");
    assert_eq!((div.topic.as_str(), div.index), (topic, k));
    assert_eq!(div.at_s, orsa::actors::Timestamp(original.log_time).as_secs_f64());
    assert_eq!(div.recorded.as_deref(), Some(altered.as_str()));
    assert_eq!(
        div.replayed.as_deref().map(str::as_bytes),
        Some(original.data.as_slice()),
        "the replay made the original"
    );
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[tokio::test(start_paused = true)]
async fn a_what_if_with_the_recorded_config_differs_in_nothing() {
    let d = dir("same");
    let rec = record(&d.join("s.mcap"), Config::default(), 5, 60.0, None).await;
    let config = orsa::replay::recorded_config(&rec).expect("config");
    assert_eq!(config, Config::default(), "the recording holds the effective config");
    let out =
        replay(&rec, ReplayOptions { config: Some(config), ..Default::default() }).await.expect("replay");
    let w = out.what_if(&rec);
    assert!(w.topics.is_empty(), "{:?}", w.topics.keys());
    assert!(w.compared_topics >= 10);
    assert_eq!(w.share_recorded, w.share_replayed);
    std::fs::remove_dir_all(&d).expect("clean up");
}

/// Wall following's commands, computed directly by its controller over the recorded infrared
/// scans and odometry, for the scans it computed on (those with a status) stamped before `until`.
fn wall_following_directly(rec: &Recording, config: &Config, until: u64) -> Vec<(f64, f64)> {
    let robot = rec.answers.robotparams.front().expect("the robot's parameters were recorded");
    let ring = RingGeometry::uniform(robot.infrared.mount_radius_m, robot.infrared.beam_width_rad);
    let mut ctl =
        WallFollower::new(config.params_of("wallfollow").expect("wall following's parameters"), ring);
    let computed: std::collections::BTreeSet<u64> = rec.outputs["wallfollow/status"]
        .iter()
        .map(|m| {
            serde_json::from_slice::<serde_json::Value>(&m.data).expect("json")["value"]["stamp"]
                .as_u64()
                .expect("stamp")
        })
        .collect();
    let mut cmds = Vec::new();
    for (_, p) in &rec.published {
        match p {
            Published::Base(b) => ctl.note_position(b.x_m, b.y_m, b.stamp),
            Published::Ir(scan) if computed.contains(&scan.stamp.0) && scan.stamp.0 < until => {
                let cmd = ctl.step(&ranges(scan), scan.stamp).cmd;
                cmds.push((cmd.v_m_s, cmd.omega_rad_s));
            }
            _ => {}
        }
    }
    cmds
}

fn status_commands(messages: &[orsa::replay::file::Recorded]) -> Vec<(f64, f64)> {
    messages
        .iter()
        .map(|m| {
            let v: serde_json::Value = serde_json::from_slice(&m.data).expect("json");
            let cmd = &v["value"]["cmd"];
            (cmd["v_m_s"].as_f64().expect("v"), cmd["omega_rad_s"].as_f64().expect("omega"))
        })
        .collect()
}

#[tokio::test(start_paused = true)]
async fn a_what_if_with_another_gain_differs_by_what_the_controller_computes() {
    let d = dir("gain");
    let recorded = Config::default();
    let rec = record(&d.join("g.mcap"), recorded.clone(), 6, 60.0, None).await;
    assert!(!rec.schemas.contains_key("nomad200/contact"), "no bump: the direct computation needs none");
    let other = recorded.with_sets(&["wallfollow.target_m=0.3".into()]).expect("a valid gain");
    let out = replay(&rec, ReplayOptions { config: Some(other.clone()), ..Default::default() })
        .await
        .expect("what-if");

    // The direct computation agrees with the recording, and with the what-if, bit for bit.
    // The recording holds the last instant; the replay stops before it (what happens at the
    // very end depends on which actor the run stopped first).
    let before = wall_following_directly(&rec, &recorded, u64::MAX);
    let after = wall_following_directly(&rec, &other, out.end);
    let statuses = status_commands(&rec.outputs["wallfollow/status"]);
    let first = before.iter().zip(&statuses).position(|(a, b)| a != b);
    assert!(
        before.len() == statuses.len() && first.is_none(),
        "the direct computation is the controller: {} computed, {} recorded, first difference at {first:?}: {:?} vs {:?}",
        before.len(),
        statuses.len(),
        first.map(|i| before[i]),
        first.map(|i| statuses[i]),
    );
    let replayed = status_commands(&out.replayed["wallfollow/status"]);
    let first = after.iter().zip(&replayed).position(|(a, b)| a != b);
    assert!(
        after.len() == replayed.len() && first.is_none(),
        "the what-if is the controller: {} computed, {} replayed, first difference at {first:?}",
        after.len(),
        replayed.len(),
    );
    let largest = |f: fn(&(f64, f64)) -> f64| {
        before.iter().zip(&after).map(|(a, b)| (f(a) - f(b)).abs()).fold(0.0, f64::max)
    };
    let (dv, dw) = (largest(|c| c.0), largest(|c| c.1));
    assert!(dw > 0.01, "a 10 cm farther wall turns the robot: {dw}");

    let w = out.what_if(&rec);
    let status = &w.topics["wallfollow/status"];
    assert_eq!(status.largest.get("value.cmd.omega_rad_s").copied().unwrap_or(0.0), dw);
    assert_eq!(status.largest.get("value.cmd.v_m_s").copied().unwrap_or(0.0), dv);
    // Centre following did not change: its gains are the same and its inputs are recorded.
    assert!(!w.topics.contains_key("centerfollow/status"), "{:?}", w.topics.keys());
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[tokio::test(start_paused = true)]
async fn a_recording_that_cannot_be_replayed_says_why_and_where() {
    let d = dir("bad");
    let good = d.join("good.mcap");
    record(&good, Config::default(), 1, 5.0, None).await;
    let bytes = std::fs::read(&good).expect("read");
    let err = |path: &Path| Recording::open(path).expect_err("refused").to_string();

    let truncated = d.join("truncated.mcap");
    std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).expect("write");
    let e = err(&truncated);
    assert!(e.contains("truncated.mcap") && e.contains("truncated"), "{e}");

    let corrupt = d.join("corrupt.mcap");
    let mut flipped = bytes.clone();
    let mid = flipped.len() / 2;
    for b in &mut flipped[mid..mid + 64] {
        *b ^= 0x5a;
    }
    std::fs::write(&corrupt, &flipped).expect("write");
    let e = err(&corrupt);
    assert!(e.contains("corrupt.mcap") && e.contains("not a readable recording"), "{e}");

    let not_mcap = d.join("not.mcap");
    std::fs::write(&not_mcap, b"{\"hello\": 1}").expect("write");
    assert!(err(&not_mcap).contains("not an MCAP file"));

    let no_meta = d.join("nometa.mcap");
    let mut r = orsa::record::Recorder::create(&no_meta).expect("recorder");
    r.write(
        "nomad200/bumpers",
        "orsa.nomad200.ContactScan/1",
        Default::default(),
        Default::default(),
        &serde_json::json!({}),
    )
    .expect("write");
    r.finish().expect("finish");
    assert!(matches!(Recording::open(&no_meta), Err(ReplayError::NoMetadata { .. })));
    assert!(err(&no_meta).contains("nometa.mcap"));

    let old = d.join("old.mcap");
    rewrite(
        &good,
        &old,
        |_, _, _| {},
        |m| {
            m.insert("orsa".into(), "0.0.9".into());
        },
    );
    let e = err(&old);
    assert!(e.contains("old.mcap") && e.contains("orsa 0.0.9"), "{e}");
    let wire = d.join("wire.mcap");
    rewrite(
        &good,
        &wire,
        |_, _, _| {},
        |m| {
            m.insert("wire".into(), "99".into());
        },
    );
    assert!(err(&wire).contains("wire version 99"));
    let partial = d.join("partial.mcap");
    rewrite(
        &good,
        &partial,
        |_, _, _| {},
        |m| {
            m.remove("config_toml");
        },
    );
    assert!(err(&partial).contains("config_toml"));
    // An executive's recording whose infrared update lost its bytes.
    let exchange = d.join("exchange.mcap");
    let mut r = orsa::record::Recorder::create(&exchange).expect("recorder");
    let meta = orsa::record::RunMeta::describe(
        "executive",
        "none",
        None,
        0,
        10.0,
        &Config::default(),
        vec!["master".into(), "planner".into()],
        true,
        1_000_000,
        None,
    )
    .expect("a description");
    r.write_metadata(orsa::record::meta::RUN_METADATA, meta.to_metadata()).expect("metadata");
    let at = orsa::actors::Timestamp(1_500_000);
    let topic = "exchange/update/nomad200/distanceir";
    r.write(topic, orsa::record::events::EXCHANGED_TYPE, at, at, &serde_json::json!({"n": 0}))
        .expect("write");
    r.finish().expect("finish");
    let e = err(&exchange);
    assert!(e.contains("exchange.mcap") && e.contains(topic) && e.contains("'cbor'"), "{e}");
    assert!(e.contains(&at.to_string()), "{e}");

    let stranger = d.join("stranger.mcap");
    rewrite(
        &good,
        &stranger,
        |_, _, _| {},
        |m| {
            m.insert("process".into(), "teleop".into());
        },
    );
    let e = err(&stranger);
    assert!(e.contains("stranger.mcap") && e.contains("'process' is 'teleop'"), "{e}");

    let undecodable = d.join("undecodable.mcap");
    let mut log_time = None;
    rewrite(
        &good,
        &undecodable,
        |t, i, data| {
            if t == "nomad200/distanceir" && i == 10 {
                *data = br#"{"seq":11,"stamp":1,"value":{"readings":"none"}}"#.to_vec();
            }
        },
        |_| {},
    );
    for m in mcap::MessageStream::new(&std::fs::read(&undecodable).expect("read")).expect("mcap") {
        let m = m.expect("message");
        if m.channel.topic == "nomad200/distanceir" && m.data.starts_with(b"{\"seq\":11,") {
            log_time = Some(m.log_time);
        }
    }
    let e = err(&undecodable);
    let at = orsa::actors::Timestamp(log_time.expect("the altered message")).to_string();
    assert!(e.contains("undecodable.mcap") && e.contains("'nomad200/distanceir'") && e.contains(&at), "{e}");

    // A channel the replay feeds whose schema is not its service's.
    let schema = d.join("schema.mcap");
    let bytes2 = std::fs::read(&good).expect("read");
    let mut out = mcap::WriteOptions::new()
        .create(std::io::BufWriter::new(std::fs::File::create(&schema).expect("create")))
        .expect("w");
    for record in mcap::read::ChunkFlattener::new(&bytes2).expect("mcap") {
        if let mcap::records::Record::Metadata(m) = record.expect("record") {
            out.write_metadata(&m).expect("meta");
        }
    }
    let s = out.add_schema("orsa.Other/1", "jsonschema", b"{}").expect("schema");
    let c = out.add_channel(s, "nomad200/distanceir", "json", &BTreeMap::new()).expect("channel");
    out.write_to_known_channel(
        &mcap::records::MessageHeader { channel_id: c, sequence: 0, log_time: 1, publish_time: 1 },
        b"{}",
    )
    .expect("msg");
    out.finish().expect("finish");
    let e = err(&schema);
    assert!(
        e.contains("schema.mcap") && e.contains("'nomad200/distanceir'") && e.contains("orsa.Other/1"),
        "{e}"
    );
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[tokio::test(start_paused = true)]
async fn a_replay_of_a_mission_of_places_is_bit_exact() {
    let d = dir("places");
    let path = d.join("office.mcap");
    let world = World::from_path(concat!(env!("CARGO_MANIFEST_DIR"), "/worlds/office.toml")).expect("world");
    let config = Config::default().with_goto(&["room-1".into(), "dock".into()]).expect("config");
    let mut opts = RunOptions::new(world, "office", config, 3, 300.0);
    opts.record = Some(path.clone());
    opts.until_mission_ends = true;
    let out = mission::run(opts).await.expect("the run");
    out.recording.expect("a recording").expect("written");
    let nav = out.report.navigation.expect("a navigation section");
    assert_eq!(nav.success_rate, 1.0, "{}", nav.table());
    let rec = Recording::open(&path).expect("a replayable recording");
    let replayed = replay_as_recorded(&rec).await;
    assert_bit_exact(&replayed);
    // The localizer, the path follower and the planner ran again and made the same.
    for topic in ["localizer/pose", "pathfollow/status", "pathfollow/path", "planner/navigation"] {
        assert!(replayed.replayed.get(topic).is_some_and(|m| m.len() > 1), "{topic} was replayed");
    }
    std::fs::remove_dir_all(&d).expect("clean up");
}
