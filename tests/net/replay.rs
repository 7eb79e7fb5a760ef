//! Replaying a recording made by the robot process of the distributed system (`orsa robot
//! --record`) with a remote executive, a teleop and a link cut: its behaviours run again on
//! the recorded scans, fed the executive's wiring and state changes and the link watchdog's
//! actions at their recorded times, and make what they made, in content and order.

use super::*;
use orsa::replay::file::{Control, Recording};
use orsa::replay::{ReplayOptions, replay};

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("orsa-test-{}-{name}", std::process::id()))
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

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_process_recording_replays_its_behaviours_with_the_executive_teleop_and_a_link_cut_fed() {
    let sys = System::new("replay");
    let path = temp("robot.mcap");
    let plan = temp("replay-plan.toml");
    std::fs::write(
        &plan,
        "[[fault]]\nat = 5.0\nkind = \"link_cut\"\ntarget = \"executive\"\nduration = 1.5\n",
    )
    .expect("write the plan");
    let mut robot = sys.robot(&[
        "--record",
        path.to_str().expect("utf-8"),
        "--faults",
        plan.to_str().expect("utf-8"),
        "--duration",
        "12",
    ]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let exec = sys.run("exec", "executive", &["--duration", "120"]);
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;
    let mut teleop = sys.run("teleop", "teleop", &["--send", "-0.1,0", "--for", "1"]);
    until_base(&mut base, STARTUP, "teleop drives backwards", |b| b.v_m_s < -0.05).await;
    drop(base);
    let (status, teleop) =
        tokio::task::spawn_blocking(move || (teleop.child.wait().expect("teleop ends"), teleop))
            .await
            .expect("join");
    assert!(status.success(), "teleop failed: {}", teleop.log_text());
    let (status, robot) =
        tokio::task::spawn_blocking(move || (robot.child.wait().expect("the robot ends"), robot))
            .await
            .expect("join");
    assert!(status.success(), "the robot failed: {}", robot.log_text());
    drop(exec);

    // What the recording says: a live run of the robot process, what came from the other
    // processes kept apart, and what the link watchdog did.
    let rec = Recording::open(&path).expect("a readable recording");
    assert_eq!((rec.meta.process.as_str(), rec.meta.live), ("robot", true));
    assert!(rec.meta.faults_toml.as_deref().is_some_and(|f| f.contains("link_cut")));
    assert!(rec.outside > 0, "teleop's commands came from another process");
    let lost = rec.controls.iter().filter(|(_, c)| {
        matches!(c, Control::Link(e) if e.command.is_some_and(|c| c.v_m_s == 0.0 && c.omega_rad_s == 0.0))
    });
    assert_eq!(lost.count(), 1, "the watchdog lost the executive once, and commanded zero");
    let wirings = rec.controls.iter().filter(|(_, c)| matches!(c, Control::Port { .. })).count();
    assert!(wirings >= 4, "wired at the start, unwired under the cut, wired again: {wirings}");

    // `orsa replay`, as a user runs it.
    let report = temp("replay-report.json");
    let recording = path.clone();
    let report_path = report.clone();
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
    assert!(out.status.success() && text.contains("bit-exact"), "{text}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("the report")).expect("json");
    assert_eq!(r["bit_exact"], true);
    assert!(r["compared"].as_u64().expect("compared") > 300, "{r}");
    assert_eq!(r["controls"].as_u64(), Some(rec.controls.len() as u64));
    assert!(r["timing"]["within"].as_u64().is_some(), "a live recording is held to a tolerance: {r}");

    // One altered behaviour output is reported at exactly that message.
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
    for p in [path, plan, report] {
        let _ = std::fs::remove_file(p);
    }
}
