//! Assembling a system, in one place: which components run, in which process, under which
//! supervisor, in which state and wired how.
//!
//! Everything that brings orsa components up goes through here: `orsa run` (every component
//! in one process), `orsa robot` and `orsa executive` (each hosts the components of its
//! [`Place`]), the benchmarks and the whole-stack tests. What to run comes from the config's
//! `[system]` table ([`SystemSpec`]); how to make each kind of component from a [`Catalog`].
//!
//! ```text
//! config [system]  ──►  SystemBuilder ──► one supervisor per process (config [supervision])
//!                        │  Catalog: kind -> maker          ├── nomad200      (place robot)
//!                        │  Parts: config, boards, duration ├── wallfollow    (place robot)
//!                        ▼                                  ├── centerfollow  (place robot)
//!             states and wiring from the entries            ├── master        (place executive)
//!                                                           └── planner       (place executive)
//! ```
//!
//! Children start in the order of `[system]`, each once the one before has set up its services.
//! Because a component keeps its services, wiring and subscriptions across restarts, one-for-one
//! is enough: a restarted server does not force its clients to restart.
//!
//! Modules: [`spec`] (the `[system]` table), [`catalog`] (kinds and how to make them),
//! [`robots`] (robot kinds: the robot a process drives, its boards and what it is),
//! [`live_params`] (the system's live parameters by name, for `orsa param` and Foxglove).

pub mod catalog;
pub mod live_params;
pub mod robots;
/// The `[system]` table (the crate's [`crate::spec`], which the config reads too).
pub use crate::spec;

pub use catalog::{BoxError, Catalog, Kind, MakeError, Parts, RobotBoards, SIM};
pub use robots::{Robot, RobotError, RobotHandle, RobotSetup};
pub use spec::{ComponentSpec, Place, SystemSpec};

use crate::config::Config;
use orsa_actors::Registry;
use orsa_actors::state::StateMaster;
use orsa_actors::supervision::{Strategy, Supervisor, SupervisorEvent, SupervisorRef, SupervisorSpec};
use orsa_actors::wiring::WiringMaster;
use std::sync::Arc;
use std::time::Duration;

/// Why a system could not be brought up.
#[derive(Debug, thiserror::Error)]
pub enum AssemblyError {
    /// The `[system]` table does not describe a system this catalog can make (the key at
    /// fault, and why).
    #[error("{0}")]
    Invalid(#[from] orsa_actors::param::Invalid),
    /// A component could not be made.
    #[error("making {0}")]
    Make(#[from] MakeError),
    /// The supervisor did not start.
    #[error("starting the supervisor '{name}': {message}")]
    Start {
        /// The supervisor.
        name: String,
        /// What went wrong.
        message: String,
    },
    /// A component's state or wiring from its entry could not be set.
    #[error("configuring {component}: {message}")]
    Configure {
        /// The component.
        component: String,
        /// What went wrong.
        message: String,
    },
}

/// A system brought up in this process.
pub struct System {
    /// The supervisor of this process's components.
    pub supervisor: SupervisorRef,
    /// The names of the components this process hosts, in start order.
    pub components: Vec<String>,
    removers: Vec<Box<dyn Fn() + Send + Sync>>,
}

impl std::fmt::Debug for System {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("System").field("components", &self.components).finish_non_exhaustive()
    }
}

/// The name of a system's supervisor unless the builder is given another (`orsa run`'s).
pub const TOP_SUPERVISOR: &str = "orsa";

/// The robot process's top supervisor (`orsa robot`).
pub const ROBOT_TOP: &str = "orsa-robot";

/// The executive process's top supervisor (`orsa executive`).
pub const EXECUTIVE_TOP: &str = "orsa-executive";

impl System {
    /// Starts describing the system of `config` (its `[system]` table).
    pub fn builder(config: &Config) -> SystemBuilder<'_> {
        SystemBuilder {
            config,
            catalog: Catalog::builtin(),
            place: None,
            names: None,
            robot: None,
            world: None,
            duration_s: 3600.0,
            name: TOP_SUPERVISOR.into(),
            on_event: None,
        }
    }

    /// Stops every component of this process (the robot server stops the motors and waits
    /// for the axes) and takes them out of the registry.
    pub async fn shutdown(self) {
        self.supervisor.shutdown().await;
        for remove in &self.removers {
            remove();
        }
    }
}

type EventSink = Arc<dyn Fn(SupervisorEvent) + Send + Sync>;

/// What to bring up: see [`System::builder`].
pub struct SystemBuilder<'a> {
    config: &'a Config,
    catalog: Catalog,
    place: Option<Place>,
    names: Option<Vec<String>>,
    robot: Option<RobotBoards>,
    world: Option<orsa_hardware::world::World>,
    duration_s: f64,
    name: String,
    on_event: Option<EventSink>,
}

impl std::fmt::Debug for SystemBuilder<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SystemBuilder")
            .field("place", &self.place)
            .field("name", &self.name)
            .field("catalog", &self.catalog.kinds())
            .finish_non_exhaustive()
    }
}

impl<'a> SystemBuilder<'a> {
    /// Makes components from this catalog (default: [`Catalog::builtin`]).
    pub fn catalog(mut self, catalog: Catalog) -> Self {
        self.catalog = catalog;
        self
    }

    /// Hosts only the components of `place` (default: all of them).
    pub fn only(mut self, place: Place) -> Self {
        self.place = Some(place);
        self
    }

    /// Hosts only these components of the system, in the system's order (default: those of
    /// the place, or all); for a program that splits a system its own way (the benchmarks).
    pub fn select(mut self, names: &[&str]) -> Self {
        self.names = Some(names.iter().map(|n| n.to_string()).collect());
        self
    }

    /// The robot's boards, for the robot server.
    pub fn robot(mut self, boards: RobotBoards) -> Self {
        self.robot = Some(boards);
        self
    }

    /// The world the robot is in, as far as this process knows it: the known map of the
    /// navigation components (the localizer's and the planner's).
    pub fn world(mut self, world: orsa_hardware::world::World) -> Self {
        self.world = Some(world);
        self
    }

    /// How long the run lasts, seconds (the planner's default mission; default: an hour).
    pub fn duration(mut self, seconds: f64) -> Self {
        self.duration_s = seconds;
        self
    }

    /// The supervisor's name (default: `orsa`).
    pub fn supervisor(mut self, name: &str) -> Self {
        self.name = name.into();
        self
    }

    /// Where the supervisor's events (restarts, giving up) go.
    pub fn on_event(mut self, sink: impl Fn(SupervisorEvent) + Send + Sync + 'static) -> Self {
        self.on_event = Some(Arc::new(sink));
        self
    }

    /// The place of every component of the system, after checking the `[system]` table
    /// against the catalog.
    pub fn placed(&self) -> Result<Vec<(&'a ComponentSpec, Place)>, AssemblyError> {
        let spec = &self.config.system;
        let kinds = self.catalog.kinds();
        spec.validate(|k| self.catalog.get(k).is_some(), &kinds).map_err(AssemblyError::Invalid)?;
        Ok(spec
            .components
            .iter()
            .map(|c| {
                let place = c.place.or_else(|| self.catalog.get(c.kind()).map(Kind::place));
                (c, place.unwrap_or(Place::Robot))
            })
            .collect())
    }

    /// The components this process will host.
    pub fn hosted(&self) -> Result<Vec<&'a ComponentSpec>, AssemblyError> {
        if let Some(missing) = self.names.iter().flatten().find(|n| !self.config.system.has(n)) {
            return Err(AssemblyError::Invalid(orsa_actors::param::Invalid::new(
                "system.components",
                format!("'{missing}' is not a component of the system"),
            )));
        }
        Ok(self
            .placed()?
            .into_iter()
            .filter(|(_, p)| self.place.is_none_or(|only| only == *p))
            .filter(|(c, _)| self.names.as_ref().is_none_or(|names| names.contains(&c.name)))
            .map(|(c, _)| c)
            .collect())
    }

    /// Makes the hosted components, starts them under the supervision tree of
    /// `[supervision]` on `registry`'s clock (a top supervisor over the subtrees of the hosted
    /// components, in the order their first member is hosted) and sets the states and wiring
    /// their entries ask for. Must run inside a tokio runtime.
    pub async fn start(self, registry: &Registry) -> Result<System, AssemblyError> {
        let hosted = self.hosted()?;
        let s = &self.config.supervision;
        // Events name their supervisor: the top must be told apart from its subtrees.
        if s.subtrees.contains_key(&self.name) {
            return Err(AssemblyError::Invalid(orsa_actors::param::Invalid::new(
                format!("supervision.subtrees.{}", self.name),
                format!(
                    "'{}' is the name of this process's top supervisor; give the subtree another name",
                    self.name
                ),
            )));
        }
        let timeout = Duration::from_secs_f64(s.handler_timeout_s);
        let parts = Parts {
            config: self.config,
            duration_s: self.duration_s,
            robot: self.robot.as_ref(),
            world: self.world.as_ref(),
        };
        let retry = Duration::from_secs_f64(s.retry_start_s);
        let mut spec = SupervisorSpec::new(self.name.clone(), Strategy::OneForOne)
            .with_intensity(s.max_restarts, Duration::from_secs_f64(s.period_s))
            .with_retry_delay(retry)
            .with_clock(registry.clock());
        if let Some(sink) = self.on_event.clone() {
            spec = spec.with_event_sink(move |e| sink(e));
        }
        // Whatever fails, nothing made is left registered and nothing started is left running.
        let mut removers: Vec<Box<dyn Fn() + Send + Sync>> = Vec::new();
        let undo = |removers: &[Box<dyn Fn() + Send + Sync>]| removers.iter().for_each(|r| r());
        // The top's children in start order: a component in no subtree, or a subtree (started
        // where its first hosted member is).
        enum Slot {
            Component(orsa_actors::supervision::ChildSpec),
            Subtree(String),
        }
        let mut slots: Vec<Slot> = Vec::new();
        let mut subtrees: std::collections::BTreeMap<String, SupervisorSpec> = Default::default();
        for c in &hosted {
            match self.catalog.make(registry, &parts, c, timeout) {
                Ok(made) => {
                    match s.subtree_of(&c.name) {
                        Some((name, t)) => {
                            let tree = subtrees.entry(name.to_string()).or_insert_with(|| {
                                slots.push(Slot::Subtree(name.to_string()));
                                SupervisorSpec::new(name, t.strategy)
                                    .with_intensity(t.max_restarts, Duration::from_secs_f64(t.period_s))
                                    .with_retry_delay(retry)
                            });
                            tree.children.push(made.child);
                        }
                        None => slots.push(Slot::Component(made.child)),
                    }
                    removers.push(made.remove);
                }
                Err(e) => {
                    undo(&removers);
                    return Err(e.into());
                }
            }
        }
        for slot in slots {
            let child = match slot {
                Slot::Component(child) => child,
                Slot::Subtree(name) => match subtrees.remove(&name) {
                    Some(tree) => orsa_actors::supervision::ChildSpec::supervisor(name, tree),
                    None => continue,
                },
            };
            spec.children.push(child);
        }
        let supervisor = match Supervisor::start(spec).await {
            Ok(s) => s,
            Err(e) => {
                undo(&removers);
                return Err(AssemblyError::Start { name: self.name.clone(), message: e.to_string() });
            }
        };
        let components = hosted.iter().map(|c| c.name.clone()).collect();
        let system = System { supervisor, components, removers };
        for c in &hosted {
            if let Err(e) = configure(registry, c).await {
                system.shutdown().await;
                return Err(e);
            }
        }
        Ok(system)
    }
}

/// Sets the state and the wiring a component's entry asks for.
async fn configure(registry: &Registry, c: &ComponentSpec) -> Result<(), AssemblyError> {
    let error = |message: String| AssemblyError::Configure { component: c.name.clone(), message };
    if let Some(state) = &c.state {
        let master = StateMaster::connect(registry, &c.name).map_err(|e| error(e.to_string()))?;
        master.set_state(state).await.map_err(|e| error(format!("state '{state}': {e}")))?;
    }
    let wiring = WiringMaster::new(registry);
    for (port, target) in c.wiring().map_err(|e| error(e.to_string()))? {
        wiring
            .connect_named(&c.name, &port, &target)
            .await
            .map_err(|e| error(format!("wiring {port} to {target}: {e}")))?;
    }
    Ok(())
}
