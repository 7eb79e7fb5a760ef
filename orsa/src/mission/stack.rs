//! The whole stack in one process: the simulated robot and every component of the config's
//! `[system]` table (by default the robot server, both behaviours, the master and the planner),
//! assembled by [`crate::system`] under one supervisor, on one registry and one clock.

use crate::config::Config;
use crate::system::{Catalog, RobotBoards, System};
use orsa_actors::supervision::{SupervisorEvent, SupervisorRef};
use orsa_actors::{Clock, Registry};
use orsa_hardware::faulty::BoardFaults;
use orsa_hardware::sim::{SimNomad200, SimRobot, SimTruth};
use orsa_hardware::world::World;

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
        Self::start_with(Catalog::builtin(), world, config, seed, duration_s, tap, on_event).await
    }

    /// As [`start`](Self::start), making the components from `catalog`.
    pub async fn start_with(
        catalog: Catalog,
        world: World,
        config: &Config,
        seed: u64,
        duration_s: f64,
        tap: Option<std::sync::Arc<dyn orsa_actors::tap::Tap>>,
        on_event: impl Fn(SupervisorEvent) + Send + Sync + 'static,
    ) -> Result<Stack, StackError> {
        let clock = Clock::simulated();
        let registry = Registry::with_clock(clock);
        registry.set_tap(tap);
        // Every message is accounted for: the report says what was delivered and what lost.
        registry.ledger().enable(true);
        let sim =
            SimNomad200::new(world, config.sim.clone(), seed).map_err(|e| StackError::Sim(e.to_string()))?;
        let sim = SimRobot::spawn(sim, clock);
        let truth = sim.truth();
        let board_faults = BoardFaults::new(seed);
        let system = System::builder(config)
            .catalog(catalog)
            .robot(RobotBoards::simulated(&sim, config, &board_faults))
            .duration(duration_s)
            .on_event(on_event)
            .start(&registry)
            .await
            .map_err(|e| StackError::Start(e.to_string()))?;
        let supervisor = system.supervisor;
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
