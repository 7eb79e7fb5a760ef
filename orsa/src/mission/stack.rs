//! A whole system in one process: a robot of a kind from the catalog (the simulator's by
//! default) and the components of the config's `[system]` table (by default the robot server,
//! both behaviours, the master and the planner), assembled by [`crate::system`] under one
//! supervisor, on one registry and one clock.
//!
//! `orsa run`, the whole-stack tests and the benchmarks bring their systems up through it:
//!
//! ```no_run
//! # async fn demo() -> Result<(), orsa::mission::stack::StackError> {
//! use orsa::config::Config;
//! use orsa::hardware::world::World;
//! let config = Config::default();
//! let stack = orsa::mission::stack::Stack::builder(&config, World::palazzina().unwrap()).seed(7).start().await?;
//! // ... talk to its components through stack.registry; stack.truth() is the simulator's truth
//! stack.shutdown().await;
//! # Ok(()) }
//! ```

use crate::config::Config;
use crate::system::{AssemblyError, Catalog, Place, Robot, RobotError, RobotSetup, SIM, System};
use orsa_actors::supervision::{SupervisorEvent, SupervisorRef};
use orsa_actors::tap::Tap;
use orsa_actors::{Clock, Registry};
use orsa_hardware::faulty::BoardFaults;
use orsa_hardware::sim::SimTruth;
use orsa_hardware::world::World;
use std::sync::Arc;

/// A running stack.
pub struct Stack {
    /// The directory of its components.
    pub registry: Registry,
    /// The robot it drives (its boards, what it is, the simulator's truth if simulated).
    pub robot: Robot,
    /// The root supervisor.
    pub supervisor: SupervisorRef,
    /// The names of the components it hosts, in start order.
    pub components: Vec<String>,
    /// The switch for the robot's hardware faults (see [`orsa_hardware::faulty`]).
    pub board_faults: BoardFaults,
}

impl std::fmt::Debug for Stack {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stack").field("robot", &self.robot).field("components", &self.components).finish()
    }
}

/// What can go wrong bringing a stack up.
#[derive(Debug, thiserror::Error)]
pub enum StackError {
    /// The robot could not be brought up.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// A component could not be made, started or configured.
    #[error("starting the stack: {0}")]
    Start(#[from] AssemblyError),
}

/// What to bring up: see [`Stack::builder`].
pub struct StackBuilder<'a> {
    config: &'a Config,
    world: World,
    seed: u64,
    catalog: Catalog,
    robot_kind: String,
    duration_s: f64,
    tap: Option<Arc<dyn Tap>>,
    on_event: Option<Box<dyn Fn(SupervisorEvent) + Send + Sync + 'static>>,
    place: Option<Place>,
    names: Option<Vec<String>>,
    supervisor: Option<String>,
}

impl std::fmt::Debug for StackBuilder<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StackBuilder")
            .field("seed", &self.seed)
            .field("robot_kind", &self.robot_kind)
            .field("catalog", &self.catalog)
            .finish_non_exhaustive()
    }
}

impl<'a> StackBuilder<'a> {
    /// The seed of the simulator's noise and of the hardware fault switch (default 1).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Makes the robot and the components from `catalog` (default: [`Catalog::builtin`]).
    pub fn catalog(mut self, catalog: Catalog) -> Self {
        self.catalog = catalog;
        self
    }

    /// Drives a robot of this kind from the catalog (default: the simulator, [`SIM`]).
    pub fn robot(mut self, kind: &str) -> Self {
        self.robot_kind = kind.into();
        self
    }

    /// Seconds the run lasts (the planner's default mission patrols for as long; default 3600).
    pub fn duration(mut self, seconds: f64) -> Self {
        self.duration_s = seconds;
        self
    }

    /// `tap` sees every message from the first one on.
    pub fn tap(mut self, tap: Option<Arc<dyn Tap>>) -> Self {
        self.tap = tap;
        self
    }

    /// Supervisor events go to `sink`.
    pub fn on_event(mut self, sink: impl Fn(SupervisorEvent) + Send + Sync + 'static) -> Self {
        self.on_event = Some(Box::new(sink));
        self
    }

    /// Hosts only the components of `place`.
    pub fn only(mut self, place: Place) -> Self {
        self.place = Some(place);
        self
    }

    /// Hosts only the components named (each must be in the system).
    pub fn select(mut self, names: &[&str]) -> Self {
        self.names = Some(names.iter().map(|n| n.to_string()).collect());
        self
    }

    /// Names the top supervisor (default [`crate::system::TOP_SUPERVISOR`]).
    pub fn supervisor(mut self, name: &str) -> Self {
        self.supervisor = Some(name.into());
        self
    }

    /// Brings the stack up on a registry of its own, on a simulated clock (tokio's, paused or
    /// not), with the delivery ledger on. Must run inside a tokio runtime.
    pub async fn start(self) -> Result<Stack, StackError> {
        let registry = Registry::with_clock(Clock::simulated());
        // Every message is accounted for: the report says what was delivered and what lost.
        registry.ledger().enable(true);
        self.start_on(&registry).await
    }

    /// Brings the stack up on `registry` (and its clock). Must run inside a tokio runtime.
    pub async fn start_on(self, registry: &Registry) -> Result<Stack, StackError> {
        if self.tap.is_some() {
            registry.set_tap(self.tap.clone());
        }
        let setup =
            RobotSetup { config: self.config, world: &self.world, seed: self.seed, clock: registry.clock() };
        let robot = self.catalog.start_robot(&self.robot_kind, &setup)?;
        let board_faults = BoardFaults::new(self.seed);
        let boards = match robot.boards(&board_faults, &self.config.safety) {
            Ok(boards) => boards,
            Err(e) => {
                robot.shutdown().await;
                return Err(e.into());
            }
        };
        let mut builder =
            System::builder(self.config).catalog(self.catalog).robot(boards).duration(self.duration_s);
        builder = builder.world(self.world.clone());
        if let Some(sink) = self.on_event {
            builder = builder.on_event(sink);
        }
        if let Some(place) = self.place {
            builder = builder.only(place);
        }
        let names: Vec<&str> = self.names.iter().flatten().map(String::as_str).collect();
        if self.names.is_some() {
            builder = builder.select(&names);
        }
        if let Some(name) = &self.supervisor {
            builder = builder.supervisor(name);
        }
        let system = match builder.start(registry).await {
            Ok(system) => system,
            Err(e) => {
                robot.shutdown().await;
                return Err(e.into());
            }
        };
        Ok(Stack {
            registry: registry.clone(),
            robot,
            supervisor: system.supervisor,
            components: system.components,
            board_faults,
        })
    }
}

/// The simulator's truth of a stack a mission runs on (the mission checks there is one as it
/// starts, and refuses a robot without one).
pub(crate) fn truth_of(stack: &Stack) -> &SimTruth {
    stack.truth().expect("the mission checked at its start that its robot has a truth")
}

impl Stack {
    /// Starts describing a stack of `config` in `world`.
    pub fn builder(config: &Config, world: World) -> StackBuilder<'_> {
        StackBuilder {
            config,
            world,
            seed: 1,
            catalog: Catalog::builtin(),
            robot_kind: SIM.into(),
            duration_s: 3600.0,
            tap: None,
            on_event: None,
            place: None,
            names: None,
            supervisor: None,
        }
    }

    /// Brings a stack up on the simulator in `world` with `config` and `seed`; the mission runs
    /// for `duration_s` when the planner's mission is the default. `tap`, if given, sees every
    /// message from the first one on; supervisor events go to `on_event`. Must run inside a
    /// tokio runtime (paused or not). The short form of [`Stack::builder`].
    pub async fn start(
        world: World,
        config: &Config,
        seed: u64,
        duration_s: f64,
        tap: Option<Arc<dyn Tap>>,
        on_event: impl Fn(SupervisorEvent) + Send + Sync + 'static,
    ) -> Result<Stack, StackError> {
        Self::start_with(Catalog::builtin(), world, config, seed, duration_s, tap, on_event).await
    }

    /// As [`start`](Self::start), making the robot and the components from `catalog`.
    pub async fn start_with(
        catalog: Catalog,
        world: World,
        config: &Config,
        seed: u64,
        duration_s: f64,
        tap: Option<Arc<dyn Tap>>,
        on_event: impl Fn(SupervisorEvent) + Send + Sync + 'static,
    ) -> Result<Stack, StackError> {
        Stack::builder(config, world)
            .catalog(catalog)
            .seed(seed)
            .duration(duration_s)
            .tap(tap)
            .on_event(on_event)
            .start()
            .await
    }

    /// The simulator's ground truth, if the robot is simulated.
    pub fn truth(&self) -> Option<&SimTruth> {
        self.robot.truth.as_ref()
    }

    /// Stops the motors on the board itself, past every component; how long they took to come
    /// to rest.
    pub async fn stop_on_board(&self) -> Option<f64> {
        self.robot.stop_on_board(crate::ending::STOP_WAIT).await
    }

    /// Stops every component (the robot server stops the motors and waits for the axes) and
    /// then the robot (the simulator's task).
    pub async fn shutdown(self) {
        self.supervisor.shutdown().await;
        self.robot.shutdown().await;
    }
}
