//! The processes of a distributed orsa system and the tools to look inside it, over zenoh:
//! `orsa robot`, `orsa executive`, `orsa teleop`, `orsa list`, `orsa echo`, `orsa wire`,
//! `orsa state`, `orsa param`.
//!
//! ```text
//!   orsa robot                        orsa executive             orsa teleop
//!   ├── nomad200 (sim, real time)     ├── master  ── wiring, state, distanceir/10 ──▶ robot
//!   ├── wallfollow                    └── planner                ── nomad200/teleop ──▶ robot
//!   └── centerfollow
//! ```
//! The robot watches the executive's liveliness and its heartbeat: when its token disappears
//! (within zenoh's lease, 1 s by default) or no heartbeat came for the lease (`[link]`, 0.3 s by
//! default, at most the velocity timeout), the robot unwires every behaviour and stops its
//! motors at once, keeps its behaviours computing, and, if `--fallback MODE` is given, drives
//! that mode with a local master until an executive is back. An executive heard again after a
//! lost heartbeat (a link that was cut while its session stayed up) gets back the behaviour it
//! had wired.

/// What a process exchanged across processes, recorded: in the recording crate.
pub use orsa_record::exchange;
mod param;
mod robot;
pub mod ros2;
mod tools;

pub use param::{ParamAction, ParamOptions, param};
pub use robot::{FALLBACK, ROBOT_TOP, RobotOptions, RobotReport, robot};
pub use tools::{
    EchoOptions, ListOptions, StateOptions, SwitchOptions, WireOptions, echo, list, parse_change, state,
    switch, wire,
};

use crate::config::Config;
use crate::system::{Place, System};
use anyhow::{Context as _, bail};
use orsa_actors::send::SendClient;
use orsa_actors::{Clock, Registry, ServiceAddr};
use orsa_interfaces::nomad200::{self, NavigationVelocity};
use orsa_net::{NetOptions, ZenohTransport};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// How a process joins the network (every networked process and tool).
#[derive(Debug, Clone)]
pub struct NetworkOptions {
    /// zenoh endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable).
    pub listen: Vec<String>,
    /// zenoh endpoint of a peer to connect to, e.g. `tcp/robot.local:7447` (repeatable).
    pub connect: Vec<String>,
    /// zenoh configuration file (JSON5): TLS, user/password, everything else (see docs/security.md).
    pub zenoh_config: Option<PathBuf>,
    /// Key prefix: systems with different prefixes do not see each other.
    pub prefix: String,
}

impl NetworkOptions {
    fn options(&self, heartbeat: Option<Duration>) -> NetOptions {
        NetOptions {
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            config_file: self.zenoh_config.clone(),
            prefix: self.prefix.clone(),
            heartbeat,
        }
    }
}

/// Options of `orsa executive`.
#[derive(Debug)]
pub struct ExecutiveOptions {
    /// Configuration file (see config/orsa.toml): modes, rules, the planner's mission.
    pub config: Option<PathBuf>,
    /// Seconds of the default mission (patrol) and of the process (default: 3600).
    pub duration: f64,
    /// How long to wait for the robot's services to appear.
    pub wait: f64,
    /// Record this process here, as MCAP: its components' messages, and everything it
    /// exchanged with the robot's services, when it crossed (what `orsa replay` feeds back).
    pub record: Option<PathBuf>,
    /// At exit (whatever ends it: its time, Ctrl-C or SIGTERM, its supervisor giving up, an
    /// error), write a report here (JSON): how it ended, restarts and, with --faults, what was
    /// injected, detected and restarted.
    pub report: Option<PathBuf>,
    /// Break this process on purpose as this fault plan says (see docs/faults.md): the master
    /// and the planner, the master's push, and `link_cut` to the robot, teleop or tools. Its
    /// clock starts when the executive's components are up.
    pub faults: Option<PathBuf>,
    /// Serve this process's views live to Foxglove (WebSocket) on ADDR (default
    /// 127.0.0.1:8765: this host only; see the README). Anyone who can reach ADDR sees them.
    pub foxglove: Option<std::net::SocketAddr>,
    /// Network.
    pub net: NetworkOptions,
}

/// Options of `orsa teleop`.
#[derive(Debug)]
pub struct TeleopOptions {
    /// The robot component.
    pub robot: String,
    /// Scripted: send this velocity (m/s, rad/s) instead of reading the keyboard.
    pub send: Option<(f64, f64)>,
    /// Scripted: for this many seconds, then stop and quit.
    pub for_s: f64,
    /// Commands per second.
    pub rate: f64,
    /// How long to wait for the robot.
    pub wait: f64,
    /// Network.
    pub net: NetworkOptions,
}

fn secs(s: f64, flag: &str) -> anyhow::Result<Duration> {
    if s.is_finite() && (0.0..=1e7).contains(&s) {
        Ok(Duration::from_secs_f64(s))
    } else {
        bail!("{flag} {s}: must be a number of seconds from 0 to 1e7")
    }
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    // zenoh needs tokio's multi-thread scheduler.
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start the tokio runtime")
}

fn load_config(path: &Option<PathBuf>) -> anyhow::Result<Config> {
    Ok(match path {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    })
}

async fn open(
    registry: &Registry,
    net: &NetworkOptions,
    role: &str,
    heartbeat: Option<Duration>,
) -> anyhow::Result<ZenohTransport> {
    Ok(ZenohTransport::open(registry, &net.options(heartbeat), role).await?)
}

async fn wait_for(t: &ZenohTransport, addrs: &[ServiceAddr], wait: Duration) -> anyhow::Result<()> {
    if let Err(missing) = t.wait_for(addrs, wait).await {
        let names: Vec<String> = missing.iter().map(ToString::to_string).collect();
        bail!(
            "no peer offers {} after {:.1} s (is the robot running, with the same --prefix?)",
            names.join(", "),
            wait.as_secs_f64()
        );
    }
    Ok(())
}

/// Resolves when the process is asked to stop (Ctrl-C) or after `duration`.
async fn until_stopped(duration: Option<Duration>) {
    let limit = async {
        match duration {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        () = limit => {}
    }
}

pub use crate::system::EXECUTIVE_TOP;

/// What `orsa executive --report` writes at exit.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ExecutiveReport {
    /// How the process ended (its figures cover the time up to then).
    pub ended: crate::mission::report::Ended,
    /// Seconds the process ran (its clock at the end).
    pub duration_s: f64,
    /// Restarts by the supervisors, all components together.
    pub restarts: u64,
    /// What link cuts kept from crossing.
    pub link: orsa_net::LinkCutStats,
    /// The delivery ledger across processes (see [`RobotReport::links`]).
    #[serde(default)]
    pub links: orsa_net::LinkLedger,
    /// What the fault plan broke and how the executive came back (with `--faults`).
    pub faults: Option<crate::faults::FaultsReport>,
}

/// `orsa executive`.
pub fn executive(args: ExecutiveOptions) -> anyhow::Result<crate::ending::Outcome> {
    use crate::mission::report::Ended;
    let config = load_config(&args.config)?;
    let duration = secs(args.duration, "--duration")?;
    let wait = secs(args.wait, "--wait")?;
    let plan = match &args.faults {
        Some(p) => {
            Some(crate::faults::FaultPlan::load(p, &crate::faults::PlanTargets::for_executive(&config))?)
        }
        None => None,
    };
    for p in [args.record.as_ref(), args.report.as_ref()].into_iter().flatten() {
        crate::output::ensure_parent(p)?;
    }
    runtime()?.block_on(async move {
        let clock = Clock::start();
        let registry = Registry::with_clock(clock);
        let builder = System::builder(&config).only(Place::Executive).supervisor(EXECUTIVE_TOP);
        let hosted: Vec<String> = builder.hosted()?.iter().map(|c| c.name.clone()).collect();
        let recording = match &args.record {
            Some(path) => {
                // The executive simulates no world: the recording names none.
                let meta = crate::record::RunMeta::describe(
                    "executive",
                    "(none: the robot's process simulates it)",
                    None,
                    0,
                    args.duration,
                    &config,
                    hosted.clone(),
                    true,
                    clock.origin().as_nanos(),
                    plan.as_ref(),
                )
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
                let tap =
                    Arc::new(crate::mission::recording::McapTap::create(path, meta.to_metadata(), None)?);
                registry.set_tap(Some(tap.clone() as Arc<dyn orsa_actors::tap::Tap>));
                Some(tap)
            }
            None => None,
        };
        let live = crate::live::serve_process(
            &registry,
            args.foxglove,
            "executive",
            crate::mission::recording::view_setup(&config, None, false),
            recording.clone().map(|r| r as Arc<dyn orsa_actors::tap::Tap>),
            config.system.components.iter().map(|c| c.name.clone()).collect(),
        )?;
        let events_live = live.as_ref().map(crate::live::LiveView::tap);
        let top = crate::ending::TopWatch::new(EXECUTIVE_TOP);
        let events = Arc::new(parking_lot::Mutex::new(Vec::new()));
        let boards = orsa_hardware::faulty::BoardFaults::new(0);
        // From here on, every way out writes the report: what the run leaves is kept here.
        let mut transport: Option<ZenohTransport> = None;
        let mut supervisor = None;
        let mut plan_task = None;
        let mut plan_started_at = None;
        let link_log = Arc::new(parking_lot::Mutex::new(Vec::<(f64, String, String)>::new()));
        let run = async {
            // The heartbeat tells the robot this process still drives it (see [link] in the config).
            let beat = Duration::from_secs_f64(config.link.heartbeat_period_s);
            let t = open(&registry, &args.net, "executive", Some(beat)).await?;
            let transport = &*transport.insert(t);
            if let (Some(tap), Some(zenoh)) = (&recording, registry.transport()) {
                let noting = exchange::RecordingTransport::new(zenoh, Arc::clone(tap), clock);
                registry.set_transport(Arc::new(noting));
            }
            let robot = config.robot_name();
            let mut needed = vec![
                nomad200::DISTANCEIR.on(robot).untyped(),
                nomad200::NAVIGATIONVELOCITY.on(robot).untyped(),
            ];
            for b in config.executive().behaviours() {
                needed.push(ServiceAddr::new(&b, "state"));
                needed.push(ServiceAddr::new(&b, "wiring"));
            }
            wait_for(transport, &needed, wait).await?;
            // A robot driving its fallback mode stops it when it sees this process; two masters
            // never wire at once.
            let fallback = orsa_interfaces::executive::GOAL.on(FALLBACK).untyped();
            if !transport.wait_gone(&fallback, wait).await {
                bail!("the robot's fallback master is still running after {:.1} s", wait.as_secs_f64());
            }
            if let Some(tap) = &recording {
                use crate::record::events::{SYSTEM_STARTING, SYSTEM_STARTING_TYPE, SystemStarting};
                tap.note(SYSTEM_STARTING, SYSTEM_STARTING_TYPE, registry.now(), &SystemStarting { hosted });
            }
            let events_tap = recording.clone();
            let (top_sink, sink) = (top.clone(), Arc::clone(&events));
            let system = builder
                .duration(args.duration)
                .on_event(move |e| {
                    if let Some(r) = &events_tap {
                        r.supervisor_event(&e);
                    }
                    if let Some(l) = &events_live {
                        l.supervisor_event(&e);
                    }
                    top_sink.see(&e);
                    sink.lock().push(e);
                })
                .start(&registry)
                .await
                .context("starting the executive")?;
            supervisor = Some(system.supervisor);
            eprintln!("executive: up (zenoh id {}), driving {}", transport.zid(), config.robot_name());
            plan_started_at = plan.as_ref().map(|_| registry.now());
            if let (Some(r), Some(plan), Some(at)) = (&recording, &plan, plan_started_at) {
                use crate::record::events::{FAULTS_STARTED, FAULTS_STARTED_TYPE, FaultsStarted};
                r.note(FAULTS_STARTED, FAULTS_STARTED_TYPE, at, &FaultsStarted { faults: plan.faults.len() });
            }
            plan_task = plan.clone().map(|plan| {
                let (t, log, r) = (transport.clone(), Arc::clone(&link_log), registry.clone());
                let link: crate::faults::LinkSwitch = Arc::new(move |role: &str, cut: bool| {
                    t.cut_link(role, cut);
                    let at = r.clock().since_start(r.now()).as_secs_f64();
                    let what = if cut { "link cut" } else { "link restored" };
                    eprintln!("executive: [{at:.3} s] fault: {what} to {role}");
                    log.lock().push((at, role.to_string(), what.to_string()));
                });
                let targets = crate::faults::FaultTargets {
                    faults: registry.faults(),
                    boards: boards.clone(),
                    link: Some(link),
                };
                tokio::spawn(crate::faults::run_plan(plan, targets, duration.as_secs_f64()))
            });
            anyhow::Ok(crate::ending::until_end(Some(duration), &top).await)
        };
        // A signal while the executive waits for its robot or starts ends it too, with its
        // report.
        let run = crate::ending::or_signal(run).await;
        if let Some(p) = plan_task {
            p.abort();
        }
        let at_s = registry.clock().since_start(registry.now()).as_secs_f64();
        let mut unwired_all = true;
        let ended = match run {
            Ok(crate::ending::Stop::GaveUp(e)) => {
                // The master is gone: no behaviour may go on driving without it. The robot
                // stops its motors when this process leaves, and its watchdog stays armed.
                eprintln!(
                    "executive: [{at_s:.3} s] supervisor '{}' gave up ({}): unwiring the behaviours",
                    e.supervisor, e.reason
                );
                let wiring = orsa_actors::wiring::WiringMaster::new(&registry);
                let mut all_unwired = true;
                for b in config.executive().behaviours() {
                    let unwired = tokio::time::timeout(
                        Duration::from_secs(1),
                        wiring.disconnect(&b, orsa_interfaces::behaviour::VEL),
                    )
                    .await;
                    if !matches!(unwired, Ok(Ok(()))) {
                        all_unwired = false;
                        eprintln!("executive: cannot unwire {b}: the robot stops when this process leaves");
                    }
                }
                unwired_all = all_unwired;
                crate::ending::ended(crate::ending::Stop::GaveUp(e), at_s, None)
            }
            Ok(stop) => crate::ending::ended(stop, at_s, None),
            Err(e) => Ended::Failed { at_s, error: format!("{e:#}") },
        };
        match &ended {
            Ended::Completed => {}
            // The executive stops no motors itself (its report's `stopped_in_s` stays empty):
            // the robot does, when it sees it go.
            Ended::GaveUp { at_s, supervisor, child, reason, .. } => eprintln!(
                "executive: gave up at {at_s:.1} s: supervisor '{supervisor}' stopped after '{child}' failed \
                 once too often ({reason}); {}the robot stops as this process leaves",
                if unwired_all {
                    "the behaviours were unwired and "
                } else {
                    "not every behaviour could be unwired; "
                }
            ),
            other => eprintln!("executive: {}", other.describe()),
        }
        if let Some(s) = supervisor {
            s.shutdown().await;
        }
        registry.set_tap(None);
        if let Some(live) = live {
            let s = live.finish();
            eprintln!("executive: foxglove: {} messages made into views, {} dropped", s.handed, s.dropped);
        }
        let link = transport.as_ref().map(|t| t.link_cut_stats()).unwrap_or_default();
        let links = transport.as_ref().map(|t| t.link_ledger()).unwrap_or_default();
        if let Some(t) = transport {
            t.close().await;
        }
        let end_s = registry.clock().since_start(registry.now()).as_secs_f64();
        let (restarts, restart_ms) = crate::faults::restarts_of(&events.lock());
        let total_restarts = restarts.values().sum();
        let faults = plan.as_ref().map(|plan| {
            let plan_end =
                end_s - plan_started_at.map_or(end_s, |t| registry.clock().since_start(t).as_secs_f64());
            let mut report = crate::faults::FaultsReport::new(
                plan,
                plan_end,
                &registry.faults(),
                &registry.clock(),
                &boards,
                restarts,
                restart_ms,
            );
            report.log.extend(link_log.lock().iter().cloned());
            report.log.sort_by(|a, b| a.0.total_cmp(&b.0));
            report
        });
        let report = ExecutiveReport {
            ended: ended.clone(),
            duration_s: end_s,
            restarts: total_restarts,
            link,
            links,
            faults,
        };
        if let Some(p) = &args.report {
            std::fs::write(p, serde_json::to_string_pretty(&report)?)
                .with_context(|| format!("{}: cannot write the report", p.display()))?;
            eprintln!("executive: report: {}", p.display());
        }
        if let Some(tap) = recording {
            match tap.finish() {
                Ok(Some(r)) => {
                    let total: u64 = r.messages.values().sum();
                    eprintln!(
                        "executive: record: {} ({total} messages on {} topics)",
                        r.path.display(),
                        r.messages.len()
                    );
                }
                Ok(None) => {}
                Err(e) => bail!("the executive stopped, but its recording failed: {e}"),
            }
        }
        crate::ending::Outcome::of(&ended)
    })
}

/// `orsa teleop`.
pub fn teleop(args: TeleopOptions) -> anyhow::Result<()> {
    if !(args.rate.is_finite() && (0.5..=100.0).contains(&args.rate)) {
        bail!("--rate {}: must be from 0.5 to 100 commands per second", args.rate);
    }
    let run_for = secs(args.for_s, "--for")?;
    let wait = secs(args.wait, "--wait")?;
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "teleop", None).await?;
        let addr = ServiceAddr::new(&args.robot, "teleop");
        wait_for(&transport, std::slice::from_ref(&addr), wait).await?;
        let client = SendClient::<NavigationVelocity>::connect(&registry, &addr)?;
        let period = Duration::from_secs_f64(1.0 / args.rate);
        let send = |v: f64, w: f64| {
            client.send(NavigationVelocity { stamp: registry.now(), v_m_s: v, omega_rad_s: w })
        };
        match args.send {
            Some((v, w)) => {
                let mut tick = tokio::time::interval(period);
                let end = tokio::time::Instant::now() + run_for;
                while tokio::time::Instant::now() < end {
                    tick.tick().await;
                    send(v, w)?;
                }
                send(0.0, 0.0)?;
            }
            None => crate::keyboard::drive(period, |v, w| send(v, w).map_err(anyhow::Error::from)).await?,
        }
        // Let the last command leave before the session closes.
        tokio::time::sleep(Duration::from_millis(100)).await;
        transport.close().await;
        Ok(())
    })
}
