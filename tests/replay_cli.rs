//! `orsa run --record` then `orsa replay`, as a user types them: exit status 0 only when the
//! replay is bit-exact, the first divergence printed when it is not, a what-if's report and
//! plot, clear errors; and the recording read by the Python `mcap` package, which knows
//! nothing of orsa (`pip install -r tests/python/requirements.txt`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

#[path = "support/rewrite.rs"]
mod rewrite;
use rewrite::rewrite;

fn orsa(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orsa")).args(args).output().expect("orsa runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("orsa-replay-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Records `secs` simulated seconds of seed `seed` into `dir/run.mcap`.
fn record(d: &Path, seed: &str, secs: &str) -> PathBuf {
    let path = d.join("run.mcap");
    let p = |f: &str| d.join(f).display().to_string();
    let out = orsa(&[
        "run",
        "--quiet",
        "--seed",
        seed,
        "--duration",
        secs,
        "--record",
        &p("run.mcap"),
        "--report",
        &p("report.json"),
        "--plot",
        &p("run.svg"),
    ]);
    assert!(out.status.success(), "orsa run: {}", text(&out.stderr));
    path
}

#[test]
fn orsa_replay_says_bit_exact_and_exits_zero_only_when_it_is() {
    let d = dir("exact");
    let rec = record(&d, "9", "30");
    let rec_s = rec.display().to_string();
    let out = orsa(&["replay", "--quiet", &rec_s]);
    assert!(out.status.success(), "{}{}", text(&out.stdout), text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("bit-exact:") && stdout.contains("messages on"), "{stdout}");

    // A recording whose command differs from what the behaviour computes: exit 1, and where.
    let bad = d.join("altered.mcap");
    rewrite(
        &rec,
        &bad,
        |topic, i, data| {
            if topic == "wallfollow/status" && i == 49 {
                *data = text(data).replacen("\"v_m_s\":", "\"v_m_s\":-", 1).into_bytes();
            }
        },
        |_| {},
    );
    let out = orsa(&["replay", "--quiet", &bad.display().to_string()]);
    assert_eq!(out.status.code(), Some(1));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("DIVERGED at") && stdout.contains("wallfollow/status (message 50 of the topic)"),
        "{stdout}"
    );
    assert!(text(&out.stderr).contains("not bit-exact"), "{}", text(&out.stderr));
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[test]
fn orsa_replay_what_if_reports_and_draws_and_refuses_bad_flags() {
    let d = dir("whatif");
    let rec = record(&d, "2", "60").display().to_string();
    let (report, plot) = (d.join("w.json"), d.join("w.svg"));
    let out = orsa(&[
        "replay",
        "--quiet",
        &rec,
        "--set",
        "wallfollow.target_m=0.3",
        "--report",
        &report.display().to_string(),
        "--plot",
        &plot.display().to_string(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("wallfollow/status") && stdout.contains("value.cmd.omega_rad_s"), "{stdout}");
    let w: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).expect("report")).expect("json");
    assert!(w["topics"]["wallfollow/status"]["differing"].as_u64().is_some_and(|n| n > 0), "{w}");
    let svg = std::fs::read_to_string(&plot).expect("plot");
    assert_eq!(svg.matches(r#"class="series""#).count(), 4, "recorded and what-if, v and omega");

    for (args, says) in [
        (vec!["replay", &rec, "--plot", "x.svg"], "--plot draws a what-if"),
        (vec!["replay", &rec, "--set", "wallfollow.target_m=-1"], "wallfollow.target_m"),
        (vec!["replay", &rec, "--set", "nonsense"], "table.key=value"),
        (vec!["replay", "/no/such/file.mcap"], "/no/such/file.mcap"),
    ] {
        let out = orsa(&args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(text(&out.stderr).contains(says), "{args:?}: {}", text(&out.stderr));
    }
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[test]
fn a_recording_is_read_whole_by_the_python_mcap_package() {
    let d = dir("python");
    let rec = record(&d, "4", "20");
    let out = Command::new("python3")
        .arg("tests/python/read_recording.py")
        .arg(&rec)
        .output()
        .expect("python3 runs (a Python 3.11 with `pip install -r tests/python/requirements.txt`)");
    assert!(
        out.status.success(),
        "the Python reader refused the recording (is `pip install -r tests/python/requirements.txt` done?): {}",
        text(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the reader prints JSON");
    assert_eq!(v["seed"], 4);
    assert_eq!(v["robot_name"], "nomad200");
    assert_eq!(v["world_name"], "Palazzina 1 corridor");
    assert_eq!(
        v["hosted"],
        serde_json::json!(["nomad200", "wallfollow", "centerfollow", "master", "planner"])
    );
    // What Python counted is what orsa's own reader counted.
    let recording = orsa::replay::file::Recording::open(&rec).expect("replayable");
    let total: u64 = v["counts"].as_object().expect("counts").values().map(|n| n.as_u64().expect("n")).sum();
    assert_eq!(total, recording.messages);
    assert_eq!(v["last_log_time"].as_u64(), Some(recording.last_log_time));
    // The views for Foxglove are there, and the replay left them alone.
    let views: u64 = v["views"].as_object().expect("views").values().map(|n| n.as_u64().expect("n")).sum();
    assert!(views > 0, "{v}");
    assert_eq!(views, recording.views);
    std::fs::remove_dir_all(&d).expect("clean up");
}
