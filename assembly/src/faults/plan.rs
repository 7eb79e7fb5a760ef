//! Fault plans: the plan file, its parsing, and the checks of every fault against what the
//! process can break (its components, services, boards and links).

use crate::system::Place;
use orsa_actors::ServiceAddr;
use orsa_actors::fault::MessageFault;
use orsa_hardware::faulty::{FaultRing, SensorFault};
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// The kinds of fault, as plans name them.
pub const KINDS: [&str; 13] = [
    "panic",
    "hang",
    "kill",
    "drop",
    "delay",
    "duplicate",
    "sensor_stuck",
    "sensor_dropout",
    "sensor_noise",
    "motor_stall",
    "link_cut",
    "box_placed",
    "kidnap",
];

/// The kinds that change the simulated world rather than break a part of the robot: the
/// standard plan (`config/faults.example.toml`, a corridor patrol that does not localize) leaves
/// them out; the navigation tests put them in.
pub const WORLD_EVENTS: [&str; 2] = ["box_placed", "kidnap"];

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    #[serde(default)]
    fault: Vec<toml::Spanned<RawFault>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFault {
    at: f64,
    kind: String,
    target: String,
    duration: Option<f64>,
    every: Option<f64>,
    until: Option<f64>,
    delay_s: Option<f64>,
    sigma_m: Option<f64>,
    min: Option<[f64; 2]>,
    max: Option<[f64; 2]>,
    to: Option<[f64; 3]>,
}

/// What one fault does.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Action {
    /// The component's next handler panics.
    Panic {
        /// The component.
        component: String,
    },
    /// The component's next handler hangs.
    Hang {
        /// The component.
        component: String,
    },
    /// The component's instance is killed.
    Kill {
        /// The component.
        component: String,
    },
    /// The service's messages are dropped, delayed or duplicated.
    Message {
        /// The service.
        service: ServiceAddr,
        /// How.
        fault: MessageFault,
    },
    /// A sensor ring fails.
    Sensor {
        /// The ring.
        ring: FaultRing,
        /// How.
        fault: SensorFault,
    },
    /// The motors stall.
    MotorStall,
    /// The link to processes of this role is cut.
    LinkCut {
        /// The role.
        role: String,
    },
    /// A box is put down in the simulated world (and taken away when the fault ends).
    BoxPlaced {
        /// Its corner with the smallest coordinates, m.
        min: [f64; 2],
        /// Its corner with the largest coordinates, m.
        max: [f64; 2],
    },
    /// The simulated robot is picked up and set down elsewhere.
    Kidnap {
        /// Where, m.
        x: f64,
        /// .
        y: f64,
        /// Facing, degrees counter-clockwise from +x.
        heading_deg: f64,
    },
}

/// One fault of a plan, checked.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlannedFault {
    /// The kind, as the plan names it.
    pub kind: String,
    /// First occurrence, simulated seconds.
    pub at_s: f64,
    /// What it does.
    pub action: Action,
    /// How long each occurrence lasts (lasting kinds).
    pub duration_s: Option<f64>,
    /// Repeat period.
    pub every_s: Option<f64>,
    /// Last time an occurrence may start.
    pub until_s: Option<f64>,
}

/// A checked fault plan.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct FaultPlan {
    /// Its faults, in file order.
    pub faults: Vec<PlannedFault>,
    /// The text it was read from (a recording keeps it, so a replay can read it again).
    #[serde(skip)]
    pub source: String,
}

/// What a plan may name: the system it will run against.
#[derive(Debug, Clone)]
pub struct PlanTargets {
    /// Components.
    pub components: Vec<String>,
    /// Services whose messages can be faulted (Send and push services).
    pub services: Vec<ServiceAddr>,
    /// The roles of the other processes this one may cut its link to (`link_cut`); empty in a
    /// single-process run.
    pub roles: Vec<String>,
    /// Whether the robot's boards are here (sensor and motor faults, and the world events of
    /// a simulated robot).
    pub boards: bool,
}

impl PlanTargets {
    /// What `orsa run`'s stack offers to a plan: every component of the system, the robot
    /// server's Send and push services, every behaviour's status and the master's push.
    pub fn for_stack(config: &crate::config::Config) -> Self {
        let components = config.system.components.iter().map(|c| c.name.clone()).collect();
        let mut services = robot_and_behaviour_services(config);
        services.extend(master_services(config));
        PlanTargets { components, services, roles: Vec::new(), boards: true }
    }

    /// What `orsa robot`'s process offers to a plan: the components it hosts (the robot
    /// server and the behaviours), their Send and push services, and the links to the other
    /// processes.
    pub fn for_robot(config: &crate::config::Config) -> Self {
        let components = hosted(config, Place::Robot);
        let services = robot_and_behaviour_services(config);
        let roles = ["executive", "teleop", "tool"].map(String::from).to_vec();
        PlanTargets { components, services, roles, boards: true }
    }

    /// What `orsa executive`'s process offers to a plan: the components it hosts (the master
    /// and the planner), the master's push, and the links to the robot and the tools.
    pub fn for_executive(config: &crate::config::Config) -> Self {
        let components = hosted(config, Place::Executive);
        let services = master_services(config);
        let roles = ["robot", "teleop", "tool"].map(String::from).to_vec();
        PlanTargets { components, services, roles, boards: false }
    }
}

/// The components of the system that `place` hosts, read from the system (a kind's own place
/// where its entry gives none, as the built-in catalog says; a kind it does not know is a
/// robot-side one, as `Catalog::register`'s examples are).
fn hosted(config: &crate::config::Config, place: Place) -> Vec<String> {
    let catalog = crate::system::Catalog::builtin();
    config
        .system
        .components
        .iter()
        .filter(|c| {
            c.place.or_else(|| catalog.get(c.kind()).map(|k| k.place())).unwrap_or(Place::Robot) == place
        })
        .map(|c| c.name.clone())
        .collect()
}

/// The behaviours of the system: the components the executive's modes arbitrate, read from
/// the config rather than from a list of names, so a new behaviour is a target as soon as a mode
/// names it.
fn behaviours(config: &crate::config::Config) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for mode in config.executive().modes.values() {
        for b in &mode.behaviours {
            if config.system.has(b) && !out.contains(b) {
                out.push(b.clone());
            }
        }
    }
    out
}

/// The master's push, where the system has a master.
fn master_services(config: &crate::config::Config) -> Vec<ServiceAddr> {
    let master = orsa_interfaces::executive::NAME;
    if config.system.has(master) { vec![ServiceAddr::new(master, "driving")] } else { Vec::new() }
}

/// The robot server's Send and push services and the behaviours' status pushes, which every
/// process that runs them offers to a plan.
fn robot_and_behaviour_services(config: &crate::config::Config) -> Vec<ServiceAddr> {
    let robot = config.robot_name();
    let mut services: Vec<ServiceAddr> =
        ["navigationvelocity", "teleop", "distanceir", "distanceson", "bumpers", "basestate"]
            .iter()
            .map(|s| ServiceAddr::new(robot, *s))
            .collect();
    services.extend(behaviours(config).iter().map(|b| ServiceAddr::new(b, "status")));
    services
}

/// A plan that cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("{origin}: {message}")]
pub struct PlanError {
    /// The file.
    pub origin: String,
    /// What and where.
    pub message: String,
}

fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// The longest time a plan may name, seconds (the longest run `orsa run` accepts).
const MAX_TIME_S: f64 = 1e7;

fn positive(v: Option<f64>, key: &str) -> Result<Option<f64>, String> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0 && x <= MAX_TIME_S) => {
            Err(format!("{key} must be a positive number of seconds, at most {MAX_TIME_S:e}, not {x}"))
        }
        other => Ok(other),
    }
}

impl FaultPlan {
    /// Parses and checks a plan against the system it will run on. `origin` names the file
    /// in errors.
    pub fn parse(text: &str, origin: &str, targets: &PlanTargets) -> Result<FaultPlan, PlanError> {
        let err = |message: String| PlanError { origin: origin.to_string(), message };
        let file: PlanFile = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| format!("line {}: ", line_of(text, s.start))).unwrap_or_default();
            err(format!("{line}{}", e.message()))
        })?;
        let mut faults = Vec::new();
        for (i, spanned) in file.fault.iter().enumerate() {
            let line = line_of(text, spanned.span().start);
            let raw = spanned.get_ref();
            let checked =
                check(raw, targets).map_err(|m| err(format!("fault #{} (line {line}): {m}", i + 1)))?;
            faults.push(checked);
        }
        Ok(FaultPlan { faults, source: text.to_string() })
    }

    /// Reads and checks a plan file.
    pub fn load(path: &std::path::Path, targets: &PlanTargets) -> Result<FaultPlan, PlanError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| PlanError { origin: origin.clone(), message: format!("cannot read: {e}") })?;
        Self::parse(&text, &origin, targets)
    }

    /// Every occurrence up to `end_s`, as (start, fault) in time order.
    pub fn occurrences(&self, end_s: f64) -> Vec<(f64, &PlannedFault)> {
        let mut out = Vec::new();
        for f in &self.faults {
            let until = f.until_s.unwrap_or(end_s).min(end_s);
            let mut k = 0u64;
            loop {
                let t = f.at_s + f.every_s.map_or(0.0, |e| e * k as f64);
                if t > until || (k > 0 && f.every_s.is_none()) {
                    break;
                }
                out.push((t, f));
                k += 1;
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }
}

fn check(raw: &RawFault, targets: &PlanTargets) -> Result<PlannedFault, String> {
    if !(raw.at.is_finite() && (0.0..=MAX_TIME_S).contains(&raw.at)) {
        return Err(format!("at must be a time in seconds from 0 to {MAX_TIME_S:e}, not {}", raw.at));
    }
    let duration_s = positive(raw.duration, "duration")?;
    let every_s = positive(raw.every, "every")?;
    let until_s = match raw.until {
        Some(u) if !(u.is_finite() && u >= raw.at && u <= MAX_TIME_S) => {
            return Err(format!(
                "until ({u}) must be a time at or after at ({}), at most {MAX_TIME_S:e}",
                raw.at
            ));
        }
        other => other,
    };
    let component = |t: &str| -> Result<String, String> {
        if targets.components.iter().any(|c| c == t) {
            Ok(t.to_string())
        } else {
            Err(format!("unknown component '{t}' (known: {})", targets.components.join(", ")))
        }
    };
    let needs_duration = |kind: &str| -> Result<(), String> {
        if duration_s.is_none() {
            return Err(format!("a '{kind}' fault lasts: give its duration (seconds)"));
        }
        Ok(())
    };
    let action = match raw.kind.as_str() {
        "panic" => Action::Panic { component: component(&raw.target)? },
        "hang" => Action::Hang { component: component(&raw.target)? },
        "kill" => Action::Kill { component: component(&raw.target)? },
        k @ ("drop" | "delay" | "duplicate") => {
            needs_duration(k)?;
            let service: ServiceAddr = raw
                .target
                .parse()
                .map_err(|_| format!("'{}' is not a service: expected component/service", raw.target))?;
            if !targets.services.contains(&service) {
                let known: Vec<String> = targets.services.iter().map(ToString::to_string).collect();
                return Err(format!(
                    "unknown service '{service}' for '{k}' (Send and push services: {})",
                    known.join(", ")
                ));
            }
            let fault = match k {
                "drop" => MessageFault::Drop,
                "duplicate" => MessageFault::Duplicate,
                _ => {
                    let d =
                        positive(raw.delay_s, "delay_s")?.ok_or("a 'delay' fault needs delay_s (seconds)")?;
                    MessageFault::Delay(Duration::from_secs_f64(d))
                }
            };
            Action::Message { service, fault }
        }
        k @ ("sensor_stuck" | "sensor_dropout" | "sensor_noise" | "motor_stall") if !targets.boards => {
            return Err(format!(
                "a '{k}' fault breaks the robot's boards, which are not in this process: use it with \
                 `orsa run` or `orsa robot --faults`"
            ));
        }
        k @ ("box_placed" | "kidnap") if !targets.boards => {
            return Err(format!(
                "a '{k}' fault changes the simulated robot's world, which is not in this process: use \
                 it with `orsa run` or `orsa robot --faults`"
            ));
        }
        "box_placed" => {
            if raw.target != "world" {
                return Err(format!("unknown target '{}' for 'box_placed' (known: world)", raw.target));
            }
            let (Some(min), Some(max)) = (raw.min, raw.max) else {
                return Err("a 'box_placed' fault needs min = [x, y] and max = [x, y] (metres)".into());
            };
            if !(min.iter().chain(&max).all(|v| v.is_finite()) && min[0] < max[0] && min[1] < max[1]) {
                return Err(format!(
                    "a box needs finite corners with min < max on both axes, not min = {min:?}, max = {max:?}"
                ));
            }
            Action::BoxPlaced { min, max }
        }
        "kidnap" => {
            if raw.target != "robot" {
                return Err(format!("unknown target '{}' for 'kidnap' (known: robot)", raw.target));
            }
            let Some([x, y, heading_deg]) = raw.to else {
                return Err(
                    "a 'kidnap' fault needs to = [x, y, heading_deg]: where the robot is set down".into()
                );
            };
            if !(x.is_finite() && y.is_finite() && heading_deg.is_finite()) {
                return Err(format!("to must be finite, not [{x}, {y}, {heading_deg}]"));
            }
            Action::Kidnap { x, y, heading_deg }
        }
        k @ ("sensor_stuck" | "sensor_dropout" | "sensor_noise") => {
            needs_duration(k)?;
            let ring = FaultRing::from_name(&raw.target).ok_or_else(|| {
                format!("unknown sensor ring '{}' (known: sonar, infrared, bumpers)", raw.target)
            })?;
            let fault = match k {
                "sensor_stuck" => SensorFault::Stuck,
                "sensor_dropout" => SensorFault::Dropout,
                _ => SensorFault::Noise(
                    positive(raw.sigma_m, "sigma_m")?
                        .ok_or("a 'sensor_noise' fault needs sigma_m (metres)")?,
                ),
            };
            Action::Sensor { ring, fault }
        }
        "motor_stall" => {
            needs_duration("motor_stall")?;
            if raw.target != "motors" {
                return Err(format!("unknown target '{}' for 'motor_stall' (known: motors)", raw.target));
            }
            Action::MotorStall
        }
        "link_cut" => {
            needs_duration("link_cut")?;
            if targets.roles.is_empty() {
                return Err(
                    "'link_cut' cuts the link between processes: use it with `orsa robot --faults` or \
                     `orsa executive --faults`, not in a single-process run"
                        .into(),
                );
            }
            if !targets.roles.contains(&raw.target) {
                return Err(format!(
                    "unknown process role '{}' (known here: {})",
                    raw.target,
                    targets.roles.join(", ")
                ));
            }
            Action::LinkCut { role: raw.target.clone() }
        }
        other => return Err(format!("unknown kind '{other}' (known: {})", KINDS.join(", "))),
    };
    let extra = |present: bool, keys: &str, kind: &str| -> Result<(), String> {
        if present { Err(format!("{keys} only for '{kind}' faults, not for '{}'", raw.kind)) } else { Ok(()) }
    };
    extra(
        (raw.min.is_some() || raw.max.is_some()) && !matches!(action, Action::BoxPlaced { .. }),
        "min and max are",
        "box_placed",
    )?;
    extra(raw.to.is_some() && !matches!(action, Action::Kidnap { .. }), "to is", "kidnap")?;
    if duration_s.is_some()
        && matches!(
            action,
            Action::Panic { .. } | Action::Hang { .. } | Action::Kill { .. } | Action::Kidnap { .. }
        )
    {
        return Err(format!("a '{}' fault is instantaneous: remove its duration", raw.kind));
    }
    Ok(PlannedFault { kind: raw.kind.clone(), at_s: raw.at, action, duration_s, every_s, until_s })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn targets() -> PlanTargets {
        PlanTargets {
            components: vec!["nomad200".into(), "centerfollow".into()],
            services: vec!["nomad200/navigationvelocity".parse().expect("addr")],
            roles: Vec::new(),
            boards: true,
        }
    }

    #[test]
    fn a_plan_parses_and_expands_its_repeats() {
        let text = r#"
[[fault]]
at = 1.0
kind = "panic"
target = "centerfollow"
every = 0.5
until = 2.0

[[fault]]
at = 1.2
kind = "sensor_noise"
target = "infrared"
duration = 3.0
sigma_m = 0.02
"#;
        let plan = FaultPlan::parse(text, "plan.toml", &targets()).expect("valid");
        let times: Vec<f64> = plan.occurrences(100.0).iter().map(|(t, _)| *t).collect();
        assert_eq!(times, vec![1.0, 1.2, 1.5, 2.0]);
        assert_eq!(
            plan.faults[1].action,
            Action::Sensor { ring: FaultRing::Infrared, fault: SensorFault::Noise(0.02) }
        );
    }

    #[test]
    fn errors_name_the_fault_its_line_and_what_would_do() {
        let cases = [
            (
                "[[fault]]\nat = 1\nkind = \"pnic\"\ntarget = \"x\"\n",
                "fault #1 (line 1): unknown kind 'pnic' (known: panic, hang",
            ),
            (
                "[[fault]]\nat = 1\nkind = \"panic\"\ntarget = \"ghost\"\n",
                "unknown component 'ghost' (known: nomad200, centerfollow)",
            ),
            (
                "[[fault]]\nat = 1\nkind = \"drop\"\ntarget = \"nomad200/safety\"\nduration = 1\n",
                "unknown service 'nomad200/safety'",
            ),
            (
                "[[fault]]\nat = 1\nkind = \"sensor_stuck\"\ntarget = \"lidar\"\nduration = 1\n",
                "unknown sensor ring 'lidar'",
            ),
            (
                "[[fault]]\nat = 1\nkind = \"drop\"\ntarget = \"nomad200/navigationvelocity\"\n",
                "give its duration",
            ),
            ("[[fault]]\nat = 1\nkind = \"kill\"\ntarget = \"nomad200\"\nduration = 2\n", "instantaneous"),
            (
                "[[fault]]\nat = 1\nkind = \"link_cut\"\ntarget = \"executive\"\nduration = 2\n",
                "orsa robot --faults",
            ),
            ("[[fault]]\nat = -1\nkind = \"kill\"\ntarget = \"nomad200\"\n", "at must be"),
            (
                "[[fault]]\nat = 1\nkind = \"kill\"\ntarget = \"nomad200\"\nevery = 0\n",
                "every must be a positive",
            ),
            ("[[fault]]\nat = 1\nkind = \"kill\"\ntarget = \"nomad200\"\ncolour = 2\n", "line 5"),
            (
                "\n\n[[fault]]\nat = 1\nkind = \"panic\"\ntarget = \"nomad200\"\n\n[[fault]]\nat = 1\nkind = \"delay\"\ntarget = \"nomad200/navigationvelocity\"\nduration = 1\n",
                "fault #2 (line 8): a 'delay' fault needs delay_s",
            ),
        ];
        for (text, expected) in cases {
            let e = FaultPlan::parse(text, "plan.toml", &targets()).expect_err(text).to_string();
            assert!(e.starts_with("plan.toml: "), "{e}");
            assert!(e.contains(expected), "{e}\n  should contain: {expected}");
        }
    }

    #[test]
    fn world_events_parse_and_their_keys_are_checked() {
        let ok = "[[fault]]\nat = 30\nkind = \"box_placed\"\ntarget = \"world\"\nmin = [4.0, 1.0]\nmax = [4.6, 2.0]\nduration = 60\n\n\
                  [[fault]]\nat = 90\nkind = \"kidnap\"\ntarget = \"robot\"\nto = [12.0, 1.2, 180.0]\n";
        let plan = FaultPlan::parse(ok, "plan.toml", &targets()).expect("world events");
        assert_eq!(plan.faults[0].action, Action::BoxPlaced { min: [4.0, 1.0], max: [4.6, 2.0] });
        assert_eq!(plan.faults[0].duration_s, Some(60.0));
        assert_eq!(plan.faults[1].action, Action::Kidnap { x: 12.0, y: 1.2, heading_deg: 180.0 });
        let head = |kind: &str, target: &str| {
            format!("[[fault]]\nat = 1\nkind = \"{kind}\"\ntarget = \"{target}\"\n")
        };
        for (text, expected) in [
            (head("box_placed", "world"), "needs min = [x, y] and max = [x, y]"),
            (
                head("box_placed", "door") + "min = [0, 0]\nmax = [1, 1]\n",
                "unknown target 'door' for 'box_placed'",
            ),
            (head("box_placed", "world") + "min = [2, 0]\nmax = [1, 1]\n", "min < max on both axes"),
            (head("kidnap", "robot"), "needs to = [x, y, heading_deg]"),
            (
                head("kidnap", "nomad200") + "to = [1, 1, 0]\n",
                "unknown target 'nomad200' for 'kidnap' (known: robot)",
            ),
            (head("kidnap", "robot") + "to = [1, 1, 0]\nduration = 3\n", "instantaneous"),
            (head("kidnap", "robot") + "to = [1, 1]\n", "line 5"),
            (head("kill", "nomad200") + "to = [1, 1, 0]\n", "to is only for 'kidnap' faults, not for 'kill'"),
            (
                head("kidnap", "robot") + "to = [1, 1, 0]\nmin = [0, 0]\n",
                "min and max are only for 'box_placed' faults",
            ),
        ] {
            let e = FaultPlan::parse(&text, "plan.toml", &targets()).expect_err(&text).to_string();
            assert!(e.contains(expected), "{e}\n  should contain: {expected}");
        }
        // Where the robot is not, neither is its world.
        let e =
            FaultPlan::parse(ok, "exec.toml", &PlanTargets::for_executive(&crate::config::Config::default()))
                .expect_err("no world in the executive")
                .to_string();
        assert!(e.contains("changes the simulated robot's world, which is not in this process"), "{e}");
    }

    #[test]
    fn an_executive_plan_names_the_executives_components_and_cuts_its_link_to_the_robot() {
        let config = crate::config::Config::default();
        let targets = PlanTargets::for_executive(&config);
        let ok = "[[fault]]\nat = 1\nkind = \"hang\"\ntarget = \"master\"\n\n\
                  [[fault]]\nat = 2\nkind = \"link_cut\"\ntarget = \"robot\"\nduration = 1\n\n\
                  [[fault]]\nat = 3\nkind = \"drop\"\ntarget = \"master/driving\"\nduration = 1\n";
        let plan = FaultPlan::parse(ok, "exec.toml", &targets).expect("an executive plan");
        assert_eq!(plan.faults.len(), 3);
        for (text, expected) in [
            ("[[fault]]\nat = 1\nkind = \"kill\"\ntarget = \"nomad200\"\n", "unknown component 'nomad200'"),
            (
                "[[fault]]\nat = 1\nkind = \"link_cut\"\ntarget = \"executive\"\nduration = 1\n",
                "unknown process role 'executive' (known here: robot, teleop, tool)",
            ),
            (
                "[[fault]]\nat = 1\nkind = \"motor_stall\"\ntarget = \"motors\"\nduration = 1\n",
                "which are not in this process",
            ),
        ] {
            let e = FaultPlan::parse(text, "exec.toml", &targets).expect_err(text).to_string();
            assert!(e.contains(expected), "{e}\n  should contain: {expected}");
        }
    }

    /// A behaviour is a target because the system runs it and a mode names it, not because it
    /// is on a list: a new one is a target with no edit here, and a removed one is not.
    #[test]
    fn targets_are_read_from_the_system() {
        let default = PlanTargets::for_stack(&crate::config::Config::default());
        assert_eq!(default.components, ["nomad200", "wallfollow", "centerfollow", "master", "planner"]);
        let robot = PlanTargets::for_robot(&crate::config::Config::default());
        assert_eq!(robot.components, ["nomad200", "wallfollow", "centerfollow"]);
        let text = "[[system.components]]\nname = \"nomad200\"\n\
                    [[system.components]]\nname = \"wander\"\n\
                    [[system.components]]\nname = \"master\"\n\
                    [params.master.modes.wander]\nbehaviours = [\"wander\"]\nrules = [{ drive = \"wander\" }]\n";
        let config = crate::config::Config::from_toml(text, "wander.toml").expect("config");
        let targets = PlanTargets::for_stack(&config);
        assert_eq!(targets.components, ["nomad200", "wander", "master"]);
        let plan = "[[fault]]\nat = 1\nkind = \"kill\"\ntarget = \"wander\"\n\n\
                    [[fault]]\nat = 2\nkind = \"drop\"\ntarget = \"wander/status\"\nduration = 1\n";
        FaultPlan::parse(plan, "plan.toml", &targets).expect("the new behaviour is a target");
        let gone = "[[fault]]\nat = 1\nkind = \"kill\"\ntarget = \"wallfollow\"\n";
        let e = FaultPlan::parse(gone, "plan.toml", &targets).expect_err("not in this system").to_string();
        assert!(e.contains("unknown component 'wallfollow'"), "{e}");
        assert_eq!(
            PlanTargets::for_robot(&config).components,
            ["nomad200", "wander"],
            "an unknown kind is robot-side"
        );
    }
}
