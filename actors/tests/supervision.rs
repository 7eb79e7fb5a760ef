//! Supervision conformance: strategies, restart types, intensity and escalation, shutdown,
//! the child API, events, and a state-machine property test against a reference model of OTP.
//!
//! Every test runs on tokio's paused clock and waits on events through channels.

use orsa_actors::supervision::{
    ChildError, ChildSpec, GaveUp, Restart, Shutdown, StartError, Strategy, Supervisor, SupervisorEvent,
    SupervisorEventKind as Kind, SupervisorRef, SupervisorSpec,
};
use orsa_actors::{Clock, Timestamp};
use ractor::{Actor, ActorCell, ActorId, ActorProcessingErr, ActorRef, ActorStatus, SupervisionEvent};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};
use tokio::time::Instant;

// ---------------------------------------------------------------------------------------------
// Test actors and helpers

/// What a worker is told to do.
#[derive(Debug)]
enum Cmd {
    /// Return an error from the handler.
    Fail,
    /// Panic in the handler.
    Panic,
    /// Stop normally.
    Exit,
    /// Hang in the handler forever (ignoring any stop), after logging "hang <id>".
    Hang,
}

/// A worker that logs "start <id>" and "stop <id>" (from `post_stop`), and can be told to
/// refuse its next starts or to fail in `post_stop`.
#[derive(Clone, Default)]
struct Worker {
    id: &'static str,
    log: Option<UnboundedSender<String>>,
    refuse_starts: Option<Arc<AtomicU32>>,
    fail_in_post_stop: bool,
}

impl Worker {
    fn logging(id: &'static str, log: &UnboundedSender<String>) -> Self {
        Worker { id, log: Some(log.clone()), ..Worker::default() }
    }

    fn say(&self, what: &str) {
        if let Some(log) = &self.log {
            let _ = log.send(format!("{what} {}", self.id));
        }
    }
}

impl Actor for Worker {
    type Msg = Cmd;
    type State = ();
    type Arguments = ();

    async fn pre_start(&self, _: ActorRef<Cmd>, _: ()) -> Result<(), ActorProcessingErr> {
        if let Some(n) = &self.refuse_starts
            && n.fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1)).is_ok()
        {
            return Err("refusing to start".into());
        }
        self.say("start");
        Ok(())
    }

    async fn handle(&self, me: ActorRef<Cmd>, cmd: Cmd, _: &mut ()) -> Result<(), ActorProcessingErr> {
        match cmd {
            Cmd::Fail => Err("told to fail".into()),
            Cmd::Panic => panic!("told to panic"),
            Cmd::Exit => {
                me.stop(None);
                Ok(())
            }
            Cmd::Hang => {
                self.say("hang");
                std::future::pending::<()>().await;
                Ok(())
            }
        }
    }

    async fn post_stop(&self, _: ActorRef<Cmd>, _: &mut ()) -> Result<(), ActorProcessingErr> {
        self.say("stop");
        if self.fail_in_post_stop { Err("failing while stopping".into()) } else { Ok(()) }
    }
}

fn worker(id: &'static str) -> ChildSpec {
    ChildSpec::actor(id, Worker { id, ..Worker::default() }, || ())
}

fn logged(id: &'static str, log: &UnboundedSender<String>) -> ChildSpec {
    ChildSpec::actor(id, Worker::logging(id, log), || ())
}

/// What a probe parent saw of its linked child.
#[derive(Debug)]
enum Seen {
    Failed(ActorId, Option<GaveUp>),
    Terminated,
}

/// A parent that reports its children's exits (and never stops because of them).
struct Probe;

impl Actor for Probe {
    type Msg = ();
    type State = UnboundedSender<Seen>;
    type Arguments = UnboundedSender<Seen>;

    async fn pre_start(
        &self,
        _: ActorRef<()>,
        tx: UnboundedSender<Seen>,
    ) -> Result<UnboundedSender<Seen>, ActorProcessingErr> {
        Ok(tx)
    }

    async fn handle_supervisor_evt(
        &self,
        _: ActorRef<()>,
        event: SupervisionEvent,
        tx: &mut UnboundedSender<Seen>,
    ) -> Result<(), ActorProcessingErr> {
        let seen = match event {
            SupervisionEvent::ActorFailed(cell, err) => {
                Seen::Failed(cell.get_id(), err.downcast_ref::<GaveUp>().cloned())
            }
            SupervisionEvent::ActorTerminated(..) => Seen::Terminated,
            _ => return Ok(()),
        };
        let _ = tx.send(seen);
        Ok(())
    }
}

async fn probe() -> (ActorCell, UnboundedReceiver<Seen>) {
    let (tx, rx) = unbounded_channel();
    let (probe, _) = Actor::spawn(None, Probe, tx).await.expect("probe starts");
    (probe.get_cell(), rx)
}

/// An event sink that forwards into a channel.
fn event_channel() -> (impl Fn(SupervisorEvent) + Send + Sync + 'static, UnboundedReceiver<SupervisorEvent>) {
    let (tx, rx) = unbounded_channel();
    (move |e| drop(tx.send(e)), rx)
}

/// Receives the next item; an hour of simulated silence means it never comes.
async fn next<T>(rx: &mut UnboundedReceiver<T>) -> T {
    tokio::time::timeout(Duration::from_secs(3600), rx.recv())
        .await
        .expect("nothing arrived within a simulated hour")
        .expect("channel closed")
}

/// The next `n` events, as (supervisor, child, kind).
async fn events(rx: &mut UnboundedReceiver<SupervisorEvent>, n: usize) -> Vec<(String, String, Kind)> {
    let mut out = Vec::new();
    for _ in 0..n {
        let e = next(rx).await;
        out.push((e.supervisor, e.child, e.kind));
    }
    out
}

fn ev(sup: &str, child: &str, kind: Kind) -> (String, String, Kind) {
    (sup.to_string(), child.to_string(), kind)
}

/// The running instance of every child, in start order.
async fn ids(sup: &SupervisorRef) -> Vec<(String, Option<ActorId>)> {
    let children = sup.which_children().await.expect("which_children");
    children.into_iter().map(|c| (c.id, c.cell.map(|c| c.get_id()))).collect()
}

async fn cell(sup: &SupervisorRef, id: &str) -> ActorCell {
    sup.child(id).await.expect("which_children").expect("child is running")
}

async fn tell(sup: &SupervisorRef, id: &str, cmd: Cmd) {
    ActorRef::<Cmd>::from(cell(sup, id).await).cast(cmd).expect("cast");
}

fn drain<T>(rx: &mut UnboundedReceiver<T>) -> Vec<T> {
    let mut out = Vec::new();
    while let Ok(x) = rx.try_recv() {
        out.push(x);
    }
    out
}

fn spec(
    name: &str,
    strategy: Strategy,
    sink: impl Fn(SupervisorEvent) + Send + Sync + 'static,
) -> SupervisorSpec {
    SupervisorSpec::new(name, strategy).with_intensity(10, Duration::from_secs(10)).with_event_sink(sink)
}

// ---------------------------------------------------------------------------------------------
// Strategies

#[tokio::test(start_paused = true)]
async fn supervision_one_for_one_restarts_only_the_failed_child() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(worker("a"))
            .with_child(worker("b"))
            .with_child(worker("c")),
    )
    .await
    .expect("start");
    let before = ids(&sup).await;
    tell(&sup, "b", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "b", Kind::ChildFailed), ev("s", "b", Kind::Restarted)]);
    let after = ids(&sup).await;
    assert_eq!(after[0], before[0]);
    assert_ne!(after[1].1, before[1].1);
    assert!(after[1].1.is_some());
    assert_eq!(after[2], before[2]);
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_one_for_all_stops_in_reverse_and_restarts_all_in_order() {
    let (sink, mut rx) = event_channel();
    let (log, mut lines) = unbounded_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForAll, sink)
            .with_child(logged("a", &log))
            .with_child(logged("b", &log))
            .with_child(logged("c", &log)),
    )
    .await
    .expect("start");
    assert_eq!(drain(&mut lines), ["start a", "start b", "start c"]);
    let before = ids(&sup).await;
    tell(&sup, "b", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("s", "b", Kind::ChildFailed),
            ev("s", "a", Kind::Restarted),
            ev("s", "b", Kind::Restarted),
            ev("s", "c", Kind::Restarted)
        ]
    );
    // b failed (no post_stop); c and a were stopped in reverse order, then all started in order.
    assert_eq!(drain(&mut lines), ["stop c", "stop a", "start a", "start b", "start c"]);
    let after = ids(&sup).await;
    for (b, a) in before.iter().zip(&after) {
        assert_ne!(b.1, a.1, "{} was not restarted", b.0);
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_rest_for_one_restarts_the_failed_child_and_those_after_it() {
    let (sink, mut rx) = event_channel();
    let (log, mut lines) = unbounded_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::RestForOne, sink)
            .with_child(logged("a", &log))
            .with_child(logged("b", &log))
            .with_child(logged("c", &log))
            .with_child(logged("d", &log)),
    )
    .await
    .expect("start");
    drain(&mut lines);
    let before = ids(&sup).await;
    tell(&sup, "b", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("s", "b", Kind::ChildFailed),
            ev("s", "b", Kind::Restarted),
            ev("s", "c", Kind::Restarted),
            ev("s", "d", Kind::Restarted)
        ]
    );
    assert_eq!(drain(&mut lines), ["stop d", "stop c", "start b", "start c", "start d"]);
    let after = ids(&sup).await;
    assert_eq!(after[0], before[0], "a was started before b: untouched");
    for i in 1..4 {
        assert_ne!(after[i].1, before[i].1);
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_exit_of_a_replaced_instance_is_ignored() {
    // a and b fail together; a's restart (one-for-all) replaces b, whose own exit then
    // belongs to a former instance: one restart, not two.
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForAll, sink).with_child(worker("a")).with_child(worker("b")),
    )
    .await
    .expect("start");
    let (a, b) = (cell(&sup, "a").await, cell(&sup, "b").await);
    ActorRef::<Cmd>::from(a.clone()).cast(Cmd::Fail).expect("cast");
    ActorRef::<Cmd>::from(b.clone()).cast(Cmd::Fail).expect("cast");
    let first = next(&mut rx).await;
    assert_eq!(first.kind, Kind::ChildFailed);
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::Restarted), ev("s", "b", Kind::Restarted)]);
    let children = sup.which_children().await.expect("which_children");
    assert!(children.iter().all(|c| c.restart_count == 1 && c.cell.is_some()));
    assert!(drain(&mut rx).is_empty(), "the second exit caused nothing");
    let last = children.last().and_then(|c| c.cell.clone()).expect("b runs");
    assert_ne!(last.get_id(), b.get_id());
    sup.shutdown().await;
}

// ---------------------------------------------------------------------------------------------
// Restart types

#[tokio::test(start_paused = true)]
async fn supervision_permanent_child_is_restarted_after_exit_failure_panic_and_kill() {
    let (sink, mut rx) = event_channel();
    let sup =
        Supervisor::start(spec("s", Strategy::OneForOne, sink).with_child(worker("p"))).await.expect("start");
    let mut last = cell(&sup, "p").await.get_id();
    for (cmd, kind, reason) in [
        (Some(Cmd::Exit), Kind::ChildExited, "normal"),
        (Some(Cmd::Fail), Kind::ChildFailed, "told to fail"),
        (Some(Cmd::Panic), Kind::ChildFailed, "told to panic"),
        (None, Kind::ChildFailed, "killed"),
    ] {
        match cmd {
            Some(cmd) => tell(&sup, "p", cmd).await,
            None => cell(&sup, "p").await.kill(),
        }
        let exit = next(&mut rx).await;
        assert_eq!((exit.kind, exit.child.as_str()), (kind, "p"));
        assert!(exit.reason.contains(reason), "{}", exit.reason);
        assert_eq!(next(&mut rx).await.kind, Kind::Restarted);
        let now = cell(&sup, "p").await.get_id();
        assert_ne!(now, last);
        last = now;
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_transient_child_is_restarted_only_after_abnormal_exit() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink).with_child(worker("t").with_restart(Restart::Transient)),
    )
    .await
    .expect("start");
    tell(&sup, "t", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "t", Kind::ChildFailed), ev("s", "t", Kind::Restarted)]);
    cell(&sup, "t").await.kill();
    assert_eq!(events(&mut rx, 2).await, [ev("s", "t", Kind::ChildFailed), ev("s", "t", Kind::Restarted)]);
    tell(&sup, "t", Cmd::Exit).await;
    assert_eq!(events(&mut rx, 1).await, [ev("s", "t", Kind::ChildExited)]);
    let children = sup.which_children().await.expect("which_children");
    assert_eq!(children.len(), 1, "a transient child stays listed");
    assert!(children[0].cell.is_none(), "but is not restarted after a normal exit");
    assert_eq!(children[0].restart_count, 2);
    assert!(drain(&mut rx).is_empty());
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_temporary_child_is_never_restarted_and_leaves() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(worker("x").with_restart(Restart::Temporary))
            .with_child(worker("y").with_restart(Restart::Temporary))
            .with_child(worker("z").with_restart(Restart::Temporary)),
    )
    .await
    .expect("start");
    tell(&sup, "x", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 1).await, [ev("s", "x", Kind::ChildFailed)]);
    tell(&sup, "y", Cmd::Exit).await;
    assert_eq!(events(&mut rx, 1).await, [ev("s", "y", Kind::ChildExited)]);
    cell(&sup, "z").await.kill();
    assert_eq!(events(&mut rx, 1).await, [ev("s", "z", Kind::ChildFailed)]);
    assert!(sup.which_children().await.expect("which_children").is_empty());
    assert!(drain(&mut rx).is_empty());
    sup.shutdown().await;
}

// ---------------------------------------------------------------------------------------------
// Intensity and escalation

#[tokio::test(start_paused = true)]
async fn supervision_intensity_allows_n_restarts_and_the_next_one_fails_the_supervisor() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(3, Duration::from_secs(10))
            .with_child(worker("a"))
            .with_child(worker("b"))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    for n in 1..=3 {
        tell(&sup, "a", Cmd::Fail).await;
        assert_eq!(next(&mut rx).await.kind, Kind::ChildFailed);
        let restarted = next(&mut rx).await;
        assert_eq!(
            (restarted.kind, restarted.restart_count, restarted.restarts_in_period),
            (Kind::Restarted, n, n)
        );
        tokio::time::sleep(Duration::from_secs(3)).await; // 9 s in all: still within the period
    }
    let b = cell(&sup, "b").await;
    tell(&sup, "a", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::GaveUp)]);
    match next(&mut seen).await {
        Seen::Failed(id, Some(gave_up)) => {
            assert_eq!(id, sup.cell().get_id());
            assert_eq!(
                (gave_up.supervisor.as_str(), gave_up.child.as_str(), gave_up.intensity),
                ("s", "a", 3)
            );
        }
        other => panic!("expected the supervisor to fail with GaveUp, saw {other:?}"),
    }
    assert_eq!(b.get_status(), ActorStatus::Stopped, "children are stopped before escalating");
    assert!(drain(&mut rx).is_empty(), "no restart while giving up");
}

#[tokio::test(start_paused = true)]
async fn supervision_escalation_restarts_the_nested_supervisor_in_its_parent() {
    let (sink, mut rx) = event_channel();
    let inner = SupervisorSpec::new("inner", Strategy::OneForOne)
        .with_intensity(2, Duration::from_secs(5))
        .with_child(worker("w"));
    let top = Supervisor::start(
        SupervisorSpec::new("top", Strategy::OneForOne)
            .with_intensity(1, Duration::from_secs(60))
            .with_child(ChildSpec::supervisor("inner", inner))
            .with_child(worker("sibling"))
            .with_event_sink(sink),
    )
    .await
    .expect("start");
    let info = top.which_children().await.expect("which_children");
    let inner_ref = info[0].supervisor().expect("inner is a running supervisor");
    assert_eq!(inner_ref.name(), "inner");
    let sibling = info[1].cell.as_ref().map(|c| c.get_id());
    for _ in 0..2 {
        tell(&inner_ref, "w", Cmd::Fail).await;
        assert_eq!(
            events(&mut rx, 2).await,
            [ev("inner", "w", Kind::ChildFailed), ev("inner", "w", Kind::Restarted)]
        );
    }
    tell(&inner_ref, "w", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("inner", "w", Kind::ChildFailed),
            ev("inner", "w", Kind::GaveUp),
            ev("top", "inner", Kind::ChildFailed),
            ev("top", "inner", Kind::Restarted)
        ]
    );
    let info = top.which_children().await.expect("which_children");
    let new_inner = info[0].supervisor().expect("inner runs again");
    assert_ne!(new_inner.cell().get_id(), inner_ref.cell().get_id());
    assert_eq!(info[0].restart_count, 1);
    assert_eq!(info[1].cell.as_ref().map(|c| c.get_id()), sibling, "one-for-one: sibling untouched");
    let w = new_inner.which_children().await.expect("which_children");
    assert_eq!((w[0].restart_count, w[0].cell.is_some()), (0, true), "a fresh inner supervisor");
    top.shutdown().await;
    assert_eq!(new_inner.cell().get_status(), ActorStatus::Stopped);
}

#[tokio::test(start_paused = true)]
async fn supervision_restarts_spread_beyond_the_period_do_not_escalate() {
    let clock = Clock::start();
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(1, Duration::from_secs(5))
            .with_child(worker("a"))
            .with_clock(clock)
            .with_event_sink(sink),
    )
    .await
    .expect("start");
    for n in 1..=4u32 {
        tell(&sup, "a", Cmd::Fail).await;
        assert_eq!(next(&mut rx).await.kind, Kind::ChildFailed);
        let e = next(&mut rx).await;
        assert_eq!((e.kind, e.restart_count, e.restarts_in_period), (Kind::Restarted, n, 1));
        assert_eq!(e.at, Timestamp(u64::from(n - 1) * 5_001_000_000), "stamped with the given clock");
        // Just beyond the period (tokio's timer has millisecond resolution).
        tokio::time::sleep(Duration::from_millis(5001)).await;
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_a_restart_exactly_one_period_later_still_counts() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(1, Duration::from_secs(5))
            .with_child(worker("a"))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    tell(&sup, "a", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::Restarted)]);
    tokio::time::sleep(Duration::from_secs(5)).await;
    tell(&sup, "a", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::GaveUp)]);
    assert!(matches!(next(&mut seen).await, Seen::Failed(_, Some(_))));
}

#[tokio::test(start_paused = true)]
async fn supervision_zero_intensity_gives_up_on_the_first_restart() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForAll)
            .with_intensity(0, Duration::from_secs(5))
            .with_child(worker("a").with_restart(Restart::Transient))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    tell(&sup, "a", Cmd::Exit).await; // a transient normal exit is no restart
    assert_eq!(events(&mut rx, 1).await, [ev("s", "a", Kind::ChildExited)]);
    sup.restart_child("a").await.expect("restart_child");
    assert_eq!(events(&mut rx, 1).await, [ev("s", "a", Kind::Restarted)]);
    tell(&sup, "a", Cmd::Panic).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::GaveUp)]);
    assert!(matches!(next(&mut seen).await, Seen::Failed(_, Some(_))));
}

// ---------------------------------------------------------------------------------------------
// Start failures

#[tokio::test(start_paused = true)]
async fn supervision_start_failure_during_restart_is_retried_and_counted() {
    let (sink, mut rx) = event_channel();
    let refuse = Arc::new(AtomicU32::new(0));
    let flaky = Worker { id: "f", refuse_starts: Some(refuse.clone()), ..Worker::default() };
    let sup = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(3, Duration::from_secs(5))
            .with_child(ChildSpec::actor("f", flaky, || ()))
            .with_event_sink(sink),
    )
    .await
    .expect("start");
    refuse.store(2, Ordering::SeqCst);
    tell(&sup, "f", Cmd::Fail).await;
    let mut got = Vec::new();
    for _ in 0..4 {
        let e = next(&mut rx).await;
        got.push((e.kind, e.restarts_in_period));
    }
    assert_eq!(
        got,
        [(Kind::ChildFailed, 0), (Kind::StartFailed, 1), (Kind::StartFailed, 2), (Kind::Restarted, 3)]
    );
    assert!(sup.child("f").await.expect("which_children").is_some());
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_a_child_that_never_starts_again_exhausts_the_intensity() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let refuse = Arc::new(AtomicU32::new(0));
    let flaky = Worker { id: "f", refuse_starts: Some(refuse.clone()), ..Worker::default() };
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(2, Duration::from_secs(5))
            .with_child(ChildSpec::actor("f", flaky, || ()))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    refuse.store(u32::MAX, Ordering::SeqCst);
    tell(&sup, "f", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("s", "f", Kind::ChildFailed),
            ev("s", "f", Kind::StartFailed),
            ev("s", "f", Kind::StartFailed),
            ev("s", "f", Kind::GaveUp)
        ]
    );
    assert!(matches!(next(&mut seen).await, Seen::Failed(id, Some(_)) if id == sup.cell().get_id()));
}

#[tokio::test(start_paused = true)]
async fn supervision_initial_start_failure_stops_the_children_already_started() {
    let (log, mut lines) = unbounded_channel();
    let refusing = Worker { refuse_starts: Some(Arc::new(AtomicU32::new(1))), ..Worker::logging("b", &log) };
    let result = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_child(logged("a", &log))
            .with_child(ChildSpec::actor("b", refusing, || ()))
            .with_child(logged("c", &log)),
    )
    .await;
    match result {
        Err(StartError::ChildStart { supervisor, child, reason }) => {
            assert_eq!((supervisor.as_str(), child.as_str()), ("s", "b"));
            assert!(reason.contains("refusing to start"), "{reason}");
        }
        other => panic!("expected a child start error, got {other:?}"),
    }
    assert_eq!(drain(&mut lines), ["start a", "stop a"]);
    let dup = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne).with_child(worker("a")).with_child(worker("a")),
    )
    .await;
    assert!(matches!(dup, Err(StartError::DuplicateChild { child, .. }) if child == "a"));
}

// ---------------------------------------------------------------------------------------------
// Shutdown

#[tokio::test(start_paused = true)]
async fn supervision_child_ignoring_shutdown_is_killed_after_its_timeout() {
    let (log, mut lines) = unbounded_channel();
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(logged("h", &log).with_shutdown(Shutdown::Timeout(Duration::from_millis(2500)))),
    )
    .await
    .expect("start");
    let h = cell(&sup, "h").await;
    tell(&sup, "h", Cmd::Hang).await;
    assert_eq!(next(&mut lines).await, "start h");
    assert_eq!(next(&mut lines).await, "hang h");
    let t0 = Instant::now();
    sup.terminate_child("h").await.expect("terminate_child");
    assert_eq!(t0.elapsed(), Duration::from_millis(2500));
    assert_eq!(h.get_status(), ActorStatus::Stopped);
    assert!(drain(&mut lines).is_empty(), "killed: post_stop never ran");
    assert!(sup.child("h").await.expect("which_children").is_none(), "terminated, not restarted");
    assert!(drain(&mut rx).is_empty());
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_shutdown_stops_children_in_reverse_order_honouring_their_shutdown() {
    let (log, mut lines) = unbounded_channel();
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(logged("a", &log))
            .with_child(logged("b", &log).with_shutdown(Shutdown::Timeout(Duration::from_secs(3))))
            .with_child(logged("c", &log).with_shutdown(Shutdown::Brutal))
            .with_child(logged("d", &log)),
    )
    .await
    .expect("start");
    tell(&sup, "b", Cmd::Hang).await;
    let mut seen = Vec::new();
    for _ in 0..5 {
        seen.push(next(&mut lines).await);
    }
    assert_eq!(seen, ["start a", "start b", "start c", "start d", "hang b"]);
    let children: Vec<ActorCell> =
        sup.which_children().await.expect("which_children").into_iter().filter_map(|c| c.cell).collect();
    let t0 = Instant::now();
    sup.shutdown().await;
    assert_eq!(t0.elapsed(), Duration::from_secs(3), "only b's timeout was waited for");
    // d stops gracefully, c is killed (no post_stop), b is killed after 3 s, a stops.
    assert_eq!(drain(&mut lines), ["stop d", "stop a"]);
    assert!(children.iter().all(|c| c.get_status() == ActorStatus::Stopped));
    assert_eq!(sup.cell().get_status(), ActorStatus::Stopped);
    assert!(drain(&mut rx).is_empty(), "no exits reported, no restarts while shutting down");
}

#[tokio::test(start_paused = true)]
async fn supervision_failures_while_shutting_down_cause_no_restart() {
    let (sink, mut rx) = event_channel();
    let failing = Worker { id: "f", fail_in_post_stop: true, ..Worker::default() };
    let sup = Supervisor::start(
        spec("s", Strategy::OneForAll, sink).with_child(worker("a")).with_child(ChildSpec::actor(
            "f",
            failing,
            || (),
        )),
    )
    .await
    .expect("start");
    let children: Vec<ActorCell> =
        sup.which_children().await.expect("which_children").into_iter().filter_map(|c| c.cell).collect();
    sup.shutdown().await;
    assert!(children.iter().all(|c| c.get_status() == ActorStatus::Stopped));
    assert!(drain(&mut rx).is_empty(), "f's failure in post_stop restarted nothing");
}

// ---------------------------------------------------------------------------------------------
// The child API

#[tokio::test(start_paused = true)]
async fn supervision_which_children_terminate_restart_delete_and_start_child() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(worker("a"))
            .with_child(worker("b").with_restart(Restart::Transient))
            .with_child(worker("c").with_restart(Restart::Temporary).with_shutdown(Shutdown::Brutal)),
    )
    .await
    .expect("start");
    let info = sup.which_children().await.expect("which_children");
    let summary: Vec<_> =
        info.iter().map(|c| (c.id.as_str(), c.restart, c.restart_count, c.cell.is_some())).collect();
    assert_eq!(
        summary,
        [
            ("a", Restart::Permanent, 0, true),
            ("b", Restart::Transient, 0, true),
            ("c", Restart::Temporary, 0, true)
        ]
    );
    assert_eq!(info[2].shutdown, Shutdown::Brutal);
    assert!(info[0].supervisor().is_none());

    let b = cell(&sup, "b").await;
    sup.terminate_child("b").await.expect("terminate_child");
    assert_eq!(b.get_status(), ActorStatus::Stopped);
    assert!(sup.child("b").await.expect("which_children").is_none());
    assert!(matches!(sup.delete_child("a").await, Err(ChildError::Running { .. })));
    assert!(matches!(sup.restart_child("a").await, Err(ChildError::Running { .. })));

    let b2 = sup.restart_child("b").await.expect("restart_child");
    assert_ne!(b2.get_id(), b.get_id());
    let e = next(&mut rx).await;
    assert_eq!(
        (e.child.as_str(), e.kind, e.restart_count, e.reason.as_str()),
        ("b", Kind::Restarted, 1, "restart_child")
    );

    sup.terminate_child("c").await.expect("terminate_child");
    sup.terminate_child("b").await.expect("terminate_child");
    sup.delete_child("b").await.expect("delete_child");
    assert_eq!(ids(&sup).await.len(), 1, "c (temporary) left when terminated, b was deleted");
    assert!(matches!(sup.restart_child("b").await, Err(ChildError::NotFound { .. })));
    assert!(matches!(sup.terminate_child("zz").await, Err(ChildError::NotFound { .. })));

    let d = sup.start_child(worker("d")).await.expect("start_child");
    assert_eq!(sup.child("d").await.expect("which_children").map(|c| c.get_id()), Some(d.get_id()));
    assert!(matches!(sup.start_child(worker("a")).await, Err(ChildError::AlreadyPresent { .. })));
    let refusing = Worker { refuse_starts: Some(Arc::new(AtomicU32::new(1))), ..Worker::default() };
    assert!(matches!(
        sup.start_child(ChildSpec::actor("e", refusing, || ())).await,
        Err(ChildError::Start { .. })
    ));
    let order: Vec<_> = ids(&sup).await.into_iter().map(|(id, _)| id).collect();
    assert_eq!(order, ["a", "d"]);
    assert!(drain(&mut rx).is_empty(), "terminations by request are not exits");

    sup.shutdown().await;
    assert!(matches!(sup.which_children().await, Err(ChildError::Unreachable { .. })));
}

// ---------------------------------------------------------------------------------------------
// State-machine property test against a reference model of OTP supervision

mod model {
    use super::*;
    use proptest::prelude::{Just, prop_oneof};
    use proptest::strategy::Strategy as _;

    #[derive(Debug, Clone)]
    pub(super) enum Op {
        Fail(usize),
        Exit(usize),
        Kill(usize),
        Advance(u64),
    }

    #[derive(Debug, Clone)]
    pub(super) struct Case {
        strategy: Strategy,
        restarts: Vec<Restart>,
        intensity: u32,
        period_ms: u64,
        ops: Vec<Op>,
    }

    fn strategy() -> impl proptest::strategy::Strategy<Value = Strategy> {
        prop_oneof![Just(Strategy::OneForOne), Just(Strategy::OneForAll), Just(Strategy::RestForOne)]
    }

    fn restart() -> impl proptest::strategy::Strategy<Value = Restart> {
        prop_oneof![Just(Restart::Permanent), Just(Restart::Transient), Just(Restart::Temporary)]
    }

    fn op(n: usize) -> impl proptest::strategy::Strategy<Value = Op> {
        prop_oneof![
            3 => (0..n).prop_map(Op::Fail),
            2 => (0..n).prop_map(Op::Exit),
            2 => (0..n).prop_map(Op::Kill),
            // Multiples of 500 ms like the period, so that restarts land exactly one period
            // apart too.
            4 => (1u64..=6).prop_map(|k| Op::Advance(k * 500)),
        ]
    }

    pub(super) fn case() -> impl proptest::strategy::Strategy<Value = Case> {
        (1usize..=4).prop_flat_map(|n| {
            (
                strategy(),
                proptest::collection::vec(restart(), n),
                0u32..=4,
                (1u64..=4).prop_map(|k| k * 500),
                proptest::collection::vec(op(n), 1..48),
            )
                .prop_map(|(strategy, restarts, intensity, period_ms, ops)| Case {
                    strategy,
                    restarts,
                    intensity,
                    period_ms,
                    ops,
                })
        })
    }

    /// OTP's supervisor, reduced to what the operations can observe.
    struct Otp {
        strategy: Strategy,
        intensity: usize,
        period_ms: u64,
        now_ms: u64,
        restarts: Vec<u64>,
        /// (child index, restart type, running, restart count), in start order.
        children: Vec<(usize, Restart, bool, u32)>,
        escalated: bool,
    }

    impl Otp {
        fn exit(&mut self, child: usize, abnormal: bool) {
            let Some(p) = self.children.iter().position(|c| c.0 == child) else { return };
            self.children[p].2 = false;
            match self.children[p].1 {
                Restart::Temporary => {
                    self.children.remove(p);
                }
                Restart::Transient if !abnormal => {}
                _ => self.restart(p),
            }
        }

        fn restart(&mut self, p: usize) {
            let now = self.now_ms;
            self.restarts.retain(|&t| now - t <= self.period_ms);
            self.restarts.push(now);
            if self.restarts.len() > self.intensity {
                self.escalated = true;
                self.children.iter_mut().for_each(|c| c.2 = false);
                return;
            }
            let range = match self.strategy {
                Strategy::OneForOne => p..p + 1,
                Strategy::OneForAll => 0..self.children.len(),
                Strategy::RestForOne => p..self.children.len(),
            };
            let affected: Vec<usize> = self.children[range].iter().map(|c| c.0).collect();
            self.children.retain(|c| !(c.1 == Restart::Temporary && affected.contains(&c.0)));
            for c in self.children.iter_mut().filter(|c| affected.contains(&c.0)) {
                c.2 = true;
                c.3 += 1;
            }
        }
    }

    macro_rules! ensure {
        ($cond:expr, $($msg:tt)+) => {
            if !$cond {
                return Err(format!($($msg)+));
            }
        };
    }

    pub(super) async fn run(case: Case) -> Result<(), String> {
        let names: Vec<String> = (0..case.restarts.len()).map(|i| format!("c{i}")).collect();
        let mut spec = SupervisorSpec::new("prop", case.strategy)
            .with_intensity(case.intensity, Duration::from_millis(case.period_ms));
        for (i, r) in case.restarts.iter().enumerate() {
            let shutdown =
                if i % 2 == 0 { Shutdown::Brutal } else { Shutdown::Timeout(Duration::from_secs(1)) };
            let child = ChildSpec::actor(names[i].clone(), Worker::default(), || ());
            spec = spec.with_child(child.with_restart(*r).with_shutdown(shutdown));
        }
        let (parent, mut seen) = probe().await;
        let sup = Supervisor::start_linked(spec, parent).await.map_err(|e| e.to_string())?;
        let mut otp = Otp {
            strategy: case.strategy,
            intensity: case.intensity as usize,
            period_ms: case.period_ms,
            now_ms: 0,
            restarts: Vec::new(),
            children: case.restarts.iter().enumerate().map(|(i, r)| (i, *r, true, 0)).collect(),
            escalated: false,
        };
        // The instance of each child that ran after the previous step, by child index.
        let mut cells: Vec<Option<ActorCell>> = Vec::new();
        let mut counts: Vec<u32> = vec![0; names.len()];
        let snapshot = |children: Vec<orsa_actors::supervision::ChildInfo>| {
            let mut out: Vec<(usize, Option<ActorCell>, u32)> = Vec::new();
            for c in children {
                let i = names.iter().position(|n| *n == c.id).unwrap_or(usize::MAX);
                out.push((i, c.cell, c.restart_count));
            }
            out
        };
        let first = snapshot(sup.which_children().await.map_err(|e| e.to_string())?);
        cells.resize(names.len(), None);
        for (i, cell, _) in first {
            cells[i] = cell;
        }
        for (step, op) in case.ops.iter().enumerate() {
            let (child, abnormal) = match *op {
                Op::Advance(ms) => {
                    tokio::time::sleep(Duration::from_millis(ms)).await;
                    otp.now_ms += ms;
                    continue;
                }
                Op::Fail(i) | Op::Kill(i) => (i, true),
                Op::Exit(i) => (i, false),
            };
            let Some(target) = cells[child].clone() else { continue };
            match op {
                Op::Fail(_) => {
                    ActorRef::<Cmd>::from(target.clone()).cast(Cmd::Fail).map_err(|e| e.to_string())?
                }
                Op::Exit(_) => target.stop(None),
                _ => target.kill(),
            }
            // Once the child has stopped, its exit event is in the supervisor's queue, which
            // the supervisor serves before the request below.
            let _ = target.wait(None).await;
            otp.exit(child, abnormal);
            match sup.which_children().await {
                Ok(children) => {
                    ensure!(
                        !otp.escalated,
                        "step {step} {op:?}: the model escalates, the supervisor did not"
                    );
                    let real = snapshot(children);
                    let order: Vec<usize> = real.iter().map(|c| c.0).collect();
                    let expected: Vec<usize> = otp.children.iter().map(|c| c.0).collect();
                    ensure!(order == expected, "step {step} {op:?}: children {order:?}, model {expected:?}");
                    for ((i, cell, count), m) in real.into_iter().zip(&otp.children) {
                        ensure!(cell.is_some() == m.2, "step {step} {op:?}: c{i} running {}", cell.is_some());
                        ensure!(
                            count == m.3,
                            "step {step} {op:?}: c{i} restarted {count} times, model {}",
                            m.3
                        );
                        let restarted = count != counts[i];
                        let replaced =
                            cell.as_ref().map(|c| c.get_id()) != cells[i].as_ref().map(|c| c.get_id());
                        ensure!(
                            !m.2 || restarted == replaced,
                            "step {step} {op:?}: c{i} restarted: {restarted}, instance replaced: {replaced}"
                        );
                        counts[i] = count;
                        cells[i] = cell;
                    }
                    for (i, cell) in cells.iter_mut().enumerate() {
                        if !otp.children.iter().any(|c| c.0 == i) {
                            *cell = None;
                        }
                    }
                }
                Err(_) => {
                    ensure!(otp.escalated, "step {step} {op:?}: the supervisor failed, the model did not");
                    let failed = next(&mut seen).await;
                    ensure!(
                        matches!(&failed, Seen::Failed(id, Some(_)) if *id == sup.cell().get_id()),
                        "expected the supervisor to escalate, the parent saw {failed:?}"
                    );
                    for c in cells.iter().flatten() {
                        ensure!(c.get_status() == ActorStatus::Stopped, "a child outlived its supervisor");
                    }
                    return Ok(());
                }
            }
        }
        sup.shutdown().await;
        Ok(())
    }
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: 256,
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    })]

    #[test]
    fn supervision_matches_the_otp_reference_model(case in model::case()) {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .start_paused(true)
            .build()
            .expect("runtime");
        let result = rt.block_on(model::run(case));
        proptest::prop_assert!(result.is_ok(), "{}", result.err().unwrap_or_default());
    }
}
