//! The planner against a stand-in executive that refuses goals the way the master does when a
//! mode switch fails: it gives a goal again only when the switch could not be made now and
//! nothing changed, and aborts at once when the mode cannot be made or the system is left half
//! switched. On tokio's paused clock.

use orsa_actors::event::EventServer;
use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::query::{QueryRequest, QueryServer};
use orsa_actors::switch::{Change, Phase, SwitchFailure};
use orsa_actors::{Registry, Sink};
use orsa_interfaces::executive::{self, Goal, GoalFilter, GoalReply};
use orsa_interfaces::planner::{MISSION, MissionStatus};
use orsa_planner::{MissionStep, Planner};
use std::time::Duration;
use tokio::sync::mpsc;

fn failure(phase: Phase, left_switched: bool) -> GoalReply {
    let change = Change::State { component: "wallfollow".into(), main: "neutral".into() };
    let not_undone = if left_switched { vec![(change.clone(), "timed out".to_string())] } else { vec![] };
    GoalReply::Rejected {
        reason: "switch failed".into(),
        switch: Some(SwitchFailure { phase, change, error: "timed out".into(), undone: vec![], not_undone }),
    }
}

/// Runs a one-step mission against an executive that answers the goals with `answers` in turn
/// (then accepts); returns when each goal was asked (s from the start) and the planner's status.
async fn run(answers: Vec<GoalReply>) -> (Vec<f64>, MissionStatus) {
    let registry = Registry::new();
    let (tx, mut goals) = mpsc::unbounded_channel::<QueryRequest<Goal, GoalReply>>();
    let _goal =
        QueryServer::register(&registry, executive::GOAL.on("master"), Sink::channel(tx)).expect("goal");
    let _events = EventServer::<GoalFilter, executive::GoalEvent, ()>::register(
        &registry,
        executive::GOALS.on("master"),
        |_, _| None,
    )
    .expect("goals");
    let planner = Planner {
        mission: vec![MissionStep::mode("patrol", None)],
        executive: "master".into(),
        retries: 3,
        retry_after: Duration::from_secs(1),
        on_abort: orsa_planner::OnAbort::Skip,
        nav: None,
    };
    let _planner = orsa_actors::component::spawn(&registry, "planner", planner).await.expect("planner");
    let status =
        PushNewestClient::<MissionStatus>::connect(&registry, MISSION.on("planner")).expect("status");
    status.subscribe().expect("subscribed");
    let t0 = tokio::time::Instant::now();
    let mut asked = Vec::new();
    let mut answers = answers.into_iter();
    // Every goal asked within 10 s (the planner never waits that long between two).
    while let Ok(Some(goal)) = tokio::time::timeout(Duration::from_secs(10), goals.recv()).await {
        asked.push(t0.elapsed().as_secs_f64());
        let answer = answers.next().unwrap_or(GoalReply::Accepted { id: 7 });
        goal.answer(answer).expect("answered");
    }
    (asked, status.get_update().expect("a status").value.clone())
}

#[tokio::test(start_paused = true)]
async fn a_switch_that_could_not_be_made_now_is_tried_again_after_the_back_off() {
    let (asked, status) = run(vec![failure(Phase::Commit, false), failure(Phase::Commit, false)]).await;
    assert_eq!(asked, [0.0, 1.0, 2.0]);
    assert_eq!((status.goal_id, status.finished), (Some(7), None));
}

#[tokio::test(start_paused = true)]
async fn a_switch_that_keeps_failing_aborts_the_mission_after_the_retries() {
    let (asked, status) = run(vec![failure(Phase::Commit, false); 4]).await;
    assert_eq!(asked, [0.0, 1.0, 2.0, 3.0]);
    let finished = status.finished.expect("aborted");
    assert!(
        finished.starts_with("aborted: step 0 rejected, its mode switch failed every time"),
        "{finished}"
    );
}

#[tokio::test(start_paused = true)]
async fn a_mode_that_cannot_be_made_or_a_half_switched_system_aborts_at_once() {
    for (answer, why) in [
        (failure(Phase::Prepare, false), "its mode cannot be made"),
        (failure(Phase::Commit, true), "the system is left half switched"),
        (GoalReply::Rejected { reason: "unknown mode".into(), switch: None }, "the goal is invalid"),
    ] {
        let (asked, status) = run(vec![answer]).await;
        assert_eq!(asked, [0.0], "{why}");
        let finished = status.finished.expect("aborted");
        assert!(finished.starts_with(&format!("aborted: step 0 rejected, {why}")), "{finished}");
    }
}
