//! The catalog of component kinds: how to make each kind of component from the config.
//!
//! A kind is a name (`wallfollow`), the place that hosts it when the system is split over
//! processes, and a function that makes the component from the parts of the system
//! ([`Parts`]) and its entry in `[system]` ([`ComponentSpec`]). [`Catalog::builtin`] knows the
//! corridor mission's five kinds; adding a behaviour is one [`Catalog::register`] and one entry
//! in the config (see `examples/new_behaviour.rs`).

use super::robots::{MakeRobot, Robot, RobotError, RobotSetup};
use super::spec::{ComponentSpec, Place};
use crate::config::Config;
use orsa_actors::Registry;
use orsa_actors::component::{Component, ComponentHandle};
use orsa_actors::supervision::ChildSpec;
use orsa_executive::Master;
use orsa_hardware::any::{AnyMotorBoard, AnySensorBoard};
use orsa_hardware::faulty::{FaultyMotorBoard, FaultySensorBoard};
use orsa_hardware::safety::Guarded;
use orsa_hardware::server::{Nomad200, ServerParams};
use orsa_interfaces::nomad200::RobotParams;
use orsa_navigation::localizer::Localization;
use orsa_navigation::mapserver::MapServer;
use orsa_navigation::mcl::Pose2;
use orsa_planner::Planner;
use orsa_reactive::{CenterFollow, PathFollow, WallFollow};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

/// The navigation components' grid, m per cell.
pub const MAP_RESOLUTION_M: f64 = 0.05;

const NO_MAP: &str = "no map: the map and the localizer need the world, and this process was given none";

const NO_NAV: &str = "the mission goes to places, and the system lacks the navigation components it needs \
                      (map, localizer and pathfollow; `orsa run --goto` and config/navigation.toml add them)";

/// The simulator's robot kind, the one `orsa run` and the whole-stack tests drive.
pub const SIM: &str = "sim";

/// The robot's boards, for the process that hosts the robot server ([`Robot::boards`]).
#[derive(Debug, Clone)]
pub struct RobotBoards {
    /// The sensor board, behind the fault switch, read through the guarded board so that the
    /// judge of the sensors' health sees every scan the robot server reads.
    pub sensors: Guarded<FaultySensorBoard<AnySensorBoard>, FaultyMotorBoard<AnyMotorBoard>>,
    /// The motor board, behind the fault switch, guarded by the safety monitor (`[safety]`),
    /// which reads the sensor board as the robot server does.
    pub motors: Guarded<FaultySensorBoard<AnySensorBoard>, FaultyMotorBoard<AnyMotorBoard>>,
    /// The robot's geometry, limits and sensor layout.
    pub params: RobotParams,
}

/// What a kind's maker has to make a component from.
#[derive(Debug, Clone, Copy)]
pub struct Parts<'a> {
    /// The configuration of the whole system.
    pub config: &'a Config,
    /// Seconds the run lasts (the planner's default mission patrols for as long).
    pub duration_s: f64,
    /// The robot's boards, if this process hosts the robot.
    pub robot: Option<&'a RobotBoards>,
    /// The world, if this process knows it: the navigation components' known map.
    pub world: Option<&'a orsa_hardware::world::World>,
}

impl Parts<'_> {
    /// The robot server's name, as every client of it addresses it.
    pub fn robot_name(&self) -> &str {
        self.config.robot_name()
    }

    /// The parameters of the component `spec` describes, from its `[params.NAME]` table
    /// (defaults where it has none); unknown keys and bad values are errors that name the key.
    pub fn params<P: serde::de::DeserializeOwned>(
        &self,
        spec: &ComponentSpec,
    ) -> Result<P, orsa_actors::param::Invalid> {
        self.config.params_of(&spec.name)
    }
}

/// Why a component could not be made or started.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{component} ({kind}): {message}")]
pub struct MakeError {
    /// The component's name.
    pub component: String,
    /// Its kind.
    pub kind: String,
    /// What went wrong.
    pub message: String,
}

/// What a made component leaves the system: how to supervise it, and how to take it out again.
pub(crate) struct Made {
    pub(crate) child: ChildSpec,
    pub(crate) remove: Box<dyn Fn() + Send + Sync>,
}

type Make = dyn Fn(&Registry, &Parts<'_>, &ComponentSpec, Duration) -> Result<Made, BoxError> + Send + Sync;

/// Whatever error a maker gives: its own type, a parameter's [`Invalid`](orsa_actors::param::Invalid),
/// an I/O error, or a message (`Err("why".into())`); `?` converts any of them.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// One kind of component.
#[derive(Clone)]
pub struct Kind {
    place: Place,
    make: Arc<Make>,
}

impl std::fmt::Debug for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Kind").field("place", &self.place).finish_non_exhaustive()
    }
}

impl Kind {
    /// The place that hosts it unless its entry says otherwise.
    pub fn place(&self) -> Place {
        self.place
    }
}

/// Every kind of component a system can be made of, and every kind of robot it can run on.
#[derive(Clone, Default)]
pub struct Catalog {
    kinds: BTreeMap<String, Kind>,
    robots: BTreeMap<String, Arc<MakeRobot>>,
}

impl std::fmt::Debug for Catalog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Catalog")
            .field("kinds", &self.kinds.keys().collect::<Vec<_>>())
            .field("robots", &self.robots.keys().collect::<Vec<_>>())
            .finish()
    }
}

impl Catalog {
    /// A catalog with no kinds.
    pub fn empty() -> Self {
        Catalog::default()
    }

    /// The corridor mission's kinds: `robot` or `nomad200` (the robot server, on the robot's
    /// boards, whatever the robot),
    /// `wallfollow`, `centerfollow` (behaviours, on the robot), `master` and `planner` (with
    /// the executive); and the robot kinds `sim` (the simulator, the robot of `[sim]`) and
    /// `ros2` (a ROS 2 base, `[ros2.base]`).
    pub fn builtin() -> Self {
        let mut c = Catalog::empty();
        c.register_robot(SIM, super::robots::simulated);
        c.register_robot("ros2", super::robots::ros2);
        // The robot server, on whatever robot this process has the boards of: `robot` names
        // the kind for any robot, `nomad200` is the thesis' name for it.
        for kind in ["robot", "nomad200"] {
            c.register(kind, Place::Robot, |parts, spec| {
                let boards = parts.robot.ok_or("this process has no robot boards to serve")?;
                let params = ServerParams { name: spec.name.clone(), ..parts.params(spec)? };
                Ok(Nomad200::new(
                    params,
                    boards.params.clone(),
                    boards.sensors.clone(),
                    boards.motors.clone(),
                ))
            });
        }
        c.register("wallfollow", Place::Robot, |parts, spec| {
            Ok(WallFollow { params: parts.params(spec)?, robot: parts.robot_name().into() })
        });
        c.register("centerfollow", Place::Robot, |parts, spec| {
            Ok(CenterFollow { params: parts.params(spec)?, robot: parts.robot_name().into() })
        });
        c.register("master", Place::Executive, |parts, spec| {
            let mut params: orsa_executive::ExecutiveParams = parts.params(spec)?;
            params.robot = parts.robot_name().into();
            let cmd_timeout_s = parts.config.robot().cmd_timeout_s;
            let check: orsa_actors::param::Check<_> =
                Arc::new(move |p| crate::config::switch_step_fits(p, cmd_timeout_s));
            Ok(Master { params, check: Some(check) })
        });
        c.register("pathfollow", Place::Robot, |parts, spec| {
            Ok(PathFollow { params: parts.params(spec)?, robot: parts.robot_name().into() })
        });
        c.register("localizer", Place::Robot, |parts, spec| {
            let world = parts.world.ok_or(NO_MAP)?;
            let r = &world.robot;
            Ok(Localization {
                params: parts.params(spec)?,
                robot: parts.robot_name().into(),
                map: Arc::new(world.occupancy_grid(MAP_RESOLUTION_M)?),
                start: Pose2::new(r.x, r.y, r.heading_rad()),
            })
        });
        // The known map and its places, served to the planner wherever it runs.
        c.register(orsa_interfaces::map::NAME, Place::Robot, |parts, _spec| {
            let world = parts.world.ok_or(NO_MAP)?;
            let places = world
                .places
                .iter()
                .map(|p| orsa_interfaces::map::MapPlace {
                    name: p.name.clone(),
                    x_m: p.x,
                    y_m: p.y,
                    heading_deg: p.heading_deg,
                })
                .collect();
            let grid = world.occupancy_grid(MAP_RESOLUTION_M)?;
            Ok(MapServer { map: Arc::new(orsa_interfaces::map::KnownMap { grid, places }) })
        });
        // The planner waits up to 5 s for the master's answer to a goal: no handler timeout.
        // It needs no world: the map component gives it the map, from whichever process.
        c.register_untimed("planner", Place::Executive, |parts, spec| {
            let p: orsa_planner::PlannerParams = parts.params(spec)?;
            // It sends the robot to places where the system has the navigation components.
            let kind = |k: &str| parts.config.system.components.iter().find(|c| c.kind() == k);
            let nav = match kind(orsa_interfaces::map::NAME) {
                Some(map) if kind("localizer").is_some() && kind("pathfollow").is_some() => {
                    Some(orsa_planner::NavSetup {
                        map: map.name.clone(),
                        robot: parts.robot_name().into(),
                        judge: p.judge(),
                        recoveries: p.recoveries,
                        cruise_m_s: p.cruise_m_s,
                        clearance_m: p.clearance_m,
                    })
                }
                _ if p.navigates() => return Err(NO_NAV.into()),
                _ => None,
            };
            Ok(Planner {
                mission: p.mission_for(parts.duration_s),
                executive: orsa_interfaces::executive::NAME.into(),
                retries: p.retries,
                retry_after: Duration::from_secs_f64(p.retry_after_s),
                on_abort: p.on_abort,
                nav,
            })
        });
        c
    }

    /// Adds (or replaces) the kind `kind`, hosted by `place` unless an entry says otherwise:
    /// `make` makes the component from the system's parts and its entry. Its handler may run
    /// for at most `supervision.handler_timeout_s` before the instance is deemed hung.
    pub fn register<C: Component>(
        &mut self,
        kind: &str,
        place: Place,
        make: impl Fn(&Parts<'_>, &ComponentSpec) -> Result<C, BoxError> + Send + Sync + 'static,
    ) -> &mut Self {
        self.insert(kind, place, true, make)
    }

    /// As [`register`](Self::register), for a kind whose handler may wait longer than the
    /// handler timeout (it awaits answers inside its handler).
    pub fn register_untimed<C: Component>(
        &mut self,
        kind: &str,
        place: Place,
        make: impl Fn(&Parts<'_>, &ComponentSpec) -> Result<C, BoxError> + Send + Sync + 'static,
    ) -> &mut Self {
        self.insert(kind, place, false, make)
    }

    fn insert<C: Component>(
        &mut self,
        kind: &str,
        place: Place,
        timed: bool,
        make: impl Fn(&Parts<'_>, &ComponentSpec) -> Result<C, BoxError> + Send + Sync + 'static,
    ) -> &mut Self {
        let make: Arc<Make> = Arc::new(move |registry, parts, spec, timeout| {
            let component = make(parts, spec)?;
            let handle = ComponentHandle::new(registry, &spec.name, component)?;
            let handle = if timed { handle.with_handler_timeout(timeout) } else { handle };
            let child = handle.child_spec();
            Ok(Made { child, remove: Box::new(move || handle.remove()) })
        });
        self.kinds.insert(kind.to_string(), Kind { place, make });
        self
    }

    /// Adds (or replaces) the robot kind `kind`: `make` brings its robot up from what the
    /// process knows (see [`robots`](super::robots)).
    pub fn register_robot(
        &mut self,
        kind: &str,
        make: impl Fn(&RobotSetup<'_>) -> Result<Robot, BoxError> + Send + Sync + 'static,
    ) -> &mut Self {
        self.robots.insert(kind.to_string(), Arc::new(make));
        self
    }

    /// The names of every robot kind.
    pub fn robot_kinds(&self) -> Vec<String> {
        self.robots.keys().cloned().collect()
    }

    /// Whether `kind` is a robot kind of this catalog, or why not (naming the known ones).
    pub fn check_robot(&self, kind: &str) -> Result<(), RobotError> {
        if self.robots.contains_key(kind) {
            Ok(())
        } else {
            Err(RobotError::Unknown { kind: kind.into(), known: self.robot_kinds().join(", ") })
        }
    }

    /// Brings up a robot of kind `kind`.
    pub fn start_robot(&self, kind: &str, setup: &RobotSetup<'_>) -> Result<Robot, RobotError> {
        self.check_robot(kind)?;
        let mut robot = (self.robots[kind])(setup)
            .map_err(|e| RobotError::Make { kind: kind.into(), message: e.to_string() })?;
        robot.kind = kind.into();
        Ok(robot)
    }

    /// The kind called `kind`.
    pub fn get(&self, kind: &str) -> Option<&Kind> {
        self.kinds.get(kind)
    }

    /// The names of every kind.
    pub fn kinds(&self) -> Vec<String> {
        self.kinds.keys().cloned().collect()
    }

    /// Makes the component `spec` describes, registered in `registry`, ready to be supervised.
    pub(crate) fn make(
        &self,
        registry: &Registry,
        parts: &Parts<'_>,
        spec: &ComponentSpec,
        handler_timeout: Duration,
    ) -> Result<Made, MakeError> {
        let error = |message: String| MakeError {
            component: spec.name.clone(),
            kind: spec.kind().to_string(),
            message,
        };
        let kind = self.kinds.get(spec.kind()).ok_or_else(|| error("no such kind in the catalog".into()))?;
        (kind.make)(registry, parts, spec, handler_timeout).map_err(|e| error(e.to_string()))
    }
}
