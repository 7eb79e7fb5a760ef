//! Every way `orsa robot` and `orsa executive` end writes their report, says how they ended
//! and has its exit code: 0 completed, 3 gave up, 130 interrupted (Ctrl-C, SIGTERM), 1 failed.

use super::links::{plan, report_path};
use super::processes::wired;
use super::*;
use orsa::mission::report::Ended;
use orsa::remote::{ExecutiveReport, RobotReport};

/// Waits (at most `within`) for `p` to exit by itself: its exit code.
pub(crate) async fn exit_code(p: Proc, within: Duration) -> (i32, Proc) {
    let mut p = p;
    let waited = tokio::task::spawn_blocking(move || {
        let end = std::time::Instant::now() + within;
        loop {
            match p.child.try_wait().expect("wait") {
                Some(s) => return (s.code(), p),
                None if std::time::Instant::now() > end => return (None, p),
                // A child's exit has no event to wait on here but its status.
                None => std::thread::sleep(Duration::from_millis(20)),
            }
        }
    })
    .await
    .expect("join");
    match waited {
        (Some(code), p) => (code, p),
        (None, p) => panic!("still running {within:?} later (or killed by a signal):\n{}", p.log_text()),
    }
}

fn read<T: serde::de::DeserializeOwned>(path: &std::path::Path, p: &Proc) -> T {
    let text =
        std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}\n{}", path.display(), p.log_text()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", path.display()))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_ends_the_robot_and_the_executive_with_their_reports_and_exit_code_130() {
    let sys = System::new("term");
    let (robot_json, exec_json) = (report_path("term-robot"), report_path("term-exec"));
    let robot = sys.robot(&["--report", robot_json.to_str().expect("utf-8")]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let exec = sys.run("exec", "executive", &["--report", exec_json.to_str().expect("utf-8")]);
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;

    exec.signal("-TERM");
    let (code, exec) = exit_code(exec, Duration::from_secs(10)).await;
    assert_eq!(code, 130, "{}", exec.log_text());
    let r: ExecutiveReport = read(&exec_json, &exec);
    assert!(matches!(&r.ended, Ended::Interrupted { signal, .. } if signal == "SIGTERM"), "{:?}", r.ended);
    // The robot saw its executive leave and stopped.
    until_base(&mut base, Duration::from_secs(5), "the robot stops", |b| b.v_m_s == 0.0).await;

    robot.signal("-TERM");
    let (code, robot) = exit_code(robot, Duration::from_secs(10)).await;
    assert_eq!(code, 130, "{}", robot.log_text());
    let r: RobotReport = read(&robot_json, &robot);
    assert!(matches!(&r.ended, Ended::Interrupted { signal, .. } if signal == "SIGTERM"), "{:?}", r.ended);
    assert!(r.safety.applied > 0, "the server's counts are in the report: {:?}", r.safety);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_whose_top_supervisor_gives_up_stops_its_motors_reports_and_exits_3() {
    let sys = System::new("robotgiveup");
    let json = report_path("robotgiveup");
    // The robot server killed every 0.2 s from 4 s: its subtree gives up after 6 kills, the
    // top restarts the subtree 3 times and gives up at the 4th.
    let plan =
        plan("robotgiveup", "[[fault]]\nat = 4.0\nkind = \"kill\"\ntarget = \"nomad200\"\nevery = 0.2\n");
    let robot =
        sys.robot(&["--report", json.to_str().expect("utf-8"), "--faults", plan.to_str().expect("utf-8")]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let _exec = sys.run("exec", "executive", &[]);
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;

    let (code, robot) = exit_code(robot, Duration::from_secs(60)).await;
    assert_eq!(code, 3, "{}", robot.log_text());
    let r: RobotReport = read(&json, &robot);
    match &r.ended {
        Ended::GaveUp { supervisor, child, stopped_in_s, .. } => {
            assert_eq!(supervisor, "orsa-robot", "the top gave up");
            assert_eq!(child, "server", "after its server subtree failed once too often");
            let s = stopped_in_s.expect("the robot came to rest within the wait");
            // From at most 0.25 m/s at 0.5 m/s^2: 0.5 s, and a little for the board's period.
            assert!(s <= 0.7, "at rest {s} s after the stop");
        }
        other => panic!("{other:?}\n{}", robot.log_text()),
    }
    // nomad200 restarted 5 times by each of the 4 instances of its subtree, and the subtree
    // restarted 3 times by the top (a kill while nomad200 is restarting finds nothing to kill).
    assert_eq!(r.restarts, 5 * 4 + 3, "restarts");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_executive_whose_top_supervisor_gives_up_unwires_the_robot_reports_and_exits_3() {
    let sys = System::new("execgiveup");
    let json = report_path("execgiveup");
    let plan =
        plan("execgiveup", "[[fault]]\nat = 3.0\nkind = \"kill\"\ntarget = \"master\"\nevery = 0.25\n");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let exec = sys.run(
        "exec",
        "executive",
        &["--report", json.to_str().expect("utf-8"), "--faults", plan.to_str().expect("utf-8")],
    );
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;

    let (code, exec) = exit_code(exec, Duration::from_secs(60)).await;
    assert_eq!(code, 3, "{}", exec.log_text());
    let r: ExecutiveReport = read(&json, &exec);
    match &r.ended {
        Ended::GaveUp { supervisor, child, .. } => {
            assert_eq!(supervisor, "orsa-executive", "the top gave up");
            assert_eq!(child, "executive", "after its executive subtree failed once too often");
        }
        other => panic!("{other:?}\n{}", exec.log_text()),
    }
    let f = r.faults.as_ref().expect("a faults section");
    assert!(f.injected.get("kill").copied().unwrap_or(0) >= 6 * 4, "{:?}", f.injected);
    // The robot is left standing: nothing wired, at rest.
    until_base(&mut base, Duration::from_secs(5), "the robot stops", |b| b.v_m_s == 0.0).await;
    assert!(wired(&registry).await.is_empty(), "no behaviour stays wired");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_executive_that_cannot_find_its_robot_fails_with_a_report_and_exit_code_1() {
    let sys = System::new("norobot");
    let json = report_path("norobot");
    let exec = sys.run("exec", "executive", &["--report", json.to_str().expect("utf-8"), "--wait", "1"]);
    let (code, exec) = exit_code(exec, Duration::from_secs(30)).await;
    assert_eq!(code, 1, "{}", exec.log_text());
    let r: ExecutiveReport = read(&json, &exec);
    match &r.ended {
        Ended::Failed { error, .. } => assert!(error.contains("no peer offers"), "{error}"),
        other => panic!("{other:?}"),
    }
    assert!(exec.log_text().contains("no peer offers"), "the error is printed too: {}", exec.log_text());
}
