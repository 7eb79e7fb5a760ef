//! ROS 2 from outside: `tests/python/ros2_node.py`, a ROS 2 node as rmw_zenoh makes one,
//! written from rmw_zenoh's design with eclipse-zenoh and rosbags (its CDR codec, message
//! definitions and type hashes), none of orsa's code.
//!
//! - `orsa robot --ros2` is discovered through its liveliness tokens, its topics decoded at
//!   their rates, and it is driven through `/cmd_vel` and stops when the commands cease;
//! - bad input on `/cmd_vel` (undecodable, wrong type, not finite, a burst of 5000) is refused
//!   and counted, and the robot stays at rest and keeps running;
//! - its node's parameter services answer `ros2 param` calls (list, get, set, describe, types,
//!   atomic sets, bad requests) on the components' parameters, and its warnings reach `/rosout`;
//! - `orsa robot --hardware ros2` drives the fixture's simulated ROS 2 robot along its wall;
//! - a ROS 2 teleop driving `/cmd_vel` straight at a wall at top speed is stopped short of it.

use super::*;
use orsa::remote::RobotReport;

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/ros2_node.py");

/// Runs the fixture in `mode` against the system, within `within`: its JSON line.
pub(crate) async fn fixture(
    sys: &System,
    mode: &str,
    extra: &[&str],
    within: Duration,
    logs: &[&Proc],
) -> serde_json::Value {
    let connect = format!("tcp/127.0.0.1:{}", sys.port);
    let mut args: Vec<String> = vec![SCRIPT.into(), "--connect".into(), connect];
    args.extend(extra.iter().map(|s| s.to_string()));
    args.push(mode.into());
    let run = tokio::task::spawn_blocking(move || Command::new("python3").args(&args).output());
    let out = tokio::time::timeout(within, run)
        .await
        .unwrap_or_else(|_| panic!("ros2_node.py {mode}: not done within {within:?}"))
        .expect("join")
        .expect("run python3");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let logs: Vec<String> = logs.iter().map(|p| p.log_text()).collect();
    assert!(
        out.status.success(),
        "ros2_node.py {mode}: {stdout}\n{}\norsa:\n{}",
        String::from_utf8_lossy(&out.stderr),
        logs.join("\n---\n")
    );
    let line = stdout.lines().last().unwrap_or_default();
    serde_json::from_str(line).unwrap_or_else(|e| panic!("ros2_node.py {mode} printed {stdout:?}: {e}"))
}

/// A fixture started ahead of orsa, its first line read.
struct Started {
    child: std::process::Child,
    out: std::io::BufReader<std::process::ChildStdout>,
}

/// Starts the fixture in `mode` and waits for its first line, `first` (what it must have done
/// before orsa starts); [`finish`] reads the rest.
async fn start_fixture(sys: &System, mode: &str, extra: &[&str], first: &str) -> Started {
    let connect = format!("tcp/127.0.0.1:{}", sys.port);
    let mut args: Vec<String> = vec![SCRIPT.into(), "--connect".into(), connect];
    args.extend(extra.iter().map(|s| s.to_string()));
    args.push(mode.into());
    let first = first.to_string();
    let started = tokio::task::spawn_blocking(move || {
        use std::io::BufRead as _;
        let mut child = Command::new("python3")
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("run python3");
        let mut out = std::io::BufReader::new(child.stdout.take().expect("stdout"));
        let mut line = String::new();
        out.read_line(&mut line).expect("the fixture's first line");
        assert_eq!(line.trim(), first, "the fixture's first line");
        Started { child, out }
    });
    tokio::time::timeout(Duration::from_secs(60), started)
        .await
        .expect("the fixture's first line within 60 s")
        .expect("join")
}

/// Waits for a fixture [`start_fixture`] started, within `within`: its JSON line.
async fn finish(started: Started, mode: &str, within: Duration, logs: &[&Proc]) -> serde_json::Value {
    let done = tokio::task::spawn_blocking(move || {
        use std::io::Read as _;
        let Started { mut child, mut out } = started;
        let mut text = String::new();
        let _ = out.read_to_string(&mut text);
        (child.wait().expect("wait"), text)
    });
    let (status, stdout) = tokio::time::timeout(within, done)
        .await
        .unwrap_or_else(|_| panic!("ros2_node.py {mode}: not done within {within:?}"))
        .expect("join");
    let logs: Vec<String> = logs.iter().map(|p| p.log_text()).collect();
    assert!(status.success(), "ros2_node.py {mode}: {stdout}\norsa:\n{}", logs.join("\n---\n"));
    let line = stdout.lines().last().unwrap_or_default();
    serde_json::from_str(line).unwrap_or_else(|e| panic!("ros2_node.py {mode} printed {stdout:?}: {e}"))
}

/// Interrupts `p` (it writes its report) and reads the report at `path`.
async fn interrupt_and_report(p: Proc, path: &std::path::Path) -> RobotReport {
    p.signal("-INT");
    let p = tokio::time::timeout(
        Duration::from_secs(20),
        tokio::task::spawn_blocking(move || {
            let mut p = p;
            let _ = p.child.wait();
            p
        }),
    )
    .await
    .expect("the robot ends within 20 s of SIGINT")
    .expect("join");
    let text =
        std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}\n{}", path.display(), p.log_text()));
    serde_json::from_str(&text).expect("a robot report")
}

fn report_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("orsa-test-{}-{name}.json", std::process::id()))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ros2_node_sees_the_robot_drives_it_and_its_bad_commands_are_refused_and_counted() {
    let sys = System::new("ros2face");
    let report = report_path("ros2face");
    // The domain comes from ROS_DOMAIN_ID, as for every ROS 2 node: the node, on domain 7, sees
    // the robot only if the robot took it from its environment (it would be on 0 otherwise).
    let robot = sys
        .robot_with_env(&["--ros2", "--report", report.to_str().expect("utf-8")], &[("ROS_DOMAIN_ID", "7")]);

    let seen = fixture(&sys, "observe", &["--domain", "7"], Duration::from_secs(60), &[&robot]).await;
    eprintln!("observe: {seen}");
    assert_eq!(seen["robot_node"], "orsa", "{seen}");
    assert!(seen["moved_m"].as_f64().expect("moved_m") > 0.1, "{seen}");
    // Velocity timeout 0.5 s, then the robot decelerates: at rest well within 2 s.
    assert!(seen["at_rest_after_s"].as_f64().expect("at_rest") < 2.0, "{seen}");
    // TwistStamped drove it too (stamped now, or zero).
    assert!(seen["stamped_top_speed"].as_f64().expect("stamped speed") >= 0.1, "{seen}");

    let bad = fixture(&sys, "bad-input", &["--domain", "7"], Duration::from_secs(60), &[&robot]).await;
    eprintln!("bad input: {bad}");

    // `ros2 param` on the robot's node: its parameter services, called as rclcpp's parameter
    // client calls them, reach the components' own parameters.
    let p = fixture(&sys, "params", &["--domain", "7"], Duration::from_secs(90), &[&robot]).await;
    eprintln!("params: {p}");
    assert!(
        p["listed"].as_u64().expect("listed") >= 20 && p["shallow"].as_u64().expect("shallow") >= 5,
        "{p}"
    );
    let set: Vec<(bool, String)> = serde_json::from_value(p["set"].clone()).expect("set results");
    assert!(set[0].0, "a speed within the robot's limits is set: {p}");
    for (i, why) in
        [(1, "top speed"), (2, "no component 'nosuch'"), (3, "expected f64"), (4, "cannot be unset")]
    {
        assert!(!set[i].0 && set[i].1.contains(why), "set {i} refused for '{why}': {p}");
    }
    let (before, after) = (p["before"].as_f64().expect("before"), p["after"].as_f64().expect("after"));
    assert!((after - before * 0.8).abs() < 1e-6, "the value in force is the one set: {p}");
    assert_eq!(p["atomic"][0], false, "{p}");
    assert_eq!(p["unchanged"].as_f64(), Some(after), "a refused atomic set changed nothing: {p}");
    assert_eq!(p["still"].as_f64(), Some(after), "{p}");
    assert_eq!(p["restored"], true, "{p}");
    for (what, why) in [
        ("no_attachment", "attachment"),
        ("undecodable", "does not decode"),
        ("wrong_type", "GetParameters"),
        ("huge", "more than this service takes"),
    ] {
        assert!(p["bad"][what].as_str().expect("an error reply").contains(why), "{what}: {p}");
    }
    // /rosout: the robot's lines, as rqt_console reads them; transient local, so the client,
    // which came after the robot said it joined ROS 2, still gets that line.
    assert_eq!(p["rosout_qos"], ":1:,1000:,:,:,,", "{p}");
    let lines = p["rosout"].as_array().expect("rosout lines");
    assert!(
        lines.iter().any(|l| l["level"] == 20
            && l["name"] == "orsa.robot"
            && l["msg"].as_str().is_some_and(|m| m.contains("on ROS 2 domain 7 as node orsa"))),
        "the robot's line from before the client came: {p}"
    );
    assert!(
        lines.iter().any(|l| l["level"] == 30
            && l["name"].as_str().is_some_and(|n| n.starts_with("orsa."))
            && l["msg"].as_str().is_some_and(|m| m.contains("top speed"))),
        "the refused set is on /rosout: {p}"
    );
    let r = interrupt_and_report(robot, &report).await;
    let ros2 = r.ros2.expect("a ros2 section in the report");
    eprintln!("ros2: {ros2:?}\nsafety: {:?}", r.safety);
    assert_eq!(ros2.node.undecodable, 5, "{ros2:?}");
    assert_eq!(ros2.node.wrong_type, 3, "{ros2:?}");
    assert_eq!(ros2.node.requests_refused, 4, "{ros2:?}");
    assert!(ros2.node.requests_answered >= 12, "{ros2:?}");
    // The 5000-message burst (some may be dropped on the way under congestion): at most the
    // burst and what the rate refills while it lasts pass, with the 40 driving commands before.
    assert!(ros2.cmd_vel_rate_refused >= 1000, "{ros2:?}");
    assert!(ros2.cmd_vel_forwarded < 200, "{ros2:?}");
    // The three commands that are not finite reached the robot server, which refused them.
    assert!(r.safety.failed >= 3, "{:?}", r.safety);
    // The TwistStamped commands 5 s old reached it and were refused as stale, by their stamp.
    let stale_sent = seen["stamped_stale_sent"].as_u64().expect("stale sent");
    assert!(r.safety.stale_refused >= stale_sent, "{:?}", r.safety);
    assert!(ros2.node.published > 100, "{ros2:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn orsa_drives_a_ros2_robot_along_its_corridor_wall() {
    let sys = System::new("ros2base");
    let config = std::env::temp_dir().join(format!("orsa-test-{}-ros2base.toml", std::process::id()));
    std::fs::write(&config, "[params.planner]\nmission = [{ mode = \"follow_left_wall\", for_s = 600 }]\n")
        .expect("write the config");
    let report = report_path("ros2base");
    // The fixture's laser is mounted backwards, 0.064 m behind the centre (as on a TurtleBot 3),
    // and it says so on /tf_static once, before orsa starts: orsa must fetch it as a late
    // joiner (transient local) and place the laser by it, or it would see the wall on its
    // left on its right.
    let laser_yaw = std::f64::consts::PI.to_string();
    let started = start_fixture(
        &sys,
        "robot",
        &["--seconds", "12", "--wall-y", "0.5", "--laser-x", "-0.064", "--laser-yaw", &laser_yaw],
        "tf_static published",
    )
    .await;
    let robot = sys.robot(&["--hardware", "ros2", "--report", report.to_str().expect("utf-8")]);
    let exec = sys.run("exec", "executive", &["--config", config.to_str().expect("utf-8")]);
    // The robot starts 0.5 m from the wall (centre to wall); wall following holds its edge
    // 0.20 m from it, its centre 0.45 m.
    let run = finish(started, "robot", Duration::from_secs(90), &[&robot, &exec]).await;
    eprintln!("ros2 robot: {run}");
    drop(exec);
    let r = interrupt_and_report(robot, &report).await;
    eprintln!("report: {:?}", r.ros2);
    assert!(run["commands"].as_u64().expect("commands") > 50, "{run}");
    // Its commands came as TwistStamped (the config's default), stamped when sent: UNIX time,
    // within moments of the fixture's clock on the same host.
    assert_eq!(run["cmd_type"], "geometry_msgs/msg/TwistStamped", "{run}");
    let (lag_lo, lag_hi) = (
        run["stamp_lag_s"]["min"].as_f64().expect("stamped"),
        run["stamp_lag_s"]["max"].as_f64().expect("stamped"),
    );
    assert!(lag_lo > -0.05 && lag_hi < 1.0, "{run}");
    assert!(run["travelled_m"].as_f64().expect("travelled") > 1.0, "{run}");
    assert!(run["min_clearance_m"].as_f64().expect("clearance") > 0.0, "it touched the wall: {run}");
    let (lo, hi) = (
        run["wall_distance_m"]["min"].as_f64().expect("min"),
        run["wall_distance_m"]["max"].as_f64().expect("max"),
    );
    assert!(lo > 0.3 && hi < 0.7, "held near the wall in the second half: {run}");
    let ros2 = r.ros2.expect("a ros2 section in the report");
    assert!(ros2.node.received > 100 && ros2.node.undecodable == 0, "{ros2:?}");
    let laser = ros2.laser.expect("where the laser was placed");
    let pose = laser.from_tf.expect("placed by TF");
    assert!(
        (pose.x_m + 0.064).abs() < 1e-6
            && pose.y_m.abs() < 1e-6
            && (pose.yaw_rad.abs() - std::f64::consts::PI).abs() < 1e-6,
        "{laser:?}"
    );
    // Scans that came before the transform are placed by the config; then every one by TF.
    assert!(laser.by_tf > 100 && laser.by_tf > 10 * laser.by_config, "{laser:?}");
}

/// A ROS 2 teleop node (the fixture) turns the robot to face the corridor's wall and drives it
/// straight at it through `/cmd_vel` at the top speed (0.5 m/s) for 6 s: the safety monitor in
/// the robot's process stops it short of the wall, no bumper is pressed, and the robot's report
/// counts the monitor's interventions. Without the monitor (`[safety] enabled = false`) the
/// same commands press the bumpers: the check can fail.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ros2_cmd_vel_at_a_wall_at_top_speed_stops_short_of_it() {
    let at_wall = |monitor: bool| async move {
        let name = if monitor { "ros2wall" } else { "ros2wallunguarded" };
        let sys = System::new(name);
        let report = report_path(name);
        let config = report_path(&format!("{name}-config"));
        std::fs::write(&config, format!("[safety]\nenabled = {monitor}\n")).expect("write the config");
        let robot = sys.robot(&[
            "--ros2",
            "--report",
            report.to_str().expect("utf-8"),
            "--config",
            config.to_str().expect("utf-8"),
        ]);
        let seen = fixture(&sys, "at-wall", &["--seconds", "6"], Duration::from_secs(90), &[&robot]).await;
        eprintln!("at the wall, monitor {monitor}: {seen}");
        let r = interrupt_and_report(robot, &report).await;
        let _ = std::fs::remove_file(config);
        (seen, r.safety)
    };
    let (seen, safety) = at_wall(true).await;
    assert_eq!(seen["bumped_while_turning"], false, "{seen}");
    assert_eq!(seen["bumped"], false, "the robot touched the wall: {seen}");
    // It drove, and it was standing when the commands were still asking for 0.5 m/s.
    assert!(seen["top_speed_m_s"].as_f64().expect("top speed") > 0.2, "{seen}");
    assert!(seen["moved_m"].as_f64().expect("moved") > 0.2, "{seen}");
    assert_eq!(seen["speed_at_end_m_s"].as_f64(), Some(0.0), "{seen}");
    let front = seen["front_ir_at_end_m"].as_f64().expect("the wall is in the front infrared's range");
    // The monitor holds it about 0.29-0.30 m from the wall as the front infrared reads it
    // (noise 5 mm + 2 %): it drove up to the wall, not just somewhere short of it.
    assert!(front > 0.0 && front < 0.4, "stopped {front:.3} m from the wall: {seen}");
    let m = safety.monitor.expect("the monitor's counters");
    assert!(m.interventions >= 1 && m.obstacle_s > 1.0 && m.distance_lost_m > 0.5, "{m:?}");

    let (seen, safety) = at_wall(false).await;
    assert_eq!(seen["bumped"], true, "without the monitor the commands drive it into the wall: {seen}");
    assert_eq!(safety.monitor, None, "no monitor, no counters");
}
