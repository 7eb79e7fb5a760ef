//! The whole stack in one process: the simulated robot, its server, the behaviours, the
//! master and the planner, under one supervisor, on one registry and one clock.
//!
//! ```text
//! orsa (one-for-one)
//! ├── nomad200      robot server on the simulated boards
//! ├── wallfollow    behaviour
//! ├── centerfollow  behaviour
//! ├── master        executive
//! └── planner       deliberative layer
//! ```
//! Children start in this order, each once the one before has set up its services. Because a
//! component keeps its services, wiring and subscriptions across restarts, one-for-one is
//! enough: a restarted server does not force its clients to restart.

use crate::config::Config;
use orsa_actors::component::ComponentHandle;
use orsa_actors::supervision::{Strategy, Supervisor, SupervisorEvent, SupervisorRef, SupervisorSpec};
use orsa_actors::{Clock, Registry};
use orsa_executive::Master;
use orsa_hardware::faulty::{BoardFaults, FaultyMotorBoard, FaultySensorBoard};
use orsa_hardware::server::Nomad200;
use orsa_hardware::sim::{SimNomad200, SimRobot, SimTruth};
use orsa_hardware::world::World;
use orsa_planner::Planner;
use orsa_reactive::{CenterFollow, WallFollow};
use std::time::Duration;

/// A running stack.
pub struct Stack {
    /// The directory of its components.
    pub registry: Registry,
    /// The simulated robot (stepping on tokio's clock).
    pub sim: SimRobot,
    /// Ground truth, for metrics.
    pub truth: SimTruth,
    /// The root supervisor.
    pub supervisor: SupervisorRef,
    /// The switch for the robot's hardware faults (see [`orsa_hardware::faulty`]).
    pub board_faults: BoardFaults,
}

/// What can go wrong bringing a stack up.
#[derive(Debug, thiserror::Error)]
pub enum StackError {
    /// The simulator refused the world or its configuration.
    #[error("simulator: {0}")]
    Sim(String),
    /// A component could not be added or started.
    #[error("starting the stack: {0}")]
    Start(String),
}

impl Stack {
    /// Brings a stack up on `world` with `config` and `seed`; the mission runs for
    /// `duration_s` when the planner's mission is the default. `tap`, if given, sees every
    /// message from the first one on; supervisor events go to `on_event`. Must run inside a tokio runtime (paused or not).
    pub async fn start(
        world: World,
        config: &Config,
        seed: u64,
        duration_s: f64,
        tap: Option<std::sync::Arc<dyn orsa_actors::tap::Tap>>,
        on_event: impl Fn(SupervisorEvent) + Send + Sync + 'static,
    ) -> Result<Stack, StackError> {
        let clock = Clock::start();
        let registry = Registry::with_clock(clock);
        registry.set_tap(tap);
        // Every message is accounted for: the report says what was delivered and what lost.
        registry.ledger().enable(true);
        let sim =
            SimNomad200::new(world, config.sim.clone(), seed).map_err(|e| StackError::Sim(e.to_string()))?;
        let sim = SimRobot::spawn(sim, clock);
        let truth = sim.truth();
        let robot_params = config.sim.robot_params(config.robot.push_periods());
        let robot = config.robot.name.clone();
        let err = |e: orsa_actors::PatternError| StackError::Start(e.to_string());

        let board_faults = BoardFaults::new(seed);
        let sensors = FaultySensorBoard::new(sim.sensor_board(), board_faults.clone());
        let motors = FaultyMotorBoard::new(sim.motor_board(), board_faults.clone());
        let server = Nomad200::new(config.robot.clone(), robot_params, sensors, motors);
        let watchdog = Duration::from_secs_f64(config.supervision.handler_timeout_s);
        let nomad =
            ComponentHandle::new(&registry, &robot, server).map_err(err)?.with_handler_timeout(watchdog);
        let wall = WallFollow { params: config.wallfollow, robot: robot.clone() };
        let wall =
            ComponentHandle::new(&registry, "wallfollow", wall).map_err(err)?.with_handler_timeout(watchdog);
        let center = CenterFollow { params: config.centerfollow, robot: robot.clone() };
        let center = ComponentHandle::new(&registry, "centerfollow", center)
            .map_err(err)?
            .with_handler_timeout(watchdog);
        let mut exec = config.executive.clone();
        exec.robot = robot.clone();
        let master = ComponentHandle::new(&registry, "master", Master { params: exec })
            .map_err(err)?
            .with_handler_timeout(watchdog);
        let planner = Planner { mission: config.planner.mission_for(duration_s), executive: "master".into() };
        let planner = ComponentHandle::new(&registry, "planner", planner).map_err(err)?;

        let s = config.supervision;
        let spec = SupervisorSpec::new("orsa", Strategy::OneForOne)
            .with_intensity(s.max_restarts, Duration::from_secs_f64(s.period_s))
            .with_clock(clock)
            .with_event_sink(on_event)
            .with_child(nomad.child_spec())
            .with_child(wall.child_spec())
            .with_child(center.child_spec())
            .with_child(master.child_spec())
            .with_child(planner.child_spec());
        let supervisor = Supervisor::start(spec).await.map_err(|e| StackError::Start(e.to_string()))?;
        Ok(Stack { registry, sim, truth, supervisor, board_faults })
    }

    /// Stops every component (the robot server stops the motors and waits for the axes) and
    /// the simulator.
    pub async fn shutdown(self) {
        self.supervisor.shutdown().await;
        if let Err(e) = self.sim.shutdown().await {
            tracing::warn!("simulator task ended badly: {e}");
        }
    }
}
