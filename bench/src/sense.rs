//! Sense to act, in process, on tokio's running clock: from the stamp of the sensor update a
//! velocity command was computed from to the motor board receiving that command.
//!
//! The stack is the one `orsa run` starts (simulator, robot server, both behaviours, master,
//! planner, one supervisor, default configuration, patrol), with two instruments:
//!
//! - the motor board is wrapped in [`TimedMotors`], which notes the robot clock and the
//!   velocities when `move_velocity` is called, before passing it on;
//! - each behaviour is wrapped in [`Traced`], which notes the stamp of the update that woke its
//!   handler (the newest sensor data the step consumed: the mailbox is FIFO and stamps grow)
//!   and, after the behaviour's own handler returned, the command the step computed and
//!   whether it left through a wired port (the behaviour's `status` says both).
//!
//! After the run each command the board received is matched to the wired behaviour's step that
//! computed it: the same velocities (after the server's clamping to the robot's limits) and the
//! latest such step whose update is not later than the command. The matching happens after the
//! run, so the only cost on the measured path is the wrapper's bookkeeping: a clock read before
//! the behaviour's handler and, after it has sent, a clock read, a read lock and a push (well
//! under a microsecond). The two clock reads split the figure into legs: update to the
//! handler's start (delivery), the handler itself, and the handler's return to the board.
//!
//! The update's stamp is when the robot server published it, right after reading the board;
//! the figure from the sensor's own firing (the scan's newest reading, which the simulator
//! stamps at its 10 ms step) is reported beside it and includes that sampling delay.
//!
//! [`across`] measures the same across processes: the simulator, the robot server (with the
//! timed motor board), the master and the planner in the bench process, both behaviours
//! (traced) in the peer process ([`PeerBehaviours`]), subscribing to the robot's sensors and
//! sending their commands over zenoh, on a two-worker runtime in each process. Both ends of
//! the figure are read on the bench process's clock: the update's stamp crosses to the peer as
//! UNIX time and back (exactly, in integer nanoseconds), so no clock offset enters it.

use super::net::{PeerReply, PeerRequest, WireStep};
use super::{SenseToAct, say, stats};
use anyhow::{Context as _, anyhow};
use orsa::config::Config;
use orsa::mission::stack::Stack;
use orsa::system::Robot;
use orsa::system::{Catalog, Place, System};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::QueryClient;
use orsa_actors::{Clock, Component, ComponentError, Ctx, Empty, Registry, Timestamp};
use orsa_executive::Master;
use orsa_hardware::any::AnyMotorBoard;
use orsa_hardware::board::{AxisAccelerations, AxisVelocities, BoardError, MotorBoard, MotorState};
use orsa_hardware::server::Nomad200;
use orsa_hardware::sim::{SimNomad200, SimRobot};
use orsa_hardware::world::World;
use orsa_interfaces::behaviour::BehaviourStatus;
use orsa_interfaces::nomad200::SafetyCounters;
use orsa_reactive::components::{CenterFollowMsg, WallFollowMsg};
use orsa_reactive::{CenterFollow, WallFollow};
use parking_lot::Mutex;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::Duration;

mod ros2side;
use ros2side::Ros2Side;

/// A command as the motor board received it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Act {
    pub(crate) at: Timestamp,
    pub(crate) v: f64,
    pub(crate) w: f64,
}

/// One step of a behaviour whose command left through a wired port.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Step {
    pub(crate) behaviour: &'static str,
    /// Publication stamp of the update that woke the step.
    pub(crate) update: Timestamp,
    /// The newest sensor firing in that update.
    pub(crate) fired: Timestamp,
    /// When the behaviour's handler started (its component's clock).
    pub(crate) handled: Timestamp,
    /// When the behaviour's handler returned, the command sent.
    pub(crate) done: Timestamp,
    pub(crate) v: f64,
    pub(crate) w: f64,
}

/// The bench's robot kind: the simulator behind [`TimedMotors`].
const TIMED_SIM: &str = "timed-sim";

/// A motor board that notes when each velocity command arrives.
#[derive(Debug, Clone)]
pub(crate) struct TimedMotors<M> {
    inner: M,
    clock: Clock,
    acts: Arc<Mutex<Vec<Act>>>,
}

impl<M: MotorBoard> MotorBoard for TimedMotors<M> {
    async fn move_velocity(&self, v: AxisVelocities) -> Result<(), BoardError> {
        self.acts.lock().push(Act { at: self.clock.now(), v: v.translate_m_s, w: v.steer_rad_s });
        self.inner.move_velocity(v).await
    }
    async fn stop(&self) -> Result<(), BoardError> {
        self.inner.stop().await
    }
    async fn wait_stop(&self, timeout: Duration) -> Result<(), BoardError> {
        self.inner.wait_stop(timeout).await
    }
    async fn zero_axes(&self) -> Result<(), BoardError> {
        self.inner.zero_axes().await
    }
    async fn set_velocity_limits(&self, limits: AxisVelocities) -> Result<(), BoardError> {
        self.inner.set_velocity_limits(limits).await
    }
    async fn set_accelerations(&self, accel: AxisAccelerations) -> Result<(), BoardError> {
        self.inner.set_accelerations(accel).await
    }
    async fn read_state(&self) -> Result<MotorState, BoardError> {
        self.inner.read_state().await
    }
}

/// The bench's catalog: the robot server on a motor board that notes each command (if this
/// process hosts the robot), both behaviours traced, and the master; all without the handler
/// timeout, as measured since the bench began.
fn catalog(acts: Option<&Arc<Mutex<Vec<Act>>>>, steps: &Arc<Mutex<Vec<Step>>>) -> Catalog {
    let mut c = Catalog::builtin();
    if let Some(acts) = acts {
        // The simulator, its motor board noting when each command arrives: a robot kind of
        // the bench's own.
        let acts = Arc::clone(acts);
        c.register_robot(TIMED_SIM, move |setup| {
            let sim = SimNomad200::new(setup.world.clone(), setup.config.sim.clone(), setup.seed)
                .map_err(|e| format!("simulator: {e}"))?;
            let mut robot = Robot::simulated(SimRobot::spawn(sim, setup.clock), setup.config);
            let timed =
                TimedMotors { inner: robot.motors.clone(), clock: setup.clock, acts: Arc::clone(&acts) };
            robot.motors = AnyMotorBoard::other(timed);
            Ok(robot)
        });
        // The robot server with no handler timeout: a loaded machine must not restart it.
        c.register_untimed("nomad200", Place::Robot, |parts, _| {
            let boards = parts.robot.ok_or("this process has no robot boards to serve")?;
            Ok(Nomad200::new(
                parts.config.robot(),
                boards.params.clone(),
                boards.sensors.clone(),
                boards.motors.clone(),
            ))
        });
    }
    let s = Arc::clone(steps);
    c.register_untimed("wallfollow", Place::Robot, move |parts, spec| {
        let inner = WallFollow { params: parts.params(spec)?, robot: parts.robot_name().into() };
        Ok(Traced { inner, steps: Arc::clone(&s) })
    });
    let s = Arc::clone(steps);
    c.register_untimed("centerfollow", Place::Robot, move |parts, spec| {
        let inner = CenterFollow { params: parts.params(spec)?, robot: parts.robot_name().into() };
        Ok(Traced { inner, steps: Arc::clone(&s) })
    });
    c.register_untimed("master", Place::Executive, |parts, _| Ok(Master::new(parts.config.executive())));
    c
}

/// Counts the supervisor's restarts into `restarts`.
fn count_restarts(
    restarts: &Arc<std::sync::atomic::AtomicU64>,
) -> impl Fn(orsa_actors::supervision::SupervisorEvent) + Send + Sync + 'static {
    let r = Arc::clone(restarts);
    move |e| {
        if e.kind == orsa_actors::supervision::SupervisorEventKind::Restarted {
            r.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    }
}

/// A behaviour whose handler can say which update woke it.
pub(crate) trait Triggered: Component {
    /// The component's name in the stack.
    const NAME: &'static str;
    /// Publication stamp of the update in `msg`, and its newest sensor firing.
    fn trigger(msg: &Self::Msg) -> (Timestamp, Timestamp);
}

impl Triggered for WallFollow {
    const NAME: &'static str = "wallfollow";
    fn trigger(msg: &WallFollowMsg) -> (Timestamp, Timestamp) {
        // Odometry, contact, parameters, health, poses and paths never make a step (no status follows them), so their stamps are
        // never used.
        match msg {
            WallFollowMsg::Ir(u) | WallFollowMsg::Sonar(u) => (u.sent_at, u.value.stamp),
            WallFollowMsg::Base(u) => (u.sent_at, u.value.stamp),
            WallFollowMsg::Contact(c) => (c.event.sent_at, c.event.value.stamp),
            WallFollowMsg::Param(q) => (q.request.sent_at, q.request.sent_at),
            WallFollowMsg::Health(u) => (u.sent_at, u.value.stamp),
            WallFollowMsg::Pose(u) => (u.sent_at, u.value.stamp),
            WallFollowMsg::Path(p) => (p.sent_at, p.sent_at),
        }
    }
}

impl Triggered for CenterFollow {
    const NAME: &'static str = "centerfollow";
    fn trigger(msg: &CenterFollowMsg) -> (Timestamp, Timestamp) {
        match msg {
            CenterFollowMsg::Ir(u) | CenterFollowMsg::Sonar(u) => (u.sent_at, u.value.stamp),
            CenterFollowMsg::Base(u) => (u.sent_at, u.value.stamp),
            CenterFollowMsg::Contact(c) => (c.event.sent_at, c.event.value.stamp),
            CenterFollowMsg::Param(q) => (q.request.sent_at, q.request.sent_at),
            CenterFollowMsg::Health(u) => (u.sent_at, u.value.stamp),
            CenterFollowMsg::Pose(u) => (u.sent_at, u.value.stamp),
            CenterFollowMsg::Path(p) => (p.sent_at, p.sent_at),
        }
    }
}

/// A behaviour with its steps noted.
pub(crate) struct Traced<C> {
    pub(crate) inner: C,
    pub(crate) steps: Arc<Mutex<Vec<Step>>>,
}

/// The state of a [`Traced`] behaviour.
pub(crate) struct TracedState<S> {
    inner: S,
    status: PushNewestServer<BehaviourStatus>,
    last_seq: u64,
}

impl<C: Triggered> Component for Traced<C> {
    type Msg = C::Msg;
    type State = TracedState<C::State>;

    async fn setup(&self, ctx: &Ctx<C::Msg>) -> Result<Self::State, ComponentError> {
        let inner = self.inner.setup(ctx).await?;
        // The behaviour declared it; declaring it again gives back the same server.
        let status = ctx.push_newest_server(orsa_interfaces::behaviour::STATUS)?;
        let last_seq = status.latest().map_or(0, |u| u.seq);
        Ok(TracedState { inner, status, last_seq })
    }

    async fn handle(
        &self,
        ctx: &Ctx<C::Msg>,
        st: &mut Self::State,
        msg: C::Msg,
    ) -> Result<(), ComponentError> {
        let (update, fired) = C::trigger(&msg);
        let handled = ctx.now();
        self.inner.handle(ctx, &mut st.inner, msg).await?;
        let done = ctx.now();
        if let Some(s) = st.status.latest()
            && s.seq != st.last_seq
        {
            st.last_seq = s.seq;
            if s.delivered {
                self.steps.lock().push(Step {
                    behaviour: C::NAME,
                    update,
                    fired,
                    handled,
                    done,
                    v: s.cmd.v_m_s,
                    w: s.cmd.omega_rad_s,
                });
            }
        }
        Ok(())
    }

    async fn teardown(&self, ctx: &Ctx<C::Msg>, st: &mut Self::State) {
        self.inner.teardown(ctx, &mut st.inner).await;
    }
}

/// What matching commands to steps found.
#[derive(Debug, Default)]
pub(crate) struct Matched {
    /// Nanoseconds from the update's publication to the board, per attributed command.
    pub(crate) from_update: Vec<u64>,
    /// Nanoseconds from the newest sensor firing to the board.
    pub(crate) from_firing: Vec<u64>,
    /// Attributed commands per behaviour.
    pub(crate) by_behaviour: BTreeMap<String, u64>,
    /// Commands that matched no step (the master's zero commands when nothing is wired).
    pub(crate) unattributed: u64,
    /// Per attributed command: update published to the behaviour's handler starting; the
    /// handler (controller, status, the send); the handler's return to the board.
    pub(crate) legs: [Vec<u64>; 3],
}

/// The legs' names, in order.
pub(crate) const LEGS: [&str; 3] = [
    "update published -> behaviour's handler starts",
    "behaviour's handler (controller, status, send)",
    "handler returned -> motor board",
];

fn legs(legs: [Vec<u64>; 3]) -> Vec<super::SenseLeg> {
    LEGS.iter()
        .zip(legs)
        .map(|(leg, v)| super::SenseLeg { leg: leg.to_string(), latency: stats::summarize(v) })
        .collect()
}

/// Matches each command to the latest step with the same (clamped) velocities whose update is
/// not later than the command and at most `max_age` older.
pub(crate) fn attribute(acts: &[Act], steps: &[Step], max_v: f64, max_w: f64, max_age: Duration) -> Matched {
    let key = |v: f64, w: f64| (v.to_bits(), w.to_bits());
    let mut by_value: HashMap<(u64, u64), Vec<&Step>> = HashMap::new();
    for s in steps {
        let (v, w) = (s.v.clamp(-max_v, max_v), s.w.clamp(-max_w, max_w));
        by_value.entry(key(v, w)).or_default().push(s);
    }
    for list in by_value.values_mut() {
        list.sort_by_key(|s| s.update);
    }
    let mut m = Matched::default();
    for a in acts {
        let found = by_value.get(&key(a.v, a.w)).and_then(|list| {
            let i = list.partition_point(|s| s.update <= a.at);
            i.checked_sub(1).map(|i| list[i])
        });
        match found {
            Some(s) if a.at.saturating_since(s.update) <= max_age => {
                m.from_update.push(a.at.saturating_since(s.update).as_nanos() as u64);
                m.from_firing.push(a.at.saturating_since(s.fired).as_nanos() as u64);
                m.legs[0].push(s.handled.saturating_since(s.update).as_nanos() as u64);
                m.legs[1].push(s.done.saturating_since(s.handled).as_nanos() as u64);
                m.legs[2].push(a.at.saturating_since(s.done).as_nanos() as u64);
                *m.by_behaviour.entry(s.behaviour.to_string()).or_default() += 1;
            }
            _ => m.unattributed += 1,
        }
    }
    m
}

/// What runs beside the stack while sense to act is measured: one thing at a time, each
/// against the stack as `orsa run` starts it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Arm {
    /// The stack alone.
    Plain,
    /// The stack without the safety monitor between the robot server and the motor board
    /// (`safety.enabled = false`: the monitor's cost is the difference).
    NoMonitor,
    /// A live server (`--foxglove`) serving its views to a client subscribed to everything
    /// ([`super::live::Client`]).
    Live,
    /// The same, the client also publishing velocity commands on `/cmd_vel` at 20 Hz as a
    /// Teleop panel does, each taking the whole path and refused by the robot server as stale
    /// (see [`super::live`]).
    LivePublishing,
    /// The stack alone on the robot's runtime (`orsa robot`'s: multi-thread, two workers), the
    /// baseline of [`Arm::Ros2Services`].
    RobotRuntime,
    /// On the robot's runtime (zenoh needs a multi-thread one), the robot's ROS 2 node
    /// (`orsa robot --ros2`'s own [`orsa::remote::ros2::ParamServices`] over the
    /// components with live parameters), its `get_parameters` called back to back by a ROS 2
    /// client with a zenoh session of its own, on a thread of its own (module `ros2side`).
    Ros2Services,
}

impl Arm {
    /// The runtime the stack runs on: `orsa run`'s (current thread), or `orsa robot`'s.
    fn runtime(self) -> super::inproc::RuntimeKind {
        match self {
            Arm::RobotRuntime | Arm::Ros2Services => super::inproc::RuntimeKind::MultiThread,
            _ => super::inproc::RuntimeKind::CurrentThread,
        }
    }
}

/// Runs the instrumented stack in real time for `duration_s` with `arm` beside it and reports
/// sense to act.
pub(crate) fn run(duration_s: f64, arm: Arm) -> anyhow::Result<SenseToAct> {
    if !(duration_s.is_finite() && duration_s > 0.0) {
        anyhow::bail!("sense to act: the duration must be positive, not {duration_s}");
    }
    let rt = match arm.runtime() {
        // `orsa robot`'s runtime, I/O included, as zenoh's session needs.
        super::inproc::RuntimeKind::MultiThread => {
            tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?
        }
        kind => kind.build()?,
    };
    let out = rt.block_on(async {
        tokio::time::timeout(Duration::from_secs_f64(duration_s + 60.0), measure(duration_s, arm))
            .await
            .map_err(|_| anyhow!("sense to act did not finish in time"))?
    });
    rt.shutdown_timeout(Duration::from_secs(1));
    out
}

async fn measure(duration_s: f64, arm: Arm) -> anyhow::Result<SenseToAct> {
    let mut config = Config::default();
    config.safety.enabled = arm != Arm::NoMonitor;
    let world = World::palazzina()?;
    let clock = Clock::start();
    let registry = Registry::with_clock(clock);
    let live = matches!(arm, Arm::Live | Arm::LivePublishing);
    let server = if live {
        let setup = orsa::mission::recording::view_setup(&config, Some(world.clone()), false);
        let addr = std::net::SocketAddr::from(([127, 0, 0, 1], 0));
        // Client publish taken, as `orsa run --foxglove` takes it, to the robot's teleop.
        let teleop = Arc::new(orsa::live::publish::Teleop::new(&registry, config.robot_name()));
        let server = orsa::live::LiveView::start(addr, setup, None, Some(teleop))?;
        registry.set_tap(Some(server.tap() as Arc<dyn orsa_actors::tap::Tap>));
        let client = super::live::Client::start(server.addr(), arm == Arm::LivePublishing)?;
        Some((server, client))
    } else {
        None
    };
    let acts = Arc::new(Mutex::new(Vec::new()));
    let steps = Arc::new(Mutex::new(Vec::new()));
    let robot = config.robot_name().to_string();
    let restarts = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let stack = Stack::builder(&config, world)
        .catalog(catalog(Some(&acts), &steps))
        .robot(TIMED_SIM)
        .duration(duration_s)
        .on_event(count_restarts(&restarts))
        .start_on(&registry)
        .await
        .context("starting the stack")?;
    let (max_v, max_w) = (stack.robot.params.max_v_m_s, stack.robot.params.max_omega_rad_s);
    let ros2 = if arm == Arm::Ros2Services {
        let components = [WallFollow::NAME, CenterFollow::NAME, "master"].map(String::from).to_vec();
        Some(Ros2Side::start(&registry, components).await?)
    } else {
        None
    };

    // The first second brings everything up and gets the robot moving; it is not measured.
    let settle = Duration::from_secs(1);
    tokio::time::sleep(settle).await;
    let from = registry.now();
    acts.lock().clear();
    say(format!("  sense to act: the stack in real time for {duration_s:.0} s"));
    tokio::time::sleep(Duration::from_secs_f64(duration_s)).await;
    let acts: Vec<Act> = std::mem::take(&mut *acts.lock());
    let steps: Vec<Step> = std::mem::take(&mut *steps.lock());
    let live_client = match server {
        Some((server, client)) => {
            let subscribed = client.subscribed();
            let (messages, published) = client.stop()?;
            registry.set_tap(None);
            let s = server.finish();
            let taken = s.published.map_or(0, |p| p.taken);
            say(format!(
                "  live view: {subscribed} channels subscribed, {messages} messages read, {} dropped; {published} commands published, {taken} handed to teleop",
                s.dropped
            ));
            Some(crate::LiveClient {
                subscribed,
                messages,
                handed: s.handed,
                dropped: s.dropped,
                published,
                taken,
            })
        }
        None => None,
    };
    // Asked once the client has stopped and the server has finished: every command handed to
    // teleop is in the robot server's mailbox ahead of this query, so its counters hold them.
    let safety = QueryClient::<Empty, SafetyCounters>::connect(
        &registry,
        orsa_interfaces::nomad200::SAFETY.on(robot.as_str()),
    )?
    .query(Empty {}, Some(Duration::from_secs(1)))
    .await
    .context("the robot server's safety counters")?;
    if live_client.is_some() {
        say(format!("  live view: {} commands refused by the robot as stale", safety.stale_refused));
    }
    let ros2_calls = match ros2 {
        Some(side) => {
            let calls = side.finish().await?;
            say(format!(
                "  ROS 2 parameter services: {} calls answered with every parameter, {} incomplete, {} failed",
                calls.answered, calls.incomplete, calls.failed
            ));
            Some(calls)
        }
        None => None,
    };
    stack.shutdown().await;
    let acts: Vec<Act> = acts.into_iter().filter(|a| a.at >= from).collect();
    let m = attribute(&acts, &steps, max_v, max_w, Duration::from_secs_f64(config.robot().cmd_timeout_s));
    Ok(SenseToAct {
        duration_s,
        commands_received: acts.len() as u64,
        attributed: m.from_update.len() as u64,
        unattributed: m.unattributed,
        by_behaviour: m.by_behaviour,
        from_update: stats::summarize(m.from_update),
        from_sensor_firing: stats::summarize(m.from_firing),
        legs: legs(m.legs),
        stale_refused: safety.stale_refused,
        monitor: safety.monitor.is_some(),
        restarts: restarts.load(std::sync::atomic::Ordering::Relaxed),
        live_client,
        ros2_calls,
    })
}

/// Both behaviours, traced, in the peer process, against a robot in the bench process.
pub(crate) struct PeerBehaviours {
    supervisor: orsa_actors::supervision::SupervisorRef,
    steps: Arc<Mutex<Vec<Step>>>,
    restarts: Arc<std::sync::atomic::AtomicU64>,
}

impl PeerBehaviours {
    /// Waits for `robot`'s services, then starts both behaviours under a supervisor.
    pub(crate) async fn start(
        registry: &Registry,
        transport: &orsa_net::ZenohTransport,
        robot: &str,
    ) -> anyhow::Result<PeerBehaviours> {
        let needed: Vec<orsa_actors::ServiceAddr> =
            ["distanceir", "distanceson", "basestate", "contact", "robotparams", "navigationvelocity"]
                .iter()
                .map(|s| orsa_actors::ServiceAddr::new(robot, *s))
                .collect();
        if let Err(missing) = transport.wait_for(&needed, Duration::from_secs(30)).await {
            anyhow::bail!("the robot's services {missing:?} did not appear within 30 s");
        }
        let mut config = Config::default();
        config.rename_component(orsa::config::Config::default().robot_name(), robot);
        let steps = Arc::new(Mutex::new(Vec::new()));
        let restarts = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let supervisor = System::builder(&config)
            .catalog(catalog(None, &steps))
            .select(&[WallFollow::NAME, CenterFollow::NAME])
            .supervisor("bench-behaviours")
            .on_event(count_restarts(&restarts))
            .start(registry)
            .await
            .context("starting the behaviours")?
            .supervisor;
        Ok(PeerBehaviours { supervisor, steps, restarts })
    }

    /// Stops the behaviours; their steps (stamps as UNIX time) and the restarts.
    pub(crate) async fn stop(self) -> (Vec<WireStep>, u64) {
        let steps: Vec<Step> = std::mem::take(&mut *self.steps.lock());
        self.supervisor.shutdown().await;
        let wire = steps
            .iter()
            .map(|s| WireStep {
                behaviour: s.behaviour.to_string(),
                update_unix_ns: s.update.as_nanos(),
                fired_unix_ns: s.fired.as_nanos(),
                handled_unix_ns: s.handled.as_nanos(),
                done_unix_ns: s.done.as_nanos(),
                v: s.v,
                w: s.w,
            })
            .collect();
        (wire, self.restarts.load(std::sync::atomic::Ordering::Relaxed))
    }
}

/// A step from the peer (its stamps are UNIX time, as this process's).
pub(crate) fn step_from_wire(w: &WireStep) -> Step {
    let behaviour = match w.behaviour.as_str() {
        WallFollow::NAME => WallFollow::NAME,
        CenterFollow::NAME => CenterFollow::NAME,
        _ => "other",
    };
    Step {
        behaviour,
        update: Timestamp(w.update_unix_ns),
        fired: Timestamp(w.fired_unix_ns),
        handled: Timestamp(w.handled_unix_ns),
        done: Timestamp(w.done_unix_ns),
        v: w.v,
        w: w.w,
    }
}

/// Sense to act across processes for `duration_s`: the robot, master and planner here, the
/// behaviours in the peer that `control` reaches.
pub(crate) async fn across(
    registry: &Registry,
    transport: &orsa_net::ZenohTransport,
    control: &QueryClient<PeerRequest, PeerReply>,
    duration_s: f64,
    switch_rounds: usize,
) -> anyhow::Result<(SenseToAct, super::SwitchPair)> {
    if !(duration_s.is_finite() && duration_s > 0.0) {
        anyhow::bail!("sense to act: the duration must be positive, not {duration_s}");
    }
    let config = Config::default();
    let acts = Arc::new(Mutex::new(Vec::new()));
    let robot = config.robot_name().to_string();
    let restarts = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let steps = Arc::new(Mutex::new(Vec::new()));
    let robot_stack = Stack::builder(&config, World::palazzina()?)
        .catalog(catalog(Some(&acts), &steps))
        .robot(TIMED_SIM)
        .select(&[config.robot_name()])
        .supervisor("bench-robot")
        .on_event(count_restarts(&restarts))
        .start_on(registry)
        .await
        .context("starting the robot")?;
    let (max_v, max_w) = (robot_stack.robot.params.max_v_m_s, robot_stack.robot.params.max_omega_rad_s);

    let out = async {
        match control
            .query(PeerRequest::StartBehaviours { robot: robot.clone() }, Some(Duration::from_secs(60)))
            .await
        {
            Ok(PeerReply::Ok) => {}
            Ok(PeerReply::Failed { reason }) => {
                anyhow::bail!("the peer could not start the behaviours: {reason}")
            }
            Ok(other) => anyhow::bail!("the peer answered {other:?} to starting the behaviours"),
            Err(e) => anyhow::bail!("starting the behaviours in the peer: {e}"),
        }
        let needed: Vec<orsa_actors::ServiceAddr> = [WallFollow::NAME, CenterFollow::NAME]
            .iter()
            .flat_map(|b| {
                [orsa_actors::ServiceAddr::new(*b, "state"), orsa_actors::ServiceAddr::new(*b, "wiring")]
            })
            .collect();
        if let Err(missing) = transport.wait_for(&needed, Duration::from_secs(30)).await {
            anyhow::bail!("the behaviours' services {missing:?} did not appear within 30 s");
        }
        let exec_sup = System::builder(&config)
            .catalog(catalog(None, &steps))
            .select(&["master", "planner"])
            .duration(duration_s + 5.0)
            .supervisor("bench-executive")
            .on_event(count_restarts(&restarts))
            .start(registry)
            .await
            .context("starting the executive")?
            .supervisor;

        // Bringing everything up and getting the robot moving is not measured.
        tokio::time::sleep(Duration::from_secs(2)).await;
        let from = registry.now();
        acts.lock().clear();
        say(format!("  sense to act across processes: the stack in real time for {duration_s:.0} s"));
        tokio::time::sleep(Duration::from_secs_f64(duration_s)).await;
        let safety = QueryClient::<Empty, SafetyCounters>::connect(
            registry,
            orsa_interfaces::nomad200::SAFETY.on(robot.as_str()),
        )?
        .query(Empty {}, Some(Duration::from_secs(1)))
        .await
        .context("the robot server's safety counters")?;
        let taken: Vec<Act> = std::mem::take(&mut *acts.lock());
        // The master stops, the behaviours go on in the peer: hand the motors between them.
        exec_sup.shutdown().await;
        say(format!("  mode switch across processes: {switch_rounds} hand-overs each way"));
        let motors = orsa_interfaces::nomad200::NAVIGATIONVELOCITY.on(robot.as_str()).untyped();
        let switch =
            super::switch::measure(registry, [WallFollow::NAME, CenterFollow::NAME], &motors, switch_rounds)
                .await?;
        let (wire_steps, peer_restarts) =
            match control.query(PeerRequest::StopBehaviours, Some(Duration::from_secs(30))).await {
                Ok(PeerReply::Steps { steps, restarts }) => (steps, restarts),
                other => anyhow::bail!("the peer answered {other:?} to stopping the behaviours"),
            };
        let steps: Vec<Step> = wire_steps.iter().map(step_from_wire).collect();
        let taken: Vec<Act> = taken.into_iter().filter(|a| a.at >= from).collect();
        let m =
            attribute(&taken, &steps, max_v, max_w, Duration::from_secs_f64(config.robot().cmd_timeout_s));
        let sense = SenseToAct {
            duration_s,
            commands_received: taken.len() as u64,
            attributed: m.from_update.len() as u64,
            unattributed: m.unattributed,
            by_behaviour: m.by_behaviour,
            from_update: stats::summarize(m.from_update),
            from_sensor_firing: stats::summarize(m.from_firing),
            legs: legs(m.legs),
            stale_refused: safety.stale_refused,
            monitor: safety.monitor.is_some(),
            restarts: restarts.load(std::sync::atomic::Ordering::Relaxed) + peer_restarts,
            live_client: None,
            ros2_calls: None,
        };
        Ok((sense, switch))
    }
    .await;
    robot_stack.shutdown().await;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(update: u64, v: f64, w: f64) -> Step {
        Step {
            behaviour: "wallfollow",
            update: Timestamp(update),
            fired: Timestamp(update - 5),
            handled: Timestamp(update + 1),
            done: Timestamp(update + 3),
            v,
            w,
        }
    }

    #[test]
    fn commands_match_the_latest_step_with_their_values() {
        let steps = [step(100, 0.2, 0.1), step(200, 0.2, 0.1), step(300, 0.25, -0.3)];
        let acts = [
            Act { at: Timestamp(150), v: 0.2, w: 0.1 },
            Act { at: Timestamp(260), v: 0.2, w: 0.1 },
            Act { at: Timestamp(310), v: 0.25, w: -0.3 },
            Act { at: Timestamp(320), v: 0.0, w: 0.0 },
        ];
        let m = attribute(&acts, &steps, 1.0, 1.0, Duration::from_secs(1));
        assert_eq!(m.from_update, vec![50, 60, 10]);
        assert_eq!(m.from_firing, vec![55, 65, 15]);
        assert_eq!(m.legs, [vec![1, 1, 1], vec![2, 2, 2], vec![47, 57, 7]]);
        assert_eq!(m.unattributed, 1);
        assert_eq!(m.by_behaviour.get("wallfollow"), Some(&3));
    }

    #[test]
    fn clamped_commands_still_match_and_stale_ones_do_not() {
        let steps = [step(100, 0.9, -2.0)];
        let clamped = Act { at: Timestamp(120), v: 0.5, w: -0.75 };
        let m = attribute(&[clamped], &steps, 0.5, 0.75, Duration::from_secs(1));
        assert_eq!(m.from_update, vec![20]);
        let late = Act { at: Timestamp(100 + 2_000_000_000), v: 0.5, w: -0.75 };
        let m = attribute(&[late], &steps, 0.5, 0.75, Duration::from_secs(1));
        assert_eq!((m.from_update.len(), m.unattributed), (0, 1));
        let early = Act { at: Timestamp(99), v: 0.5, w: -0.75 };
        assert_eq!(attribute(&[early], &steps, 0.5, 0.75, Duration::from_secs(1)).unattributed, 1);
    }
}
