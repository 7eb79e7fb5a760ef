//! `orsa param` from another process: a running robot's behaviour read, set, and seen to
//! change how the robot moves; a refused value says why and changes nothing.

use super::*;
use std::io::Read as _;

/// Runs `orsa param ARGS` against `sys`: whether it succeeded, its stdout and its stderr.
fn param(sys: &System, name: &str, args: &[&str]) -> (bool, String, String) {
    let mut p = sys.run(name, "param", args);
    let mut out = String::new();
    if let Some(mut stdout) = p.child.stdout.take() {
        stdout.read_to_string(&mut out).expect("read stdout");
    }
    let status = p.child.wait().expect("orsa param ends");
    (status.success(), out, p.log_text())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_speed_set_from_another_process_slows_the_robot() {
    let sys = System::new("param");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;

    let (ok, out, log) = param(&sys, "get", &["get", "centerfollow", "v_max_m_s", "--wait", "30"]);
    assert!(ok, "{log}");
    let before: f64 = out
        .trim()
        .strip_prefix("centerfollow.v_max_m_s = ")
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("'{out}'"));
    assert!(before > 0.2, "{before}");

    let mut switch = sys.run(
        "on",
        "switch",
        &["centerfollow:active", "centerfollow.vel=nomad200/navigationvelocity", "--wait", "30"],
    );
    assert!(switch.child.wait().expect("orsa switch ends").success(), "{}", switch.log_text());
    until_base(&mut base, STARTUP, "center following drives faster than 0.2 m/s", |b| b.v_m_s > 0.2).await;

    let (ok, out, log) = param(&sys, "set", &["set", "centerfollow", "v_max_m_s", "0.1"]);
    assert!(ok, "{log}");
    assert_eq!(out.trim(), format!("centerfollow.v_max_m_s = 0.1 (was {before})"));
    // The robot slows down at its braking rate, then holds the new top speed.
    until_base(&mut base, Duration::from_secs(5), "the robot slows to 0.1 m/s", |b| b.v_m_s < 0.105).await;
    let held = tokio::time::timeout(Duration::from_secs(2), async {
        loop {
            let b = base.recv().await.expect("base states");
            assert!(b.value.v_m_s < 0.105, "faster than the new top speed: {}", b.value.v_m_s);
        }
    })
    .await;
    assert!(held.is_err(), "base states kept coming for 2 s");

    // Refused with the reason, naming the parameter; the value stays.
    let (ok, _, log) = param(&sys, "bad", &["set", "centerfollow", "v_max_m_s", "-1"]);
    assert!(!ok);
    assert!(log.contains("centerfollow refused the value: centerfollow.v_max_m_s"), "{log}");
    assert!(log.contains("centerfollow.v_max_m_s stays 0.1"), "{log}");
    let (ok, _, log) = param(&sys, "type", &["set", "centerfollow", "v_max_m_s", "fast"]);
    assert!(!ok && log.contains("v_max_m_s: invalid type: string \"fast\""), "{log}");
    let (ok, _, log) = param(&sys, "usage", &["get", "centerfollow", "v_max_m_s", "0.3"]);
    assert!(!ok && log.contains("takes no value"), "{log}");
    let (ok, _, log) = param(&sys, "none", &["get", "nosuch", "--wait", "0.5"]);
    assert!(!ok && log.contains("no peer offers nosuch/param"), "{log}");

    let (ok, out, log) = param(&sys, "table", &["get", "centerfollow", "loops", "--json"]);
    assert!(ok, "{log}");
    let loops: Vec<serde_json::Value> = serde_json::from_str(&out).expect("JSON");
    assert!(
        loops.len() >= 2
            && loops.iter().all(|p| p["name"].as_str().is_some_and(|n| n.starts_with("centerfollow.loops.")))
    );
    t.close().await;
}

/// Starts a Foxglove client (written from the WebSocket protocol's specification, in Python)
/// on `addr` watching `name`; returns once it says it subscribed.
fn watcher(
    addr: &str,
    name: &str,
    robot: &Proc,
) -> (std::process::Child, std::io::BufReader<std::process::ChildStdout>) {
    use std::io::BufRead as _;
    let mut client = Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/foxglove_client.py"))
        .args([format!("ws://{addr}").as_str(), "--watch-param", name, "--seconds", "20"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 runs");
    let mut stdout = std::io::BufReader::new(client.stdout.take().expect("stdout"));
    let mut line = String::new();
    stdout.read_line(&mut line).expect("the client's first line");
    assert_eq!(line.trim(), "subscribed", "robot:\n{}", robot.log_text());
    (client, stdout)
}

/// What the watcher saw pushed.
fn pushed(
    mut client: std::process::Child,
    mut stdout: std::io::BufReader<std::process::ChildStdout>,
) -> serde_json::Value {
    let mut rest = String::new();
    stdout.read_to_string(&mut rest).expect("the client's output");
    let status = client.wait().expect("the client ends");
    let mut err = String::new();
    client.stderr.take().expect("stderr").read_to_string(&mut err).expect("its stderr");
    assert!(status.success(), "{rest}\n{err}");
    let v: serde_json::Value = serde_json::from_str(&rest).expect("JSON");
    v["pushed"].clone()
}

/// A value set by `orsa param set` from another process is pushed to a Foxglove client of the
/// robot's live view subscribed to it (a client written from the WebSocket protocol's
/// specification, in Python): whoever changes a parameter, the subscribed panels show it. That
/// holds for a component of the robot's process (which reports its change) and for one in
/// another process (the master, in the executive's: the live server reads the subscribed
/// parameters again every second).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_value_set_from_another_process_is_pushed_to_a_subscribed_foxglove_client() {
    let sys = System::new("parampush");
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    let robot = sys.robot(&["--foxglove", &addr]);
    let _exec = sys.run("exec", "executive", &[]);
    let (registry, t) = sys.observe().await;
    let (_c, _base) = base_stream(&registry, &t).await;

    let (client, stdout) = watcher(&addr, "wallfollow.target_m", &robot);
    let (ok, out, log) = param(&sys, "set", &["set", "wallfollow", "target_m", "0.22", "--wait", "30"]);
    assert!(ok, "{log}");
    assert!(out.starts_with("wallfollow.target_m = 0.22"), "{out}");
    assert_eq!(
        pushed(client, stdout),
        serde_json::json!([{"name": "wallfollow.target_m", "type": "float64", "value": 0.22}]),
    );

    // The master runs in the executive's process: once it answers, a client watches one of its
    // parameters on the robot's live view, and another process sets it.
    let (ok, out, log) = param(&sys, "getmaster", &["get", "master", "switch_step_s", "--wait", "30"]);
    assert!(ok && out.starts_with("master.switch_step_s = "), "{out}\n{log}");
    let (client, stdout) = watcher(&addr, "master.switch_step_s", &robot);
    let (ok, out, log) =
        param(&sys, "setmaster", &["set", "master", "switch_step_s", "0.15", "--wait", "30"]);
    assert!(ok, "{log}");
    assert!(out.starts_with("master.switch_step_s = 0.15"), "{out}");
    assert_eq!(
        pushed(client, stdout),
        serde_json::json!([{"name": "master.switch_step_s", "type": "float64", "value": 0.15}]),
    );
    t.close().await;
}
