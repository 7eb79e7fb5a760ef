//! The master as a component, with the robot server and both behaviours on the simulator:
//! goals, their events, and the wiring invariant, watched through a tap on the registry.

use orsa::config::Config;
use orsa::mission::stack::Stack;
use orsa_actors::event::{EventClient, EventMode};
use orsa_actors::query::QueryClient;
use orsa_actors::tap::Tap;
use orsa_actors::{Clock, Registry, Timestamp};
use orsa_hardware::world::World;
use orsa_interfaces::executive::{self, Goal, GoalEvent, GoalFilter, GoalReply, GoalStatus};
use parking_lot::Mutex;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

/// Tracks which behaviour ports point at the motors, and the most that ever did at once.
#[derive(Default)]
struct WiringWatch {
    wired: Mutex<BTreeMap<String, bool>>,
    most_at_once: Mutex<usize>,
}
impl Tap for WiringWatch {
    fn record(&self, topic: &str, _type_id: &str, _stamp: Timestamp, json: &[u8]) {
        if let Some(component) = topic.strip_suffix("/wiring") {
            let message: serde_json::Value = serde_json::from_slice(json).expect("the tap gets JSON");
            let to_motors = message["target"]["service"] == "navigationvelocity";
            let mut wired = self.wired.lock();
            wired.insert(component.to_string(), to_motors);
            let n = wired.values().filter(|w| **w).count();
            let mut most = self.most_at_once.lock();
            *most = (*most).max(n);
        }
    }
}

#[tokio::test(start_paused = true)]
async fn master_runs_goals_reports_them_and_never_wires_two_behaviours() {
    let clock = Clock::simulated();
    let registry = Registry::with_clock(clock);
    let watch = Arc::new(WiringWatch::default());
    registry.set_tap(Some(watch.clone()));
    let config = Config::from_toml(
        r#"
        [[system.components]]
        name = "nomad200"
        [[system.components]]
        name = "wallfollow"
        [[system.components]]
        name = "centerfollow"
        [[system.components]]
        name = "master"
        "#,
        "the test's config",
    )
    .expect("config");
    let stack = Stack::builder(&config, World::palazzina().expect("world"))
        .seed(11)
        .start_on(&registry)
        .await
        .expect("stack");
    let truth = stack.truth().expect("the simulator has a truth").clone();

    let goals = QueryClient::<Goal, GoalReply>::connect(&registry, executive::GOAL.on(executive::NAME))
        .expect("goal");
    let mut events =
        EventClient::<GoalFilter, GoalEvent>::connect(&registry, executive::GOALS.on(executive::NAME))
            .expect("events")
            .activate(EventMode::Continuous, GoalFilter::default())
            .expect("activate");
    let ask = |mode: &str, for_s: Option<f64>| Goal { mode: mode.into(), for_s };
    let timeout = Some(Duration::from_secs(5));

    let bad = goals.query(ask("dance", None), timeout).await.expect("answer");
    assert!(
        matches!(bad, GoalReply::Rejected { ref reason, switch: None } if reason.contains("dance")),
        "{bad:?}"
    );
    let bad = goals.query(ask("patrol", Some(1e20)), timeout).await.expect("answer");
    assert!(matches!(bad, GoalReply::Rejected { switch: None, .. }), "{bad:?}");

    let Ok(GoalReply::Accepted { id: patrol }) = goals.query(ask("patrol", None), timeout).await else {
        panic!("patrol refused")
    };
    let e = events.next().await.expect("event").event.value;
    assert_eq!((e.id, e.status), (patrol, GoalStatus::Started));
    tokio::time::sleep(Duration::from_secs(120)).await;
    assert!(truth.truth().travelled_m > 10.0, "patrolling moves the robot");

    let Ok(GoalReply::Accepted { id: wall }) =
        goals.query(ask("follow_left_wall", Some(30.0)), timeout).await
    else {
        panic!("follow_left_wall refused")
    };
    let e = events.next().await.expect("event").event.value;
    assert_eq!((e.id, e.status), (patrol, GoalStatus::Preempted));
    let e = events.next().await.expect("event").event.value;
    assert_eq!((e.id, e.status), (wall, GoalStatus::Started));
    let started = tokio::time::Instant::now();
    let e = events.next().await.expect("event").event.value;
    assert_eq!((e.id, e.status), (wall, GoalStatus::Reached));
    assert_eq!(started.elapsed(), Duration::from_secs(30), "reached exactly at its time");

    let Ok(GoalReply::Accepted { .. }) = goals.query(ask("stop", None), timeout).await else {
        panic!("stop refused")
    };
    tokio::time::sleep(Duration::from_secs(3)).await;
    let t = truth.truth();
    assert_eq!((t.v_m_s, t.omega_rad_s), (0.0, 0.0), "the stop mode stops the robot");
    assert!(watch.wired.lock().values().all(|w| !w), "nothing wired in the stop mode");
    assert_eq!(*watch.most_at_once.lock(), 1, "never two behaviours wired to the motors");
}
