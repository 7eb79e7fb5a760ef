//! How a run ends when it cannot run its whole duration: the top supervisor giving up, or a
//! signal. Either way the run stops the robot, and reports and records what happened up to then;
//! `orsa run` exits with a code that says which (0 completed, 3 gave up, 130 interrupted).

use orsa::config::Config;
use orsa::faults::{FaultPlan, PlanTargets};
use orsa::mission::report::Ended;
use orsa::mission::{self, RunOptions};
use orsa_hardware::world::World;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

/// Both behaviours panic every 2 s from 2 s on: their restarts exceed the supervisor's
/// intensity (10 in 60 s) at the eleventh.
const EVERY_TWO_SECONDS: &str = r#"
[[fault]]
at = 2.0
kind = "panic"
target = "wallfollow"
every = 2.0

[[fault]]
at = 3.0
kind = "panic"
target = "centerfollow"
every = 2.0
"#;

fn options(duration_s: f64) -> RunOptions {
    let config = Config::default();
    let mut o =
        RunOptions::new(World::palazzina().expect("world"), "palazzina", config.clone(), 1, duration_s);
    o.faults = Some(
        FaultPlan::parse(EVERY_TWO_SECONDS, "the test's plan", &PlanTargets::for_stack(&config))
            .expect("plan"),
    );
    o
}

#[tokio::test(start_paused = true)]
async fn a_run_whose_supervisor_gives_up_stops_the_robot_and_still_reports() {
    let out = mission::run(options(600.0)).await.expect("a report, not an error");
    let r = &out.report;
    let Ended::GaveUp { at_s, supervisor, child, reason, stopped_in_s } = &r.ended else {
        panic!("ended {:?}", r.ended)
    };
    // The eleventh restart in 60 s: the panic at 12 s.
    assert_eq!((*at_s, supervisor.as_str(), child.as_str()), (12.0, "orsa", "wallfollow"));
    assert!(reason.contains("injected fault"), "{reason}");
    // Stopped straight on the board: at rest well within the robot's command timeout.
    let stopped = stopped_in_s.expect("at rest");
    assert!(stopped > 0.0 && stopped <= 0.5, "{stopped}");
    // The figures cover the time up to then; the supervisor's restarts are all counted.
    assert_eq!(r.sim_seconds, 12.0);
    assert_eq!(r.restarts, 10);
    assert!(r.distance_m > 1.0, "{}", r.distance_m);
    assert_eq!(out.metrics.trajectory.last().map(|s| s.0), Some(12.0));
}

#[tokio::test(start_paused = true)]
async fn an_interrupted_run_reports_the_time_it_ran() {
    let mut o = RunOptions::new(World::palazzina().expect("world"), "palazzina", Config::default(), 1, 600.0);
    o.interrupt = Some(Box::pin(async {
        tokio::time::sleep(Duration::from_secs(30)).await;
        "the test".to_string()
    }));
    let out = mission::run(o).await.expect("a report");
    assert_eq!(out.report.ended, Ended::Interrupted { at_s: 30.0, signal: "the test".into() });
    assert_eq!(out.report.sim_seconds, 30.0);
    // The same 30 s as a run of 30 s: the interruption changes nothing before it.
    let whole = mission::run(RunOptions::new(
        World::palazzina().expect("world"),
        "palazzina",
        Config::default(),
        1,
        30.0,
    ))
    .await
    .expect("run");
    assert_eq!(out.metrics.trajectory, whole.metrics.trajectory);
    assert_eq!(whole.report.ended, Ended::Completed);
}

/// `orsa run` as a user runs it, interrupted by SIGTERM: exit code 130, the report says so, and
/// the recording is closed cleanly (the Python `mcap` reader reads it to its end).
#[cfg(unix)]
#[test]
fn orsa_run_interrupted_by_sigterm_writes_its_report_and_recording() {
    let d = std::env::temp_dir().join(format!("orsa-ending-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    let p = |f: &str| d.join(f).display().to_string();
    let mut child = Command::new(env!("CARGO_BIN_EXE_orsa"))
        .args(["run", "--realtime", "--quiet", "--duration", "600", "--log", "orsa_executive=info"])
        .args(["--report", &p("report.json"), "--record", &p("run.mcap"), "--plot", &p("run.svg")])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("orsa runs");
    // Running: the master has started its first goal.
    let mut lines = BufReader::new(child.stderr.take().expect("stderr")).lines();
    let started = lines.by_ref().map_while(Result::ok).any(|l| l.contains("Started"));
    assert!(started, "the master never started a goal");
    let killed = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().expect("kill");
    assert!(killed.success());
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    let status = child.wait().expect("orsa ends");
    assert_eq!(status.code(), Some(130), "{}", rest.join("\n"));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("report.json")).expect("report written"))
            .expect("report JSON");
    assert_eq!(report["ended"]["how"], "interrupted");
    assert_eq!(report["ended"]["signal"], "SIGTERM");
    assert!(report["sim_seconds"].as_f64().is_some_and(|s| s < 600.0), "{report}");
    let read = Command::new("python3")
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/read_recording.py"))
        .arg(d.join("run.mcap"))
        .output()
        .expect("python3 runs");
    assert!(read.status.success(), "the recording does not read: {}", String::from_utf8_lossy(&read.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&read.stdout).expect("summary JSON");
    assert!(summary["counts"]["nomad200/navigationvelocity"].as_u64().is_some_and(|n| n > 0), "{summary}");
}
