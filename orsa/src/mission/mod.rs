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
pub mod metrics;
pub mod report;
pub mod stack;

/// A run's recording: in the recording crate, `orsa_record::recording`.
pub use orsa_record::recording;

use crate::config::Config;
use metrics::{Metrics, Sample};
use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::query::QueryClient;
use orsa_actors::supervision::{SupervisorEvent, SupervisorEventKind};
use orsa_actors::{Empty, Sink, Update};
use orsa_hardware::sim::Side;
use orsa_hardware::world::World;
use orsa_interfaces::executive::{self, WiringChange};
use orsa_interfaces::nomad200::{self, SafetyCounters};
use report::{Ended, Report, SafetyFigures};
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
        }
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
    .map_err(MissionError::Invalid)
}

/// Runs the corridor mission for `duration_s` simulated seconds and measures it.
pub async fn run(mut opts: RunOptions) -> Result<RunOutcome, MissionError> {
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
    let recording = match &opts.record {
        Some(path) => {
            let views = recording::view_setup(&opts.config, Some(opts.world.clone()), true);
            Some(Arc::new(recording::McapTap::create(path, run_meta(&opts)?.to_metadata(), Some(views))?))
        }
        None => None,
    };
    let (ev_tx, mut ev_rx) = mpsc::unbounded_channel::<SupervisorEvent>();
    // The top supervisor giving up ends the run (its children are gone).
    let (gave_up_tx, mut gave_up_rx) = tokio::sync::watch::channel(None::<SupervisorEvent>);
    let ev_rec = recording.clone();
    let live = opts.live.take();
    let ev_live = live.clone();
    let tap = crate::live::tap::both(
        recording.clone().map(|r| r as Arc<dyn orsa_actors::tap::Tap>),
        live.clone().map(|l| l as Arc<dyn orsa_actors::tap::Tap>),
    );
    let stack = Stack::start_with(
        opts.catalog,
        opts.world,
        &opts.config,
        opts.seed,
        opts.duration_s,
        tap,
        move |e| {
            if let Some(r) = &ev_rec {
                r.supervisor_event(&e);
            }
            if let Some(l) = &ev_live {
                l.supervisor_event(&e);
            }
            if e.kind == SupervisorEventKind::GaveUp && e.supervisor == crate::system::TOP_SUPERVISOR {
                let _ = gave_up_tx.send(Some(e.clone()));
            }
            // The receiver lives until the run ends.
            let _ = ev_tx.send(e);
        },
    )
    .await?;
    let Some(truth) = stack.truth().cloned() else {
        let kind = stack.robot.kind.clone();
        stack.shutdown().await;
        return Err(MissionError::Invalid(format!(
            "the mission is measured against the simulator's truth; robot kind '{kind}' has none"
        )));
    };

    let plan = opts.faults.clone().map(|plan| {
        let targets = crate::faults::FaultTargets {
            faults: stack.registry.faults(),
            boards: stack.board_faults.clone(),
            link: None,
        };
        tokio::spawn(crate::faults::run_plan(plan, targets, opts.duration_s))
    });

    if let Some(on_start) = opts.on_start.take() {
        on_start(&stack.registry);
    }

    let (wtx, mut wrx) = mpsc::unbounded_channel::<Update<WiringChange>>();
    let wiring = PushNewestClient::connect_to(
        &stack.registry,
        executive::DRIVING.on(executive::NAME),
        Sink::channel(wtx),
    )?;
    wiring.subscribe()?;

    let period = Duration::from_secs_f64(opts.sample_period_s);
    let samples = (opts.duration_s / opts.sample_period_s).round() as u64;
    let progress_every = ((opts.progress_every_s / opts.sample_period_s).round() as u64).max(1);
    let mut metrics = Metrics::new(opts.sample_period_s).keeping_series(opts.keep_series);
    let mut hours = Hours::new(opts.figures_every_s, opts.sample_period_s, &stack.registry);
    let mut events = Vec::new();
    let mut driving: Option<String> = None;
    let start = tokio::time::Instant::now();
    let mut ticks = tokio::time::interval_at(start + period, period);
    let mut watch = integrity::Watch::new(
        stack.board_faults.clone(),
        Duration::from_secs_f64(opts.config.robot().cmd_timeout_s),
    );
    let behaviours = opts.config.executive().behaviours();
    let behaviours: Vec<&str> = behaviours.iter().map(String::as_str).collect();
    let check_every = ((1.0 / opts.sample_period_s).round() as u64).max(1);
    // What may end the run before its time: a signal, or the top supervisor giving up.
    let interrupt = opts.interrupt.take();
    let early = async move {
        let signal = async move {
            match interrupt {
                Some(i) => i.await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            signal = signal => Early::Interrupted(signal),
            e = gave_up_rx.wait_for(Option::is_some) => match e.ok().and_then(|e| e.clone()) {
                Some(e) => Early::GaveUp(e),
                None => std::future::pending().await,
            },
        }
    };
    tokio::pin!(early);
    let mut ended = Ended::Completed;
    let mut simulated_s = opts.duration_s;
    if let Some(r) = &recording {
        r.truth(truth_sample(truth.truth(), &truth));
    }
    if let Some(l) = &live {
        l.truth(truth_sample(truth.truth(), &truth));
    }
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
        while let Ok(change) = wrx.try_recv() {
            driving = change.driving.clone();
        }
        let t = truth.truth();
        let t_s = k as f64 * opts.sample_period_s;
        if recording.is_some() || live.is_some() {
            let sample = truth_sample(t, &truth);
            if let Some(l) = &live {
                l.truth(sample.clone());
            }
            if let Some(r) = &recording {
                r.truth(sample);
            }
        }
        watch.sample(t_s, opts.sample_period_s, t.v_m_s, t.omega_rad_s, driving.is_some());
        if k % check_every == 0 {
            watch.check_clients(&stack.registry, t_s);
            watch.check_wiring(&stack.registry, &behaviours, driving.as_deref(), t_s).await;
        }
        let following = driving.is_some();
        let center = driving.as_deref() == Some("centerfollow");
        let sample = Sample {
            t_s: k as f64 * opts.sample_period_s,
            x_m: t.x_m,
            y_m: t.y_m,
            travelled_m: t.travelled_m,
            driving: driving.clone(),
            left_m: following.then(|| truth.side_nearest(Side::Left)).flatten(),
            right_m: center.then(|| truth.side_nearest(Side::Right)).flatten(),
            bumps: t.contact_onsets,
        };
        metrics.add(&sample);
        hours.span.add(&sample);
        if k % hours.every == 0 {
            while let Ok(e) = ev_rx.try_recv() {
                events.push(e);
            }
            hours.take(sample.t_s, &stack.registry, &metrics, &events, Some(&sample));
        }
        if k % progress_every == 0
            && let Some(p) = &opts.progress
        {
            p(k as f64 * opts.sample_period_s);
        }
    }
    if let Some(p) = plan {
        p.abort();
    }
    // The span since the last row, if any (a run that is not a whole number of periods, or
    // that ended early).
    if hours.rows.last().is_none_or(|h| h.end_s < simulated_s - 1e-6) {
        while let Ok(e) = ev_rx.try_recv() {
            events.push(e);
        }
        hours.take(simulated_s, &stack.registry, &metrics, &events, None);
    }
    let robot = opts.config.robot_name();
    // A robot server the supervisor gave up on has no counters to give: the report says how
    // the run ended, and its safety figures are zero.
    let safety =
        match QueryClient::<Empty, SafetyCounters>::connect(&stack.registry, nomad200::SAFETY.on(robot)) {
            Ok(c) => c.query(Empty {}, Some(Duration::from_secs(1))).await,
            Err(e) => Err(e),
        };
    let safety = match (safety, &ended) {
        (Ok(s), _) => s,
        (Err(e), Ended::Completed) => return Err(e.into()),
        (Err(e), _) => {
            tracing::warn!("the robot server's safety counters are lost with it: {e}");
            SafetyCounters::default()
        }
    };
    let faults_switch = stack.registry.faults();
    let clock = stack.registry.clock();
    let boards = stack.board_faults.clone();
    let delivery = integrity::DeliveryReport::from_ledger(&stack.registry);
    while let Ok(change) = wrx.try_recv() {
        driving = change.driving.clone();
    }
    let held = watch.finish(&stack.registry, &behaviours, driving.as_deref()).await;
    drop(wiring);
    stack.shutdown().await;
    while let Ok(e) = ev_rx.try_recv() {
        events.push(e);
    }
    let restarts = events.iter().filter(|e| e.kind == SupervisorEventKind::Restarted).count() as u64;
    let safety = SafetyFigures {
        commands_applied: safety.applied,
        stale_commands_refused: safety.stale_refused,
        command_timeouts: safety.timeouts,
        stale_commands_applied: safety.stale_applied,
    };
    let mut report = Report::new(opts.world_label, opts.seed, simulated_s, &metrics, restarts, safety);
    report.ended = ended;
    report.delivery = delivery;
    report.integrity = held;
    report.hours = hours.rows;
    if let Some(plan) = &opts.faults {
        let (by_child, restart_ms) = crate::faults::restarts_of(&events);
        report.faults = Some(crate::faults::FaultsReport::new(
            plan,
            opts.duration_s,
            &faults_switch,
            &clock,
            &boards,
            by_child,
            restart_ms,
        ));
        if let Some(f) = report.faults.as_mut() {
            let (d, i) = (&report.delivery, &report.integrity);
            f.loss = Some(crate::faults::LossFigures {
                lost_must_arrive: d.lost_must_arrive,
                lost: d.total.lost,
                failed: d.total.failed,
                duplicates: d.total.duplicates,
                dropped_by_plan: d.total.dropped,
                superseded: d.total.superseded,
                subscription_mismatches: i.client_mismatches,
                wiring_mismatches: i.wiring_mismatches,
            });
            f.safety = Some(crate::faults::FaultSafety {
                bumps: report.bumps,
                driven_unwired_s: i.driven_unwired_s,
                driven_on_stale_command_s: i.driven_on_stale_command_s,
                stale_commands_applied: report.safety.stale_commands_applied,
            });
        }
    }
    let recording = recording.and_then(|r| r.finish().transpose());
    Ok(RunOutcome { report, metrics, supervisor_events: events, recording })
}

/// The truth `t` and the people `truth` knows of, for the recording's views.
fn truth_sample(
    t: orsa_hardware::sim::Truth,
    truth: &orsa_hardware::sim::SimTruth,
) -> crate::record::views::TruthSample {
    let people = truth
        .movers()
        .into_iter()
        .map(|m| crate::record::views::Person {
            x_m: m.x_m,
            y_m: m.y_m,
            radius_m: m.radius_m,
            yielding: m.yielding,
        })
        .collect();
    crate::record::views::TruthSample {
        at: t.stamp,
        x_m: t.x_m,
        y_m: t.y_m,
        heading_rad: t.heading_rad,
        people,
    }
}

/// The report's hourly rows, as a run takes them.
struct Hours {
    /// Metric samples between two rows.
    every: u64,
    sample_period_s: f64,
    /// The current span's measures.
    span: Metrics,
    /// Where the current span started, s, and the distance travelled then, m.
    start: (f64, f64),
    /// The ledger's totals at the start of the span: (lost that must arrive, all).
    ledger_before: (u64, orsa_actors::ledger::DeliveryCounts),
    rows: Vec<report::HourFigures>,
}

impl Hours {
    fn new(every_s: f64, sample_period_s: f64, registry: &orsa_actors::Registry) -> Self {
        let every = ((every_s / sample_period_s).round() as u64).max(1);
        let d = integrity::DeliveryReport::from_ledger(registry);
        Hours {
            every,
            sample_period_s,
            span: Metrics::new(sample_period_s).keeping_series(false),
            start: (0.0, 0.0),
            ledger_before: (d.lost_must_arrive, d.total),
            rows: Vec::new(),
        }
    }

    /// Takes the row of the span ending now, at `end_s`, and starts the next one after `last`
    /// (the sample that ended it; `None` at the end of the run).
    fn take(
        &mut self,
        end_s: f64,
        registry: &orsa_actors::Registry,
        whole: &Metrics,
        events: &[SupervisorEvent],
        last: Option<&Sample>,
    ) {
        let (start_s, start_m) = self.start;
        let mut row =
            report::HourFigures::measures(end_s, end_s - start_s, &self.span, whole.distance_m - start_m);
        (row.rss_kib, row.hwm_kib) = metrics::process_memory();
        row.restarts = events.iter().filter(|e| e.kind == SupervisorEventKind::Restarted).count() as u64;
        row.bumps = whole.bumps;
        row.stalls = whole.stalls;
        let d = integrity::DeliveryReport::from_ledger(registry);
        let (must_before, before) = self.ledger_before;
        row.lost_must_arrive = d.lost_must_arrive.saturating_sub(must_before);
        row.lost = d.total.lost.saturating_sub(before.lost);
        row.failed = d.total.failed.saturating_sub(before.failed);
        row.duplicates = d.total.duplicates.saturating_sub(before.duplicates);
        row.sizes = report::Sizes {
            components: registry.components().len(),
            services: registry.services().len(),
            subscriptions: registry.clients().values().sum(),
            ledger_services: registry.ledger().counts().len(),
            tasks: tokio::runtime::Handle::current().metrics().num_alive_tasks(),
            supervisor_events: events.len(),
            fault_log: registry.faults().event_count(),
            trajectory: whole.trajectory.len(),
        };
        self.rows.push(row);
        self.ledger_before = (d.lost_must_arrive, d.total);
        if let Some(last) = last {
            self.span = Metrics::after(self.sample_period_s, last);
            self.start = (last.t_s, last.travelled_m);
        }
    }
}

/// What ended a run before its time.
enum Early {
    /// A signal, by name.
    Interrupted(String),
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
