//! `orsa robot`: the robot process, its behaviours, and what it does when the executive is lost.

use super::{NetArgs, load_config, open, runtime, secs};
use crate::config::Config;
use crate::mission::report::Ended;
use crate::record::events::{LINK_EVENT, LINK_EVENTS, LinkEvent, LinkEventKind};
use crate::system::{Place, RobotBoards, System};
use anyhow::{Context as _, bail};
use orsa_actors::component::ComponentHandle;
use orsa_actors::send::SendClient;
use orsa_actors::wiring::WiringMaster;
use orsa_actors::{Clock, Registry, ServiceAddr};
use orsa_executive::Master;
use orsa_hardware::faulty::BoardFaults;
use orsa_hardware::ros2base::Ros2Base;
use orsa_hardware::sim::{SimNomad200, SimRobot};
use orsa_hardware::world::World;
use orsa_interfaces::behaviour::VEL;
use orsa_interfaces::executive::{Goal, GoalReply};
use orsa_interfaces::nomad200::NavigationVelocity;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// The robot process's top supervisor (`orsa run`'s is [`TOP_SUPERVISOR`](crate::system::TOP_SUPERVISOR)).
pub const ROBOT_TOP: &str = "orsa-robot";

/// Arguments of `orsa robot`.
#[derive(Debug, clap::Args)]
pub struct RobotArgs {
    /// World file (TOML); default: the reference corridor, built in.
    #[arg(long, value_name = "PATH")]
    pub world: Option<PathBuf>,
    /// Seed of the simulator's noise.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Configuration file (see config/orsa.toml).
    #[arg(long, value_name = "PATH")]
    pub config: Option<PathBuf>,
    /// Drive this mode (from the config's executive.modes) with a local master while no
    /// executive is connected; default: stand still.
    #[arg(long, value_name = "MODE")]
    pub fallback: Option<String>,
    /// Stop after this many seconds (default: run until interrupted).
    #[arg(long, value_name = "SECS")]
    pub duration: Option<f64>,
    /// Break this process on purpose as this fault plan says (see docs/faults.md): components,
    /// services, sensors, motors, and `link_cut` to the executive, teleop or tools. Its clock
    /// starts when the robot is on the network.
    #[arg(long, value_name = "PLAN.toml")]
    pub faults: Option<PathBuf>,
    /// At exit, write a report here (JSON): safety counters, link-cut counts and, with
    /// --faults, what was injected, detected and restarted.
    #[arg(long, value_name = "PATH.json")]
    pub report: Option<PathBuf>,
    /// Record every pattern message and control event of this process here, as MCAP, with
    /// what `orsa replay` needs to run its behaviours again (see the README).
    #[arg(long, value_name = "PATH.mcap")]
    pub record: Option<PathBuf>,
    /// Also be a ROS 2 node, as rmw_zenoh (ROS 2 Jazzy) lays one out: publish /scan,
    /// /ir_scan, /odom, /tf and /bumper, and take /cmd_vel as teleoperation (see docs/ros2.md).
    #[arg(long)]
    pub ros2: bool,
    /// The ROS 2 domain (ROS_DOMAIN_ID) of --ros2 and --hardware ros2.
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=232))]
    pub domain: u32,
    /// The robot to drive: the simulated Nomad 200, or a ROS 2 robot that publishes a laser
    /// scan and odometry and takes Twist commands, described by the config's [ros2.base].
    #[arg(long, value_enum, default_value_t = Hardware::Sim)]
    pub hardware: Hardware,
    /// Serve this process's views live to Foxglove (WebSocket) on ADDR (default
    /// 127.0.0.1:8765: this host only; see the README). Anyone who can reach ADDR sees them.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = crate::live::DEFAULT_ADDR,
          value_parser = crate::live::parse_addr)]
    pub foxglove: Option<std::net::SocketAddr>,
    /// Network.
    #[command(flatten)]
    pub net: NetArgs,
}

/// The robot `orsa robot` drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Hardware {
    /// The simulated Nomad 200 in the world file.
    Sim,
    /// A ROS 2 robot on the zenoh network (rmw_zenoh): its scan and odometry in, Twist out.
    Ros2,
}

/// What `orsa robot --report` writes at exit.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RobotReport {
    /// How the process ended (its figures cover the time up to then).
    #[serde(default)]
    pub ended: Ended,
    /// Seconds the robot ran (its clock at the end).
    pub duration_s: f64,
    /// When the fault plan's clock started (its `at` 0), seconds on the robot's clock.
    pub plan_started_at_s: Option<f64>,
    /// What the robot server did with velocity commands over its whole life (zero when its
    /// supervisor gave up: the server's counts went with it).
    pub safety: orsa_interfaces::nomad200::SafetyCounters,
    /// Restarts by the supervisors, all components together.
    #[serde(default)]
    pub restarts: u64,
    /// What link cuts kept from crossing.
    pub link: orsa_net::LinkCutStats,
    /// The delivery ledger across processes: what the robot put on its links, and what
    /// arrived from each peer (lost and duplicated on the way counted here).
    #[serde(default)]
    pub links: orsa_net::LinkLedger,
    /// Every time the robot stopped itself because it lost its executive: how fast it reacted
    /// and how far it went.
    #[serde(default)]
    pub stops: Vec<StopReport>,
    /// What the fault plan broke and how the robot came back (with `--faults`).
    pub faults: Option<crate::faults::FaultsReport>,
    /// What the ROS 2 node did (with `--ros2` or `--hardware ros2`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ros2: Option<super::ros2::Ros2Report>,
}

/// One stop the robot made by itself: from the moment it knew it had to stop to the moment it
/// was at rest. Times are seconds on the robot's clock.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StopReport {
    /// Why it stopped.
    pub cause: String,
    /// When the loss was established (a lease expired, a token disappeared).
    pub detected_at_s: f64,
    /// When the zero command was handed to the robot server.
    pub zero_at_s: f64,
    /// Its speed then, from its last base state, m/s.
    pub v_m_s: f64,
    /// When its base state first read at rest (base states come every 100 ms).
    pub at_rest_at_s: Option<f64>,
    /// How far it went from the detection to rest, by odometry, m.
    pub distance_m: f64,
    /// When something drove it again before it came to rest (the executive back, the
    /// fallback): the stop ended there, and `distance_m` counts up to then.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub driven_again_at_s: Option<f64>,
    /// Where it was at the last base state seen (odometry), for the distance.
    #[serde(skip)]
    last: Option<(f64, f64)>,
}

impl StopReport {
    fn new(
        registry: &Registry,
        cause: String,
        detected: orsa_actors::Timestamp,
        zero: orsa_actors::Timestamp,
        base: Option<&orsa_interfaces::nomad200::BaseState>,
    ) -> Self {
        let s = |t| registry.clock().since_start(t).as_secs_f64();
        StopReport {
            cause,
            detected_at_s: s(detected),
            zero_at_s: s(zero),
            v_m_s: base.map_or(0.0, |b| b.v_m_s),
            at_rest_at_s: None,
            distance_m: 0.0,
            driven_again_at_s: None,
            last: base.map(|b| (b.x_m, b.y_m)),
        }
    }

    /// A base state at `t_s`: the distance grows until the robot is at rest (or driven again).
    fn see(&mut self, t_s: f64, b: &orsa_interfaces::nomad200::BaseState) {
        if self.at_rest_at_s.is_some() || self.driven_again_at_s.is_some() || t_s < self.detected_at_s {
            return;
        }
        if let Some((x, y)) = self.last {
            self.distance_m += (b.x_m - x).hypot(b.y_m - y);
        }
        self.last = Some((b.x_m, b.y_m));
        if b.v_m_s == 0.0 && b.omega_rad_s == 0.0 {
            self.at_rest_at_s = Some(t_s);
        }
    }
}

impl StopReport {
    /// Something drives the robot again: the stops still open end now.
    fn driven_again(registry: &Registry, stops: &mut [StopReport]) {
        let t = registry.clock().since_start(registry.now()).as_secs_f64();
        for s in stops.iter_mut().filter(|s| s.at_rest_at_s.is_none() && s.driven_again_at_s.is_none()) {
            s.driven_again_at_s = Some(t);
        }
    }
}

/// The registry's timestamp of tokio instant `at` (now, minus how long ago `at` was).
fn now_ts(registry: &Registry, at: tokio::time::Instant) -> orsa_actors::Timestamp {
    let ago = tokio::time::Instant::now().saturating_duration_since(at);
    orsa_actors::Timestamp(registry.now().0.saturating_sub(ago.as_nanos() as u64))
}

/// What the robot's main loop hears about.
enum RobotEvent {
    /// A process of role executive appeared (its token).
    ExecutiveFound(String),
    /// An executive's token disappeared.
    ExecutiveGone(String),
    /// A heartbeat of an executive, with its period in ms.
    Beat(String, u64),
    /// The fault plan cut (true) or restored (false) the link to a role.
    Link(String, bool),
}

/// An executive as the robot sees it.
struct Executive {
    /// No heartbeat by then: lost.
    deadline: tokio::time::Instant,
    /// Lost (token gone or heartbeat lease expired) and not heard since.
    lost: bool,
    /// The behaviour it had wired to the motors when it was lost, given back when it returns.
    restore: Option<String>,
    /// Whether its heartbeat period was found too slow for the lease (warned once).
    warned: bool,
}

/// `orsa robot`.
pub fn robot(args: RobotArgs) -> anyhow::Result<crate::cli::Outcome> {
    let world = match &args.world {
        Some(p) => World::from_path(p)?,
        None => World::palazzina()?,
    };
    let config = load_config(&args.config)?;
    if let Some(mode) = &args.fallback
        && !config.executive.modes.contains_key(mode)
    {
        let known: Vec<&String> = config.executive.modes.keys().collect();
        bail!("--fallback {mode}: no such mode in executive.modes (known: {known:?})");
    }
    let duration = args.duration.map(|d| secs(d, "--duration")).transpose()?;
    if args.ros2 && args.hardware == Hardware::Ros2 {
        bail!(
            "--ros2 with --hardware ros2: the robot's own topics (/scan, /odom, /cmd_vel) would be \
             the base's; drive a ROS 2 robot, or be one"
        );
    }
    let plan = match &args.faults {
        Some(p) => Some(crate::faults::FaultPlan::load(p, &crate::faults::PlanTargets::for_robot(&config))?),
        None => None,
    };
    for p in [args.report.as_ref(), args.record.as_ref()].into_iter().flatten() {
        crate::cli::ensure_parent(p)?;
    }
    let world_label = match &args.world {
        Some(p) => p.display().to_string(),
        None => "palazzina (built in)".to_string(),
    };
    let lease = config.link.lease(config.robot.cmd_timeout_s);
    runtime()?.block_on(async move {
        let clock = Clock::start();
        let registry = Registry::with_clock(clock);
        let (sim, ros2_base, base_slot) = match args.hardware {
            Hardware::Sim => {
                let sim = SimNomad200::new(world.clone(), config.sim.clone(), args.seed)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
                (Some(SimRobot::spawn(sim, clock)), None, None)
            }
            Hardware::Ros2 => {
                let (slot, send) = super::ros2::command_slot(clock);
                (None, Some(Ros2Base::new(config.ros2.base.clone(), clock, send)), Some(slot))
            }
        };
        let robot = config.robot.name.clone();
        let boards = BoardFaults::new(args.seed);
        let robot_boards = match (&sim, &ros2_base) {
            (Some(sim), _) => RobotBoards::simulated(sim, &config, &boards),
            (None, Some(base)) => RobotBoards::ros2(base, &config, &boards),
            (None, None) => bail!("the robot has neither a simulator nor a ROS 2 base"),
        };
        let robot_params = robot_boards.params.clone();
        let supervisor_events = Arc::new(parking_lot::Mutex::new(Vec::new()));
        let sink = Arc::clone(&supervisor_events);
        let builder = System::builder(&config).only(Place::Robot);
        let recording = match &args.record {
            Some(path) => {
                let hosted = builder.hosted()?.iter().map(|c| c.name.clone()).collect();
                let meta = crate::record::RunMeta::describe(
                    "robot",
                    &world_label,
                    Some(&world),
                    args.seed,
                    args.duration.unwrap_or(1e7),
                    &config,
                    hosted,
                    true,
                    clock.origin().as_nanos(),
                    plan.as_ref(),
                )
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
                let tap = Arc::new(crate::mission::recording::McapTap::create(
                    path,
                    meta.to_metadata(),
                    Some(crate::mission::recording::view_setup(&config, Some(world.clone()), false)),
                )?);
                registry.set_tap(Some(tap.clone() as Arc<dyn orsa_actors::tap::Tap>));
                Some(tap)
            }
            None => None,
        };
        let live = crate::live::serve_process(
            &registry,
            args.foxglove,
            "robot",
            crate::mission::recording::view_setup(&config, Some(world.clone()), false),
            recording.clone().map(|r| r as Arc<dyn orsa_actors::tap::Tap>),
            config.system.components.iter().map(|c| c.name.clone()).collect(),
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
        let mut fallback: Option<ComponentHandle<Master>> = None;
        let mut links: Vec<crate::faults::LinkCutReport> = Vec::new();
        let mut link_log: Vec<(f64, String, String)> = Vec::new();
        let mut base = None;
        let mut stops: Vec<StopReport> = Vec::new();
        let mut ros2_face: Option<super::ros2::RobotRos2> = None;
        let mut base_link: Option<super::ros2::BaseLink> = None;
        let run = async {
            supervisor = Some(start_system.await.context("starting the robot")?.supervisor);
            let t = open(&registry, &args.net, "robot", None).await?;
            eprintln!("robot: up as {} (zenoh id {})", robot, t.zid());
            let transport = &*transport.insert(t);
            if args.ros2 {
                let face =
                    super::ros2::RobotRos2::start(&registry, transport, &robot, &robot_params, &config.ros2, args.domain)
                        .await
                        .context("joining ROS 2 (--ros2)")?;
                eprintln!("robot: on ROS 2 domain {} as node {}", args.domain, config.ros2.node);
                ros2_face = Some(face);
            }
            if let (Some(b), Some(slot)) = (&ros2_base, &base_slot) {
                let link = super::ros2::BaseLink::connect(&registry, transport, &config.ros2, args.domain, b, slot)
                    .await
                    .context("joining the ROS 2 base (--hardware ros2)")?;
                eprintln!(
                    "robot: driving the ROS 2 robot on domain {} ({} and {} in, {} out)",
                    args.domain, config.ros2.base.scan_topic, config.ros2.base.odom_topic, config.ros2.base.cmd_vel_topic
                );
                base_link = Some(link);
            }

            let (ev_tx, mut ev_rx) = tokio::sync::mpsc::unbounded_channel::<RobotEvent>();
            let tx = ev_tx.clone();
            transport.on_process_lost(move |p| {
                if p.role == "executive" {
                    let _ = tx.send(RobotEvent::ExecutiveGone(p.zid.clone()));
                }
            });
            let tx = ev_tx.clone();
            transport.on_process_found(move |p| {
                if p.role == "executive" {
                    let _ = tx.send(RobotEvent::ExecutiveFound(p.zid.clone()));
                }
            });
            let tx = ev_tx.clone();
            let _beats = transport
                .on_heartbeat("executive", move |zid, h| {
                    let _ = tx.send(RobotEvent::Beat(zid.to_string(), h.period_ms));
                })
                .await?;
            // The robot's own base state, to report when it came to rest and moved again.
            let (base_tx, mut base_rx) = tokio::sync::mpsc::unbounded_channel();
            let b = orsa_actors::push_timed::PushTimedClient::<orsa_interfaces::nomad200::BaseState>::connect_to(
                &registry,
                orsa_interfaces::nomad200::BASESTATE.on(robot.as_str()),
                orsa_actors::Sink::channel(base_tx),
            )?;
            b.subscribe(1)?;
            base = Some(b);

            plan_started_at = plan.as_ref().map(|_| registry.now());
            if let (Some(r), Some(plan), Some(at)) = (&recording, &plan, plan_started_at) {
                use crate::record::events::{FAULTS_STARTED, FAULTS_STARTED_TYPE, FaultsStarted};
                r.note(FAULTS_STARTED, FAULTS_STARTED_TYPE, at, &FaultsStarted { faults: plan.faults.len() });
            }
            plan_task = plan.clone().map(|plan| {
                let t = transport.clone();
                let tx = ev_tx.clone();
                let link: crate::faults::LinkSwitch = Arc::new(move |role: &str, cut: bool| {
                    t.cut_link(role, cut);
                    let _ = tx.send(RobotEvent::Link(role.to_string(), cut));
                });
                let targets =
                    crate::faults::FaultTargets { faults: registry.faults(), boards: boards.clone(), link: Some(link) };
                tokio::spawn(crate::faults::run_plan(plan, targets, duration.map_or(1e7, |d| d.as_secs_f64())))
            });
            drop(ev_tx);

            let behaviours = ["wallfollow", "centerfollow"];
            let motors_addr = ServiceAddr::new(&robot, "navigationvelocity");
            let motors = SendClient::<NavigationVelocity>::connect(&registry, &motors_addr)?;
            let mut executives: std::collections::BTreeMap<String, Executive> = std::collections::BTreeMap::new();
            let mut last_base: Option<orsa_interfaces::nomad200::BaseState> = None;
            let mut departed: std::collections::BTreeSet<String> = std::collections::BTreeSet::new();
            let far = Duration::from_secs(86_400);
            let stop = crate::ending::until_end(duration, &top);
            tokio::pin!(stop);
            let why = loop {
                let now = tokio::time::Instant::now();
                let next = executives.values().filter(|e| !e.lost).map(|e| e.deadline).min().unwrap_or(now + far);
                tokio::select! {
                    stop = &mut stop => break stop,
                    () = tokio::time::sleep_until(next) => {
                        let now = tokio::time::Instant::now();
                        let expired: Vec<(String, tokio::time::Instant)> = executives
                            .iter()
                            .filter(|(_, e)| !e.lost && e.deadline <= now)
                            .map(|(z, e)| (z.clone(), e.deadline))
                            .collect();
                        for (zid, deadline) in expired {
                            let why = format!("no heartbeat for {} ms", lease.as_millis());
                            let (restore, commanded) = lose_executive(&registry, &behaviours, &motors, &motors_addr, &zid, &why, &recording).await;
                            stops.push(StopReport::new(&registry, format!("executive lost: {why}"), now_ts(&registry, deadline), commanded, last_base.as_ref()));
                            if let Some(e) = executives.get_mut(&zid) {
                                e.lost = true;
                                e.restore = restore;
                            }
                            note_loss(&registry, &mut links, &mut link_log, &zid, &why);
                            if start_fallback_if(&registry, &config, &args.fallback, &mut fallback).await {
                                StopReport::driven_again(&registry, &mut stops);
                            }
                        }
                    }
                    Some(ev) = ev_rx.recv() => match ev {
                        RobotEvent::ExecutiveFound(zid) => {
                            departed.remove(&zid);
                            // A new executive takes over: the fallback master goes first (the
                            // executive waits for its services to disappear before it starts).
                            if let Some(f) = fallback.take() {
                                eprintln!("robot: executive {zid} is back: stopping the fallback");
                                f.stop().await;
                            }
                            let e = executives.entry(zid.clone()).or_insert(Executive {
                                deadline: tokio::time::Instant::now() + lease,
                                lost: false,
                                restore: None,
                                warned: false,
                            });
                            if e.lost {
                                e.lost = false;
                                e.deadline = tokio::time::Instant::now() + lease;
                                let restore = e.restore.take();
                                executive_back(&registry, &behaviours, &motors_addr, &zid, restore, &mut links, &recording).await;
                                StopReport::driven_again(&registry, &mut stops);
                            }
                        }
                        RobotEvent::ExecutiveGone(zid) => {
                            // A heartbeat it sent before it left may still arrive: it must not
                            // bring it back (zenoh ids are never reused).
                            departed.insert(zid.clone());
                            let was_lost = executives.remove(&zid).is_some_and(|e| e.lost);
                            if !was_lost {
                                let why = "its process token disappeared";
                                let detected = registry.now();
                                let (_, commanded) = lose_executive(&registry, &behaviours, &motors, &motors_addr, &zid, why, &recording).await;
                                stops.push(StopReport::new(&registry, format!("executive lost: {why}"), detected, commanded, last_base.as_ref()));
                                note_loss(&registry, &mut links, &mut link_log, &zid, why);
                            }
                            if start_fallback_if(&registry, &config, &args.fallback, &mut fallback).await {
                                StopReport::driven_again(&registry, &mut stops);
                            }
                        }
                        RobotEvent::Beat(zid, _) if departed.contains(&zid) => {}
                        RobotEvent::Beat(zid, period_ms) => {
                            let e = executives.entry(zid.clone()).or_insert(Executive {
                                deadline: tokio::time::Instant::now() + lease,
                                lost: false,
                                restore: None,
                                warned: false,
                            });
                            e.deadline = tokio::time::Instant::now() + lease;
                            if !e.warned && Duration::from_millis(period_ms.saturating_mul(2)) > lease {
                                e.warned = true;
                                eprintln!(
                                    "robot: executive {zid} beats every {period_ms} ms: too slow for the {} ms lease \
                                     (link.heartbeat_period_s in its config)",
                                    lease.as_millis()
                                );
                            }
                            if e.lost {
                                e.lost = false;
                                let restore = e.restore.take();
                                if let Some(f) = fallback.take() {
                                    eprintln!("robot: executive {zid} is heard again: stopping the fallback");
                                    f.stop().await;
                                }
                                executive_back(&registry, &behaviours, &motors_addr, &zid, restore, &mut links, &recording).await;
                                StopReport::driven_again(&registry, &mut stops);
                            }
                        }
                        RobotEvent::Link(role, cut) => {
                            let t = registry.clock().since_start(registry.now()).as_secs_f64();
                            if cut {
                                eprintln!("robot: [{t:.3} s] fault: link to {role} cut");
                                links.push(crate::faults::LinkCutReport { role: role.clone(), cut_at_s: t, ..Default::default() });
                                link_log.push((t, role, "link cut".into()));
                            } else {
                                eprintln!("robot: [{t:.3} s] fault: link to {role} restored");
                                if let Some(l) = links.iter_mut().rev().find(|l| l.role == role && l.restored_at_s.is_none()) {
                                    l.restored_at_s = Some(t);
                                }
                                link_log.push((t, role, "link restored".into()));
                            }
                        }
                    },
                    Some(u) = base_rx.recv() => {
                        let u: orsa_actors::Update<orsa_interfaces::nomad200::BaseState> = u;
                        let t = registry.clock().since_start(u.sent_at).as_secs_f64();
                        let b = &u.value;
                        let at_rest = b.v_m_s == 0.0 && b.omega_rad_s == 0.0;
                        for stop in &mut stops {
                            stop.see(t, b);
                        }
                        last_base = Some(*b);
                        for l in &mut links {
                            if l.at_rest_at_s.is_none() && t >= l.cut_at_s && at_rest {
                                l.at_rest_at_s = Some(t);
                            }
                            if l.moving_again_at_s.is_none() && l.restored_at_s.is_some_and(|r| t >= r) && !at_rest {
                                l.moving_again_at_s = Some(t);
                            }
                        }
                    }
                }
            };
            anyhow::Ok(why)
        };
        // A signal while the robot starts ends it too, with its report.
        let run = crate::ending::or_signal(run).await;
        if let Some(p) = plan_task {
            p.abort();
        }
        let at_s = registry.clock().since_start(registry.now()).as_secs_f64();
        let ended = match run {
            Ok(crate::ending::Stop::GaveUp(e)) => {
                // The robot server is gone with its watchdog: the motors are stopped on the board.
                eprintln!("robot: [{at_s:.3} s] supervisor '{}' gave up ({}): stopping the motors", e.supervisor, e.reason);
                // Once every component has stopped: none may drive after the board's stop.
                if let Some(s) = &supervisor {
                    s.shutdown().await;
                }
                let stopped_in = match (&sim, &ros2_base) {
                    (Some(sim), _) => crate::ending::stop_on_board(&sim.motor_board()).await,
                    (None, Some(base)) => crate::ending::stop_on_board(&base.boards().1).await,
                    (None, None) => None,
                };
                crate::ending::ended(crate::ending::Stop::GaveUp(e), at_s, stopped_in)
            }
            Ok(stop) => crate::ending::ended(stop, at_s, None),
            Err(e) => Ended::Failed { at_s, error: format!("{e:#}") },
        };
        if ended != Ended::Completed {
            eprintln!("robot: {}", ended.describe());
        }
        let safety = if matches!(ended, Ended::GaveUp { .. }) || supervisor.is_none() {
            // Its server is gone (or never started): what it counted went with it.
            Default::default()
        } else {
            let counters = async {
                orsa_actors::query::QueryClient::<orsa_actors::Empty, orsa_interfaces::nomad200::SafetyCounters>::connect(
                    &registry,
                    orsa_interfaces::nomad200::SAFETY.on(robot.as_str()),
                )?
                .query(orsa_actors::Empty {}, Some(Duration::from_secs(1)))
                .await
            };
            counters.await.unwrap_or_else(|e: orsa_actors::PatternError| {
                eprintln!("robot: cannot read the safety counters: {e}");
                Default::default()
            })
        };
        if let Some(f) = fallback {
            f.stop().await;
        }
        drop(base);
        let faults_switch = registry.faults();
        if let Some(s) = supervisor {
            s.shutdown().await;
        }
        if let Some(sim) = sim {
            let _ = sim.shutdown().await;
        }
        if let Some(base) = &ros2_base {
            // The server has stopped the base; nothing drives it from here on.
            base.close();
        }
        let ros2 = ros2_face.as_ref().map(|f| f.report()).or_else(|| base_link.as_ref().map(|l| l.report()));
        drop(ros2_face);
        drop(base_link);
        registry.set_tap(None);
        if let Some(live) = live {
            let s = live.finish();
            eprintln!("robot: foxglove: {} messages made into views, {} dropped", s.handed, s.dropped);
        }
        let recorded = recording.map(|r| r.finish());
        let end_s = registry.clock().since_start(registry.now()).as_secs_f64();
        let faults = plan.as_ref().map(|plan| {
            let plan_end = end_s - plan_started_at.map_or(0.0, |t| registry.clock().since_start(t).as_secs_f64());
            let (restarts, restart_ms) = crate::faults::restarts_of(&supervisor_events.lock());
            let mut report =
                crate::faults::FaultsReport::new(plan, plan_end, &faults_switch, &registry.clock(), &boards, restarts, restart_ms);
            for (_, role, what) in &link_log {
                if what.starts_with("detected") {
                    *report.detected.entry(role.clone()).or_default() += 1;
                }
            }
            report.log.extend(link_log.iter().cloned());
            report.log.sort_by(|a, b| a.0.total_cmp(&b.0));
            report.links = links.clone();
            report
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
            stops,
            faults,
            ros2,
        };
        if let Some(t) = transport {
            t.close().await;
        }
        if let Some(p) = &args.report {
            std::fs::write(p, serde_json::to_string_pretty(&report)?)
                .with_context(|| format!("{}: cannot write the report", p.display()))?;
            eprintln!("robot: report: {}", p.display());
        }
        match recorded {
            Some(Ok(Some(r))) => {
                let total: u64 = r.messages.values().sum();
                eprintln!("robot: record: {} ({total} messages on {} topics)", r.path.display(), r.messages.len());
            }
            Some(Err(e)) => bail!("the robot stopped, but its recording failed: {e}"),
            _ => {}
        }
        crate::cli::Outcome::of(&ended)
    })
}

/// How long the robot waits for each behaviour to be unwired when its executive is lost (the
/// motors were commanded to zero before).
const UNWIRE_WAIT: Duration = Duration::from_millis(250);

/// The executive `zid` is lost (`why`): commands the motors to zero at once, then unwires
/// every behaviour (all at once, each within [`UNWIRE_WAIT`]) and commands zero again, in case
/// a behaviour's command landed in between. Answers the behaviour it had wired to the motors,
/// and when the first zero was handed to the robot server.
async fn lose_executive(
    registry: &Registry,
    behaviours: &[&str],
    motors: &SendClient<NavigationVelocity>,
    motors_addr: &ServiceAddr,
    zid: &str,
    why: &str,
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
) -> (Option<String>, orsa_actors::Timestamp) {
    let detected = registry.now();
    let zero = || NavigationVelocity { stamp: registry.now(), v_m_s: 0.0, omega_rad_s: 0.0 };
    let first = zero();
    // Noted first: a replay feeds the note back and sends its command there.
    note_link(registry, recording, zid, LinkEventKind::Lost, why, Some(first));
    if let Err(e) = motors.send(first) {
        tracing::warn!("robot: cannot stop the motors: {e}");
    }
    let commanded = registry.now();
    let t = registry.clock().since_start(detected).as_secs_f64();
    eprintln!(
        "robot: [{t:.3} s] executive {zid} lost ({why}): motors commanded to zero, unwiring the behaviours"
    );
    let wiring = WiringMaster::new(registry);
    let unwire = |b: &str| {
        let (wiring, b) = (wiring.clone(), b.to_string());
        async move {
            let drove = async {
                let ports = wiring.ports(&b).await.ok()?;
                ports
                    .iter()
                    .any(|p| p.port == VEL.name() && p.target.as_ref() == Some(motors_addr))
                    .then_some(())
            };
            let drove = tokio::time::timeout(UNWIRE_WAIT, drove).await.ok().flatten().is_some();
            match tokio::time::timeout(UNWIRE_WAIT, wiring.disconnect(&b, VEL)).await {
                Ok(Ok(())) => {}
                Ok(Err(e)) => tracing::warn!("robot: cannot unwire {b}: {e}"),
                Err(_) => tracing::warn!("robot: {b} was not unwired within {UNWIRE_WAIT:?}"),
            }
            drove.then_some(b)
        }
    };
    let driving =
        futures::future::join_all(behaviours.iter().map(|b| unwire(b))).await.into_iter().flatten().next();
    let again = zero();
    note_link(registry, recording, zid, LinkEventKind::Unwired, "behaviours unwired", Some(again));
    if let Err(e) = motors.send(again) {
        tracing::warn!("robot: cannot stop the motors: {e}");
    }
    (driving, commanded)
}

/// Notes what the link watchdog did in the recording, if there is one (a replay feeds it back).
fn note_link(
    registry: &Registry,
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
    zid: &str,
    event: LinkEventKind,
    why: &str,
    command: Option<NavigationVelocity>,
) {
    if let Some(r) = recording {
        let e = LinkEvent { executive: zid.to_string(), event, why: why.to_string(), command };
        r.note(LINK_EVENTS, LINK_EVENT, registry.now(), &e);
    }
}

/// Records the loss of an executive against the link cut it happened under, if any.
fn note_loss(
    registry: &Registry,
    links: &mut [crate::faults::LinkCutReport],
    log: &mut Vec<(f64, String, String)>,
    zid: &str,
    why: &str,
) {
    let t = registry.clock().since_start(registry.now()).as_secs_f64();
    log.push((
        t,
        "executive".into(),
        format!("detected: executive {zid} lost ({why}); motors commanded to zero"),
    ));
    if let Some(l) = links
        .iter_mut()
        .rev()
        .find(|l| l.role == "executive" && l.restored_at_s.is_none() && l.lost_at_s.is_none())
    {
        l.lost_at_s = Some(t);
        l.stop_commanded_at_s = Some(t);
    }
}

/// The executive `zid`, lost, is heard again: gives it back the behaviour it had wired.
async fn executive_back(
    registry: &Registry,
    behaviours: &[&str],
    motors_addr: &ServiceAddr,
    zid: &str,
    restore: Option<String>,
    links: &mut [crate::faults::LinkCutReport],
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
) {
    let t = registry.clock().since_start(registry.now()).as_secs_f64();
    note_link(registry, recording, zid, LinkEventKind::Back, "heard again", None);
    let wiring = WiringMaster::new(registry);
    if let Some(b) = &restore {
        // Whatever a fallback wired goes first: never two behaviours on the motors.
        for other in behaviours.iter().filter(|o| **o != b.as_str()) {
            if let Err(e) = wiring.disconnect(other, VEL).await {
                tracing::warn!("robot: cannot unwire {other}: {e}");
            }
        }
        match wiring.connect(b, VEL, motors_addr).await {
            Ok(()) => {
                eprintln!("robot: [{t:.3} s] executive {zid} is back: {b} drives again, as it had wired")
            }
            Err(e) => eprintln!("robot: executive {zid} is back, but {b} cannot be wired again: {e}"),
        }
    } else {
        eprintln!("robot: [{t:.3} s] executive {zid} is back (it had nothing wired)");
    }
    if let Some(l) = links
        .iter_mut()
        .rev()
        .find(|l| l.role == "executive" && l.lost_at_s.is_some() && l.back_at_s.is_none())
    {
        l.back_at_s = Some(t);
    }
}

/// Starts the fallback master if one is asked for and none runs; whether it started one.
async fn start_fallback_if(
    registry: &Registry,
    config: &Config,
    mode: &Option<String>,
    fallback: &mut Option<ComponentHandle<Master>>,
) -> bool {
    if let (Some(mode), None) = (mode, &*fallback) {
        match start_fallback(registry, config, mode).await {
            Ok(f) => {
                eprintln!("robot: driving fallback mode '{mode}'");
                *fallback = Some(f);
                return true;
            }
            Err(e) => eprintln!("robot: cannot start the fallback: {e:#}"),
        }
    }
    false
}

/// The component name of the robot's fallback master.
pub const FALLBACK: &str = "fallback";

async fn start_fallback(
    registry: &Registry,
    config: &Config,
    mode: &str,
) -> anyhow::Result<ComponentHandle<Master>> {
    let mut exec = config.executive.clone();
    exec.robot = config.robot.name.clone();
    let master = orsa_actors::component::spawn(registry, FALLBACK, Master::new(exec)).await?;
    let goals = orsa_actors::query::QueryClient::<Goal, GoalReply>::connect(
        registry,
        orsa_interfaces::executive::GOAL.on(FALLBACK),
    )?;
    let reply = goals.query(Goal { mode: mode.to_string(), for_s: None }, Some(Duration::from_secs(5))).await;
    match reply {
        Ok(GoalReply::Accepted { .. }) => Ok(master),
        Ok(GoalReply::Rejected { reason, .. }) => {
            master.stop().await;
            bail!("fallback goal rejected: {reason}")
        }
        Err(e) => {
            master.stop().await;
            Err(e.into())
        }
    }
}
