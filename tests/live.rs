//! The live view (`--foxglove`) as a user meets it: the built `orsa` binary runs in real time
//! with its server on a loopback port picked at run time, and `tests/python/foxglove_client.py`
//! (a client of the public Foxglove WebSocket protocol, Python `websockets`, not the SDK's)
//! lists its channels, subscribes, decodes scans and frames at their rates, and sends it bad
//! input and a client that stalls; the run goes on to its end and nothing panics.
//!
//! Every wait is for a condition with a deadline; no test sleeps to let something happen.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A child process killed when dropped.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port()
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("orsa-live-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Starts `orsa run --realtime --foxglove` for `duration` s; returns it once it listens, and
/// the rest of its stdout as it comes.
fn live_run(d: &std::path::Path, port: u16, duration: &str) -> (Proc, std::sync::mpsc::Receiver<String>) {
    let child = Command::new(env!("CARGO_BIN_EXE_orsa"))
        .args(["run", "--realtime", "--quiet", "--seed", "2", "--duration", duration, "--foxglove"])
        .arg(format!("127.0.0.1:{port}"))
        .arg("--report")
        .arg(d.join("report.json"))
        .arg("--plot")
        .arg(d.join("run.svg"))
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(d.join("stderr.log")).expect("log file"))
        .spawn()
        .expect("start orsa");
    let mut proc = Proc(child);
    let stdout = proc.0.stdout.take().expect("stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(line) if line.starts_with("foxglove: serving") => {
                assert!(line.contains(&format!("ws://127.0.0.1:{port}")), "{line}");
                return (proc, rx);
            }
            Ok(_) => {}
            Err(_) => panic!(
                "orsa did not say it serves within 20 s: {}",
                std::fs::read_to_string(d.join("stderr.log")).unwrap_or_default()
            ),
        }
    }
}

/// Waits for `proc` to end, at most `within`.
fn wait_end(proc: &mut Proc, within: Duration) -> std::process::ExitStatus {
    let deadline = Instant::now() + within;
    loop {
        if let Some(status) = proc.0.try_wait().expect("try_wait") {
            return status;
        }
        assert!(Instant::now() < deadline, "orsa did not end within {within:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_foxglove_client_lists_subscribes_decodes_at_rate_and_bad_input_harms_nothing() {
    let d = dir("client");
    let port = free_port();
    let (mut orsa, rest) = live_run(&d, port, "14");
    let out = Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/foxglove_client.py"))
        .arg(format!("ws://127.0.0.1:{port}"))
        .args(["--seconds", "5"])
        .output()
        .expect("python3 runs (with `pip install -r tests/python/requirements.txt`)");
    assert!(
        out.status.success(),
        "the client's checks failed: {}\norsa: {}",
        text(&out.stderr),
        std::fs::read_to_string(d.join("stderr.log")).unwrap_or_default()
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the client prints JSON");
    // The live parameters are served: the server says so.
    let caps = v["server"]["capabilities"].as_array().expect("capabilities");
    assert!(caps.iter().any(|c| c == "parameters"), "{v}");
    for topic in ["/infrared", "/sonar", "/tf"] {
        assert!(v["periods"][topic]["messages"].as_u64().is_some_and(|n| n >= 40), "{topic}: {v}");
    }
    // Every bad input was answered with a status or ignored; what the server said to those it
    // answers is an error or a warning.
    let bad = v["bad_inputs"].as_object().expect("bad inputs");
    assert_eq!(bad.len(), 10, "{v}");
    for (name, answer) in bad {
        for s in answer["statuses"].as_array().expect("statuses") {
            assert!(s["level"].as_u64().is_some_and(|l| l >= 1), "{name}: {s}");
        }
    }
    assert!(
        !bad["subscribe_unknown_channel"]["statuses"].as_array().expect("statuses").is_empty(),
        "a subscription to a channel that does not exist is answered with a status: {v}"
    );

    // The run went on to its end, through all of it, and reported it.
    let status = wait_end(&mut orsa, Duration::from_secs(30));
    let stderr = std::fs::read_to_string(d.join("stderr.log")).unwrap_or_default();
    assert!(status.success(), "orsa run: {status}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("report.json")).expect("the report"))
            .expect("the report is JSON");
    assert_eq!(report["ended"]["how"], "completed", "{report}");
    let summary: Vec<String> = rest.try_iter().collect();
    assert!(
        summary.iter().any(|l| l.starts_with("foxglove: ") && l.contains("made into views")),
        "{summary:?}"
    );
    std::fs::remove_dir_all(&d).expect("clean up");
}

#[test]
fn foxglove_without_realtime_and_a_bad_address_are_refused_naming_the_flag() {
    let out = Command::new(env!("CARGO_BIN_EXE_orsa"))
        .args(["run", "--quiet", "--duration", "1", "--foxglove"])
        .output()
        .expect("orsa runs");
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("--foxglove needs --realtime"), "{}", text(&out.stderr));
    let out = Command::new(env!("CARGO_BIN_EXE_orsa"))
        .args(["run", "--realtime", "--duration", "1", "--foxglove", "localhost"])
        .output()
        .expect("orsa runs");
    assert!(!out.status.success());
    let e = text(&out.stderr);
    assert!(e.contains("--foxglove") && e.contains("IP:PORT"), "{e}");
}

/// Setting a speed from Foxglove's parameter panel, as the protocol does it, and seeing the
/// robot slow down, while a second client subscribed to the speeds is pushed the new values;
/// values the component refuses (out of range, of the wrong type, above the robot's top speed,
/// unknown) are answered with an error status naming the parameter, change nothing, and are
/// pushed to no one.
#[test]
fn a_speed_set_from_foxglove_slows_the_robot() {
    let d = dir("params");
    let port = free_port();
    let (mut orsa, _rest) = live_run(&d, port, "25");
    let out = Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/foxglove_client.py"))
        .arg(format!("ws://127.0.0.1:{port}"))
        .args(["--params", "centerfollow.v_max_m_s", "0.1"])
        .output()
        .expect("python3 runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    // The panel lists the behaviours' and the master's parameters.
    let names = v["parameters"].as_object().expect("parameters");
    for name in
        ["centerfollow.v_max_m_s", "wallfollow.target_m", "master.modes.patrol.rules.0.when.0.below_m"]
    {
        assert!(names.contains_key(name), "{name}: {:?}", names.keys().collect::<Vec<_>>());
    }
    assert_eq!(v["applied"].as_array().map(Vec::len), Some(2), "{v}");
    assert!(v["applied"].as_array().expect("applied").iter().all(|p| p["value"] == 0.1), "{v}");
    for (label, needle) in [
        ("negative", "centerfollow.v_max_m_s"),
        ("text", "invalid type"),
        ("too_fast", "above the robot's top speed of 0.5 m/s"),
        ("unknown", "no parameter 'v_max_m_s_nope'"),
    ] {
        let r = &v["refusals"][label];
        assert_eq!(r["applied"].as_array().map(Vec::len), Some(0), "{label}: {v}");
        assert!(
            r["statuses"]
                .as_array()
                .expect("statuses")
                .iter()
                .any(|s| s.as_str().is_some_and(|s| s.contains(needle))),
            "{label}: {r}"
        );
    }
    assert_eq!(v["now"][0]["value"], 0.1, "the refusals changed nothing: {v}");
    // The second client, subscribed to both, was pushed both new values (the client checks
    // they carry no request id), and nothing of the refused ones.
    let pushed = v["pushed"].as_array().expect("pushed");
    for name in ["wallfollow.v_max_m_s", "centerfollow.v_max_m_s"] {
        assert!(pushed.iter().any(|p| p["name"] == name && p["value"] == 0.1), "{name}: {v}");
    }
    assert!(
        v["pushed_after_refusals"].as_array().expect("late").iter().all(|p| p["value"] == 0.1),
        "a refused value was pushed: {v}"
    );
    let before = v["speed_before"].as_f64().expect("speed before");
    let after = v["speed_after"].as_f64().expect("speed after");
    assert!(before > 0.2, "before the set the robot went {before} m/s");
    assert!(v["positions_after"].as_u64().is_some_and(|n| n >= 20), "{v}");
    assert!(after < 0.11, "after the set the robot went {after} m/s");
    let status = wait_end(&mut orsa, Duration::from_secs(40));
    assert!(status.success(), "orsa run: {status}");
    std::fs::remove_dir_all(&d).expect("clean up");
}

/// Driving from Foxglove as its Teleop panel does (client publish of JSON
/// `geometry_msgs/msg/Twist` on `/cmd_vel`, from a client written from the protocol's
/// specification): zero commands hold the robot the behaviours drive, as teleop's do;
/// TwistStamped commands stamped 10 s ago are refused as stale by the robot, which drives on;
/// a channel on another topic, a message that is not JSON and a lateral speed are each answered
/// with a status, and the run reports what clients published.
#[test]
fn velocity_commands_published_from_foxglove_drive_under_teleops_rules() {
    let d = dir("teleop");
    let port = free_port();
    let (mut orsa, rest) = live_run(&d, port, "25");
    let out = Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/foxglove_client.py"))
        .arg(format!("ws://127.0.0.1:{port}"))
        .arg("--teleop")
        .output()
        .expect("python3 runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let speed = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k}: {v}"));
    assert!(speed("speed_before") > 0.15, "the behaviours drive: {v}");
    assert!(v["positions_held"].as_u64().is_some_and(|n| n >= 15), "{v}");
    assert!(speed("still_share_held") >= 0.8, "teleop's zeros hold the robot: {v}");
    assert!(speed("speed_stale") > 0.15, "stale commands are refused, the behaviours drive: {v}");
    let statuses: Vec<String> = v["statuses"]
        .as_array()
        .expect("statuses")
        .iter()
        .map(|s| format!("{} {}", s["level"], s["message"].as_str().unwrap_or_default()))
        .collect();
    for needle in
        ["'/elsewhere' is ignored", "/elsewhere: refused", "/cmd_vel: refused: expected", "linear.y 0.3"]
    {
        assert!(statuses.iter().any(|s| s.contains(needle)), "{needle}: {statuses:?}");
    }
    let status = wait_end(&mut orsa, Duration::from_secs(40));
    assert!(status.success(), "orsa run: {status}");
    let summary: Vec<String> = rest.try_iter().collect();
    let line = summary.iter().find(|l| l.starts_with("foxglove: ")).expect("the live view's summary");
    let taken: u64 = line
        .split("; ")
        .nth(1)
        .and_then(|p| p.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    // Three seconds of each kind at ten a second were handed on (the stale ones too: the
    // robot judges them); the three bad messages were refused here.
    assert!(taken >= 40, "{line}");
    assert!(line.ends_with(", 3 refused"), "{line}");
    std::fs::remove_dir_all(&d).expect("clean up");
}
