//! The recording's views for Foxglove (channels in its well-known protobuf schemas), read by
//! the Python `mcap` package with its protobuf support, which know nothing of orsa
//! (`pip install -r tests/python/requirements.txt`): `tests/python/read_views.py` decodes
//! every view and checks it against the world file and the recording's own JSON channels.

use std::path::PathBuf;
use std::process::Command;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// What `tests/python/read_views.py` says of the recording at `rec`, as JSON.
fn read_views(rec: &std::path::Path) -> serde_json::Value {
    let out = Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/read_views.py"))
        .arg(rec)
        .output()
        .expect("python3 runs (a Python 3.11 with `pip install -r tests/python/requirements.txt`)");
    assert!(
        out.status.success(),
        "the views do not check out (is `pip install -r tests/python/requirements.txt` done?): {}",
        text(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("the reader prints JSON")
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("orsa-views-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn the_views_of_a_run_decode_and_agree_with_the_world_and_the_json_channels() {
    let d = dir("run");
    let rec = d.join("run.mcap");
    let out = Command::new(env!("CARGO_BIN_EXE_orsa"))
        .args(["run", "--quiet", "--seed", "3", "--duration", "120", "--record"])
        .arg(&rec)
        .arg("--report")
        .arg(d.join("report.json"))
        .arg("--plot")
        .arg(d.join("run.svg"))
        .output()
        .expect("orsa runs");
    assert!(out.status.success(), "orsa run: {}", text(&out.stderr));

    let v = read_views(&rec);
    let views = &v["views"];
    for topic in [
        "/world",
        "/map",
        "/people",
        "/robot",
        "/tf",
        "/truth/tf",
        "/infrared",
        "/sonar",
        "/trajectory",
        "/driving",
    ] {
        assert!(views[topic].as_u64().is_some_and(|n| n > 0), "no {topic}: {v}");
    }
    // The corridor's map: a floor with walls round it, and nothing known outside.
    let cells = &v["map_cells"];
    for kind in ["free", "occupied", "unknown"] {
        assert!(cells[kind].as_u64().is_some_and(|n| n > 100), "{kind}: {v}");
    }
    assert!(cells["free"].as_u64() > cells["occupied"].as_u64(), "{v}");
    // 120 s of truth sampled every 100 ms, and the first sample at 0.
    assert_eq!(views["/truth/tf"], 1201, "{v}");
    assert_eq!(v["scan_period_ms"]["/infrared"], 40.0);
    assert_eq!(v["scan_period_ms"]["/sonar"], 64.0);
    // The master handed the motors over at least twice: centre following, then another.
    let driving: Vec<&str> =
        v["driving"].as_array().expect("driving").iter().filter_map(|d| d.as_str()).collect();
    assert!(driving.contains(&"centerfollow") && driving.contains(&"wallfollow"), "{v}");

    // What orsa's own replay reader sets aside as views is what Python decoded.
    let recording = orsa::replay::file::Recording::open(&rec).expect("replayable");
    let total: u64 = views.as_object().expect("views").values().map(|n| n.as_u64().expect("n")).sum();
    assert_eq!(total, recording.views);

    // Every topic the shipped Foxglove layout shows is one the recording has.
    let layout: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/foxglove/orsa-layout.json"))
            .expect("the layout"),
    )
    .expect("the layout is JSON");
    let panels = layout["configById"].as_object().expect("configById");
    let mut shown = Vec::new();
    for (id, config) in panels {
        match id.split_once('!').map(|(kind, _)| kind) {
            Some("3D") => shown.extend(config["topics"].as_object().expect("3D topics").keys().cloned()),
            Some("Plot") => {
                for p in config["paths"].as_array().expect("plot paths") {
                    let path = p["value"].as_str().expect("path");
                    shown.push(path.split_once('.').expect("topic.field").0.to_owned());
                }
            }
            Some("Log") => shown.push(config["topicToRender"].as_str().expect("log topic").to_owned()),
            Some("RawMessages") => shown.push(config["topicPath"].as_str().expect("topic").to_owned()),
            // The live parameters: no topic (a recording has none to show; a live server does).
            Some("Parameters") => {}
            other => panic!("a panel of kind {other:?} that this test does not know"),
        }
    }
    assert!(shown.len() >= 10, "{shown:?}");
    for topic in &shown {
        assert!(
            recording.schemas.contains_key(topic.as_str()),
            "the layout shows {topic}, which the recording lacks"
        );
    }
    std::fs::remove_dir_all(&d).expect("clean up");
}

/// A navigation run's recording draws where the localizer puts the robot and the path it
/// follows: `/estimate/tf` one frame per estimate, `/plan` one path per path given, each equal to
/// its JSON channel (checked by the Python reader, which also compares the estimate with the
/// truth).
#[test]
fn a_navigation_recording_draws_the_estimate_and_the_path() {
    let d = dir("navigation");
    let rec = d.join("nav.mcap");
    let world = concat!(env!("CARGO_MANIFEST_DIR"), "/worlds/office.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_orsa"))
        .args(["run", "--quiet", "--seed", "3", "--world", world, "--goto", "room-1", "--record"])
        .arg(&rec)
        .output()
        .expect("orsa runs");
    assert!(out.status.success(), "orsa run: {}", text(&out.stderr));
    let v = read_views(&rec);
    let e = &v["estimate"];
    // An estimate per odometry update (10 Hz) over the 15-20 s to room-1.
    assert!(e["estimates"].as_u64().is_some_and(|n| n > 100), "{v}");
    assert!(e["rms_m"].as_f64().is_some_and(|r| r < 0.10), "{v}");
    // At least the path to room-1 (some 5 m at 5 cm steps), and the stop at the end.
    assert!(e["plans"].as_u64().is_some_and(|n| n >= 2), "{v}");
    assert!(e["plan_poses"].as_u64().is_some_and(|n| n > 60), "{v}");
    std::fs::remove_dir_all(&d).expect("clean up");
}
