//! How a run ends when it cannot run its whole duration: the top supervisor giving up, or a
//! signal. Either way the run stops the robot, and reports and records what happened up to then;
//! `orsa run` exits with a code that says which (0 completed, 3 gave up, 130 interrupted, 4 a
//! mission of places that did not reach them all).

use orsa::config::Config;
use orsa::faults::{FaultPlan, PlanTargets};
use orsa::mission::report::Ended;
use orsa::mission::{self, RunOptions};
use orsa_actors::supervision::SupervisorEventKind;
use orsa_hardware::world::World;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

/// The robot server is killed every 2 s from 2 s on: its subtree (5 restarts in 60 s) gives up
/// at the sixth kill, 12 s later; the top restarts the subtree, which gives up again 12 s later,
/// and the fourth give-up in 60 s is one more than the top allows (3).
const SERVER_KILLED_EVERY_TWO_SECONDS: &str = r#"
[[fault]]
at = 2.0
kind = "kill"
target = "nomad200"
every = 2.0
"#;

/// The plan that, with every component under one supervisor (10 restarts in 60 s), ended the run
/// at 35 s: the robot server killed every 23 s, the behaviours panicking every 11 and 13 s,
/// the master hanging every 17 s.
const OVERLAPPING: &str = r#"
[[fault]]
at = 5.0
kind = "kill"
target = "nomad200"
every = 23.0

[[fault]]
at = 3.0
kind = "panic"
target = "wallfollow"
every = 11.0

[[fault]]
at = 4.0
kind = "panic"
target = "centerfollow"
every = 13.0

[[fault]]
at = 6.0
kind = "hang"
target = "master"
every = 17.0
"#;

fn options(config: Config, plan: &str, duration_s: f64) -> RunOptions {
    let targets = PlanTargets::for_stack(&config);
    let mut o = RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 1, duration_s);
    o.faults = Some(FaultPlan::parse(plan, "the test's plan", &targets).expect("plan"));
    o
}

#[tokio::test(start_paused = true)]
async fn a_run_whose_supervisor_gives_up_stops_the_robot_and_still_reports() {
    let out = mission::run(options(Config::default(), SERVER_KILLED_EVERY_TWO_SECONDS, 600.0))
        .await
        .expect("a report, not an error");
    let r = &out.report;
    let Ended::GaveUp { at_s, supervisor, child, reason, stopped_in_s } = &r.ended else {
        panic!("ended {:?}", r.ended)
    };
    assert_eq!((*at_s, supervisor.as_str(), child.as_str()), (48.0, "orsa", "server"));
    assert!(reason.contains("supervisor `server` gave up") && reason.contains("nomad200"), "{reason}");
    // Stopped straight on the board: at rest within the robot's command timeout.
    let stopped = stopped_in_s.expect("at rest");
    assert!(stopped > 0.0 && stopped <= 0.5, "{stopped}");
    // The figures cover the time up to then.
    assert_eq!(r.sim_seconds, 48.0);
    assert_eq!(out.metrics.trajectory.last().map(|s| s.0), Some(48.0));
    let gave_up: Vec<&str> = out
        .supervisor_events
        .iter()
        .filter(|e| e.kind == SupervisorEventKind::GaveUp)
        .map(|e| e.supervisor.as_str())
        .collect();
    assert_eq!(gave_up, ["server", "server", "server", "server", "orsa"]);
}

/// The tree keeps each part's failures to its own budget: under overlapping faults at several per
/// minute the run goes on, and the robot server is restarted only when it is killed itself. With
/// everything under one supervisor, as before, the same plan ends the run.
#[tokio::test(start_paused = true)]
async fn behaviours_crashing_often_never_take_the_robot_server_down() {
    let out = mission::run(options(Config::default(), OVERLAPPING, 600.0)).await.expect("run");
    let r = &out.report;
    assert_eq!(r.ended, Ended::Completed);
    assert_eq!((r.bumps, r.stalls), (0, 0));
    let restarts = &r.faults.as_ref().expect("faults").restarts;
    // Killed at 5, 28, ... 580 s: 26 times, restarted 26 times.
    assert_eq!(restarts.get("nomad200"), Some(&26), "{restarts:?}");
    assert!(restarts.get("wallfollow").is_some_and(|n| *n >= 50), "{restarts:?}");
    assert!(!out.supervisor_events.iter().any(|e| e.kind == SupervisorEventKind::GaveUp));

    let flat =
        Config::from_toml("[supervision]\nmax_restarts = 10\nsubtrees = {}\n", "flat.toml").expect("config");
    let out = mission::run(options(flat, OVERLAPPING, 600.0)).await.expect("a report");
    assert!(
        matches!(out.report.ended, Ended::GaveUp { ref supervisor, .. } if supervisor == "orsa"),
        "{:?}",
        out.report.ended
    );
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

/// `orsa run --goto` as a script runs it: a mission that did not reach every place exits with
/// 4, not 0, and its report says which step was given up and why; one that reached them all
/// exits with 0 (a place rejected at once keeps both runs short).
#[test]
fn orsa_run_goto_exits_with_4_when_a_place_is_not_reached() {
    let d = std::env::temp_dir().join(format!("orsa-goto-exit-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    let world = concat!(env!("CARGO_MANIFEST_DIR"), "/worlds/office.toml");
    let run_for = |name: &str, places: &[&str], duration: &str| {
        let report = d.join(format!("{name}.json"));
        let mut c = Command::new(env!("CARGO_BIN_EXE_orsa"));
        c.args(["run", "--quiet", "--world", world, "--duration", duration])
            .args(["--report", &report.display().to_string()])
            .args(["--plot", &d.join(format!("{name}.svg")).display().to_string()]);
        for p in places {
            c.args(["--goto", p]);
        }
        let out = c.output().expect("orsa runs");
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).expect("report written")).expect("JSON");
        let said =
            format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        (out.status.code(), report, said)
    };
    let run = |name: &str, places: &[&str]| run_for(name, places, "600");
    let (code, report, err) = run("missed", &["kitchen", "room-1"]);
    assert_eq!(code, Some(4), "{err}");
    assert_eq!(report["ended"]["how"], "mission_ended", "{}", report["ended"]);
    let result = report["ended"]["result"].as_str().expect("the mission's result");
    assert!(result.starts_with("completed with 1 of 2 steps skipped: step 0 rejected: "), "{result}");
    assert!(result.contains("no place 'kitchen'"), "{result}");
    let (code, report, err) = run("reached", &["room-1"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(report["ended"]["result"], "completed", "{}", report["ended"]);
    // The plot draws the path planned, the estimate and the goal, reached (green).
    let plot = |name: &str| std::fs::read_to_string(d.join(format!("{name}.svg"))).expect("plot written");
    let svg = plot("reached");
    for class in ["planned", "estimate", "place"] {
        assert!(svg.contains(&format!("class=\"{class}\"")), "no {class} in the plot");
    }
    let goals: Vec<&str> = svg.lines().filter(|l| l.contains(r#"class="goal""#)).collect();
    assert!(goals.len() == 1 && goals[0].contains("#1a9850"), "{goals:?}");
    assert!(svg.contains("1 of 1 goals reached"), "the headline counts the goal");
    // Out of time before the place: the run ends with its time, and the place was not reached.
    let (code, report, err) = run_for("short", &["room-5"], "5");
    assert_eq!(code, Some(4), "{err}");
    assert_eq!(report["ended"]["how"], "completed", "{}", report["ended"]);
    assert!(err.contains("did not end within --duration 5 s"), "{err}");
    let svg = plot("short");
    let goals: Vec<&str> = svg.lines().filter(|l| l.contains(r#"class="goal""#)).collect();
    assert!(goals.len() == 1 && goals[0].contains("#d62728"), "missed, in red: {goals:?}");
    assert!(svg.contains("0 of 1 goals reached"), "the headline counts the goal");
}
