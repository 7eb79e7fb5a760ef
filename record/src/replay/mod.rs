//! Replaying a recording: running its deciding components again, bit for bit, or with other
//! parameters ("what if").
//!
//! A recording made with `--record` carries what a replay needs (see [`crate::record::meta`]):
//! the effective config, the world, the seed, the versions and the components that ran. A
//! replay brings the same system up again on a paused clock, from the recorded config, with one
//! change: the robot server is a stand-in ([`standin`]) that publishes and answers what the
//! recording says the robot published and answered, at the recorded times. Everything else
//! (behaviours, master, planner, or whatever the recording says ran) is the real code, and
//! everything it produces (every Send, query, push, event, wiring and state change, restart)
//! is compared with the recording, message by message, byte for byte.
//!
//! - [`mod@file`]: reads and checks a recording;
//! - [`standin`]: the robot server's stand-in;
//! - [`diff`]: the first divergence, and what a what-if changed.
//!
//! The recording's last instant is left out of the comparison: the recording process stops
//! recording in the middle of it, so which of its messages made it into the file is not part of
//! what the system decided. A run's recording ends, for the comparison, at the run's end: what
//! it holds after that is its process shutting the system down.

pub mod diff;
pub mod exchange;
pub mod file;
mod sequence;
pub mod standin;

use crate::config::Config;
use crate::system::{Catalog, System};
use diff::{Divergence, Messages, Timing, WhatIf};
use file::{Control, Recorded, Recording};
use orsa_actors::supervision::SupervisorEvent;
use orsa_actors::tap::Tap;
use orsa_actors::{Clock, Registry, Timestamp};
use parking_lot::Mutex;
use std::future::Future;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// Why a recording cannot be replayed. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The file could not be read.
    #[error("{path}: cannot read the recording: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// It is not a readable MCAP file.
    #[error("{path}: not a readable recording: {problem}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong, and where.
        problem: String,
    },
    /// It has no `run` metadata record.
    #[error(
        "{path}: the recording says nothing of the run that made it (no '{}' metadata record): \
         it was not made by `orsa run|robot|executive --record` of this version, so it cannot be replayed",
        crate::record::meta::RUN_METADATA
    )]
    NoMetadata {
        /// The file.
        path: PathBuf,
    },
    /// Its metadata is incomplete or wrong.
    #[error("{path}: {problem}")]
    Metadata {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// It was made by another orsa or wire version.
    #[error("{path}: cannot be replayed by this orsa: {problem}")]
    Version {
        /// The file.
        path: PathBuf,
        /// The versions.
        problem: String,
    },
    /// A channel's schema or encoding is not the one its service carries.
    #[error("{path}: channel '{topic}': {problem}")]
    Schema {
        /// The file.
        path: PathBuf,
        /// The channel's topic.
        topic: String,
        /// What does not match.
        problem: String,
    },
    /// A message the replay feeds does not decode.
    #[error("{path}: channel '{topic}', message at log time {log_time}: {problem}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// The channel's topic.
        topic: String,
        /// The message's log time.
        log_time: Timestamp,
        /// Why.
        problem: String,
    },
    /// The recorded configuration (or the what-if's) cannot be used.
    #[error("{0}")]
    Config(String),
    /// The system could not be brought up.
    #[error("starting the replayed system: {0}")]
    Start(String),
}

/// How to replay.
#[derive(Default)]
pub struct ReplayOptions {
    /// Replay with this configuration instead of the recorded one (a what-if).
    pub config: Option<Config>,
    /// Called with the replayed time, s, every `progress_every_s`.
    pub progress: Option<Arc<dyn Fn(f64) + Send + Sync>>,
    /// How often to call `progress`, replayed seconds (default: every 10 s).
    pub progress_every_s: Option<f64>,
    /// For a recording made live: how far from its recorded log time a replayed message may
    /// be (default [`LIVE_TOLERANCE`]). A paused-clock recording is replayed to the instant.
    pub tolerance: Option<Duration>,
}

/// How far a replayed message of a live recording may be from its recorded log time, unless
/// told otherwise: a live process logs each message when its handler gets to it, some
/// microseconds to milliseconds after the input that caused it (and, at start, after the
/// components came up); the replay logs it at the instant of the input.
pub const LIVE_TOLERANCE: Duration = Duration::from_millis(250);

/// What a replay produced.
#[derive(Debug)]
pub struct Replayed {
    /// Messages the stand-in published or answered from the recording.
    pub fed: usize,
    /// Recorded messages compared (before the end).
    pub compared: usize,
    /// Topics compared.
    pub topics: usize,
    /// The recording's last instant, ns (the comparison ends there, or a tolerance before it).
    pub end: u64,
    /// How instants are compared: to the nanosecond, or within a tolerance (live recordings).
    pub timing: Timing,
    /// The largest offset between a replayed message's log time and its recorded one, ns.
    pub largest_offset_ns: u64,
    /// Control events fed from the recording (a remote executive's wiring and state changes,
    /// the link watchdog's).
    pub controls: usize,
    /// What the replayed components produced, per topic.
    pub replayed: Messages,
    /// The first divergence, if any.
    pub divergence: Option<Divergence>,
    /// Replayed seconds.
    pub replayed_s: f64,
}

impl Replayed {
    /// Whether every compared message was replayed bit for bit.
    pub fn bit_exact(&self) -> bool {
        self.divergence.is_none()
    }

    /// What a what-if changed against `recording`.
    pub fn what_if(&self, recording: &Recording) -> WhatIf {
        let driving =
            format!("{}/{}", orsa_interfaces::executive::NAME, orsa_interfaces::executive::DRIVING.name());
        diff::what_if(
            &recording.outputs,
            &self.replayed,
            recording.meta.clock_origin_ns,
            self.end,
            &driving,
            self.timing,
        )
    }
}

/// The configuration a recording ran with.
pub fn recorded_config(rec: &Recording) -> Result<Config, ReplayError> {
    let origin =
        format!("{} (metadata '{}', key config_toml)", rec.path.display(), crate::record::meta::RUN_METADATA);
    let config =
        Config::from_toml(&rec.meta.config_toml, &origin).map_err(|e| ReplayError::Config(e.to_string()))?;
    Ok(config)
}

/// A tap that keeps what the replayed components produce, leaving out what is fed.
struct Capture {
    meta: crate::record::RunMeta,
    messages: Arc<Mutex<Messages>>,
    /// Told of every output, in a live replay (see [`sequence`]).
    sequencer: std::sync::OnceLock<std::sync::Weak<sequence::Sequencer>>,
}

impl Capture {
    fn keep(&self, topic: &str, stamp: Timestamp, json: &[u8]) {
        if !file::is_compared(&self.meta, topic) {
            return;
        }
        // The recorder stores the tap's bytes as they are, so equal messages are equal bytes.
        let data = json.to_vec();
        let mut m = self.messages.lock();
        let list = match m.get_mut(topic) {
            Some(list) => list,
            None => m.entry(Arc::from(topic)).or_default(),
        };
        list.push(Recorded { log_time: stamp.as_nanos(), data });
        drop(m);
        if let Some(seq) = self.sequencer.get().and_then(std::sync::Weak::upgrade) {
            // A control that waited for this output goes at once, before anything else runs,
            // as it went right after it live; one that goes after the steps is the feeder's.
            seq.apply_ready(false);
            seq.moved.notify_one();
        }
    }
}

impl Tap for Capture {
    fn record(&self, topic: &str, _type_id: &str, stamp: Timestamp, json: &[u8]) {
        self.keep(topic, stamp, json);
    }
}

/// Replays `rec` (see the module docs). Runs on whatever tokio runtime calls it: a paused
/// current-thread runtime replays as fast as it can, and deterministically.
pub async fn replay(rec: &Recording, opts: ReplayOptions) -> Result<Replayed, ReplayError> {
    let config = match opts.config {
        Some(c) => c,
        None => recorded_config(rec)?,
    };
    if config.robot_name() != rec.meta.robot {
        return Err(ReplayError::Config(format!(
            "robot.name: the recording's robot server is '{}', and the configuration names '{}'",
            rec.meta.robot,
            config.robot_name()
        )));
    }
    let Some(robot) = config.system.components.iter().find(|c| c.name == rec.meta.robot) else {
        return Err(ReplayError::Config(format!(
            "system.components: the recording's robot server '{}' is not a component of the system",
            rec.meta.robot
        )));
    };
    let clock = match rec.meta.clock_origin_ns {
        0 => Clock::simulated(),
        origin => Clock::starting_at(tokio::time::Instant::now(), Timestamp(origin)),
    };
    let registry = Registry::with_clock(clock);
    let capture = Arc::new(Capture {
        meta: rec.meta.clone(),
        messages: Arc::default(),
        sequencer: std::sync::OnceLock::new(),
    });
    registry.set_tap(Some(capture.clone() as Arc<dyn Tap>));
    registry.ledger().enable(true);

    // Where the robot is replayed, its stand-in makes the requests to parameters, in order
    // among its publications; elsewhere (an executive's recording) they are made at their times.
    let standin_asks = rec.meta.process == "run" || rec.meta.hosted.contains(&rec.meta.robot);
    let playback = Arc::new(standin::Playback {
        published: rec.published.clone(),
        answers: Mutex::new(rec.answers.clone()),
        cursor: Default::default(),
        requests: rec
            .controls
            .iter()
            .filter(|_| standin_asks)
            .filter_map(|(at, c)| match c {
                Control::Param { component, request, after } => {
                    Some((*at, *after, component.clone(), request.clone()))
                }
                _ => None,
            })
            .collect(),
        asked: Default::default(),
        // Where the stand-in publishes, the controls keep their recorded place among its
        // publications.
        order: (standin_asks && !rec.controls.is_empty() && rec.controls_after.len() == rec.controls.len())
            .then(|| standin::Order { controls_after: rec.controls_after.clone(), ..Default::default() }),
    });
    let gate = playback.order.is_some().then(|| Arc::clone(&playback));
    // Live, each control goes where the recording has it among the publications and the
    // outputs of what it acts on (see `sequence`).
    let sequencer = (rec.meta.live && gate.is_some() && rec.controls_outputs.len() == rec.controls.len())
        .then(|| {
            let seq = Arc::new(sequence::Sequencer::new(
                registry.clone(),
                rec,
                !standin_asks,
                Arc::clone(&playback),
                Arc::clone(&capture.messages),
            ));
            let _ = capture.sequencer.set(Arc::downgrade(&seq));
            if let Some(order) = &playback.order {
                let weak = Arc::downgrade(&seq);
                order.on_publish.set(move || {
                    if let Some(seq) = weak.upgrade() {
                        seq.apply_ready(false);
                        // What goes after the steps on it is the feeder's.
                        seq.moved.notify_one();
                    }
                });
            }
            seq
        });
    let mut catalog = Catalog::builtin();
    let params = config.robot().clone();
    catalog.register(robot.kind(), crate::system::Place::Robot, move |_, _| {
        Ok(standin::RecordedRobot { params: params.clone(), playback: Arc::clone(&playback) })
    });
    let hosted: Vec<&str> = rec.meta.hosted.iter().map(String::as_str).collect();
    let events = Arc::clone(&capture);
    // The supervisor as the recording process named it (its events carry the name).
    let supervisor = match rec.meta.process.as_str() {
        "run" => crate::system::TOP_SUPERVISOR,
        "robot" => crate::system::ROBOT_TOP,
        "executive" => crate::system::EXECUTIVE_TOP,
        other => {
            return Err(ReplayError::Metadata {
                path: rec.path.clone(),
                problem: format!(
                    "metadata '{}': key 'process' is '{other}': this orsa replays recordings of \
                     `orsa run`, `orsa robot` and `orsa executive`",
                    crate::record::meta::RUN_METADATA
                ),
            });
        }
    };
    // What came back from other processes' services comes back again, at its times.
    if !rec.exchange.is_empty() {
        let sink = Arc::clone(&capture);
        let note: exchange::Note = Arc::new(move |topic, stamp, json| sink.keep(topic, stamp, json));
        let playback = exchange::PlaybackTransport::new(Arc::new(rec.exchange.clone()), clock, note);
        registry.set_transport(Arc::new(playback));
    }
    if let Some(at) = rec.system_starting {
        tokio::time::sleep_until(clock.instant_of(Timestamp(at))).await;
    }
    // The navigation components' known map is the recorded world (none for a process that
    // simulated none).
    let world = match rec.meta.world_toml.trim() {
        "" => None,
        text => Some(orsa_hardware::world::World::from_str(text, "the recording's world").map_err(|e| {
            ReplayError::Metadata {
                path: rec.path.clone(),
                problem: format!("metadata '{}': key 'world_toml': {e}", crate::record::meta::RUN_METADATA),
            }
        })?),
    };
    let mut builder = System::builder(&config);
    if let Some(world) = world {
        builder = builder.world(world);
    }
    let system = builder
        .catalog(catalog)
        .select(&hosted)
        .supervisor(supervisor)
        .duration(rec.meta.duration_s)
        .on_event(move |e: SupervisorEvent| {
            // As the recording writes them (`McapTap::supervisor_event`).
            if let Ok(json) = serde_json::to_vec(&e) {
                events.keep(crate::record::events::SUPERVISION_EVENTS, e.at, &json);
            }
        })
        .start(&registry)
        .await
        .map_err(|e| ReplayError::Start(e.to_string()))?;

    // The recorded fault plan breaks the replayed system as it broke the recorded one: the
    // same handler faults at the same times, the same messages dropped, delayed, duplicated.
    // (Hardware faults are already in the recorded scans; nothing reads the boards here.)
    let plan = match &rec.meta.faults_toml {
        Some(text) => {
            let origin = format!(
                "{} (metadata '{}', key faults_toml)",
                rec.path.display(),
                crate::record::meta::RUN_METADATA
            );
            let targets = match rec.meta.process.as_str() {
                "robot" => crate::faults::PlanTargets::for_robot(&config),
                _ => crate::faults::PlanTargets::for_stack(&config),
            };
            let mut plan = crate::faults::FaultPlan::parse(text, &origin, &targets)
                .map_err(|e| ReplayError::Config(e.to_string()))?;
            // The robot server is a stand-in here: what its failures made it publish is in the
            // recording, and its panics, hangs and kills are not its stand-in's to repeat.
            plan.faults.retain(|f| {
                use crate::faults::Action;
                !matches!(&f.action,
                    Action::Panic { component } | Action::Hang { component } | Action::Kill { component }
                        if *component == rec.meta.robot)
            });
            // Nor are the world's events: what the sensors saw of them is in the recording.
            plan.faults.retain(|f| !crate::faults::WORLD_EVENTS.contains(&f.kind.as_str()));
            // Link cuts are not replayed: what the robot did about them is in the recording
            // (the link watchdog's events, the wiring changes) and is fed back.
            let targets = crate::faults::FaultTargets {
                faults: registry.faults(),
                boards: orsa_hardware::faulty::BoardFaults::new(rec.meta.seed),
                link: None,
                stage: None,
            };
            let start = rec.plan_started.map(|t| clock.instant_of(Timestamp(t)));
            let end_s = rec.meta.duration_s;
            Some(tokio::spawn(async move {
                if let Some(start) = start {
                    tokio::time::sleep_until(start).await;
                }
                crate::faults::run_plan(plan, targets, end_s).await
            }))
        }
        None => None,
    };

    // What came from outside the replayed components, at its recorded time.
    let controls = match sequencer {
        Some(seq) => tokio::spawn(sequence::feed(seq)),
        None => tokio::spawn(feed_controls(
            registry.clone(),
            rec.controls.clone(),
            rec.meta.robot.clone(),
            !standin_asks,
            gate,
        )),
    };

    // A recording goes on while its process shuts the system down (a hung component may hold
    // that up for seconds); what the system decided ends with the run's last instant, which
    // the recording says (a process may have been quiet for seconds before it: an executive
    // that decided everything at its start). Older recordings end at their last message.
    let end = match rec.meta.process.as_str() {
        "run" => {
            let ended =
                Timestamp(rec.meta.clock_origin_ns).after(Duration::from_secs_f64(rec.meta.duration_s));
            rec.last_log_time.min(ended.as_nanos()).min(rec.ended.as_ref().map_or(u64::MAX, |e| e.at_ns))
        }
        _ => rec.ended.as_ref().map_or(rec.last_log_time, |e| e.at_ns),
    };
    let end_at = clock.instant_of(Timestamp(end));
    let every = Duration::from_secs_f64(opts.progress_every_s.unwrap_or(10.0).max(0.001));
    let mut next = tokio::time::Instant::now() + every;
    while next < end_at {
        tokio::time::sleep_until(next).await;
        if let Some(p) = &opts.progress {
            p(clock.since_start(clock.now()).as_secs_f64());
        }
        next += every;
    }
    tokio::time::sleep_until(end_at).await;
    registry.set_tap(None);
    if let Some(p) = plan {
        p.abort();
    }
    controls.abort();
    let replayed_s = clock.since_start(clock.now()).as_secs_f64();
    system.shutdown().await;

    let replayed = std::mem::take(&mut *capture.messages.lock());
    let timing = if rec.meta.live {
        Timing::Within(opts.tolerance.unwrap_or(LIVE_TOLERANCE).as_nanos().try_into().unwrap_or(u64::MAX))
    } else {
        Timing::Exact
    };
    let (divergence, largest_offset_ns) =
        diff::first_divergence(&rec.outputs, &replayed, rec.meta.clock_origin_ns, end, timing);
    let cut = timing.cut(end);
    let compared = rec.outputs.values().map(|v| v.partition_point(|r| r.log_time < cut)).sum();
    let topics = rec.outputs.len();
    Ok(Replayed {
        fed: rec.published.len()
            + rec.answers.robotparams.len()
            + rec.answers.safety.len()
            + rec.exchange.len(),
        compared,
        topics,
        end,
        timing,
        largest_offset_ns,
        controls: rec.controls.len(),
        replayed,
        divergence,
        replayed_s,
    })
}

/// How often the control feeder yields, after the publications recorded before a control are
/// out, so that what they set going runs before the control (see [`feed_controls`]).
pub(super) const SETTLE_YIELDS: usize = 32;

/// Feeds `controls` to the replayed components at their recorded times: a behaviour's port
/// wired or its state set as the recording says, and, where the link watchdog lost an
/// executive, the command it sent `robot` (zero), as it was; if `ask`, the requests to
/// parameters too (otherwise the robot's stand-in makes them). With `gate`, each goes after
/// the stand-in's publications recorded before it, and before those recorded after it.
async fn feed_controls(
    registry: Registry,
    controls: Vec<(u64, Control)>,
    robot: String,
    ask: bool,
    gate: Option<Arc<standin::Playback>>,
) {
    let clock = registry.clock();
    let applier = Applier::new(&registry, &robot, ask);
    let order = gate.as_ref().and_then(|p| p.order.as_ref().map(|o| (p, o)));
    for (j, (at, control)) in controls.into_iter().enumerate() {
        tokio::time::sleep_until(clock.instant_of(Timestamp(at))).await;
        if let Some((playback, order)) = order {
            let after = order.controls_after[j];
            order.until(|| playback.cursor.load(std::sync::atomic::Ordering::SeqCst) >= after).await;
            // What those publications set going (a behaviour's step, its command) runs first, as
            // it did before the control in the recording: each yield lets every task that is
            // ready run once, and a publication reaches a command in a few hops.
            for _ in 0..SETTLE_YIELDS {
                tokio::task::yield_now().await;
            }
        }
        if let Some(pending) = applier.apply(control) {
            pending.await;
        }
        if let Some((_, order)) = order {
            order.applied(j);
        }
    }
}

/// Applies the controls fed from outside the replayed components.
pub(crate) struct Applier {
    registry: Registry,
    /// The robot's velocity commands, as the link watchdog sent them (one client: its
    /// sequence numbers go on from one command to the next, as the watchdog's did).
    /// Connected at the first command (the stand-in serves it once the system is up).
    motors: std::sync::OnceLock<
        Option<orsa_actors::send::SendClient<orsa_interfaces::nomad200::NavigationVelocity>>,
    >,
    robot: String,
    /// Whether it makes the requests to parameters (otherwise the robot's stand-in does).
    ask: bool,
}

impl Applier {
    /// An applier for the components of `registry`, with `robot` the robot server's name.
    pub(crate) fn new(registry: &Registry, robot: &str, ask: bool) -> Applier {
        Applier { registry: registry.clone(), motors: Default::default(), robot: robot.to_owned(), ask }
    }

    /// Applies `control`: a behaviour's port wired or its state set as the recording says
    /// (what may wait is the future returned: a local change does not), the command the link
    /// watchdog sent (zero), a request to a component's parameters.
    pub(crate) fn apply(
        &self,
        control: Control,
    ) -> Option<std::pin::Pin<Box<dyn Future<Output = ()> + Send>>> {
        use orsa_actors::state::StateMaster;
        use orsa_actors::wiring::WiringMaster;
        let registry = self.registry.clone();
        match control {
            Control::Port { component, status } => Some(Box::pin(async move {
                let wiring = WiringMaster::new(&registry);
                let done = match &status.target {
                    Some(target) => wiring.connect_named(&component, &status.port, target).await,
                    None => wiring.disconnect_named(&component, &status.port).await,
                };
                if let Err(e) = done {
                    tracing::warn!("replay: cannot wire {component}.{} as recorded: {e}", status.port);
                }
            })),
            Control::State { component, status } => Some(Box::pin(async move {
                if let Ok(master) = StateMaster::connect(&registry, &component) {
                    let wanted = status.pending.unwrap_or(status.current);
                    // At once where nothing holds it up; else on its own task: a state change
                    // waits for its substates to be released.
                    if master.try_set_state(&wanted).await.is_err() {
                        tokio::spawn(async move {
                            if let Err(e) = master.set_state(&wanted).await {
                                tracing::warn!(
                                    "replay: cannot set {component} to '{wanted}' as recorded: {e}"
                                );
                            }
                        });
                    }
                }
            })),
            Control::Param { component, request, .. } => {
                if self.ask {
                    standin::ask(&registry, &component, request);
                }
                None
            }
            Control::Link(e) => {
                let motors = self.motors.get_or_init(|| {
                    let motors =
                        orsa_interfaces::nomad200::NAVIGATIONVELOCITY.on(self.robot.as_str()).untyped();
                    orsa_actors::send::SendClient::connect(&self.registry, &motors)
                        .inspect_err(|e| tracing::warn!("replay: cannot reach the robot's motors: {e}"))
                        .ok()
                });
                if let (Some(command), Some(m)) = (e.command, motors)
                    && let Err(e) = m.send(command)
                {
                    tracing::warn!("replay: cannot command zero as the link watchdog did: {e}");
                }
                None
            }
        }
    }
}
