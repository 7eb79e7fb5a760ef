//! The corridor mission: the whole stack on the simulator, measured as the thesis measured it.
//!
//! - [`stack`]: brings the components up under one supervisor;
//! - [`metrics`]: the thesis' measures, from ground truth;
//! - [`report`]: `report.json` and the table against the original experiment;
//! - [`integrity`]: what was delivered and lost, and whether the stack held together.
//!
//! [`run`] is what `orsa run` does, minus argument parsing and printing: it runs on whatever
//! tokio runtime calls it, so the same code runs an hour in seconds on a paused clock or in
//! real time, and tests call it directly.

pub mod integrity;
mod measures;
pub mod metrics;
pub mod navigation;
pub mod observe;
pub mod report;
pub mod stack;
pub mod tour;

/// A run's recording: in the recording crate, `orsa_record::recording`.
pub use orsa_record::recording;

use crate::config::Config;
use measures::{End, Measures};
use metrics::Metrics;
pub use observe::{RunObserver, RunTap, Tick};
use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::query::QueryClient;
use orsa_actors::supervision::{SupervisorEvent, SupervisorEventKind};
use orsa_actors::tap::Tap;
use orsa_actors::{Empty, Sink, Update};
use orsa_hardware::world::World;
use orsa_interfaces::executive::{self, WiringChange};
use orsa_interfaces::nomad200::{self, SafetyCounters};
use report::{Ended, Report};
use stack::{Stack, StackError};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::mpsc;

/// What a run needs.
pub struct RunOptions {
    /// The world.
    pub world: World,
    /// How the report names it (the file, or `palazzina (built in)`).
    pub world_label: String,
    /// The stack's configuration.
    pub config: Config,
    /// The seed of every noise source.
    pub seed: u64,
    /// Simulated seconds to run.
    pub duration_s: f64,
    /// How often the truth is sampled for metrics, s.
    pub sample_period_s: f64,
    /// How often the figures are sampled into the report's `hours` (memory, restarts, the
    /// span's measures, sizes), simulated s; a run that ends between two takes one more
    /// sample at its end (a run shorter than this has just that one).
    pub figures_every_s: f64,
    /// Whether the series for the plot are kept (`RunOutcome::metrics`'s trajectory, offset
    /// and clearance over time): they take memory in proportion to the run's length.
    pub keep_series: bool,
    /// Called with the simulated time every `progress_every_s`.
    pub progress: Option<Arc<dyn Fn(f64) + Send + Sync>>,
    /// How often to call `progress`, simulated s.
    pub progress_every_s: f64,
    /// Record every message to this MCAP file.
    pub record: Option<std::path::PathBuf>,
    /// Break the stack on purpose as this plan says.
    pub faults: Option<crate::faults::FaultPlan>,
    /// Whether the run goes in real time (the caller's runtime is not paused): a recording
    /// then says its times are live, and a replay holds them to a tolerance.
    pub realtime: bool,
    /// The kinds of component the config's `[system]` table may name (default: the built-in
    /// ones; a program adds its own, see `examples/new_behaviour.rs`).
    pub catalog: crate::system::Catalog,
    /// Ends the run early when it completes, with the name of what interrupted it (`orsa run`
    /// passes Ctrl-C and SIGTERM): the run stops the motors, and reports and records what
    /// happened up to then.
    pub interrupt: Option<futures::future::BoxFuture<'static, String>>,
    /// Called once the system is up, with its registry: what talks to the running system from
    /// outside it (the live server, a test setting parameters) starts here.
    pub on_start: Option<OnStart>,
    /// Serve the run's views live (`--foxglove`): this tap is given every message and the
    /// ground truth, as a recording is.
    pub live: Option<Arc<crate::live::tap::LiveTap>>,
    /// A program's own observers of the run, told of it after the built-in ones (see
    /// [`observe`] and [`RunOptions::observe`]).
    pub observers: Vec<Box<dyn RunObserver>>,
    /// End the run when the planner's mission ends (completed or aborted), if it ends before
    /// the duration: `orsa run --goto`.
    pub until_mission_ends: bool,
}

/// See [`RunOptions::on_start`].
pub type OnStart = Box<dyn FnOnce(&orsa_actors::Registry) + Send>;

impl RunOptions {
    /// Options with the defaults: 10 Hz sampling, figures every simulated hour, the plot's
    /// series kept, no progress reports.
    pub fn new(
        world: World,
        world_label: impl Into<String>,
        config: Config,
        seed: u64,
        duration_s: f64,
    ) -> Self {
        RunOptions {
            world,
            world_label: world_label.into(),
            config,
            seed,
            duration_s,
            sample_period_s: 0.1,
            figures_every_s: 3600.0,
            keep_series: true,
            progress: None,
            progress_every_s: 10.0,
            record: None,
            faults: None,
            realtime: false,
            catalog: crate::system::Catalog::builtin(),
            interrupt: None,
            on_start: None,
            live: None,
            observers: Vec::new(),
            until_mission_ends: false,
        }
    }

    /// Attaches `observer` to the run (after those attached before it).
    pub fn observe(mut self, observer: impl RunObserver + 'static) -> Self {
        self.observers.push(Box::new(observer));
        self
    }
}

/// What a run produced.
pub struct RunOutcome {
    /// The report (`wall_seconds` is left for the caller to fill).
    pub report: Report,
    /// Every measure and series, for plots.
    pub metrics: Metrics,
    /// What the supervisor reported.
    pub supervisor_events: Vec<SupervisorEvent>,
    /// What the recording holds, if one was made, or why it failed (the run's figures stand
    /// either way).
    pub recording: Option<Result<crate::record::RecordSummary, crate::record::RecordError>>,
}

/// Why a run could not be made.
#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    /// The stack did not come up.
    #[error(transparent)]
    Stack(#[from] StackError),
    /// A stack service could not be reached.
    #[error("{0}")]
    Service(#[from] orsa_actors::PatternError),
    /// A duration or period that cannot be run.
    #[error("{0}")]
    Invalid(String),
    /// The recording could not be written.
    #[error("recording: {0}")]
    Record(#[from] crate::record::RecordError),
}

/// What the recording of a run says about it (see [`crate::record::meta`]).
fn run_meta(opts: &RunOptions) -> Result<crate::record::RunMeta, MissionError> {
    crate::record::RunMeta::describe(
        "run",
        &opts.world_label,
        Some(&opts.world),
        opts.seed,
        opts.duration_s,
        &opts.config,
        opts.config.system.components.iter().map(|c| c.name.clone()).collect(),
        opts.realtime,
        0,
        opts.faults.as_ref(),
    )
    .map_err(|e| MissionError::Invalid(e.to_string()))
}

/// Runs the corridor mission for `duration_s` simulated seconds and measures it.
///
/// The run itself brings the stack up, ticks the sampling clock, ends at its duration, on an
/// interrupt or when the top supervisor gives up, and shuts the stack down; its recording,
/// live view, fault plan, progress reports and a program's own observers are
/// [`RunObserver`]s told of each step (see [`observe`]).
pub async fn run(mut opts: RunOptions) -> Result<RunOutcome, MissionError> {
    check(&opts)?;
    let mut observers = observers(&mut opts)?;
    let (ev_tx, mut events) = Events::new();
    // The top supervisor giving up ends the run (its children are gone).
    let (gave_up_tx, gave_up_rx) = tokio::sync::watch::channel(None::<SupervisorEvent>);
    let taps: Vec<Arc<dyn RunTap>> = observers.iter().filter_map(|o| o.tap()).collect();
    let tap = taps.iter().fold(None, |all, t| crate::live::tap::both(all, Some(t.clone() as Arc<dyn Tap>)));
    let on_event = move |e: SupervisorEvent| {
        for t in &taps {
            t.supervisor_event(&e);
        }
        if e.kind == SupervisorEventKind::GaveUp && e.supervisor == crate::system::TOP_SUPERVISOR {
            let _ = gave_up_tx.send(Some(e.clone()));
        }
        // The receiver lives until the run ends.
        let _ = ev_tx.send(e);
    };
    let stack =
        Stack::start_with(opts.catalog, opts.world, &opts.config, opts.seed, opts.duration_s, tap, on_event)
            .await?;
    if stack.truth().is_none() {
        let kind = stack.robot.kind.clone();
        stack.shutdown().await;
        return Err(MissionError::Invalid(format!(
            "the mission is measured against the simulator's truth; robot kind '{kind}' has none"
        )));
    }
    let mut driving = Driving::watch(&stack)?;
    for o in &mut observers {
        o.on_start(&stack);
    }
    let measuring = measures::Options {
        config: &opts.config,
        sample_period_s: opts.sample_period_s,
        figures_every_s: opts.figures_every_s,
        keep_series: opts.keep_series,
    };
    let mut measures = Measures::new(&measuring, &stack);
    let period = Duration::from_secs_f64(opts.sample_period_s);
    let samples = (opts.duration_s / opts.sample_period_s).round() as u64;
    let mut ticks = tokio::time::interval_at(tokio::time::Instant::now() + period, period);
    let mission = if opts.until_mission_ends { Some(mission_end(&stack)?) } else { None };
    let early = early(opts.interrupt.take(), gave_up_rx, mission);
    tokio::pin!(early);
    let (mut ended, mut simulated_s) = (Ended::Completed, opts.duration_s);
    for k in 1..=samples {
        tokio::select! {
            biased;
            _ = ticks.tick() => {}
            why = &mut early => {
                simulated_s = (k - 1) as f64 * opts.sample_period_s;
                ended = stop_early(&stack, why, simulated_s).await;
                break;
            }
        }
        events.drain(&mut observers);
        driving.update();
        let truth = stack::truth_of(&stack).truth();
        let t_s = k as f64 * opts.sample_period_s;
        let tick = Tick { k, t_s, truth: &truth, driving: driving.now(), stack: &stack };
        for o in &mut observers {
            o.on_tick(&tick);
        }
        if let Some(last) = measures.tick(k, &truth, driving.now(), &stack).await {
            events.drain(&mut observers);
            measures.row(&last, &stack, &events.all);
        }
    }
    for o in &mut observers {
        o.on_stop(&stack, simulated_s);
    }
    if measures.last_row_due(simulated_s) {
        events.drain(&mut observers);
        measures.last_row(simulated_s, &stack, &events.all);
    }
    let safety = safety_counters(&stack, opts.config.robot_name(), &ended).await?;
    let delivery = integrity::DeliveryReport::from_ledger(&stack.registry);
    driving.update();
    let (held, measured) = measures.finish(&stack, driving.now()).await;
    drop(driving);
    stack.shutdown().await;
    events.drain(&mut observers);
    let end =
        End { world_label: opts.world_label, seed: opts.seed, simulated_s, ended, safety, delivery, held };
    let (report, metrics) = measured.report(end, &events.all);
    let mut outcome = RunOutcome { report, metrics, supervisor_events: events.all, recording: None };
    for o in &mut observers {
        o.on_end(&mut outcome);
    }
    Ok(outcome)
}

/// Refuses options no run can be made of.
fn check(opts: &RunOptions) -> Result<(), MissionError> {
    if !(opts.duration_s.is_finite() && opts.duration_s > 0.0) {
        return Err(MissionError::Invalid(format!(
            "duration must be a positive number of seconds, not {}",
            opts.duration_s
        )));
    }
    if !(opts.figures_every_s.is_finite() && opts.figures_every_s > 0.0) {
        return Err(MissionError::Invalid(format!(
            "the figures' period must be a positive number of seconds, not {}",
            opts.figures_every_s
        )));
    }
    Ok(())
}

/// The observers the options ask for (fault plan, `on_start`, recording, live view,
/// progress), then the program's own.
fn observers(opts: &mut RunOptions) -> Result<Vec<Box<dyn RunObserver>>, MissionError> {
    let mut all: Vec<Box<dyn RunObserver>> = Vec::new();
    if let Some(plan) = opts.faults.clone() {
        all.push(Box::new(observe::FaultPlanRun::new(plan, opts.duration_s)));
    }
    if let Some(f) = opts.on_start.take() {
        all.push(Box::new(observe::StartHook(Some(f))));
    }
    if let Some(path) = &opts.record {
        let views = recording::view_setup(&opts.config, Some(opts.world.clone()), true);
        let tap = recording::McapTap::create(path, run_meta(opts)?.to_metadata(), Some(views))?;
        all.push(Box::new(observe::Recorder(Arc::new(tap))));
    }
    if let Some(live) = opts.live.take() {
        all.push(Box::new(observe::LiveView(live)));
    }
    // A system with the navigation components is measured as navigation too.
    let kinds = opts.config.system.kinds();
    if ["localizer", "pathfollow"].iter().all(|k| kinds.values().any(|have| have == k)) {
        let radius_m = opts.config.sim.robot_params(opts.config.robot().push_periods()).body_radius_m;
        all.push(Box::new(navigation::NavigationRun::new(opts.world.clone(), radius_m)));
    }
    if let Some(report) = opts.progress.clone() {
        let every = ((opts.progress_every_s / opts.sample_period_s).round() as u64).max(1);
        all.push(Box::new(observe::Progress { report, every }));
    }
    all.append(&mut opts.observers);
    Ok(all)
}

/// The supervisors' events of a run, as they arrive.
struct Events {
    rx: mpsc::UnboundedReceiver<SupervisorEvent>,
    /// Every one so far.
    all: Vec<SupervisorEvent>,
}

impl Events {
    fn new() -> (mpsc::UnboundedSender<SupervisorEvent>, Events) {
        let (tx, rx) = mpsc::unbounded_channel();
        (tx, Events { rx, all: Vec::new() })
    }

    /// Takes those that arrived, and tells `observers` of them.
    fn drain(&mut self, observers: &mut [Box<dyn RunObserver>]) {
        while let Ok(e) = self.rx.try_recv() {
            for o in observers.iter_mut() {
                o.on_supervisor_event(&e);
            }
            self.all.push(e);
        }
    }
}

/// Which behaviour drives the motors, as the executive says.
struct Driving {
    rx: mpsc::UnboundedReceiver<Update<WiringChange>>,
    /// Held for the subscription.
    _client: PushNewestClient<WiringChange>,
    now: Option<String>,
}

impl Driving {
    fn watch(stack: &Stack) -> Result<Self, MissionError> {
        let (tx, rx) = mpsc::unbounded_channel::<Update<WiringChange>>();
        let client = PushNewestClient::connect_to(
            &stack.registry,
            executive::DRIVING.on(executive::NAME),
            Sink::channel(tx),
        )?;
        client.subscribe()?;
        Ok(Driving { rx, _client: client, now: None })
    }

    /// Takes the changes that arrived.
    fn update(&mut self) {
        while let Ok(change) = self.rx.try_recv() {
            self.now = change.driving.clone();
        }
    }

    fn now(&self) -> Option<&str> {
        self.now.as_deref()
    }
}

/// When the planner's mission ends: how it ended.
fn mission_end(stack: &Stack) -> Result<futures::future::BoxFuture<'static, String>, MissionError> {
    let (tx, mut rx) = mpsc::unbounded_channel::<Update<orsa_interfaces::planner::MissionStatus>>();
    let client = PushNewestClient::connect_to(
        &stack.registry,
        orsa_interfaces::planner::MISSION.on(orsa_interfaces::planner::NAME),
        Sink::channel(tx),
    )?;
    client.subscribe()?;
    Ok(Box::pin(async move {
        let _client = client;
        while let Some(status) = rx.recv().await {
            if let Some(how) = &status.finished {
                return how.clone();
            }
        }
        std::future::pending().await
    }))
}

/// What may end the run before its time: `interrupt`, the top supervisor giving up, or the
/// end of the planner's `mission` if the run ends with it.
async fn early(
    interrupt: Option<futures::future::BoxFuture<'static, String>>,
    mut gave_up: tokio::sync::watch::Receiver<Option<SupervisorEvent>>,
    mission: Option<futures::future::BoxFuture<'static, String>>,
) -> Early {
    let signal = async move {
        match interrupt {
            Some(i) => i.await,
            None => std::future::pending().await,
        }
    };
    let mission = async move {
        match mission {
            Some(m) => m.await,
            None => std::future::pending().await,
        }
    };
    tokio::select! {
        signal = signal => Early::Interrupted(signal),
        result = mission => Early::MissionEnded(result),
        e = gave_up.wait_for(Option::is_some) => match e.ok().and_then(|e| e.clone()) {
            Some(e) => Early::GaveUp(e),
            None => std::future::pending().await,
        },
    }
}

/// The robot server's safety counters. A robot server the supervisor gave up on has no
/// counters to give: the report says how the run ended, and its safety figures are zero.
async fn safety_counters(stack: &Stack, robot: &str, ended: &Ended) -> Result<SafetyCounters, MissionError> {
    let safety =
        match QueryClient::<Empty, SafetyCounters>::connect(&stack.registry, nomad200::SAFETY.on(robot)) {
            Ok(c) => c.query(Empty {}, Some(Duration::from_secs(1))).await,
            Err(e) => Err(e),
        };
    match (safety, ended) {
        (Ok(s), _) => Ok(s),
        (Err(e), Ended::Completed) => Err(e.into()),
        (Err(e), _) => {
            tracing::warn!("the robot server's safety counters are lost with it: {e}");
            Ok(SafetyCounters::default())
        }
    }
}

/// What ended a run before its time.
enum Early {
    /// A signal, by name.
    Interrupted(String),
    /// The planner's mission ended, so.
    MissionEnded(String),
    /// The top supervisor gave up.
    GaveUp(SupervisorEvent),
}

/// Ends a run before its time at `at_s`. Interrupted, the stack is shut down as at the end of
/// a run (the robot server stops the motors). Given up, the robot server is gone with its
/// watchdog: the motors are stopped straight on the board, and the robot is given
/// [`STOP_WAIT`](crate::ending::STOP_WAIT) to come to rest.
async fn stop_early(stack: &Stack, why: Early, at_s: f64) -> Ended {
    match why {
        Early::Interrupted(signal) => {
            tracing::warn!("interrupted by {signal} at {at_s:.1} s: writing the report");
            Ended::Interrupted { at_s, signal }
        }
        Early::MissionEnded(result) => {
            tracing::info!("the mission ended at {at_s:.1} s ({result})");
            Ended::MissionEnded { at_s, result }
        }
        Early::GaveUp(e) => {
            // Once every component has stopped (the top stops its children after it reports
            // giving up): none may drive after the board's stop.
            stack.supervisor.shutdown().await;
            let stopped_in_s = stack.stop_on_board().await;
            let ended = Ended::GaveUp {
                at_s,
                supervisor: e.supervisor,
                child: e.child,
                reason: e.reason,
                stopped_in_s,
            };
            tracing::error!("the run {}", ended.describe());
            ended
        }
    }
}
