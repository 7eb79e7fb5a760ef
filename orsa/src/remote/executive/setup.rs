//! Setting the executive process up: checking its arguments before anything starts, opening
//! its recording, joining the robot over zenoh (its services up, its fallback master gone),
//! and starting its fault plan.

use super::ExecutiveOptions;
use crate::config::Config;
use crate::remote::{FALLBACK, exchange, load_config, open, secs, wait_for};
use anyhow::bail;
use orsa_actors::{Registry, ServiceAddr};
use orsa_hardware::faulty::BoardFaults;
use orsa_interfaces::nomad200;
use orsa_net::ZenohTransport;
use std::sync::Arc;
use std::time::Duration;

/// The fault plan's log of link cuts and restorations: (s since the start, role, what).
pub(super) type LinkLog = Arc<parking_lot::Mutex<Vec<(f64, String, String)>>>;

/// The executive's recording.
pub(super) type Recording = Option<Arc<crate::mission::recording::McapTap>>;

/// What `orsa executive` reads and checks before it starts anything.
pub(super) struct Checked {
    pub(super) config: Config,
    /// `--duration`.
    pub(super) duration: Duration,
    /// `--wait`.
    pub(super) wait: Duration,
    /// `--faults`.
    pub(super) plan: Option<crate::faults::FaultPlan>,
}

impl Checked {
    /// Reads the config and the fault plan of `args`, checks the durations, and makes the
    /// directories of the files it will write.
    pub(super) fn of(args: &ExecutiveOptions) -> anyhow::Result<Self> {
        let config = load_config(&args.config)?;
        let duration = secs(args.duration, "--duration")?;
        let wait = secs(args.wait, "--wait")?;
        let targets = crate::faults::PlanTargets::for_executive(&config);
        let plan = args.faults.as_ref().map(|p| crate::faults::FaultPlan::load(p, &targets)).transpose()?;
        for p in [args.record.as_ref(), args.report.as_ref()].into_iter().flatten() {
            crate::output::ensure_parent(p)?;
        }
        Ok(Checked { config, duration, wait, plan })
    }
}

/// Opens the recording of `args.record`, if any, as the tap of `registry`; the process hosts
/// `hosted`.
pub(super) fn start_recording(
    registry: &Registry,
    args: &ExecutiveOptions,
    checked: &Checked,
    hosted: &[String],
) -> anyhow::Result<Recording> {
    let Some(path) = &args.record else { return Ok(None) };
    // The executive simulates no world: the recording names none.
    let meta = crate::record::RunMeta::describe(
        "executive",
        "(none: the robot's process simulates it)",
        None,
        0,
        args.duration,
        &checked.config,
        hosted.to_vec(),
        true,
        registry.clock().origin().as_nanos(),
        checked.plan.as_ref(),
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let tap = Arc::new(crate::mission::recording::McapTap::create(path, meta.to_metadata(), None)?);
    registry.set_tap(Some(tap.clone() as Arc<dyn orsa_actors::tap::Tap>));
    Ok(Some(tap))
}

/// Gets on the network (kept in `transport`, to be closed at the end), recording what crosses
/// it, and waits for the robot: its services up, its fallback master gone.
pub(super) async fn join<'t>(
    registry: &Registry,
    args: &ExecutiveOptions,
    checked: &Checked,
    recording: &Recording,
    transport: &'t mut Option<ZenohTransport>,
) -> anyhow::Result<&'t ZenohTransport> {
    let config = &checked.config;
    // The heartbeat tells the robot this process still drives it (see [link] in the config).
    let beat = Duration::from_secs_f64(config.link.heartbeat_period_s);
    let t = open(registry, &args.net, "executive", Some(beat)).await?;
    let transport = &*transport.insert(t);
    if let (Some(tap), Some(zenoh)) = (recording, registry.transport()) {
        let noting = exchange::RecordingTransport::new(zenoh, Arc::clone(tap), registry.clock());
        registry.set_transport(Arc::new(noting));
    }
    let robot = config.robot_name();
    // Every robot service the master connects to when it starts (the sonar too: the default
    // rules read it). Each is announced on its own, so seeing one says nothing of the others:
    // an executive that waited for the infrared alone failed to start, now and then under
    // load, for want of the sonar.
    let mut needed = vec![
        nomad200::DISTANCEIR.on(robot).untyped(),
        nomad200::DISTANCESON.on(robot).untyped(),
        nomad200::NAVIGATIONVELOCITY.on(robot).untyped(),
    ];
    for b in config.executive().behaviours() {
        needed.push(ServiceAddr::new(&b, "state"));
        needed.push(ServiceAddr::new(&b, "wiring"));
    }
    wait_for(transport, &needed, checked.wait).await?;
    // A robot driving its fallback mode stops it when it sees this process; two masters
    // never wire at once.
    let fallback = orsa_interfaces::executive::GOAL.on(FALLBACK).untyped();
    if !transport.wait_gone(&fallback, checked.wait).await {
        bail!("the robot's fallback master is still running after {:.1} s", checked.wait.as_secs_f64());
    }
    Ok(transport)
}

/// Starts the fault plan, if any, now (its clock's start, returned with its task): it breaks
/// this process's components through `registry` and cuts links through `transport`, noting
/// each cut in `link_log`.
pub(super) fn start_plan(
    registry: &Registry,
    checked: &Checked,
    recording: &Recording,
    transport: &ZenohTransport,
    link_log: &LinkLog,
    boards: &BoardFaults,
) -> (Option<orsa_actors::Timestamp>, Option<tokio::task::JoinHandle<usize>>) {
    let Some(plan) = &checked.plan else { return (None, None) };
    let at = registry.now();
    if let Some(r) = recording {
        use crate::record::events::{FAULTS_STARTED, FAULTS_STARTED_TYPE, FaultsStarted};
        r.note(FAULTS_STARTED, FAULTS_STARTED_TYPE, at, &FaultsStarted { faults: plan.faults.len() });
    }
    let (t, log, r) = (transport.clone(), Arc::clone(link_log), registry.clone());
    let link: crate::faults::LinkSwitch = Arc::new(move |role: &str, cut: bool| {
        t.cut_link(role, cut);
        let at = r.clock().since_start(r.now()).as_secs_f64();
        let what = if cut { "link cut" } else { "link restored" };
        crate::say!("executive", "[{at:.3} s] fault: {what} to {role}");
        log.lock().push((at, role.to_string(), what.to_string()));
    });
    let targets = crate::faults::FaultTargets {
        faults: registry.faults(),
        boards: boards.clone(),
        link: Some(link),
        stage: None,
    };
    let task = tokio::spawn(crate::faults::run_plan(plan.clone(), targets, checked.duration.as_secs_f64()));
    (Some(at), Some(task))
}
