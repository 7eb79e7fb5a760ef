//! A program's own observer attached to a run ([`RunOptions::observe`]) is told of the run's
//! steps in order: the stack up, a tick every sampling period, the supervisors' events (here a
//! behaviour the fault plan kills, and its restart), the loop's end and the outcome, and its
//! tap sees the messages and the events as they happen. Attaching one changes nothing.

use orsa::config::Config;
use orsa::faults::{FaultPlan, PlanTargets};
use orsa::mission::{self, RunObserver, RunOptions, RunOutcome, RunTap, Tick, stack::Stack};
use orsa_actors::Timestamp;
use orsa_actors::supervision::{SupervisorEvent, SupervisorEventKind};
use orsa_actors::tap::Tap;
use orsa_hardware::world::World;
use parking_lot::Mutex;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Wall following is killed once, 2 s in.
const KILL_WALLFOLLOW: &str = r#"
[[fault]]
at = 2.0
kind = "kill"
target = "wallfollow"
"#;

/// Everything the observer was told, in order.
#[derive(Debug, PartialEq)]
enum Seen {
    Start { components: usize },
    Tick { k: u64, t_s: f64, elapsed: Duration },
    Event { child: String, kind: SupervisorEventKind },
    Stop { at_s: f64 },
    End { events: usize, has_faults_report: bool },
}

/// Counts what the tap saw.
#[derive(Default)]
struct Counting {
    messages: AtomicU64,
    events: AtomicU64,
}

impl Tap for Counting {
    fn record(&self, _topic: &str, _type_id: &str, _stamp: Timestamp, _json: &[u8]) {
        self.messages.fetch_add(1, Ordering::Relaxed);
    }
}

impl RunTap for Counting {
    fn supervisor_event(&self, _e: &SupervisorEvent) {
        self.events.fetch_add(1, Ordering::Relaxed);
    }
}

struct Watcher {
    seen: Arc<Mutex<Vec<Seen>>>,
    tap: Arc<Counting>,
    started: Option<tokio::time::Instant>,
}

impl RunObserver for Watcher {
    fn tap(&self) -> Option<Arc<dyn RunTap>> {
        Some(self.tap.clone())
    }

    fn on_start(&mut self, stack: &Stack) {
        self.started = Some(tokio::time::Instant::now());
        self.seen.lock().push(Seen::Start { components: stack.registry.components().len() });
    }

    fn on_tick(&mut self, tick: &Tick<'_>) {
        let elapsed = self.started.expect("started before the first tick").elapsed();
        self.seen.lock().push(Seen::Tick { k: tick.k, t_s: tick.t_s, elapsed });
    }

    fn on_supervisor_event(&mut self, e: &SupervisorEvent) {
        self.seen.lock().push(Seen::Event { child: e.child.clone(), kind: e.kind });
    }

    fn on_stop(&mut self, _stack: &Stack, at_s: f64) {
        self.seen.lock().push(Seen::Stop { at_s });
    }

    fn on_end(&mut self, outcome: &mut RunOutcome) {
        self.seen.lock().push(Seen::End {
            events: outcome.supervisor_events.len(),
            has_faults_report: outcome.report.faults.is_some(),
        });
    }
}

fn options(duration_s: f64) -> RunOptions {
    let config = Config::default();
    let targets = PlanTargets::for_stack(&config);
    let mut o = RunOptions::new(World::palazzina().expect("world"), "palazzina", config, 1, duration_s);
    o.faults = Some(FaultPlan::parse(KILL_WALLFOLLOW, "the test's plan", &targets).expect("plan"));
    o
}

#[tokio::test(start_paused = true)]
async fn a_users_observer_is_told_of_every_step_of_a_run() {
    let seen = Arc::new(Mutex::new(Vec::new()));
    let tap = Arc::new(Counting::default());
    let watcher = Watcher { seen: seen.clone(), tap: tap.clone(), started: None };
    let out = mission::run(options(5.0).observe(watcher)).await.expect("the run");
    let seen = std::mem::take(&mut *seen.lock());

    // The stack was up when it started.
    let Some(Seen::Start { components }) = seen.first() else { panic!("first {:?}", seen.first()) };
    assert!(*components >= 5, "{components} components at the start");

    // A tick every 100 ms of the paused clock, 50 in 5 s, numbered from 1.
    let ticks: Vec<_> = seen
        .iter()
        .filter_map(|s| match s {
            Seen::Tick { k, t_s, elapsed } => Some((*k, *t_s, *elapsed)),
            _ => None,
        })
        .collect();
    assert_eq!(ticks.len(), 50);
    for (i, (k, t_s, elapsed)) in ticks.iter().enumerate() {
        assert_eq!(*k, i as u64 + 1);
        assert!((t_s - *k as f64 * 0.1).abs() < 1e-9, "tick {k} at {t_s} s");
        assert_eq!(*elapsed, Duration::from_millis(100 * k), "tick {k}");
    }

    // Wall following killed at 2 s, and restarted, told at the first tick after it.
    let at = |want: &dyn Fn(&Seen) -> bool| seen.iter().position(want).expect("seen");
    let failed = at(
        &|s| matches!(s, Seen::Event { child, kind: SupervisorEventKind::ChildFailed } if child == "wallfollow"),
    );
    let restarted = at(
        &|s| matches!(s, Seen::Event { child, kind: SupervisorEventKind::Restarted } if child == "wallfollow"),
    );
    assert!(failed < restarted);
    let ticks_before = seen[..failed].iter().filter(|s| matches!(s, Seen::Tick { .. })).count();
    assert!((20..=21).contains(&ticks_before), "the kill at 2 s told after {ticks_before} ticks");

    // The loop stopped at the end of the duration, after the last tick; then the end, last,
    // after the built-in fault plan's report was made; and every event was told.
    let stop = at(&|s| matches!(s, Seen::Stop { .. }));
    assert_eq!(seen[stop], Seen::Stop { at_s: 5.0 });
    assert!(
        matches!(seen[stop - 1], Seen::Tick { k: 50, .. }) || matches!(seen[stop - 1], Seen::Event { .. })
    );
    let events = out.supervisor_events.len();
    assert_eq!(seen.last(), Some(&Seen::End { events, has_faults_report: true }));
    assert_eq!(seen.iter().filter(|s| matches!(s, Seen::Event { .. })).count(), events);

    // The tap saw the messages, and each event as it happened.
    assert!(tap.messages.load(Ordering::Relaxed) > 100);
    assert_eq!(tap.events.load(Ordering::Relaxed), events as u64);
}

#[tokio::test(start_paused = true)]
async fn an_observer_that_only_watches_changes_nothing() {
    let seen = Arc::new(Mutex::new(Vec::new()));
    let watcher = Watcher { seen, tap: Arc::default(), started: None };
    let watched = mission::run(options(5.0).observe(watcher)).await.expect("the run");
    let alone = mission::run(options(5.0)).await.expect("the run");
    assert_eq!(watched.metrics.trajectory, alone.metrics.trajectory);
    assert_eq!(watched.metrics.distance_m, alone.metrics.distance_m);
    assert_eq!(watched.report.restarts, alone.report.restarts);
    assert!(watched.report.restarts >= 1, "the kill restarted wall following");
}
