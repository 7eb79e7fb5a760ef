//! `orsa robot`: the robot process, its behaviours, and what it does when the executive is lost.
//!
//! This module holds its arguments and its course: set up ([`setup`]), start the system, get on
//! the network, run the link watchdog ([`watchdog`]) until the end, then shut down in order and
//! write the report ([`report`]).

mod fallback;
mod report;
mod setup;
mod watchdog;

pub use fallback::FALLBACK;
pub use report::RobotReport;

use super::{NetworkOptions, runtime};
use crate::mission::report::Ended;
use crate::system::{Place, System};
use anyhow::{Context as _, bail};
use orsa_actors::{Clock, Registry};
use orsa_hardware::faulty::BoardFaults;
use orsa_net::{NetOptions, ZenohTransport};
use setup::{Checked, Faces};
use std::path::PathBuf;
use std::sync::Arc;
use watchdog::{RobotEvent, Watchdog, Watched};

pub use crate::system::ROBOT_TOP;

/// Options of `orsa robot`.
#[derive(Debug)]
pub struct RobotOptions {
    /// World file (TOML); default: the reference corridor, built in.
    pub world: Option<PathBuf>,
    /// Seed of the simulator's noise.
    pub seed: u64,
    /// Configuration file (see config/orsa.toml).
    pub config: Option<PathBuf>,
    /// Drive this mode (from the config's executive.modes) with a local master while no
    /// executive is connected; default: stand still.
    pub fallback: Option<String>,
    /// Stop after this many seconds (default: run until interrupted).
    pub duration: Option<f64>,
    /// Break this process on purpose as this fault plan says (see docs/faults.md): components,
    /// services, sensors, motors, and `link_cut` to the executive, teleop or tools. Its clock
    /// starts when the robot is on the network.
    pub faults: Option<PathBuf>,
    /// At exit, write a report here (JSON): safety counters, link-cut counts and, with
    /// --faults, what was injected, detected and restarted.
    pub report: Option<PathBuf>,
    /// Record every pattern message and control event of this process here, as MCAP, with
    /// what `orsa replay` needs to run its behaviours again (see the README).
    pub record: Option<PathBuf>,
    /// Also be a ROS 2 node, as rmw_zenoh (ROS 2 Jazzy) lays one out: publish /scan,
    /// /ir_scan, /odom, /tf and /bumper, and take /cmd_vel as teleoperation (see docs/ros2.md).
    pub ros2: bool,
    /// The ROS 2 domain (ROS_DOMAIN_ID) of --ros2 and --hardware ros2.
    pub domain: u32,
    /// The robot to drive: a robot kind of `catalog` (`sim`: the simulator, the robot the
    /// config's `[sim]` describes; `ros2`: a ROS 2 robot that publishes a laser scan and
    /// odometry and takes Twist commands, described by the config's `[ros2.base]`).
    pub hardware: String,
    /// The kinds of robot and of component this process can make (default:
    /// [`Catalog::builtin`](crate::system::Catalog::builtin)).
    pub catalog: crate::system::Catalog,
    /// Serve this process's views live to Foxglove (WebSocket) on ADDR (default
    /// 127.0.0.1:8765: this host only; see the README). Anyone who can reach ADDR sees them.
    pub foxglove: Option<std::net::SocketAddr>,
    /// Network.
    pub net: NetworkOptions,
}

/// `orsa robot`.
pub fn robot(args: RobotOptions) -> anyhow::Result<crate::ending::Outcome> {
    let checked = Checked::of(&args)?;
    runtime()?.block_on(run(args, checked))
}

/// The robot process, from its clock's start to its report.
async fn run(args: RobotOptions, checked: Checked) -> anyhow::Result<crate::ending::Outcome> {
    let config = &checked.config;
    let clock = Clock::start();
    let registry = Registry::with_clock(clock);
    let drive = setup::robot(&args, &checked, clock)?;
    let robot = config.robot_name().to_string();
    let boards = BoardFaults::new(args.seed);
    let robot_boards = drive.boards(&boards, &config.safety)?;
    let supervisor_events = Arc::new(parking_lot::Mutex::new(Vec::new()));
    let sink = Arc::clone(&supervisor_events);
    // The world is the robot's map too: the map and the localizer serve it to the navigation.
    let builder =
        System::builder(config).catalog(args.catalog.clone()).only(Place::Robot).world(checked.world.clone());
    let recording = setup::start_recording(&registry, &args, &checked, &builder)?;
    let live = crate::live::serve_process(
        &registry,
        args.foxglove,
        "robot",
        crate::mission::recording::view_setup(config, Some(checked.world.clone()), false),
        recording.clone().map(|r| r as Arc<dyn orsa_actors::tap::Tap>),
        config.system.components.iter().map(|c| c.name.clone()).collect(),
        config.navigating_planner(),
    )?;
    let events_live = live.as_ref().map(crate::live::LiveView::tap);
    if let Some(tap) = &recording {
        use crate::record::events::{SYSTEM_STARTING, SYSTEM_STARTING_TYPE, SystemStarting};
        let hosted = builder.hosted()?.iter().map(|c| c.name.clone()).collect();
        tap.note(SYSTEM_STARTING, SYSTEM_STARTING_TYPE, registry.now(), &SystemStarting { hosted });
    }
    let events_tap = recording.clone();
    let top = crate::ending::TopWatch::new(ROBOT_TOP);
    let top_sink = top.clone();
    let start_system = builder
        .robot(robot_boards)
        .supervisor(ROBOT_TOP)
        .on_event(move |e| {
            if let Some(r) = &events_tap {
                r.supervisor_event(&e);
            }
            if let Some(l) = &events_live {
                l.supervisor_event(&e);
            }
            top_sink.see(&e);
            sink.lock().push(e)
        })
        .start(&registry);
    let mut supervisor: Option<orsa_actors::supervision::SupervisorRef> = None;
    // From here on, every way out writes the report: what the loop leaves is kept here.
    let mut transport: Option<orsa_net::ZenohTransport> = None;
    let mut plan_task = None;
    let mut plan_started_at = None;
    let mut watched = Watched::default();
    let mut base = None;
    let mut faces = Faces::default();
    let run = async {
        supervisor = Some(start_system.await.context("starting the robot")?.supervisor);
        // A process on ROS 2 stamps its samples, as rmw_zenoh's do (transient local topics).
        let on_ros2 = args.ros2 || drive.handle::<orsa_assembly::system::robots::Ros2Robot>().is_some();
        let net = NetOptions { timestamping: on_ros2, ..args.net.options(None) };
        let t = ZenohTransport::open(&registry, &net, "robot").await?;
        crate::say!("robot", "up as {} (zenoh id {})", robot, t.zid());
        let transport = &*transport.insert(t);
        faces.join(&registry, transport, &args, config, &drive).await?;

        let (ev_tx, ev_rx) = tokio::sync::mpsc::unbounded_channel::<RobotEvent>();
        let _beats = watchdog::listen(transport, &ev_tx).await?;
        // The robot's own base state, to report when it came to rest and moved again.
        let (base_tx, base_rx) = tokio::sync::mpsc::unbounded_channel();
        let b = orsa_actors::push_timed::PushTimedClient::<orsa_interfaces::nomad200::BaseState>::connect_to(
            &registry,
            orsa_interfaces::nomad200::BASESTATE.on(robot.as_str()),
            orsa_actors::Sink::channel(base_tx),
        )?;
        b.subscribe(1)?;
        base = Some(b);

        (plan_started_at, plan_task) = setup::start_plan(
            &registry,
            &checked,
            &recording,
            transport,
            &ev_tx,
            &boards,
            drive.truth.as_ref().map(|t| t.stage()),
        );
        drop(ev_tx);

        let watchdog = Watchdog::new(
            &registry,
            config,
            &args.fallback,
            checked.lease,
            &recording,
            &robot,
            &mut watched,
        )?;
        let stop = crate::ending::until_end(checked.duration, &top);
        let why = watchdog.run(stop, ev_rx, base_rx).await;
        anyhow::Ok(why)
    };
    // A signal while the robot starts ends it too, with its report.
    let run = crate::ending::or_signal(run).await;
    if let Some(p) = plan_task {
        p.abort();
    }
    let ended_at = registry.now();
    let at_s = registry.clock().since_start(ended_at).as_secs_f64();
    let ended = match run {
        Ok(crate::ending::Stop::GaveUp(e)) => {
            // The robot server is gone with its watchdog: the motors are stopped on the board.
            crate::say!(
                "robot",
                "[{at_s:.3} s] supervisor '{}' gave up ({}): stopping the motors",
                e.supervisor,
                e.reason
            );
            // Once every component has stopped: none may drive after the board's stop.
            if let Some(s) = &supervisor {
                s.shutdown().await;
            }
            let stopped_in = drive.stop_on_board(crate::ending::STOP_WAIT).await;
            crate::ending::ended(crate::ending::Stop::GaveUp(e), at_s, stopped_in)
        }
        Ok(stop) => crate::ending::ended(stop, at_s, None),
        Err(e) => Ended::Failed { at_s, error: format!("{e:#}") },
    };
    if ended != Ended::Completed {
        crate::say!("robot", "{}", ended.describe());
    }
    let safety = if matches!(ended, Ended::GaveUp { .. }) || supervisor.is_none() {
        // Its server is gone (or never started): what it counted went with it.
        Default::default()
    } else {
        report::safety_counters(&registry, &robot).await
    };
    if let Some(f) = watched.fallback.take() {
        f.stop().await;
    }
    drop(base);
    let faults_switch = registry.faults();
    if let Some(s) = supervisor {
        s.shutdown().await;
    }
    // The server has stopped the motors; nothing drives the robot from here on.
    drive.shutdown().await;
    let ros2 = faces.report();
    drop(faces);
    registry.set_tap(None);
    if let Some(live) = live {
        let s = live.finish();
        crate::say!("robot", "foxglove: {s}");
    }
    let recorded = recording.map(|r| {
        r.ended(ended_at, &ended.describe());
        r.finish()
    });
    let end_s = registry.clock().since_start(registry.now()).as_secs_f64();
    let faults = checked.plan.as_ref().map(|plan| {
        let plan_end = end_s - plan_started_at.map_or(0.0, |t| registry.clock().since_start(t).as_secs_f64());
        report::faults_report(
            &registry,
            plan,
            plan_end,
            &faults_switch,
            &boards,
            &supervisor_events.lock(),
            &watched,
        )
    });
    let (restarts, _) = crate::faults::restarts_of(&supervisor_events.lock());
    let report = RobotReport {
        ended: ended.clone(),
        duration_s: end_s,
        plan_started_at_s: plan_started_at.map(|t| registry.clock().since_start(t).as_secs_f64()),
        safety,
        restarts: restarts.values().sum(),
        link: transport.as_ref().map(|t| t.link_cut_stats()).unwrap_or_default(),
        links: transport.as_ref().map(|t| t.link_ledger()).unwrap_or_default(),
        stops: watched.stops,
        faults,
        ros2,
    };
    if let Some(t) = transport {
        t.close().await;
    }
    if let Some(p) = &args.report {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("{}: cannot write the report", p.display()))?;
        crate::say!("robot", "report: {}", p.display());
    }
    match recorded {
        Some(Ok(Some(r))) => {
            let total: u64 = r.messages.values().sum();
            crate::say!(
                "robot",
                "record: {} ({total} messages on {} topics)",
                r.path.display(),
                r.messages.len()
            );
        }
        Some(Err(e)) => bail!("the robot stopped, but its recording failed: {e}"),
        _ => {}
    }
    crate::ending::Outcome::of(&ended)
}
