//! Process chaos: the robot and the executive as real processes on loopback, killed
//! (SIGKILL), frozen (SIGSTOP, SIGCONT; the executive for longer than zenoh's lease) and
//! started again, one fault after the other. After
//! each the system comes back by itself: the robot stops when it loses its executive and
//! patrols again when an executive is back (a restarted robot is wired again by the
//! executive's master); no stale command is ever applied; and the robot's report counts every
//! stop the faults called for, each commanded within 0.1 s of the loss.

use super::links::report_path;
use super::*;
use orsa::mission::report::Ended;
use orsa::remote::{ExecutiveReport, RobotReport};

/// How long the system may take to come back after a fault (a process starting included).
const BACK: Duration = Duration::from_secs(20);
/// A freeze shorter than zenoh's 1 s lease, longer than the 0.3 s heartbeat lease: only the
/// heartbeat notices.
const FREEZE: Duration = Duration::from_millis(700);
/// A freeze longer than zenoh's 1 s lease: the peers' sessions to the frozen process close.
const LONG_FREEZE: Duration = Duration::from_millis(2500);

/// SIGTERMs `p` and waits for it: its exit code.
async fn terminate(p: Proc) -> (Option<i32>, Proc) {
    p.signal("-TERM");
    tokio::task::spawn_blocking(move || {
        let mut p = p;
        let s = p.child.wait().expect("wait");
        (s.code(), p)
    })
    .await
    .expect("join")
}

async fn driving(base: &mut mpsc::UnboundedReceiver<Update<BaseState>>, what: &str) -> Update<BaseState> {
    until_base(base, BACK, what, |b| b.v_m_s > 0.15).await
}

async fn stopped(base: &mut mpsc::UnboundedReceiver<Update<BaseState>>, what: &str) {
    until_base(base, Duration::from_secs(5), what, |b| b.v_m_s == 0.0).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn killed_frozen_and_restarted_processes_come_back_by_themselves_and_the_counts_add_up() {
    let sys = System::new("chaos");
    let robot_json = report_path("chaos-robot");
    let exec_json = report_path("chaos-exec");
    let robot1 = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let exec1 = sys.run("exec1", "executive", &[]);
    driving(&mut base, "the executive drives").await;

    // 1. The robot's process frozen: it patrols again once it runs.
    robot1.signal("-STOP");
    tokio::time::sleep(FREEZE).await; // the fault's own length, not a wait for something
    robot1.signal("-CONT");
    driving(&mut base, "patrols again after the robot's freeze").await;

    // 2. The robot's process killed and started again: the executive wires the new one.
    let mut robot1 = robot1;
    robot1.child.kill().expect("kill -9 the robot");
    let _ = robot1.child.wait();
    let robot2 = sys.robot(&["--report", robot_json.to_str().expect("utf-8")]);
    driving(&mut base, "the executive drives the restarted robot").await;

    // 3. The executive frozen for longer than zenoh's lease: the robot stops on the missing
    //    heartbeat, zenoh then closes the session, and the executive, once it runs again,
    //    opens a new one and gets its behaviour back.
    let frozen = tokio::time::Instant::now();
    exec1.signal("-STOP");
    stopped(&mut base, "stops while the executive is frozen").await;
    tokio::time::sleep_until(frozen + LONG_FREEZE).await; // the fault's own length
    exec1.signal("-CONT");
    driving(&mut base, "patrols again after the executive's freeze").await;

    // 4. The executive killed, then another one started.
    let mut exec1 = exec1;
    exec1.child.kill().expect("kill -9 the executive");
    let _ = exec1.child.wait();
    stopped(&mut base, "stops when the executive is killed").await;
    let exec2 = sys.run("exec2", "executive", &["--report", exec_json.to_str().expect("utf-8")]);
    let drove = driving(&mut base, "a new executive drives").await;
    // Its ledger is checked below: let the robot run on for a second of its own time, so that
    // it has pushed the new executive's master two of its infrared updates (one in 400 ms)
    // before the executive is ended (it was ended 0.4 s after its start, having heard nothing).
    let since = drove.value.stamp.0;
    until_base(&mut base, BACK, "the robot runs on for a second", |b| b.stamp.0 >= since + 1_000_000_000)
        .await;

    // 5. Both end as a user ends them, and report.
    let (code, exec2) = terminate(exec2).await;
    assert_eq!(code, Some(130), "{}", exec2.log_text());
    stopped(&mut base, "stops when the executive leaves").await;
    let (code, robot2) = terminate(robot2).await;
    assert_eq!(code, Some(130), "{}", robot2.log_text());

    let e: ExecutiveReport =
        serde_json::from_str(&std::fs::read_to_string(&exec_json).expect("the executive's report"))
            .expect("json");
    assert!(matches!(e.ended, Ended::Interrupted { .. }), "{:?}", e.ended);
    assert_eq!(e.restarts, 0, "nothing in the executive failed");
    let r: RobotReport =
        serde_json::from_str(&std::fs::read_to_string(&robot_json).expect("the robot's report"))
            .expect("json");
    assert!(matches!(r.ended, Ended::Interrupted { .. }), "{:?}", r.ended);
    // The restarted robot lost its executive three times: frozen, killed, ended.
    let causes: Vec<&str> = r.stops.iter().map(|s| s.cause.as_str()).collect();
    assert_eq!(r.stops.len(), 3, "{causes:?}\n{}", robot2.log_text());
    assert!(causes.iter().all(|c| c.starts_with("executive lost")), "{causes:?}");
    assert!(causes[1].ends_with("its process token disappeared"), "the kill: {causes:?}");
    assert!(causes[2].ends_with("its process token disappeared"), "the end: {causes:?}");
    for s in &r.stops {
        eprintln!("stop: {s:?}");
        let reaction = s.zero_at_s - s.detected_at_s;
        assert!((0.0..=0.1).contains(&reaction), "zero {reaction} s after the loss: {s:?}");
        assert!(s.at_rest_at_s.is_some(), "came to rest: {s:?}");
    }
    assert_eq!(r.safety.stale_applied, 0, "no stale command applied: {:?}", r.safety);
    assert_eq!(r.restarts, 0, "nothing in the robot failed");
    // The ledger across processes, between the two that reported: what one put on the link
    // and what the other counted add up, both ways.
    let exec_zid = heartbeat_zid(&e.links);
    let robot_zid =
        e.links.incoming.iter().find(|i| i.role.as_deref() == Some("robot")).map(|i| i.from.clone());
    let robot_zid = robot_zid.unwrap_or_else(|| {
        panic!("the executive heard the robot: incoming {:?}\n{}", e.links.incoming, exec2.log_text())
    });
    assert!(add_up(&exec_zid, &e.links, &r.links, "executive -> robot") >= 1);
    assert!(add_up(&robot_zid, &r.links, &e.links, "robot -> executive") >= 1);
    assert!(r.safety.applied > 0);
}
