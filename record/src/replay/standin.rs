//! The robot server's stand-in in a replay: it serves the robot's interface, and publishes and
//! answers what the recording says the robot published and answered, at the recorded times.
//!
//! It declares the same services as the robot server (`orsa_interfaces::nomad200`), so the
//! replayed components connect, subscribe and wire to it exactly as they did to the robot. Its
//! push services never tick: an activity publishes each recorded scan when the paused clock
//! reaches its log time, in the recorded order, and tests the `contact` event on the recorded
//! bumpers as the server does. Commands sent to it are taken and dropped: the replay has
//! already seen them, where they entered the pattern.

use super::file::{Answers, Published};
use orsa_actors::event::EventServer;
use orsa_actors::param::{PARAM, ParamRequest};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::push_timed::{PushTimedServer, Tick};
use orsa_actors::query::{QueryClient, QueryRequest};
use orsa_actors::{Component, ComponentError, Ctx, Empty, Registry, Stamped, Timestamp};
use orsa_hardware::server::{ServerParams, contact_fires, health_fires};
use orsa_interfaces::health::{self, Health};
use orsa_interfaces::nomad200::{
    self, BaseState, ContactScan, DistanceScan, NavigationVelocity, RobotParams, SafetyCounters,
};
use parking_lot::Mutex;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

/// What the stand-in plays back.
#[derive(Debug, Default)]
pub struct Playback {
    /// What the robot published, at its log time (ns), in order.
    pub published: Vec<(u64, Published)>,
    /// The robot's recorded answers, taken as requests come.
    pub answers: Mutex<Answers>,
    /// How far the publication has gone (a restarted stand-in goes on from here).
    pub cursor: AtomicUsize,
    /// Requests to the replayed components' parameters from outside them, at their log time
    /// (ns), in order: (time, publications before it, component, request).
    pub requests: Vec<(u64, usize, String, ParamRequest)>,
    /// How many of them were made.
    pub asked: AtomicUsize,
    /// The order between the publications and the controls fed from outside the stand-in
    /// (`None`: no such controls, or nothing to keep in order with them).
    pub order: Option<Order>,
}

/// Keeps the recorded order between the robot's publications and the controls fed from
/// outside (wiring and state changes, what the link watchdog did) in a replay.
///
/// Each side sleeps until its next item's log time, but tokio's timer wakes on whole
/// milliseconds: a state change recorded 0.6 ms before a scan would wake on the same tick as
/// the scan and could go after it, and the behaviour would not step on that scan as it had.
/// So the stand-in does not publish a scan before every control recorded before it is applied,
/// and a control is not applied before every scan recorded before it is out.
#[derive(Debug, Default)]
pub struct Order {
    /// For each control, in order: the publications recorded before it.
    pub controls_after: Vec<usize>,
    /// Controls applied so far.
    pub applied: AtomicUsize,
    /// Woken when a control is applied or a publication goes out.
    pub moved: tokio::sync::Notify,
    /// Called before each publication and right after it goes out, before anything it sets
    /// going runs (a live replay applies there the controls whose place it is).
    pub on_publish: Hook,
}

/// A function called where something happens; none until it is set.
#[derive(Default)]
pub struct Hook(std::sync::OnceLock<Box<dyn Fn() + Send + Sync>>);

impl Hook {
    /// Sets the function (once: later calls change nothing).
    pub fn set(&self, f: impl Fn() + Send + Sync + 'static) {
        let _ = self.0.set(Box::new(f));
    }

    /// Calls it, if it is set.
    pub fn call(&self) {
        if let Some(f) = self.0.get() {
            f();
        }
    }
}

impl std::fmt::Debug for Hook {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.get().is_some() { "Hook(set)" } else { "Hook(none)" })
    }
}

impl Order {
    /// Waits until `ready` holds, checking again whenever the other side moves.
    pub async fn until(&self, ready: impl Fn() -> bool) {
        loop {
            let moved = self.moved.notified();
            if ready() {
                return;
            }
            moved.await;
        }
    }

    /// Notes that control `j` has been applied.
    pub fn applied(&self, j: usize) {
        self.applied.store(j + 1, Ordering::SeqCst);
        self.moved.notify_waiters();
    }
}

/// The stand-in component.
pub struct RecordedRobot {
    /// The robot server's parameters (its push periods: the services are declared with them).
    pub params: ServerParams,
    /// What to play back.
    pub playback: Arc<Playback>,
}

/// The stand-in's messages.
#[derive(Debug)]
pub enum StandInMsg {
    /// A push service's timer (never started).
    Tick(Tick),
    /// A command on `navigationvelocity` or `teleop`.
    Velocity(Stamped<NavigationVelocity>),
    /// A request for the robot's parameters.
    Params(QueryRequest<Empty, RobotParams>),
    /// A request for the safety counters.
    Safety(QueryRequest<Empty, SafetyCounters>),
}

/// The stand-in's services.
#[derive(Clone)]
struct Servers {
    ir: PushTimedServer<DistanceScan>,
    sonar: PushTimedServer<DistanceScan>,
    bumpers: PushTimedServer<ContactScan>,
    base: PushTimedServer<BaseState>,
    contact: EventServer<Empty, ContactScan, ContactScan>,
    health: PushNewestServer<Health>,
    health_changes: EventServer<Empty, Health, Health>,
}

impl Component for RecordedRobot {
    type Msg = StandInMsg;
    type State = ();

    async fn setup(&self, ctx: &Ctx<StandInMsg>) -> Result<(), ComponentError> {
        let p = &self.params;
        let secs = Duration::from_secs_f64;
        let servers = Servers {
            ir: ctx.push_timed_server(nomad200::DISTANCEIR, secs(p.distanceir_period_s), StandInMsg::Tick)?,
            sonar: ctx.push_timed_server(
                nomad200::DISTANCESON,
                secs(p.distanceson_period_s),
                StandInMsg::Tick,
            )?,
            bumpers: ctx.push_timed_server(nomad200::BUMPERS, secs(p.bumpers_period_s), StandInMsg::Tick)?,
            base: ctx.push_timed_server(nomad200::BASESTATE, secs(p.basestate_period_s), StandInMsg::Tick)?,
            contact: ctx.event_server(nomad200::CONTACT, contact_fires)?,
            health: ctx.push_newest_server(health::HEALTH)?,
            health_changes: ctx.event_server(health::HEALTH_CHANGES, health_fires)?,
        };
        ctx.send_server(nomad200::NAVIGATIONVELOCITY, StandInMsg::Velocity)?;
        ctx.send_server(nomad200::TELEOP, StandInMsg::Velocity)?;
        ctx.query_server(nomad200::ROBOTPARAMS, StandInMsg::Params)?;
        ctx.query_server(nomad200::SAFETY, StandInMsg::Safety)?;
        ctx.spawn_activity(play(ctx.registry().clone(), servers, Arc::clone(&self.playback)));
        Ok(())
    }

    async fn handle(&self, ctx: &Ctx<StandInMsg>, _: &mut (), msg: StandInMsg) -> Result<(), ComponentError> {
        match msg {
            StandInMsg::Tick(_) | StandInMsg::Velocity(_) => {}
            StandInMsg::Params(q) => match self.playback.answers.lock().robotparams.pop_front() {
                Some(answer) => {
                    let _ = q.answer(answer);
                }
                None => tracing::warn!(
                    "replay: {} was asked for its parameters more often than recorded",
                    ctx.name()
                ),
            },
            StandInMsg::Safety(q) => match self.playback.answers.lock().safety.pop_front() {
                Some(answer) => {
                    let _ = q.answer(answer);
                }
                None => tracing::warn!(
                    "replay: {} was asked for its safety counters more often than recorded",
                    ctx.name()
                ),
            },
        }
        Ok(())
    }
}

/// Publishes every recorded scan at its log time. Scans of one instant go out together, with
/// nothing else running in between (but a control recorded among them, see [`Order`]), as the
/// robot server published them one handler after the other. Requests to parameters are made among them in the recorded order: a set recorded
/// after a scan of the same instant reaches its component after that scan, as it did.
async fn play(registry: Registry, servers: Servers, playback: Arc<Playback>) {
    let clock = registry.clock();
    let mut last_health: Option<Health> = None;
    loop {
        let first = playback.cursor.load(Ordering::SeqCst);
        let asked = playback.asked.load(Ordering::SeqCst);
        let next_published = playback.published.get(first).map(|p| p.0);
        let next_asked = playback.requests.get(asked).map(|r| r.0);
        let at = match (next_published, next_asked) {
            (Some(p), Some(a)) => p.min(a),
            (Some(t), None) | (None, Some(t)) => t,
            (None, None) => return,
        };
        tokio::time::sleep_until(clock.instant_of(Timestamp(at))).await;
        let mut i = first;
        loop {
            let j = playback.asked.load(Ordering::SeqCst);
            if let Some((_, _, component, request)) =
                playback.requests.get(j).filter(|(t, after, _, _)| *t == at && *after <= i)
            {
                ask(&registry, component, request.clone());
                playback.asked.store(j + 1, Ordering::SeqCst);
                continue;
            }
            let Some((_, p)) = playback.published.get(i).filter(|(t, _)| *t == at) else { break };
            if let Some(order) = &playback.order {
                // Every control recorded before this publication first.
                order.on_publish.call();
                let before = order.controls_after.partition_point(|&after| after <= i);
                order.until(|| order.applied.load(Ordering::SeqCst) >= before).await;
            }
            match p {
                Published::Ir(scan) => {
                    servers.ir.put(scan.clone());
                }
                Published::Sonar(scan) => {
                    servers.sonar.put(scan.clone());
                }
                Published::Bumpers(scan) => {
                    servers.contact.put(scan);
                    servers.bumpers.put(scan.clone());
                }
                Published::Base(state) => {
                    servers.base.put(*state);
                }
                Published::Health(h) => {
                    // The server pushes its health every second and fires it on a change.
                    if last_health.as_ref().is_none_or(|l: &Health| l.sensors != h.sensors) {
                        servers.health_changes.put(h);
                        last_health = Some(h.clone());
                    }
                    servers.health.put(h.clone());
                }
            }
            i += 1;
            playback.cursor.store(i, Ordering::SeqCst);
            if let Some(order) = &playback.order {
                order.moved.notify_waiters();
                order.on_publish.call();
            }
        }
        playback.cursor.store(i, Ordering::SeqCst);
    }
}

/// Asks `component` what was asked of it; its answer and the change it makes are compared
/// with the recording, where the tap sees them.
pub(crate) fn ask(registry: &Registry, component: &str, request: ParamRequest) {
    match QueryClient::connect(registry, PARAM.on(component)) {
        Ok(client) => match client.request(request) {
            Ok(pending) => drop(tokio::spawn(async move { pending.receive(None).await })),
            Err(e) => tracing::warn!("replay: cannot ask {component} as recorded: {e}"),
        },
        Err(e) => tracing::warn!("replay: cannot ask {component} as recorded: {e}"),
    }
}
