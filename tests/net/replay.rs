//! Replaying the recordings of the processes of the distributed system (`orsa robot --record`,
//! `orsa executive --record`) with a teleop and a link cut: the robot's behaviours run again
//! on the recorded scans, fed the executive's wiring and state changes and the link watchdog's
//! actions at their recorded times; the executive's master and planner run again on what
//! reached them from the robot, when it reached them; both make what they made, in content
//! and order.

use super::*;
use orsa::replay::file::{Control, Recording};
use orsa::replay::{ReplayOptions, replay};
use std::path::Path;

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("orsa-test-{}-{name}", std::process::id()))
}

/// Waits for a process to end; it must end well.
async fn ends_well(mut p: Proc, what: &'static str) {
    let (status, p) =
        tokio::task::spawn_blocking(move || (p.child.wait().expect("it ends"), p)).await.expect("join");
    assert!(status.success(), "{what} failed: {}", p.log_text());
}

/// `orsa replay PATH --quiet --report REPORT`, as a user runs it: it must say bit-exact and
/// exit 0. Its report.
async fn orsa_replay(path: &Path, report: &Path) -> serde_json::Value {
    let (recording, report_path) = (path.to_path_buf(), report.to_path_buf());
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_orsa"))
            .args(["replay", recording.to_str().expect("utf-8"), "--quiet", "--report"])
            .arg(&report_path)
            .output()
            .expect("orsa replay runs")
    })
    .await
    .expect("join");
    let text = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && text.contains("bit-exact"), "{}: {text}", path.display());
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).expect("the report")).expect("json");
    assert_eq!(r["bit_exact"], true);
    assert!(r["timing"]["within"].as_u64().is_some(), "a live recording is held to a tolerance: {r}");
    r
}

/// What the Python `mcap` package, which orsa did not write, reads in a recording.
async fn read_in_python(path: &Path) -> serde_json::Value {
    let path = path.to_path_buf();
    let out = tokio::task::spawn_blocking(move || {
        std::process::Command::new("python3")
            .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/read_recording.py"))
            .arg(&path)
            .output()
            .expect("python3 runs (see tests/python/requirements.txt)")
    })
    .await
    .expect("join");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("the reader's JSON")
}

/// Replays `rec` on a paused clock, as `orsa replay` does.
fn replay_paused(rec: &Recording) -> orsa::replay::Replayed {
    tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .start_paused(true)
        .build()
        .expect("runtime")
        .block_on(replay(rec, ReplayOptions::default()))
        .expect("the recording replays")
}

/// `rec` as a loaded machine records it: the first wiring of centre following to the motors
/// heard by the recorder 2.5 ms after the scan that came next (more than the replay timer's
/// millisecond), and the behaviour's step on that scan after it, so delivered. `None` if the
/// recording has no such wiring followed by a scan and centre following's step on it.
fn wired_heard_late(mut rec: Recording) -> Option<Recording> {
    use orsa::replay::file::Published;
    let scan = |p: &Published| matches!(p, Published::Ir(_) | Published::Sonar(_));
    let (j, k, heard, step) = (0..rec.controls.len()).find_map(|j| {
        let wired = matches!(&rec.controls[j].1, Control::Port { component, status }
            if component == "centerfollow" && status.target.is_some());
        if !wired || rec.controls_early[j] {
            return None;
        }
        // The scan after it, the step on it before the next scan, and the next control later.
        let k = (rec.controls_after[j]..rec.published.len()).find(|&k| scan(&rec.published[k].1))?;
        let heard = rec.published[k].0 + 2_500_000;
        let next_scan = rec.published[k + 1..].iter().find(|p| scan(&p.1)).map_or(u64::MAX, |p| p.0);
        let step = rec.outputs["centerfollow/status"].iter().position(|m| m.log_time > rec.published[k].0)?;
        let next_control_ok =
            rec.controls.get(j + 1).is_none_or(|c| rec.controls_after[j + 1] > k && c.0 > heard + 100_000);
        (next_control_ok
            && heard + 100_000 < next_scan
            && rec.outputs["centerfollow/status"][step].log_time < next_scan)
            .then_some((j, k, heard, step))
    })?;
    rec.outputs.get_mut("centerfollow/status")?[step].log_time = heard + 100_000;
    rec.controls[j].0 = heard;
    rec.controls_after[j] = k + 1;
    rec.controls_early[j] = true;
    Some(rec)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_robot_and_executive_processes_replay_from_their_recordings_with_teleop_and_a_link_cut() {
    let sys = System::new("replay");
    let path = temp("robot.mcap");
    let exec_path = temp("executive.mcap");
    // The planner switches modes, so the executive hands the motors to wall following and back.
    let mission = temp("replay-mission.toml");
    std::fs::write(
        &mission,
        "[params.planner]\nmission = [{mode=\"patrol\",for_s=3},{mode=\"follow_left_wall\",for_s=3},{mode=\"patrol\",for_s=30}]\n",
    )
    .expect("write the mission");
    let plan = temp("replay-plan.toml");
    std::fs::write(
        &plan,
        "[[fault]]\nat = 5.0\nkind = \"link_cut\"\ntarget = \"executive\"\nduration = 1.5\n",
    )
    .expect("write the plan");
    let robot = sys.robot(&[
        "--record",
        path.to_str().expect("utf-8"),
        "--faults",
        plan.to_str().expect("utf-8"),
        "--duration",
        "12",
    ]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let exec = sys.run(
        "exec",
        "executive",
        &[
            "--duration",
            "9",
            "--config",
            mission.to_str().expect("utf-8"),
            "--record",
            exec_path.to_str().expect("utf-8"),
        ],
    );
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;
    let teleop = sys.run("teleop", "teleop", &["--send", "-0.1,0", "--for", "1"]);
    until_base(&mut base, STARTUP, "teleop drives backwards", |b| b.v_m_s < -0.05).await;
    drop(base);
    ends_well(teleop, "teleop").await;
    ends_well(exec, "the executive").await;
    ends_well(robot, "the robot").await;

    // What the robot's recording says: a live run of the robot process, what came from the
    // other processes kept apart, and what the link watchdog did.
    let rec = Recording::open(&path).expect("a readable recording");
    assert_eq!((rec.meta.process.as_str(), rec.meta.live), ("robot", true));
    assert!(rec.meta.faults_toml.as_deref().is_some_and(|f| f.contains("link_cut")));
    assert!(rec.outside > 0, "teleop's commands came from another process");
    let lost = rec.controls.iter().filter(|(_, c)| {
        matches!(c, Control::Link(e) if e.command.is_some_and(|c| c.v_m_s == 0.0 && c.omega_rad_s == 0.0))
    });
    assert!(lost.count() >= 1, "the watchdog lost the executive, and commanded zero");
    let to_wall = rec.controls.iter().filter(|(_, c)| {
        matches!(c, Control::Port { component, status } if component == "wallfollow" && status.target.is_some())
    });
    assert!(to_wall.count() >= 1, "the mission handed the motors to wall following");
    let py = read_in_python(&path).await;
    assert_eq!((py["process"].as_str(), py["clock"].as_str()), (Some("robot"), Some("live")));
    assert!(py["from_other_processes"]["nomad200/teleop"].as_u64() > Some(0), "{py}");
    let report = temp("replay-report.json");
    let r = orsa_replay(&path, &report).await;
    assert!(r["compared"].as_u64().expect("compared") > 300, "{r}");
    assert_eq!(r["controls"].as_u64(), Some(rec.controls.len() as u64));

    // What the executive's recording says: what reached it from the robot, when.
    let exec_rec = Recording::open(&exec_path).expect("the executive's recording");
    assert_eq!(exec_rec.meta.process, "executive");
    assert_eq!(exec_rec.meta.hosted, ["master", "planner"]);
    // (The master also subscribes to the sonar: the default rules read it.)
    let ir = (exec_rec.exchange.updates.iter())
        .filter(|((addr, _), _)| addr.to_string() == "nomad200/distanceir")
        .map(|(_, updates)| updates.len())
        .sum::<usize>();
    assert!(ir > 10, "the master's infrared updates came over the network: {ir}");
    let requests = exec_rec.outputs.get("exchange/request/wallfollow/wiring").map_or(0, Vec::len);
    assert!(requests >= 2, "the master wired wall following and unwired it: {requests}");
    let py = read_in_python(&exec_path).await;
    assert_eq!(py["process"].as_str(), Some("executive"));
    assert_eq!(py["counts"]["exchange/update/nomad200/distanceir"].as_u64(), Some(ir as u64), "{py}");
    // The executive's run ended when its 9 s were up (counted once it joined its robot), and
    // its recording says so.
    let origin = py["clock_origin_ns"].as_u64().expect("origin");
    let ended_at = py["ended"]["at_ns"].as_u64().expect("the run's end").saturating_sub(origin);
    assert_eq!(py["ended"]["how"].as_str(), Some("completed"), "{py}");
    assert!((9.0..11.0).contains(&(ended_at as f64 / 1e9)), "{py}");
    let exec_report = temp("replay-exec-report.json");
    let r = orsa_replay(&exec_path, &exec_report).await;
    assert!(r["fed"].as_u64().expect("fed") as usize >= ir, "{r}");
    assert!(r["compared"].as_u64().expect("compared") as usize >= requests + 3, "{r}");

    // The deployment's two recordings in one command, as the README shows it.
    let (robot_path, executive_path) = (path.clone(), exec_path.clone());
    let both = tokio::task::spawn_blocking(move || {
        std::process::Command::new(env!("CARGO_BIN_EXE_orsa"))
            .arg("replay")
            .args([&robot_path, &executive_path])
            .arg("--quiet")
            .output()
            .expect("orsa replay runs")
    })
    .await
    .expect("join");
    let text = String::from_utf8_lossy(&both.stdout).into_owned() + &String::from_utf8_lossy(&both.stderr);
    assert!(both.status.success() && text.contains("all 2 recordings bit-exact"), "{text}");

    // A wiring the recorder heard late, after the scan whose step saw it: the replay applies it
    // where the recording places it, between the scan and the step, whatever its log time.
    let late = wired_heard_late(Recording::open(&path).expect("readable"))
        .expect("centre following was wired before a scan and its step");
    let out = tokio::task::spawn_blocking(move || replay_paused(&late)).await.expect("join");
    assert!(out.divergence.is_none(), "a wiring heard late replays bit-exact: {:?}", out.divergence);

    // One altered behaviour output, and one altered wiring request, are reported at exactly
    // that message.
    let mut altered = rec;
    let statuses = altered.outputs.get_mut("centerfollow/status").expect("centre following's statuses");
    let k = statuses.len() / 2;
    let mut v: serde_json::Value = serde_json::from_slice(&statuses[k].data).expect("json");
    let omega = v["value"]["cmd"]["omega_rad_s"].as_f64().expect("a command");
    v["value"]["cmd"]["omega_rad_s"] = serde_json::json!(omega + 0.001);
    statuses[k].data = serde_json::to_vec(&v).expect("json");
    let out = tokio::task::spawn_blocking(move || replay_paused(&altered)).await.expect("join");
    let d = out.divergence.expect("the altered message is found");
    assert_eq!((d.topic.as_str(), d.index), ("centerfollow/status", k));
    let mut altered = exec_rec;
    let topic = "exchange/request/wallfollow/wiring";
    let sent = altered.outputs.get_mut(topic).expect("wiring requests");
    let k = sent.iter().rposition(|m| m.data.windows(7).any(|w| w == b"connect")).expect("a wiring change");
    let text = String::from_utf8(sent[k].data.clone()).expect("utf-8");
    let other = if text.contains("\"disconnect\"") {
        text.replace("\"disconnect\"", "\"connect\"")
    } else {
        text.replace("\"connect\"", "\"disconnect\"")
    };
    assert_ne!(other, text);
    sent[k].data = other.into_bytes();
    let out = tokio::task::spawn_blocking(move || replay_paused(&altered)).await.expect("join");
    let d = out.divergence.expect("the altered request is found");
    assert_eq!((d.topic.as_str(), d.index), (topic, k));
    for p in [path, exec_path, mission, plan, report, exec_report] {
        let _ = std::fs::remove_file(p);
    }
}

/// How one process of the deployment ends, or loses its peer, in
/// [`recordings_ended_by_a_lost_peer_or_ctrl_c_replay`].
#[derive(Clone, Copy, Debug)]
enum Ending {
    /// The executive is SIGKILLed; later the robot gets Ctrl-C. The robot's recording replays.
    ExecutiveKilled,
    /// The robot is SIGKILLed; later the executive gets Ctrl-C. The executive's recording
    /// replays.
    RobotKilled,
    /// The executive gets Ctrl-C, then the robot: both replay.
    ExecutiveInterrupted,
    /// The robot gets Ctrl-C, then the executive: both replay.
    RobotInterrupted,
    /// The robot's link to the executive is cut (a `link_cut` fault from 3 s, for 4 s) and the
    /// robot gets Ctrl-C at a moment in the cut or after it, then the executive: both replay.
    InterruptedAroundALinkCut,
}

/// A moment in `[lo, hi)` seconds, from `state` (splitmix64): the moments differ from round to
/// round and the test prints them, so a failing round can be run again as it was.
fn moment(state: &mut u64, lo: f64, hi: f64) -> Duration {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    Duration::from_secs_f64(lo + (hi - lo) * (z >> 11) as f64 / (1u64 << 53) as f64)
}

/// Waits for a process that got SIGKILL or Ctrl-C to be gone; Ctrl-C must end it with 130.
async fn gone(p: Proc, interrupted: bool, what: &str) {
    let (code, p) = tokio::task::spawn_blocking(move || {
        let mut p = p;
        (p.child.wait().expect("wait").code(), p)
    })
    .await
    .expect("join");
    if interrupted {
        assert_eq!(code, Some(130), "{what} after Ctrl-C: {}", p.log_text());
    }
}

/// One deployment (robot and executive, both recording) ended as `ending` says, after the
/// executive drove and a moment drawn from `state`; what it recorded is replayed with
/// `orsa replay`, which must say bit-exact. The moments, for the test's output.
async fn one_ending(ending: Ending, round: usize, state: &mut u64) -> String {
    let name = format!("end{round}{ending:?}");
    let sys = System::new(&name);
    let (robot_path, exec_path) = (temp(&format!("{name}-robot.mcap")), temp(&format!("{name}-exec.mcap")));
    let plan = temp(&format!("{name}-plan.toml"));
    std::fs::write(
        &plan,
        "[[fault]]\nat = 3.0\nkind = \"link_cut\"\ntarget = \"executive\"\nduration = 4.0\n",
    )
    .expect("write the plan");
    let mut robot_args = vec!["--record", robot_path.to_str().expect("utf-8")];
    if matches!(ending, Ending::InterruptedAroundALinkCut) {
        robot_args.extend(["--faults", plan.to_str().expect("utf-8")]);
    }
    let robot = sys.robot(&robot_args);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let exec = sys.run(&name, "executive", &["--record", exec_path.to_str().expect("utf-8")]);
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;
    drop(base);
    let (first, second) = match ending {
        Ending::InterruptedAroundALinkCut => (moment(state, 1.0, 7.0), moment(state, 0.0, 2.0)),
        _ => (moment(state, 0.0, 4.0), moment(state, 0.0, 3.0)),
    };
    tokio::time::sleep(first).await;
    // Who goes first and how; the other always gets Ctrl-C after `second`. A process that was
    // SIGKILLed cannot close its recording: only the other's is replayed.
    let (robot_first, kill) = match ending {
        Ending::ExecutiveKilled => (false, true),
        Ending::RobotKilled => (true, true),
        Ending::ExecutiveInterrupted => (false, false),
        Ending::RobotInterrupted | Ending::InterruptedAroundALinkCut => (true, false),
    };
    let ((a, a_name, a_path), (b, b_name, b_path)) = {
        let (r, e) = ((robot, "the robot", &robot_path), (exec, "the executive", &exec_path));
        if robot_first { (r, e) } else { (e, r) }
    };
    a.signal(if kill { "-KILL" } else { "-INT" });
    gone(a, !kill, a_name).await;
    tokio::time::sleep(second).await;
    b.signal("-INT");
    gone(b, true, b_name).await;
    // Each replayed recording runs to the moment its run ended, which is at least as late
    // as the signal: the first process ran `first` after the robot drove, the second `first`
    // and `second`. (A quiet executive's last message may come seconds before.)
    let replayed: Vec<(&PathBuf, Duration)> =
        if kill { vec![(b_path, first + second)] } else { vec![(a_path, first), (b_path, first + second)] };
    drop(t);
    for (path, ran) in replayed {
        let report = temp(&format!("{name}-report.json"));
        let r = orsa_replay(path, &report).await;
        let what = format!("{ending:?}, {} after {first:?} and {second:?}", path.display());
        assert!(r["compared"].as_u64().expect("compared") > 0, "{what}: {r}");
        let replayed_s = r["replayed_s"].as_f64().expect("replayed_s");
        assert!(replayed_s >= ran.as_secs_f64(), "{what}: the replay stopped short of the run's end: {r}");
        let _ = std::fs::remove_file(report);
    }
    for p in [robot_path, exec_path, plan] {
        let _ = std::fs::remove_file(p);
    }
    format!("{ending:?} after {:.2} s and {:.2} s", first.as_secs_f64(), second.as_secs_f64())
}

/// `rounds` rounds of every ending, each at its own moments.
async fn recordings_ended_by_a_lost_peer_or_ctrl_c_replay(rounds: usize, seed: u64) {
    eprintln!("endings drawn from seed {seed}");
    let mut state = seed;
    for round in 0..rounds {
        for ending in [
            Ending::ExecutiveKilled,
            Ending::RobotKilled,
            Ending::ExecutiveInterrupted,
            Ending::RobotInterrupted,
            Ending::InterruptedAroundALinkCut,
        ] {
            let done = one_ending(ending, round, &mut state).await;
            eprintln!("round {}: {done}: replayed bit-exact", round + 1);
        }
    }
}

/// The recordings of a robot and an executive process replay bit for bit (within the live
/// tolerance), whatever ended them or their peer: the other process SIGKILLed, Ctrl-C at a
/// moment drawn at random, Ctrl-C during or after a cut link. One round here; ten in a row in
/// the long-test command (`.ci/long`).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn recordings_ended_by_a_lost_peer_or_ctrl_c_at_any_moment_replay() {
    recordings_ended_by_a_lost_peer_or_ctrl_c_replay(1, std::process::id() as u64).await;
}

/// Ten rounds in a row of the test above (about ten minutes): run by `.ci/long`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[ignore = "ten rounds in a row, about ten minutes: run by .ci/long"]
async fn long_recordings_ended_by_a_lost_peer_or_ctrl_c_replay_ten_times_in_a_row() {
    recordings_ended_by_a_lost_peer_or_ctrl_c_replay(10, std::process::id() as u64).await;
}
