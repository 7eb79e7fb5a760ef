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
use orsa_actors::push_timed::{PushTimedServer, Tick};
use orsa_actors::query::QueryRequest;
use orsa_actors::{Clock, Component, ComponentError, Ctx, Empty, Stamped, Timestamp};
use orsa_hardware::server::{ServerParams, contact_fires};
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
        };
        ctx.send_server(nomad200::NAVIGATIONVELOCITY, StandInMsg::Velocity)?;
        ctx.send_server(nomad200::TELEOP, StandInMsg::Velocity)?;
        ctx.query_server(nomad200::ROBOTPARAMS, StandInMsg::Params)?;
        ctx.query_server(nomad200::SAFETY, StandInMsg::Safety)?;
        ctx.spawn_activity(play(ctx.clock(), servers, Arc::clone(&self.playback)));
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
/// nothing else running in between, as the robot server published them one handler after the
/// other.
async fn play(clock: Clock, servers: Servers, playback: Arc<Playback>) {
    loop {
        let first = playback.cursor.load(Ordering::SeqCst);
        let Some(&(at, _)) = playback.published.get(first) else { return };
        tokio::time::sleep_until(clock.instant_of(Timestamp(at))).await;
        let mut i = first;
        while let Some((t, p)) = playback.published.get(i).filter(|(t, _)| *t == at) {
            debug_assert_eq!(*t, at);
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
            }
            i += 1;
        }
        playback.cursor.store(i, Ordering::SeqCst);
    }
}
