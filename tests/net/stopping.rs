//! Stopping at top speed: the robot commands zero within 0.1 s of losing its executive, and
//! then needs its braking distance, v^2 / 2a (0.25 m from 0.5 m/s at 0.5 m/s^2); when teleop
//! goes silent, the velocity timeout stops it (docs/faults.md, "Stopping").

use super::links::report_path;
use super::*;
use orsa::remote::RobotReport;

/// The robot's top speed and braking (sim.drive in config/orsa.toml).
const TOP_M_S: f64 = 0.5;
const BRAKE_M_S2: f64 = 0.5;
/// The velocity timeout (robot.cmd_timeout_s).
const CMD_TIMEOUT_S: f64 = 0.5;

/// The shipped config with both behaviours allowed to drive at the robot's top speed.
fn top_speed_config() -> PathBuf {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/config/orsa.toml")).expect("config");
    let fast = text.replace("v_max_m_s = 0.25", &format!("v_max_m_s = {TOP_M_S}"));
    assert_eq!(fast.matches(&format!("v_max_m_s = {TOP_M_S}")).count(), 2, "both behaviours sped up");
    let p = std::env::temp_dir().join(format!("orsa-test-{}-top-speed.toml", std::process::id()));
    std::fs::write(&p, fast).expect("write the config");
    p
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn at_top_speed_the_robot_commands_zero_within_0_1_s_of_losing_its_executive_and_brakes_in_its_distance()
 {
    let sys = System::new("topexec");
    let config = top_speed_config();
    let json = report_path("topexec");
    let mut robot =
        sys.robot(&["--config", config.to_str().expect("utf-8"), "--report", json.to_str().expect("utf-8")]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let mut exec = sys.run("exec", "executive", &["--config", config.to_str().expect("utf-8")]);
    until_base(&mut base, STARTUP, "a behaviour drives at top speed", |b| b.v_m_s >= 0.45).await;
    exec.child.kill().expect("kill -9 the executive");
    until_base(&mut base, Duration::from_secs(10), "the robot stops", |b| b.v_m_s == 0.0).await;
    robot.signal("-TERM");
    let status = tokio::task::spawn_blocking(move || {
        let s = robot.child.wait().expect("the robot ends");
        (s, robot)
    })
    .await
    .expect("join");
    assert_eq!(status.0.code(), Some(130), "{}", status.1.log_text());
    let text = std::fs::read_to_string(&json).expect("the robot's report");
    let r: RobotReport = serde_json::from_str(&text).expect("a robot report");
    assert_eq!(r.stops.len(), 1, "{:?}", r.stops);
    let s = &r.stops[0];
    assert!(s.cause.starts_with("executive lost"), "{s:?}");
    assert!(s.v_m_s >= 0.45, "it was at top speed when it knew: {s:?}");
    eprintln!("stop: {s:?}");
    let reaction = s.zero_at_s - s.detected_at_s;
    assert!((0.0..=0.1).contains(&reaction), "zero commanded {reaction} s after the loss: {s:?}");
    // Braking at 0.5 m/s^2; the distance counts from the last base state before the loss (at
    // most 0.1 s earlier) and the reaction, each at most v x 0.1 s.
    let braking = s.v_m_s * s.v_m_s / (2.0 * BRAKE_M_S2);
    assert!(
        s.distance_m >= 0.8 * braking && s.distance_m <= braking + 2.0 * 0.1 * s.v_m_s,
        "went {} m, braking distance {braking} m: {s:?}",
        s.distance_m
    );
    let at_rest = s.at_rest_at_s.expect("at rest") - s.zero_at_s;
    assert!(at_rest <= s.v_m_s / BRAKE_M_S2 + 0.15, "at rest {at_rest} s after the zero: {s:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn at_top_speed_a_silent_teleop_stops_the_robot_within_the_velocity_timeout_and_its_braking_distance() {
    let sys = System::new("topteleop");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let mut teleop =
        sys.run("teleop", "teleop", &["--send", &format!("{TOP_M_S},0"), "--for", "60", "--wait", "30"]);
    let fast = until_base(&mut base, STARTUP, "teleop drives at top speed", |b| b.v_m_s >= TOP_M_S).await;
    teleop.child.kill().expect("kill -9 teleop");
    let killed = registry.now();
    // From the kill on: its last command (at most 0.1 s before, at 10 Hz) runs out after the
    // velocity timeout, and the robot brakes.
    let mut last = (fast.value.x_m, fast.value.y_m);
    let mut went = 0.0;
    let rest = loop {
        let u = tokio::time::timeout(Duration::from_secs(5), base.recv())
            .await
            .expect("base states")
            .expect("base state stream");
        if u.sent_at >= killed {
            went += (u.value.x_m - last.0).hypot(u.value.y_m - last.1);
        }
        last = (u.value.x_m, u.value.y_m);
        if u.value.v_m_s == 0.0 {
            break u;
        }
    };
    let took = rest.sent_at.saturating_since(killed).as_secs_f64();
    eprintln!("teleop killed at top speed: at rest {took:.3} s later, {went:.3} m further");
    let braking_s = TOP_M_S / BRAKE_M_S2;
    let braking_m = TOP_M_S * TOP_M_S / (2.0 * BRAKE_M_S2);
    assert!(took <= CMD_TIMEOUT_S + braking_s + 0.2, "at rest {took} s after the kill");
    assert!(went <= TOP_M_S * CMD_TIMEOUT_S + braking_m + 0.1, "went {went} m after the kill");
    assert!(went >= braking_m * 0.8, "it braked at its rate: {went} m");
}
