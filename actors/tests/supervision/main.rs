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

mod child_api;
mod intensity;
mod model_check;
mod restart_types;
mod shutdown;
mod start_failures;
mod strategies;
