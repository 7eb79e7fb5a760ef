//! `orsa executive`: the master and the planner in a process of their own, driving the robot's
//! behaviours over the network.
//!
//! This module holds its arguments and its course: check them and set up ([`setup`]), join the
//! robot, start the system and the fault plan, run until the end (its time, a signal, its
//! supervisor giving up), then end in order and write the report ([`ending`]).

mod ending;
mod setup;

use super::{NetworkOptions, runtime};
use crate::system::{Place, System};
use anyhow::Context as _;
use orsa_actors::supervision::SupervisorEvent;
use orsa_actors::{Clock, Registry};
use setup::{Checked, LinkLog, Recording};
use std::path::PathBuf;
use std::sync::Arc;

pub use crate::system::EXECUTIVE_TOP;

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
    /// The delivery ledger across processes (see [`RobotReport::links`](super::RobotReport::links)).
    #[serde(default)]
    pub links: orsa_net::LinkLedger,
    /// What the fault plan broke and how the executive came back (with `--faults`).
    pub faults: Option<crate::faults::FaultsReport>,
}

/// `orsa executive`.
pub fn executive(args: ExecutiveOptions) -> anyhow::Result<crate::ending::Outcome> {
    let checked = Checked::of(&args)?;
    runtime()?.block_on(run(args, checked))
}

/// The executive process, from its clock's start to its report.
async fn run(args: ExecutiveOptions, checked: Checked) -> anyhow::Result<crate::ending::Outcome> {
    let config = &checked.config;
    let clock = Clock::start();
    let registry = Registry::with_clock(clock);
    let builder = System::builder(config).only(Place::Executive).supervisor(EXECUTIVE_TOP);
    let hosted: Vec<String> = builder.hosted()?.iter().map(|c| c.name.clone()).collect();
    let recording = setup::start_recording(&registry, &args, &checked, &hosted)?;
    let live = crate::live::serve_process(
        &registry,
        args.foxglove,
        "executive",
        crate::mission::recording::view_setup(config, None, false),
        recording.clone().map(|r| r as Arc<dyn orsa_actors::tap::Tap>),
        config.system.components.iter().map(|c| c.name.clone()).collect(),
        config.navigating_planner(),
    )?;
    let top = crate::ending::TopWatch::new(EXECUTIVE_TOP);
    let events = Arc::new(parking_lot::Mutex::new(Vec::new()));
    let on_event = on_event(&recording, live.as_ref().map(crate::live::LiveView::tap), &top, &events);
    let boards = orsa_hardware::faulty::BoardFaults::new(0);
    // From here on, every way out writes the report: what the run leaves is kept here.
    let mut transport = None;
    let mut supervisor = None;
    let (mut plan_task, mut plan_started_at) = (None, None);
    let link_log: LinkLog = Arc::default();
    let run = async {
        let transport = setup::join(&registry, &args, &checked, &recording, &mut transport).await?;
        if let Some(tap) = &recording {
            use crate::record::events::{SYSTEM_STARTING, SYSTEM_STARTING_TYPE, SystemStarting};
            tap.note(SYSTEM_STARTING, SYSTEM_STARTING_TYPE, registry.now(), &SystemStarting { hosted });
        }
        let system = builder
            .duration(args.duration)
            .on_event(on_event)
            .start(&registry)
            .await
            .context("starting the executive")?;
        supervisor = Some(system.supervisor);
        crate::say!("executive", "up (zenoh id {}), driving {}", transport.zid(), config.robot_name());
        (plan_started_at, plan_task) =
            setup::start_plan(&registry, &checked, &recording, transport, &link_log, &boards);
        anyhow::Ok(crate::ending::until_end(Some(checked.duration), &top).await)
    };
    // A signal while the executive waits for its robot or starts ends it too, with its
    // report.
    let run = crate::ending::or_signal(run).await;
    if let Some(p) = plan_task {
        p.abort();
    }
    let ended_at = registry.now();
    let at_s = registry.clock().since_start(ended_at).as_secs_f64();
    let (ended, unwired_all) = ending::ended(run, &registry, config, at_s).await;
    if let Some(tap) = &recording {
        tap.ended(ended_at, &ended.describe());
    }
    ending::tell(&ended, unwired_all);
    if let Some(s) = supervisor {
        s.shutdown().await;
    }
    registry.set_tap(None);
    if let Some(live) = live {
        let s = live.finish();
        crate::say!("executive", "foxglove: {s}");
    }
    let link = transport.as_ref().map(|t| t.link_cut_stats()).unwrap_or_default();
    let links = transport.as_ref().map(|t| t.link_ledger()).unwrap_or_default();
    if let Some(t) = transport {
        t.close().await;
    }
    let end_s = registry.clock().since_start(registry.now()).as_secs_f64();
    let plan = ending::PlanRun {
        plan: checked.plan.as_ref(),
        started_at: plan_started_at,
        link_log: &link_log,
        boards: &boards,
    };
    let report = ending::report(&ended, end_s, &registry, &events.lock(), plan, link, links);
    ending::write_report(args.report.as_deref(), &report)?;
    ending::finish_recording(recording)?;
    crate::ending::Outcome::of(&ended)
}

/// What the supervisors' events go to: the recording, the live view, the watch on the top
/// supervisor and the report's list.
fn on_event(
    recording: &Recording,
    live: Option<Arc<crate::live::tap::LiveTap>>,
    top: &crate::ending::TopWatch,
    events: &Arc<parking_lot::Mutex<Vec<SupervisorEvent>>>,
) -> impl Fn(SupervisorEvent) + Send + Sync + 'static {
    let (recording, top, events) = (recording.clone(), top.clone(), Arc::clone(events));
    move |e| {
        if let Some(r) = &recording {
            r.supervisor_event(&e);
        }
        if let Some(l) = &live {
            l.supervisor_event(&e);
        }
        top.see(&e);
        events.lock().push(e);
    }
}
