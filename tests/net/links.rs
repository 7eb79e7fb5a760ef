//! Link cuts (`orsa robot --faults` with `link_cut`): the link between the robot and a process
//! is cut while both zenoh sessions stay up, so liveliness does not notice; the robot must.
//! Every figure is what the robot reports (`--report`), on its own clock.

use super::*;
use orsa::faults::LinkCutReport;
use orsa::remote::RobotReport;

pub(crate) fn plan(name: &str, text: &str) -> PathBuf {
    let p = std::env::temp_dir().join(format!("orsa-test-{}-{name}.toml", std::process::id()));
    std::fs::write(&p, text).expect("write the plan");
    p
}

pub(crate) fn report_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("orsa-test-{}-{name}.json", std::process::id()))
}

/// Waits for the robot to end (it runs for --duration) and reads its report.
async fn robot_report(mut robot: Proc, path: PathBuf) -> RobotReport {
    let (status, robot) = tokio::task::spawn_blocking(move || {
        let s = robot.child.wait().expect("the robot ends");
        (s, robot)
    })
    .await
    .expect("join");
    assert!(status.success(), "the robot failed: {}", robot.log_text());
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e}\n{}", path.display(), robot.log_text()));
    serde_json::from_str(&text).expect("a robot report")
}

fn only_cut(r: &RobotReport) -> LinkCutReport {
    let f = r.faults.as_ref().expect("a faults section");
    assert_eq!(f.links.len(), 1, "{:?}", f.links);
    f.links[0].clone()
}

/// The default velocity timeout (robot.cmd_timeout_s).
const CMD_TIMEOUT_S: f64 = 0.5;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cut_link_to_the_executive_stops_the_robot_within_the_velocity_timeout_and_it_patrols_again() {
    let sys = System::new("cutexec");
    let plan =
        plan("cutexec", "[[fault]]\nat = 5.0\nkind = \"link_cut\"\ntarget = \"executive\"\nduration = 2.0\n");
    let report = report_path("cutexec");
    let robot = sys.robot(&[
        "--faults",
        plan.to_str().expect("utf-8"),
        "--report",
        report.to_str().expect("utf-8"),
        "--duration",
        "11",
    ]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let exec = sys.run("exec", "executive", &["--duration", "120"]);
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;
    // The cut: the robot stops, then drives again when the link is back.
    until_base(&mut base, Duration::from_secs(10), "the robot stops under the cut", |b| b.v_m_s == 0.0).await;
    until_base(&mut base, Duration::from_secs(10), "the robot patrols again", |b| b.v_m_s > 0.15).await;
    drop(base);
    let r = robot_report(robot, report).await;
    let cut = only_cut(&r);
    let restored = cut.restored_at_s.expect("restored");
    assert!((restored - cut.cut_at_s - 2.0).abs() < 0.1, "{cut:?}");
    let lost = cut.lost_at_s.expect("the robot noticed the cut") - cut.cut_at_s;
    let stop = cut.stop_commanded_at_s.expect("the robot commanded zero") - cut.cut_at_s;
    assert!(lost > 0.0 && stop <= CMD_TIMEOUT_S, "zero commanded {stop:.3} s after the cut: {cut:?}");
    // Then the axes decelerate (0.25 m/s at 0.5 m/s^2) and the next base state (100 ms) shows it.
    let rest = cut.at_rest_at_s.expect("at rest") - cut.cut_at_s;
    assert!(rest > 0.1, "the robot was not moving when the link was cut: {cut:?}");
    assert!(rest <= CMD_TIMEOUT_S + 0.5 + 0.15, "at rest {rest:.3} s after the cut: {cut:?}");
    // Back: the executive's next heartbeat hands it back what it drove.
    let back = cut.back_at_s.expect("the executive is heard again") - restored;
    assert!((0.0..0.5).contains(&back), "back {back:.3} s after the restore: {cut:?}");
    let moving = cut.moving_again_at_s.expect("moving again") - restored;
    assert!(moving < 1.0, "moving {moving:.3} s after the restore: {cut:?}");
    let faults = r.faults.as_ref().expect("faults");
    assert_eq!(faults.injected.get("link_cut"), Some(&1));
    assert_eq!(faults.detected.get("executive"), Some(&1), "{faults:?}");
    assert!(r.link.dropped_in > 0 && r.link.withheld_out > 0, "{:?}", r.link);
    drop(exec);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cut_link_to_teleop_stops_the_robot_within_the_velocity_timeout_and_teleop_drives_again() {
    let sys = System::new("cutteleop");
    let plan =
        plan("cutteleop", "[[fault]]\nat = 3.0\nkind = \"link_cut\"\ntarget = \"teleop\"\nduration = 1.5\n");
    let report = report_path("cutteleop");
    let robot = sys.robot(&[
        "--faults",
        plan.to_str().expect("utf-8"),
        "--report",
        report.to_str().expect("utf-8"),
        "--duration",
        "8",
    ]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let teleop = sys.run("teleop", "teleop", &["--send", "-0.1,0", "--for", "6"]);
    until_base(&mut base, STARTUP, "teleop drives backwards", |b| b.v_m_s < -0.05).await;
    drop(base);
    let r = robot_report(robot, report).await;
    drop(teleop);
    let cut = only_cut(&r);
    let restored = cut.restored_at_s.expect("restored");
    // The robot server's watchdog: zero at the last applied command's stamp + the timeout,
    // then the axes decelerate (0.1 m/s at 0.5 m/s^2), seen on the next base state (100 ms).
    let rest = cut.at_rest_at_s.expect("at rest") - cut.cut_at_s;
    assert!(rest > 0.1, "the robot was not moving when the link was cut: {cut:?}");
    assert!(rest <= CMD_TIMEOUT_S + 0.2 + 0.15, "at rest {rest:.3} s after the cut: {cut:?}");
    assert!(cut.at_rest_at_s.expect("at rest") < restored, "{cut:?}");
    // Control is given back: teleop's next command drives again.
    let moving = cut.moving_again_at_s.expect("teleop drives again") - restored;
    assert!(moving < 0.5, "moving {moving:.3} s after the restore: {cut:?}");
    assert!(r.safety.timeouts >= 1, "the watchdog stopped the robot: {:?}", r.safety);
    assert!(r.link.dropped_in > 0, "teleop's commands were dropped: {:?}", r.link);
    assert_eq!(cut.lost_at_s, None, "teleop is not watched by heartbeat");
}
