//! Setting the robot process up: checking its arguments before anything starts, choosing the
//! robot it drives (the simulator or a ROS 2 base), opening its recording, joining ROS 2 (its
//! own node with `--ros2`, the base's topics with `--hardware ros2`) and starting its fault plan.

use super::watchdog::RobotEvent;
use super::{Hardware, RobotOptions as RobotArgs};
use crate::config::Config;
use crate::remote::{load_config, ros2, secs};
use crate::system::RobotBoards;
use anyhow::{Context as _, bail};
use orsa_actors::{Clock, Registry};
use orsa_hardware::faulty::BoardFaults;
use orsa_hardware::ros2base::Ros2Base;
use orsa_hardware::sim::{SimNomad200, SimRobot};
use orsa_hardware::world::World;
use orsa_net::ros2::Ros2Publisher;
use orsa_net::ros2::msg::Twist;
use std::sync::Arc;
use std::time::Duration;

/// What `orsa robot` reads and checks before it starts anything.
pub(super) struct Checked {
    /// The world of the simulator (and of the recording's views).
    pub(super) world: World,
    /// What `world` is, for the recording.
    pub(super) world_label: String,
    pub(super) config: Config,
    /// `--duration`.
    pub(super) duration: Option<Duration>,
    /// `--faults`.
    pub(super) plan: Option<crate::faults::FaultPlan>,
    /// An executive not heard for this long is lost.
    pub(super) lease: Duration,
}

impl Checked {
    /// Reads the world, the config and the fault plan of `args`, and checks them together.
    pub(super) fn of(args: &RobotArgs) -> anyhow::Result<Self> {
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
            Some(p) => {
                Some(crate::faults::FaultPlan::load(p, &crate::faults::PlanTargets::for_robot(&config))?)
            }
            None => None,
        };
        for p in [args.report.as_ref(), args.record.as_ref()].into_iter().flatten() {
            crate::output::ensure_parent(p)?;
        }
        let world_label = match &args.world {
            Some(p) => p.display().to_string(),
            None => "palazzina (built in)".to_string(),
        };
        let lease = config.link.lease(config.robot.cmd_timeout_s);
        Ok(Checked { world, world_label, config, duration, plan, lease })
    }
}

/// The robot the process drives: the simulator, or a ROS 2 base (one of the two).
pub(super) struct Drive {
    pub(super) sim: Option<SimRobot>,
    pub(super) ros2_base: Option<Ros2Base>,
    /// Where the base's command publisher goes once the robot is on the network.
    pub(super) base_slot: Option<Arc<std::sync::OnceLock<Ros2Publisher<Twist>>>>,
}

impl Drive {
    /// The robot `args.hardware` says.
    pub(super) fn choose(args: &RobotArgs, checked: &Checked, clock: Clock) -> anyhow::Result<Self> {
        let (sim, ros2_base, base_slot) = match args.hardware {
            Hardware::Sim => {
                let sim = SimNomad200::new(checked.world.clone(), checked.config.sim.clone(), args.seed)
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
                (Some(SimRobot::spawn(sim, clock)), None, None)
            }
            Hardware::Ros2 => {
                let (slot, send) = ros2::command_slot(clock);
                (None, Some(Ros2Base::new(checked.config.ros2.base.clone(), clock, send)), Some(slot))
            }
        };
        Ok(Drive { sim, ros2_base, base_slot })
    }

    /// Its boards, behind the fault switch `boards`.
    pub(super) fn boards(&self, config: &Config, boards: &BoardFaults) -> anyhow::Result<RobotBoards> {
        Ok(match (&self.sim, &self.ros2_base) {
            (Some(sim), _) => RobotBoards::simulated(sim, config, boards),
            (None, Some(base)) => RobotBoards::ros2(base, config, boards),
            (None, None) => bail!("the robot has neither a simulator nor a ROS 2 base"),
        })
    }

    /// Stops the motors on the board, once nothing drives any more; how long it took.
    pub(super) async fn stop_on_board(&self) -> Option<f64> {
        match (&self.sim, &self.ros2_base) {
            (Some(sim), _) => crate::ending::stop_on_board(&sim.motor_board()).await,
            (None, Some(base)) => crate::ending::stop_on_board(&base.boards().1).await,
            (None, None) => None,
        }
    }
}

/// With `--record`: the recording of the process, set as `registry`'s tap.
pub(super) fn start_recording(
    registry: &Registry,
    args: &RobotArgs,
    checked: &Checked,
    builder: &crate::system::SystemBuilder<'_>,
) -> anyhow::Result<Option<Arc<crate::mission::recording::McapTap>>> {
    let Checked { world, world_label, config, plan, .. } = checked;
    Ok(match &args.record {
        Some(path) => {
            let hosted = builder.hosted()?.iter().map(|c| c.name.clone()).collect();
            let meta = crate::record::RunMeta::describe(
                "robot",
                world_label,
                Some(world),
                args.seed,
                args.duration.unwrap_or(1e7),
                config,
                hosted,
                true,
                registry.clock().origin().as_nanos(),
                plan.as_ref(),
            )
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            let tap = Arc::new(crate::mission::recording::McapTap::create(
                path,
                meta.to_metadata(),
                Some(crate::mission::recording::view_setup(config, Some(world.clone()), false)),
            )?);
            registry.set_tap(Some(tap.clone() as Arc<dyn orsa_actors::tap::Tap>));
            Some(tap)
        }
        None => None,
    })
}

/// The robot's faces on ROS 2: its own node (`--ros2`), the link to the base it drives
/// (`--hardware ros2`).
#[derive(Default)]
pub(super) struct Faces {
    pub(super) ros2_face: Option<ros2::RobotRos2>,
    pub(super) base_link: Option<ros2::BaseLink>,
}

impl Faces {
    /// Joins ROS 2 as `args` says, on the network of `transport`.
    pub(super) async fn join(
        &mut self,
        registry: &Registry,
        transport: &orsa_net::ZenohTransport,
        args: &RobotArgs,
        config: &Config,
        robot_params: &orsa_interfaces::nomad200::RobotParams,
        drive: &Drive,
    ) -> anyhow::Result<()> {
        let robot = &config.robot.name;
        if args.ros2 {
            let face =
                ros2::RobotRos2::start(registry, transport, robot, robot_params, &config.ros2, args.domain)
                    .await
                    .context("joining ROS 2 (--ros2)")?;
            eprintln!("robot: on ROS 2 domain {} as node {}", args.domain, config.ros2.node);
            self.ros2_face = Some(face);
        }
        if let (Some(b), Some(slot)) = (&drive.ros2_base, &drive.base_slot) {
            let link = ros2::BaseLink::connect(registry, transport, &config.ros2, args.domain, b, slot)
                .await
                .context("joining the ROS 2 base (--hardware ros2)")?;
            eprintln!(
                "robot: driving the ROS 2 robot on domain {} ({} and {} in, {} out)",
                args.domain,
                config.ros2.base.scan_topic,
                config.ros2.base.odom_topic,
                config.ros2.base.cmd_vel_topic
            );
            self.base_link = Some(link);
        }
        Ok(())
    }

    /// What the ROS 2 node did, if there is one.
    pub(super) fn report(&self) -> Option<ros2::Ros2Report> {
        self.ros2_face.as_ref().map(|f| f.report()).or_else(|| self.base_link.as_ref().map(|l| l.report()))
    }
}

/// Starts the fault plan, if any, on the robot's boards, switchboard and links (the link cuts
/// go to the watchdog as events too); when its clock started, and its task.
pub(super) fn start_plan(
    registry: &Registry,
    checked: &Checked,
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
    transport: &orsa_net::ZenohTransport,
    ev_tx: &tokio::sync::mpsc::UnboundedSender<RobotEvent>,
    boards: &BoardFaults,
) -> (Option<orsa_actors::Timestamp>, Option<tokio::task::JoinHandle<usize>>) {
    let (plan, duration) = (&checked.plan, checked.duration);
    let plan_started_at = plan.as_ref().map(|_| registry.now());
    if let (Some(r), Some(plan), Some(at)) = (recording, plan, plan_started_at) {
        use crate::record::events::{FAULTS_STARTED, FAULTS_STARTED_TYPE, FaultsStarted};
        r.note(FAULTS_STARTED, FAULTS_STARTED_TYPE, at, &FaultsStarted { faults: plan.faults.len() });
    }
    let plan_task = plan.clone().map(|plan| {
        let t = transport.clone();
        let tx = ev_tx.clone();
        let link: crate::faults::LinkSwitch = Arc::new(move |role: &str, cut: bool| {
            t.cut_link(role, cut);
            let _ = tx.send(RobotEvent::Link(role.to_string(), cut));
        });
        let targets = crate::faults::FaultTargets {
            faults: registry.faults(),
            boards: boards.clone(),
            link: Some(link),
        };
        tokio::spawn(crate::faults::run_plan(plan, targets, duration.map_or(1e7, |d| d.as_secs_f64())))
    });
    (plan_started_at, plan_task)
}
