//! Setting the robot process up: checking its arguments before anything starts, choosing the
//! robot it drives (a robot kind of its catalog: the simulator, a ROS 2 base, a user's own), opening its recording, joining ROS 2 (its
//! own node with `--ros2`, the base's topics with `--hardware ros2`) and starting its fault plan.

use super::RobotOptions as RobotArgs;
use super::watchdog::RobotEvent;
use crate::config::Config;
use crate::remote::{load_config, ros2, secs};
use crate::system::robots::Ros2Robot;
use crate::system::{Robot, RobotSetup};
use anyhow::{Context as _, bail};
use orsa_actors::{Clock, Registry};
use orsa_hardware::faulty::BoardFaults;
use orsa_hardware::world::World;
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
            && !config.executive().modes.contains_key(mode)
        {
            let known: Vec<String> = config.executive().modes.keys().cloned().collect();
            bail!("--fallback {mode}: no such mode in the master's modes (known: {known:?})");
        }
        let duration = args.duration.map(|d| secs(d, "--duration")).transpose()?;
        args.catalog.check_robot(&args.hardware).context("--hardware")?;
        if args.ros2 && args.hardware == "ros2" {
            bail!(
                "--ros2 with --hardware ros2: the robot's own topics (/scan, /odom, /cmd_vel) would be \
                 the base's; drive a ROS 2 robot, or be one"
            );
        }
        let targets = crate::faults::PlanTargets::for_robot(&config);
        let plan = args.faults.as_ref().map(|p| crate::faults::FaultPlan::load(p, &targets)).transpose()?;
        for p in [args.report.as_ref(), args.record.as_ref()].into_iter().flatten() {
            crate::output::ensure_parent(p)?;
        }
        let world_label = match &args.world {
            Some(p) => p.display().to_string(),
            None => "palazzina (built in)".to_string(),
        };
        let lease = config.link.lease(config.robot().cmd_timeout_s);
        Ok(Checked { world, world_label, config, duration, plan, lease })
    }
}

/// Brings up the robot `args.hardware` names, from `args.catalog`.
pub(super) fn robot(args: &RobotArgs, checked: &Checked, clock: Clock) -> anyhow::Result<Robot> {
    let setup = RobotSetup { config: &checked.config, world: &checked.world, seed: args.seed, clock };
    Ok(args.catalog.start_robot(&args.hardware, &setup)?)
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
        robot: &Robot,
    ) -> anyhow::Result<()> {
        let name = &config.robot_name();
        if args.ros2 {
            let faced = ros2::FacedRobot {
                name,
                params: &robot.params,
                drift: &config.sim.odometry,
                // Goals on /goal_pose where the system has a planner and the map it plans on.
                planner: config.navigating_planner(),
                // /map where the system has a map component in this process.
                map: config.map_server(),
            };
            let face = ros2::RobotRos2::start(
                registry,
                transport,
                &faced,
                &config.ros2,
                args.domain,
                crate::system::live_params::ParamDirectory::new(
                    registry,
                    config.system.components.iter().map(|c| c.name.clone()).collect(),
                ),
            )
            .await
            .context("joining ROS 2 (--ros2)")?;
            crate::say!("robot", "on ROS 2 domain {} as node {}", args.domain, config.ros2.node);
            self.ros2_face = Some(face);
        }
        if let Some(base) = robot.handle::<Ros2Robot>() {
            let link = ros2::BaseLink::connect(registry, transport, &config.ros2, args.domain, base)
                .await
                .context("joining the ROS 2 base (--hardware ros2)")?;
            crate::say!(
                "robot",
                "driving the ROS 2 robot on domain {} ({} and {} in, {} out)",
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

/// Starts the fault plan, if any, on the robot's boards, switchboard, links (the link cuts go
/// to the watchdog as events too) and simulated world; when its clock started, and its task.
pub(super) fn start_plan(
    registry: &Registry,
    checked: &Checked,
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
    transport: &orsa_net::ZenohTransport,
    ev_tx: &tokio::sync::mpsc::UnboundedSender<RobotEvent>,
    boards: &BoardFaults,
    stage: Option<orsa_hardware::sim::SimStage>,
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
            stage,
        };
        tokio::spawn(crate::faults::run_plan(plan, targets, duration.map_or(1e7, |d| d.as_secs_f64())))
    });
    (plan_started_at, plan_task)
}
