//! Simulation speed and scale: the full stack on the reference corridor on a paused clock.
//!
//! - [`mission`] is `orsa run` minus the printing: one robot, with the metrics sampling.
//! - [`scale`] brings up N robots, each with its whole stack (simulator, server, two
//!   behaviours, master, planner under its own supervisor and registry), on one current-thread
//!   runtime with a paused clock (as `orsa run` runs), lets them settle, then measures how many
//!   simulated seconds the whole set covers per wall second.
//! - [`raw_scale`] is its baseline, measured beside each [`scale`] row: N copies of the
//!   stack's skeleton in raw tokio, with none of its work or data: per robot the same number of
//!   tasks (13), timers at the same periods (the simulator's step and the four timed sensor
//!   services), and the same message flow per simulated second (each sensor tick goes to the
//!   server, which asks the simulator and answers through a oneshot, then hands infrared scans
//!   to both behaviours and sonar scans to the wired one, which sends a command back through
//!   the server to the simulator: about 580 task wake-ups per robot per simulated second, as
//!   the stack's deliveries count them), through unbounded channels. What the skeleton's cost
//!   per robot does from 1 to 1000 robots is the scheduler's, the timer wheel's and the
//!   channels' on this machine, not orsa's.
//! - [`raw_scale`] also runs the skeleton with the stack's six actors (server, behaviours,
//!   master, planner and their supervisor) as plain ractor actors, the rest as above: what the actor
//!   runtime adds to the raw skeleton, per robot and as robots are added, still with none of
//!   the stack's work or data.

use super::{MissionRtf, ScaleRow};
use anyhow::{Context as _, anyhow};
use orsa::config::Config;
use orsa::mission::stack::Stack;
use orsa::mission::{self, RunOptions};
use orsa_actors::supervision::SupervisorEventKind;
use orsa_hardware::sim::SimRobot;
use orsa_hardware::world::World;
use ractor::{Actor, ActorCell, ActorProcessingErr, ActorRef};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender};

fn paused_runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .start_paused(true)
        .build()
        .context("cannot start a tokio runtime")
}

/// The corridor mission for `duration_s` simulated seconds, timed as `orsa run` times it
/// (start-up and shutdown included).
pub(crate) fn mission(duration_s: f64) -> anyhow::Result<MissionRtf> {
    let world = World::palazzina()?;
    let opts = RunOptions::new(world, "palazzina (built in)", Config::default(), 1, duration_s);
    let rt = paused_runtime()?;
    let wall = Instant::now();
    let out = rt.block_on(mission::run(opts))?;
    let wall_s = wall.elapsed().as_secs_f64();
    Ok(MissionRtf {
        simulated_s: duration_s,
        wall_s,
        rtf: duration_s / wall_s,
        distance_m: out.report.distance_m,
        restarts: out.report.restarts,
    })
}

/// The runs [`record_replay`] alternates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Variant {
    Plain,
    Record,
    /// With a live server (`--foxglove`) and no client.
    Live,
}

/// `orsa run` without and with `--record`, with a live server and no client, and `orsa replay`
/// of the recording, `runs` times each, alternated, for `duration_s` simulated seconds.
pub(crate) fn record_replay(duration_s: f64, runs: usize) -> anyhow::Result<super::RecordReplay> {
    let world = World::palazzina()?;
    let dir = std::env::temp_dir().join(format!("orsa-bench-replay-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let path = dir.join("run.mcap");
    let (mut plain, mut recorded, mut replayed) = (Vec::new(), Vec::new(), Vec::new());
    let mut live = Vec::new();
    let (mut bit_exact, mut messages, mut compared) = (true, 0, 0);
    for _ in 0..runs.max(1) {
        for variant in [Variant::Plain, Variant::Record, Variant::Live] {
            let mut opts =
                RunOptions::new(world.clone(), "palazzina (built in)", Config::default(), 1, duration_s);
            opts.record = (variant == Variant::Record).then(|| path.clone());
            // A live server with no client, as `--foxglove` starts it (its start is not timed:
            // `orsa run` starts it before the run).
            let server = match variant {
                Variant::Live => {
                    let setup = orsa::mission::recording::view_setup(&opts.config, Some(world.clone()), true);
                    let server = orsa::live::LiveView::start(
                        std::net::SocketAddr::from(([127, 0, 0, 1], 0)),
                        setup,
                        None,
                        None,
                    )?;
                    opts.live = Some(server.tap());
                    Some(server)
                }
                _ => None,
            };
            let rt = paused_runtime()?;
            let wall = Instant::now();
            let out = rt.block_on(mission::run(opts))?;
            if let Some(r) = out.recording {
                r?;
            }
            let wall_s = wall.elapsed().as_secs_f64();
            if let Some(server) = server {
                server.finish();
            }
            match variant {
                Variant::Plain => plain.push(wall_s),
                Variant::Record => recorded.push(wall_s),
                Variant::Live => live.push(wall_s),
            }
        }
        let rt = paused_runtime()?;
        let wall = Instant::now();
        let rec = orsa::replay::file::Recording::open(&path)?;
        let out = rt.block_on(orsa::replay::replay(&rec, orsa::replay::ReplayOptions::default()))?;
        replayed.push(wall.elapsed().as_secs_f64());
        bit_exact &= out.bit_exact();
        messages = rec.messages;
        compared = out.compared as u64;
    }
    let file_bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let _ = std::fs::remove_dir_all(&dir);
    let median = |v: &[f64]| super::stats::median(v.to_vec()).unwrap_or(f64::NAN);
    let base = median(&plain);
    Ok(super::RecordReplay {
        simulated_s: duration_s,
        record_ratio: median(&recorded) / base,
        replay_ratio: median(&replayed) / base,
        live_ratio: median(&live) / base,
        live_wall_s: live,
        run_wall_s: plain,
        record_wall_s: recorded,
        replay_wall_s: replayed,
        bit_exact,
        messages,
        compared,
        file_bytes,
    })
}

/// What the skeleton's server receives.
enum RawServerMsg {
    /// A timed sensor service ticked (0: infrared, 1: sonar, 2: bumpers, 3: base state).
    Tick(u8),
    /// The wired behaviour's command.
    Command(u64),
}

/// What the skeleton's simulator receives.
enum RawSimMsg {
    /// Read a sensor; the answer goes back through the oneshot.
    Read(tokio::sync::oneshot::Sender<u64>),
    /// A motor command.
    Command(u64),
}

/// What [`raw_scale`] measured.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct RawScale {
    /// Wall µs per robot per simulated second, over the measured span.
    pub(crate) us_per_robot_sim_s: f64,
    /// Simulator steps, all robots, the whole run.
    pub(crate) steps: u64,
    /// Commands that reached a simulator, all robots, the whole run.
    pub(crate) commands: u64,
}

/// What every robot's skeleton counts into.
#[derive(Default)]
struct RawCounts {
    steps: AtomicU64,
    commands: AtomicU64,
}

/// The skeleton's simulator: steps on its timer, answers reads, takes commands.
async fn raw_sim(mut sim_rx: UnboundedReceiver<RawSimMsg>, step: Duration, counts: Arc<RawCounts>) {
    let mut tick = tokio::time::interval(step);
    let (mut steps, mut command) = (0u64, 0u64);
    loop {
        tokio::select! {
            _ = tick.tick() => {
                steps = steps.wrapping_add(1 + command % 2);
                counts.steps.fetch_add(1, Ordering::Relaxed);
            }
            msg = sim_rx.recv() => match msg {
                Some(RawSimMsg::Read(reply)) => {
                    let _ = reply.send(steps);
                }
                Some(RawSimMsg::Command(c)) => {
                    command = c;
                    counts.commands.fetch_add(1, Ordering::Relaxed);
                }
                None => return,
            },
        }
    }
}

/// The skeleton's four timed sensor services, each a task that sends its kind (as
/// [`RawServerMsg::Tick`]) through `tick` at its period until `tick` fails.
fn raw_timers(
    config: &Config,
    tasks: &mut Vec<tokio::task::JoinHandle<()>>,
    tick: impl Fn(u8) -> bool + Clone + Send + 'static,
) {
    let p = config.robot().push_periods();
    for (kind, period) in
        [p.distanceir_s, p.distanceson_s, p.bumpers_s, p.basestate_s].into_iter().enumerate()
    {
        let tick = tick.clone();
        let period = Duration::from_secs_f64(period);
        let kind = u8::try_from(kind).unwrap_or(u8::MAX);
        tasks.push(tokio::spawn(async move {
            let mut timer = tokio::time::interval(period);
            loop {
                timer.tick().await;
                if !tick(kind) {
                    return;
                }
            }
        }));
    }
}

/// The skeleton server's answer to a tick of `kind`: reads the simulator, then hands infrared
/// to both behaviours and sonar to the wired one (`center`). `None`: the simulator is gone.
async fn raw_serve_tick(
    sim: &UnboundedSender<RawSimMsg>,
    kind: u8,
    wall: impl Fn(u64),
    center: impl Fn(u64),
) -> Option<()> {
    let (tx, rx) = tokio::sync::oneshot::channel();
    sim.send(RawSimMsg::Read(tx)).ok()?;
    let reading = rx.await.ok()?;
    match kind {
        0 => {
            wall(reading);
            center(reading);
        }
        1 => center(reading),
        _ => {}
    }
    Some(())
}

/// `n` idle tasks, as the master, planner and supervisor mostly are.
fn raw_idle(n: usize, tasks: &mut Vec<tokio::task::JoinHandle<()>>) {
    for _ in 0..n {
        let (keep, mut idle) = tokio::sync::mpsc::unbounded_channel::<()>();
        tasks.push(tokio::spawn(async move {
            let _keep = keep;
            while idle.recv().await.is_some() {}
        }));
    }
}

/// Starts one robot's skeleton (13 tasks) on the current runtime.
fn raw_robot(config: &Config, counts: &Arc<RawCounts>, tasks: &mut Vec<tokio::task::JoinHandle<()>>) {
    use tokio::sync::mpsc::unbounded_channel;
    let (sim_tx, sim_rx) = unbounded_channel::<RawSimMsg>();
    let (srv_tx, mut srv_rx) = unbounded_channel::<RawServerMsg>();
    let (wall_tx, mut wall_rx) = unbounded_channel::<u64>();
    let (center_tx, mut center_rx) = unbounded_channel::<u64>();
    tasks.push(tokio::spawn(raw_sim(sim_rx, Duration::from_secs_f64(config.sim.step_s), Arc::clone(counts))));
    let srv = srv_tx.clone();
    raw_timers(config, tasks, move |kind| srv.send(RawServerMsg::Tick(kind)).is_ok());
    // The server: reads the simulator on every tick, hands scans on, passes commands down.
    let sim = sim_tx.clone();
    tasks.push(tokio::spawn(async move {
        while let Some(msg) = srv_rx.recv().await {
            match msg {
                RawServerMsg::Tick(kind) => {
                    let wall = |r| {
                        let _ = wall_tx.send(r);
                    };
                    let center = |r| {
                        let _ = center_tx.send(r);
                    };
                    if raw_serve_tick(&sim, kind, wall, center).await.is_none() {
                        return;
                    }
                }
                RawServerMsg::Command(c) => {
                    let _ = sim.send(RawSimMsg::Command(c));
                }
            }
        }
    }));
    // The behaviours: the wired one answers every scan with a command.
    tasks.push(tokio::spawn(async move { while wall_rx.recv().await.is_some() {} }));
    let srv = srv_tx.clone();
    tasks.push(tokio::spawn(async move {
        while let Some(reading) = center_rx.recv().await {
            if srv.send(RawServerMsg::Command(reading)).is_err() {
                return;
            }
        }
    }));
    // The rest of the stack's tasks.
    raw_idle(5, tasks);
    drop((sim_tx, srv_tx));
}

/// What the ractor skeleton's server actor receives.
enum RactorServerMsg {
    /// The behaviours to hand scans to (sent once, after they are spawned).
    Wire(ActorRef<u64>, ActorRef<u64>),
    /// A timed sensor service ticked (as [`RawServerMsg::Tick`]).
    Tick(u8),
    /// The wired behaviour's command.
    Command(u64),
}

/// The ractor skeleton's server: [`raw_robot`]'s server task as an actor.
struct RactorServer;

impl Actor for RactorServer {
    type Msg = RactorServerMsg;
    type State = (UnboundedSender<RawSimMsg>, Option<(ActorRef<u64>, ActorRef<u64>)>);
    type Arguments = UnboundedSender<RawSimMsg>;

    async fn pre_start(
        &self,
        _me: ActorRef<Self::Msg>,
        sim: UnboundedSender<RawSimMsg>,
    ) -> Result<Self::State, ActorProcessingErr> {
        Ok((sim, None))
    }

    async fn handle(
        &self,
        _me: ActorRef<Self::Msg>,
        msg: Self::Msg,
        (sim, behaviours): &mut Self::State,
    ) -> Result<(), ActorProcessingErr> {
        match msg {
            RactorServerMsg::Wire(wall, center) => *behaviours = Some((wall, center)),
            RactorServerMsg::Tick(kind) => {
                if let Some((wall, center)) = behaviours {
                    let wall = |r| {
                        let _ = wall.cast(r);
                    };
                    let center = |r| {
                        let _ = center.cast(r);
                    };
                    raw_serve_tick(sim, kind, wall, center)
                        .await
                        .ok_or("the skeleton's simulator is gone")?;
                }
            }
            RactorServerMsg::Command(c) => {
                let _ = sim.send(RawSimMsg::Command(c));
            }
        }
        Ok(())
    }
}

/// A ractor skeleton's behaviour: the wired one (`to` set) answers every scan with a command;
/// with `to` unset it only receives, as the other behaviour and the idle actors do.
struct RactorBehaviour {
    to: Option<ActorRef<RactorServerMsg>>,
}

impl Actor for RactorBehaviour {
    type Msg = u64;
    type State = ();
    type Arguments = ();

    async fn pre_start(&self, _me: ActorRef<u64>, _args: ()) -> Result<(), ActorProcessingErr> {
        Ok(())
    }

    async fn handle(&self, _me: ActorRef<u64>, reading: u64, _st: &mut ()) -> Result<(), ActorProcessingErr> {
        if let Some(server) = &self.to {
            server.cast(RactorServerMsg::Command(reading))?;
        }
        Ok(())
    }
}

/// Starts one robot's skeleton on ractor: [`raw_robot`] with the stack's six actors (the
/// server, the two behaviours, and three idle ones as the master, the planner and the
/// supervisor mostly are) as plain ractor actors; the simulator, the four timers and two idle
/// tasks stay tokio tasks, as in the stack. Its actors go to `actors`.
async fn ractor_robot(
    config: &Config,
    counts: &Arc<RawCounts>,
    tasks: &mut Vec<tokio::task::JoinHandle<()>>,
    actors: &mut Vec<ActorCell>,
) -> anyhow::Result<()> {
    let (sim_tx, sim_rx) = tokio::sync::mpsc::unbounded_channel::<RawSimMsg>();
    tasks.push(tokio::spawn(raw_sim(sim_rx, Duration::from_secs_f64(config.sim.step_s), Arc::clone(counts))));
    let spawn_failed = |e: ractor::SpawnErr| anyhow!("cannot spawn a ractor actor: {e}");
    let (server, _) = Actor::spawn(None, RactorServer, sim_tx).await.map_err(spawn_failed)?;
    let (wall, _) = Actor::spawn(None, RactorBehaviour { to: None }, ()).await.map_err(spawn_failed)?;
    let (center, _) =
        Actor::spawn(None, RactorBehaviour { to: Some(server.clone()) }, ()).await.map_err(spawn_failed)?;
    server.cast(RactorServerMsg::Wire(wall.clone(), center.clone()))?;
    let to = server.clone();
    raw_timers(config, tasks, move |kind| to.cast(RactorServerMsg::Tick(kind)).is_ok());
    actors.extend([server.get_cell(), wall.get_cell(), center.get_cell()]);
    for _ in 0..3 {
        let (idle, _) = Actor::spawn(None, RactorBehaviour { to: None }, ()).await.map_err(spawn_failed)?;
        actors.push(idle.get_cell());
    }
    raw_idle(2, tasks);
    Ok(())
}

/// What a skeleton of the stack is made of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Skeleton {
    /// Raw tokio tasks and channels ([`raw_robot`]).
    Tokio,
    /// The stack's six actors as plain ractor actors, the rest tokio tasks
    /// ([`ractor_robot`]).
    Ractor,
}

/// The baselines of [`scale`]: `n` robots' skeletons (see the module docs) for `warm_s` then
/// `measure_s` simulated seconds; only the second span is timed.
pub(crate) fn raw_scale(
    skeleton: Skeleton,
    n: usize,
    warm_s: f64,
    measure_s: f64,
) -> anyhow::Result<RawScale> {
    if n == 0 || !(warm_s >= 0.0 && measure_s > 0.0 && measure_s.is_finite() && warm_s.is_finite()) {
        anyhow::bail!("raw scale: need at least one robot and a positive duration");
    }
    let config = Config::default();
    let rt = paused_runtime()?;
    let counts = Arc::new(RawCounts::default());
    let cost = rt.block_on(async {
        let mut tasks = Vec::with_capacity(13 * n);
        let mut actors = Vec::new();
        for _ in 0..n {
            match skeleton {
                Skeleton::Tokio => raw_robot(&config, &counts, &mut tasks),
                Skeleton::Ractor => ractor_robot(&config, &counts, &mut tasks, &mut actors).await?,
            }
        }
        tokio::time::sleep(Duration::from_secs_f64(warm_s)).await;
        let (wall, sim) = (Instant::now(), tokio::time::Instant::now());
        tokio::time::sleep(Duration::from_secs_f64(measure_s)).await;
        let (wall_s, simulated_s) = (wall.elapsed().as_secs_f64(), sim.elapsed().as_secs_f64());
        for a in &actors {
            a.stop(None);
        }
        for t in &tasks {
            t.abort();
        }
        Ok::<_, anyhow::Error>(wall_s * 1e6 / (n as f64 * simulated_s))
    })?;
    drop(rt);
    Ok(RawScale {
        us_per_robot_sim_s: cost,
        steps: counts.steps.load(Ordering::Relaxed),
        commands: counts.commands.load(Ordering::Relaxed),
    })
}

/// The resident set of this process now, in MiB (Linux; `None` elsewhere).
fn rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// `n` robots for `warm_s` then `measure_s` simulated seconds; only the second span is timed.
pub(crate) fn scale(n: usize, warm_s: f64, measure_s: f64) -> anyhow::Result<ScaleRow> {
    if n == 0 || !(warm_s >= 0.0 && measure_s > 0.0 && measure_s.is_finite() && warm_s.is_finite()) {
        anyhow::bail!("scale: need at least one robot and a positive duration");
    }
    let world = World::palazzina()?;
    let config = Config::default();
    let rt = paused_runtime()?;
    let rss_before = rss_mib();
    let restarts = Arc::new(AtomicU64::new(0));
    let row = rt.block_on(async {
        let up = Instant::now();
        let mut stacks = Vec::with_capacity(n);
        for i in 0..n {
            let restarts = Arc::clone(&restarts);
            let stack =
                Stack::start(world.clone(), &config, 1 + i as u64, warm_s + measure_s, None, move |e| {
                    if e.kind == SupervisorEventKind::Restarted {
                        restarts.fetch_add(1, Ordering::Relaxed);
                    }
                })
                .await
                .with_context(|| format!("robot {i} of {n}"))?;
            stacks.push(stack);
        }
        let startup_wall_s = up.elapsed().as_secs_f64();
        let rss_after = rss_mib();
        tokio::time::sleep(Duration::from_secs_f64(warm_s)).await;
        let sims = stacks
            .iter()
            .map(|s| s.robot.handle::<SimRobot>().context("the stack's robot is not the simulator"))
            .collect::<anyhow::Result<Vec<&SimRobot>>>()?;
        let truths = stacks
            .iter()
            .map(|s| s.truth().context("the stack's robot has no truth"))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let steps0: Vec<u64> = sims.iter().map(|s| s.steps()).collect();
        let (wall, sim) = (Instant::now(), tokio::time::Instant::now());
        tokio::time::sleep(Duration::from_secs_f64(measure_s)).await;
        let (wall_s, simulated_s) = (wall.elapsed().as_secs_f64(), sim.elapsed().as_secs_f64());
        let steps: Vec<u64> = sims.iter().zip(&steps0).map(|(s, s0)| s.steps() - s0).collect();
        let distance: f64 = truths.iter().map(|t| t.truth().travelled_m).sum();
        drop((sims, truths));
        let down = Instant::now();
        futures::future::join_all(stacks.into_iter().map(Stack::shutdown)).await;
        let shutdown_wall_s = down.elapsed().as_secs_f64();
        let rtf = simulated_s / wall_s;
        Ok::<_, anyhow::Error>(ScaleRow {
            robots: n,
            startup_wall_s,
            simulated_s,
            wall_s,
            rtf,
            robot_seconds_per_wall_s: rtf * n as f64,
            wall_us_per_robot_sim_s: wall_s * 1e6 / (n as f64 * simulated_s),
            min_steps_per_robot: steps.iter().copied().min().unwrap_or(0),
            expected_steps_per_robot: (simulated_s / config.sim.step_s).round() as u64,
            mean_distance_m: distance / n as f64,
            restarts: restarts.load(Ordering::Relaxed),
            rss_mib_per_robot: match (rss_before, rss_after) {
                (Some(a), Some(b)) => Some((b - a).max(0.0) / n as f64),
                _ => None,
            },
            shutdown_wall_s,
            raw_wall_us_per_robot_sim_s: None,
            ractor_wall_us_per_robot_sim_s: None,
            rtf_runs: Vec::new(),
        })
    })?;
    // Dropping the runtime ends whatever the shutdown left (nothing, normally).
    drop(rt);
    Ok(row)
}
