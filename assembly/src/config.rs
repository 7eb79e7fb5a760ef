//! The configuration of a whole orsa stack: one TOML file, every table typed and checked.
//!
//! Every table may be left out (its defaults apply) and every key inside one too; an unknown key
//! is an error, as is a value out of range. Errors name the file, the line and column, and the
//! key. The shipped [`DEFAULT_CONFIG`] (`config/orsa.toml`) lists every key with its default
//! and what it means.

use orsa_actors::param::Invalid;
use orsa_executive::ExecutiveParams;
use orsa_hardware::server::ServerParams;
use orsa_hardware::sim::SimConfig;
use orsa_navigation::localizer::LocalizerParams;
use orsa_planner::PlannerParams;
use orsa_reactive::centerfollow::CenterFollowParams;
use orsa_reactive::pathfollow::PathFollowParams;
use orsa_reactive::wallfollow::WallFollowParams;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The commented default configuration, as shipped.
pub const DEFAULT_CONFIG: &str = include_str!("../../config/orsa.toml");

/// Everything a stack needs besides the world and the seed.
///
/// Two kinds of table: the process-level ones (`[sim]`, `[supervision]`, `[link]`, `[ros2]`,
/// and `[system]`, which says what runs), and one `[params.NAME]` per component, by its name in
/// the system, for every kind alike: the robot server, the behaviours, the master and the
/// planner read theirs from there as a user's own kind does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// The simulated robot (`[sim]`).
    pub sim: SimConfig,
    /// How the stack's supervisor restarts what fails (`[supervision]`).
    pub supervision: SupervisionParams,
    /// How the robot watches its executive across processes (`[link]`).
    pub link: LinkParams,
    /// Which components run, where, in which state and wired how (`[system]`).
    pub system: crate::spec::SystemSpec,
    /// The robot as a ROS 2 node, and a ROS 2 robot as orsa's hardware (`[ros2]`).
    pub ros2: Ros2Params,
    /// The safety monitor between every driver and the motors (`[safety]`), read at start
    /// only: no client can loosen it at run time.
    pub safety: orsa_hardware::safety::SafetyParams,
    /// Each component's parameters, by its name in the system (`[params.NAME]`). At load, a
    /// built-in kind's table is checked and written out in full, its defaults included.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub params: BTreeMap<String, toml::Table>,
}

impl Default for Config {
    /// The corridor mission, every parameter at its default.
    fn default() -> Self {
        let mut c = Config {
            sim: Default::default(),
            supervision: Default::default(),
            link: Default::default(),
            system: Default::default(),
            ros2: Default::default(),
            safety: Default::default(),
            params: BTreeMap::new(),
        };
        if let Err(e) = c.complete_params() {
            // The defaults of every built-in kind are valid (the shipped file's test holds it).
            tracing::error!("the default parameters do not check: {}", e.1);
        }
        c
    }
}

/// The tables a built-in kind's parameters had before they moved to `[params.NAME]`.
const MOVED_TABLES: [(&str, &str); 5] = [
    ("robot", "the robot server"),
    ("wallfollow", "wall following"),
    ("centerfollow", "center following"),
    ("executive", "the master"),
    ("planner", "the planner"),
];

/// The built-in kinds whose parameters the config checks at load: the kind, the name its
/// validators give the table in messages, and how to read, check and write them out in full.
type Complete = fn(&toml::Table) -> Result<toml::Table, String>;

fn typed<P: serde::de::DeserializeOwned + Serialize>(
    table: &toml::Table,
    check: impl Fn(&P) -> Result<(), orsa_actors::param::Invalid>,
) -> Result<toml::Table, String> {
    // Read from text, so that an error has a place: the key it is at.
    let text = toml::to_string(table).map_err(|e| format!("cannot write the parameters: {e}"))?;
    let p: P = toml::from_str(&text).map_err(|e| {
        let message = e.message().trim().replace('\n', " ");
        match e.span().and_then(|s| key_at(&text, s.start)) {
            Some(key) if !message.contains(&format!("`{key}`")) => format!("{key}: {message}"),
            _ => message,
        }
    })?;
    check(&p).map_err(String::from)?;
    toml::Table::try_from(&p).map_err(|e| format!("cannot write the parameters back: {e}"))
}

/// The dotted key of the line at `offset` in `text` (a TOML document of `key = value` lines
/// under `[table]` headers), if that line holds a key.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let start = text[..offset.min(text.len())].rfind('\n').map_or(0, |i| i + 1);
    let line = text[start..].lines().next()?.trim();
    let (key, _) = line.split_once('=')?;
    let table = text[..start].lines().rev().find_map(|l| {
        let l = l.trim();
        l.strip_prefix('[').and_then(|l| l.strip_suffix(']')).map(str::to_string)
    });
    let key = key.trim().trim_matches('"');
    Some(match table {
        Some(t) => format!("{t}.{key}"),
        None => key.to_string(),
    })
}

fn builtin(kind: &str) -> Option<(&'static str, Complete)> {
    Some(match kind {
        "robot" | "nomad200" => ("robot", |t| typed::<ServerParams>(t, ServerParams::validate)),
        "wallfollow" => ("wallfollow", |t| typed::<WallFollowParams>(t, WallFollowParams::validate)),
        "centerfollow" => ("centerfollow", |t| typed::<CenterFollowParams>(t, CenterFollowParams::validate)),
        "master" => ("executive", |t| typed::<ExecutiveParams>(t, ExecutiveParams::validate)),
        "planner" => ("planner", |t| typed::<PlannerParams>(t, |_| Ok(()))),
        "localizer" => ("localizer", |t| typed::<LocalizerParams>(t, LocalizerParams::validate)),
        "pathfollow" => ("pathfollow", |t| typed::<PathFollowParams>(t, PathFollowParams::validate)),
        _ => return None,
    })
}

/// The robot server's kinds.
const ROBOT_KINDS: [&str; 2] = ["robot", "nomad200"];

/// The robot as a ROS 2 node (`orsa robot --ros2`), and a ROS 2 robot behind orsa's boards
/// (`orsa robot --hardware ros2`). See `docs/ros2.md`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ros2Params {
    /// The node's name on the ROS 2 graph.
    pub node: String,
    /// The node's namespace (`/` for none): its topics are under it.
    pub namespace: String,
    /// `/cmd_vel` messages accepted per second, beyond a burst (more are refused and counted).
    pub cmd_vel_rate_hz: f64,
    /// `/cmd_vel` messages accepted at once before the rate applies.
    pub cmd_vel_burst: u32,
    /// The ROS 2 robot orsa drives with `--hardware ros2` (`[ros2.base]`).
    pub base: orsa_hardware::ros2base::Ros2BaseParams,
}

impl Default for Ros2Params {
    fn default() -> Self {
        Ros2Params {
            node: "orsa".into(),
            namespace: "/".into(),
            cmd_vel_rate_hz: 50.0,
            cmd_vel_burst: 20,
            base: Default::default(),
        }
    }
}

impl Ros2Params {
    /// Checks every value; the message names the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        orsa_net::ros2::Ros2Options { domain: 0, namespace: self.namespace.clone(), name: self.node.clone() }
            .validate()
            .map_err(|e| Invalid::new("ros2.node / ros2.namespace", e.to_string()))?;
        let r = self.cmd_vel_rate_hz;
        if !(r.is_finite() && r > 0.0 && r <= 10_000.0) {
            return Err(Invalid::new(
                "ros2.cmd_vel_rate_hz",
                format!("must be from 0 to 10000 per second, not {r}"),
            ));
        }
        if !(1..=10_000).contains(&self.cmd_vel_burst) {
            return Err(Invalid::new(
                "ros2.cmd_vel_burst",
                format!("must be from 1 to 10000, not {}", self.cmd_vel_burst),
            ));
        }
        self.base.validate().map_err(|e| e.under("ros2.base"))
    }
}

/// A hand-over leaves the motors without a driver for one switch step, two if it fails and is
/// undone: that must fit in the robot's command timeout, or the watchdog stops the robot in the
/// middle of every slow hand-over. (Checked for the file, and for every live set of the
/// master's parameters.)
pub fn switch_step_fits(
    executive: &ExecutiveParams,
    cmd_timeout_s: f64,
) -> Result<(), orsa_actors::param::Invalid> {
    let step = executive.switch_step_s;
    if 2.0 * step > cmd_timeout_s {
        return Err(orsa_actors::param::Invalid::new(
            "switch_step_s",
            format!(
                "{step} s is too long for the robot server's cmd_timeout_s = {cmd_timeout_s} s: a \
                 hand-over leaves the motors without a driver for up to two steps"
            ),
        ));
    }
    Ok(())
}

/// How the robot watches its executive across processes: the executive publishes a heartbeat,
/// and the robot treats it as lost when none came for the lease (as when its process token
/// disappears), so a link that goes silent while zenoh's session stays up stops the robot
/// within the velocity timeout.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinkParams {
    /// The executive publishes a heartbeat this often, seconds.
    pub heartbeat_period_s: f64,
    /// The robot treats the executive as lost after this long without a heartbeat, seconds;
    /// default: 0.6 x `robot.cmd_timeout_s`. At most `robot.cmd_timeout_s`.
    pub lease_s: Option<f64>,
}

impl Default for LinkParams {
    fn default() -> Self {
        LinkParams { heartbeat_period_s: 0.1, lease_s: None }
    }
}

impl LinkParams {
    /// The lease for a robot whose command timeout is `cmd_timeout_s`.
    pub fn lease(&self, cmd_timeout_s: f64) -> std::time::Duration {
        std::time::Duration::from_secs_f64(self.lease_s.unwrap_or(0.6 * cmd_timeout_s))
    }

    /// Checks the values against the robot's command timeout; the message names the key.
    pub fn validate(&self, cmd_timeout_s: f64) -> Result<(), Invalid> {
        let p = self.heartbeat_period_s;
        if !(p.is_finite() && (0.001..=10.0).contains(&p)) {
            return Err(Invalid::new(
                "link.heartbeat_period_s",
                format!("must be from 0.001 to 10 seconds, not {p}"),
            ));
        }
        if let Some(l) = self.lease_s
            && !(l.is_finite() && l > 0.0 && l <= cmd_timeout_s)
        {
            return Err(Invalid::new(
                "link.lease_s",
                format!(
                    "must be more than 0 and at most robot.cmd_timeout_s ({cmd_timeout_s} s), so that a \
                     silent executive stops the robot within the velocity timeout, not {l}"
                ),
            ));
        }
        let lease = self.lease(cmd_timeout_s).as_secs_f64();
        if lease < 2.0 * p {
            return Err(Invalid::new(
                "link.lease_s",
                format!(
                    "{lease} s must be at least twice link.heartbeat_period_s ({p} s): one late heartbeat \
                     would lose the executive"
                ),
            ));
        }
        Ok(())
    }
}

/// How the stack's supervisors restart what fails: a top supervisor over subtrees, each with its
/// own strategy and intensity, so that a behaviour crashing often uses up the behaviours'
/// budget, never the robot server's. A subtree that gives up is restarted whole by the top; the
/// top giving up ends the run in a safe state (the motors stopped on the board).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SupervisionParams {
    /// The top supervisor: more restarts than this (of subtrees, and of components in no
    /// subtree) within `period_s` and the system gives up.
    pub max_restarts: u32,
    /// The window of `max_restarts`, seconds.
    pub period_s: f64,
    /// A handler running longer than this fails its instance (the hung-handler watchdog).
    pub handler_timeout_s: f64,
    /// A component whose restart failed to start it (its setup failed: a robot process
    /// briefly unreachable, say) is tried again after this, doubled at each failure in a row
    /// up to 16 times; 0: at once, as in OTP, and the restart budget goes in one instant.
    pub retry_start_s: f64,
    /// The subtrees, by name (given in a file, they replace the default ones). A component in
    /// none is a child of the top supervisor.
    pub subtrees: BTreeMap<String, Subtree>,
}

/// One subtree of the supervision tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Subtree {
    /// The components it supervises, in start order.
    pub members: Vec<String>,
    /// Which members a restart affects (`one_for_one`, `one_for_all`, `rest_for_one`).
    #[serde(default = "one_for_one")]
    pub strategy: orsa_actors::supervision::Strategy,
    /// More restarts than this within `period_s` and the subtree gives up (the top restarts it).
    pub max_restarts: u32,
    /// The window of `max_restarts`, seconds.
    pub period_s: f64,
}

fn one_for_one() -> orsa_actors::supervision::Strategy {
    orsa_actors::supervision::Strategy::OneForOne
}

impl Default for SupervisionParams {
    fn default() -> Self {
        let tree = |members: &[&str], max_restarts| Subtree {
            members: members.iter().map(|m| m.to_string()).collect(),
            strategy: one_for_one(),
            max_restarts,
            period_s: 60.0,
        };
        SupervisionParams {
            max_restarts: 3,
            period_s: 60.0,
            handler_timeout_s: 1.0,
            retry_start_s: 0.1,
            subtrees: BTreeMap::from([
                ("server".to_string(), tree(&["nomad200"], 5)),
                ("behaviours".to_string(), tree(&["wallfollow", "centerfollow"], 20)),
                ("executive".to_string(), tree(&["master"], 5)),
                ("deliberative".to_string(), tree(&["planner"], 5)),
            ]),
        }
    }
}

impl SupervisionParams {
    /// Checks the values; the message names the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        if !(self.period_s.is_finite() && self.period_s > 0.0 && self.period_s <= 86_400.0) {
            return Err(Invalid::new(
                "supervision.period_s",
                format!("must be from 0 to 86400 seconds, not {}", self.period_s),
            ));
        }
        if !(self.retry_start_s.is_finite() && (0.0..=60.0).contains(&self.retry_start_s)) {
            return Err(Invalid::new(
                "supervision.retry_start_s",
                format!("must be from 0 to 60 seconds, not {}", self.retry_start_s),
            ));
        }
        if !(self.handler_timeout_s.is_finite()
            && self.handler_timeout_s > 0.0
            && self.handler_timeout_s <= 3600.0)
        {
            return Err(Invalid::new(
                "supervision.handler_timeout_s",
                format!("must be from 0 to 3600 seconds, not {}", self.handler_timeout_s),
            ));
        }
        let mut seen = std::collections::BTreeSet::new();
        for (name, t) in &self.subtrees {
            let key = format!("supervision.subtrees.{name}");
            if !(t.period_s.is_finite() && t.period_s > 0.0 && t.period_s <= 86_400.0) {
                return Err(Invalid::new(
                    format!("{key}.period_s"),
                    format!("must be from 0 to 86400 seconds, not {}", t.period_s),
                ));
            }
            if t.members.is_empty() {
                return Err(Invalid::new(
                    format!("{key}.members"),
                    "a subtree supervises at least one component",
                ));
            }
            if let Some(m) = t.members.iter().find(|m| !seen.insert(m.as_str())) {
                return Err(Invalid::new(
                    format!("{key}.members"),
                    format!("'{m}' is in two subtrees (or twice in one)"),
                ));
            }
        }
        Ok(())
    }

    /// The subtree `component` is in, if any.
    pub fn subtree_of(&self, component: &str) -> Option<(&str, &Subtree)> {
        self.subtrees
            .iter()
            .find(|(_, t)| t.members.iter().any(|m| m == component))
            .map(|(n, t)| (n.as_str(), t))
    }
}

/// A configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The text is not TOML of the right shape.
    #[error("{origin}:{line}:{column}: {message}")]
    Parse {
        /// The file (or `<default>`).
        origin: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong, with the key.
        message: String,
    },
    /// A value is out of range or inconsistent.
    #[error("{origin}: {error}")]
    Invalid {
        /// The file (or `<default>`).
        origin: String,
        /// The key and what is wrong.
        error: Invalid,
    },
    /// A `--set` (or several) could not be applied.
    #[error("--set {set}: {message}")]
    Set {
        /// The set or sets, as given (several joined by ` --set `).
        set: String,
        /// What is wrong, with the key.
        message: String,
    },
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl Config {
    /// Parses and checks a configuration; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Config, ConfigError> {
        let at = |offset: usize, message: String| {
            let (line, column) = line_col(text, offset);
            ConfigError::Parse { origin: origin.to_string(), line, column, message }
        };
        let mut config: Config = toml::from_str(text).map_err(|e| {
            // A table that moved says where it went.
            let moved = toml::from_str::<toml::Table>(text).ok().and_then(|top| {
                MOVED_TABLES
                    .iter()
                    .find(|(t, _)| top.contains_key(*t))
                    .map(|(t, what)| (table_offset(text, t), *t, *what))
            });
            match moved {
                Some((offset, table, what)) => at(
                    offset,
                    format!(
                        "[{table}]: the parameters of {what} are in [params.NAME] now, NAME being its \
                         component's name in [system] (e.g. [params.{}])",
                        default_name(table)
                    ),
                ),
                None => at(e.span().map_or(0, |s| s.start), e.message().trim().to_string()),
            }
        })?;
        if let Err((name, message)) = config.complete_params() {
            // The line of the component's table, the key in the message.
            let offset = toml::from_str::<Places>(text)
                .ok()
                .and_then(|p| p.params.get(&name).map(|s| s.span().start))
                .unwrap_or(0);
            // The line of the table (its header or its first key), from its first column.
            let line_start = text[..offset.min(text.len())].rfind('\n').map_or(0, |i| i + 1);
            return Err(at(line_start, message));
        }
        // A system with a path follower has the master's mode that wires it, unless given.
        if config
            .navigate_mode()
            .map_err(|error| ConfigError::Invalid { origin: origin.to_string(), error })?
        {
            config.complete_params().map_err(|(_, m)| ConfigError::Invalid {
                origin: origin.to_string(),
                error: Invalid::new("", m),
            })?;
        }
        config.validate().map_err(|error| ConfigError::Invalid { origin: origin.to_string(), error })?;
        Ok(config)
    }

    /// Reads, parses and checks a configuration file.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| ConfigError::Read { path: path.display().to_string(), source })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Checks the parameters of every component of a built-in kind and writes them out in
    /// full (defaults included); refuses a `[params.NAME]` for a component the system does not
    /// have. The error names the component and the key.
    fn complete_params(&mut self) -> Result<(), (String, String)> {
        if let Some(name) = self.params.keys().find(|n| !self.system.has(n)) {
            return Err((
                name.clone(),
                format!("params.{name}: '{name}' is not a component of the system (system.components)"),
            ));
        }
        for c in &self.system.components {
            let Some((table, complete)) = builtin(c.kind()) else { continue };
            let given = self.params.get(&c.name).cloned().unwrap_or_default();
            let full = complete(&given).map_err(|m| {
                // The validators name their keys after the kind's old table.
                let m = m.strip_prefix(&format!("{table}.")).unwrap_or(&m);
                let keyed = m.split_once(": ").is_some_and(|(key, _)| !key.is_empty() && !key.contains(' '));
                let message =
                    if keyed { format!("params.{}.{m}", c.name) } else { format!("params.{}: {m}", c.name) };
                (c.name.clone(), message)
            })?;
            self.params.insert(c.name.clone(), full);
        }
        Ok(())
    }

    /// The parameters of the component `name` (its `[params.NAME]`, defaults where it has
    /// none); an error names the key.
    pub fn params_of<P: serde::de::DeserializeOwned>(&self, name: &str) -> Result<P, Invalid> {
        let table = self.params.get(name).cloned().unwrap_or_default();
        toml::Value::Table(table).try_into::<P>().map_err(|e: toml::de::Error| {
            Invalid::new(format!("params.{name}"), e.message().trim().replace('\n', " "))
        })
    }

    /// Renames the component `from` to `to`: its entry in the system (its kind stays what it
    /// was), its parameters, its place in the supervision subtrees, and where a master's modes
    /// and rules name it.
    pub fn rename_component(&mut self, from: &str, to: &str) {
        for c in self.system.components.iter_mut().filter(|c| c.name == from) {
            c.kind = Some(c.kind().to_string());
            c.name = to.to_string();
        }
        if let Some(p) = self.params.remove(from) {
            self.params.insert(to.to_string(), p);
        }
        for t in self.supervision.subtrees.values_mut() {
            t.members.iter_mut().filter(|m| *m == from).for_each(|m| *m = to.to_string());
        }
        // A master names the behaviours it arbitrates in its modes and rules.
        let masters: Vec<String> =
            self.system.components.iter().filter(|c| c.kind() == "master").map(|c| c.name.clone()).collect();
        let rename = |v: &mut toml::Value| {
            if v.as_str() == Some(from) {
                *v = toml::Value::String(to.to_string());
            }
        };
        for master in masters {
            let Some(modes) = self.params.get_mut(&master).and_then(|p| p.get_mut("modes")) else { continue };
            for mode in modes.as_table_mut().into_iter().flat_map(|m| m.iter_mut().map(|(_, v)| v)) {
                let Some(mode) = mode.as_table_mut() else { continue };
                if let Some(bs) = mode.get_mut("behaviours").and_then(toml::Value::as_array_mut) {
                    bs.iter_mut().for_each(rename);
                }
                if let Some(rules) = mode.get_mut("rules").and_then(toml::Value::as_array_mut) {
                    for rule in rules.iter_mut().filter_map(toml::Value::as_table_mut) {
                        if let Some(d) = rule.get_mut("drive") {
                            rename(d);
                        }
                    }
                }
            }
        }
    }

    /// This configuration with the navigation components (what `orsa run --goto` adds, and
    /// what `config/navigation.toml` spells out): a `map` (the known map and its places, for
    /// the planner wherever it runs) and a `localizer` after the robot server, a
    /// `pathfollow` behaviour with the other behaviours (in their supervision subtree), and the
    /// master's mode `navigate`, which wires the path follower to the motors. What the system
    /// already has is kept.
    pub fn with_navigation(&self) -> Result<Config, ConfigError> {
        let mut c = self.clone();
        let invalid = |error: Invalid| ConfigError::Invalid { origin: "navigation".into(), error };
        let after = |c: &Config, kinds: &[&str]| {
            c.system.components.iter().rposition(|s| kinds.contains(&s.kind())).map_or(0, |i| i + 1)
        };
        if c.of_kind(&[orsa_interfaces::map::NAME]).is_none() {
            let at = after(&c, &ROBOT_KINDS);
            c.system.components.insert(at, crate::system::ComponentSpec::named(orsa_interfaces::map::NAME));
            if let Some(t) = c.supervision.subtrees.get_mut("navigation") {
                t.members.insert(0, orsa_interfaces::map::NAME.into());
            }
        }
        if c.of_kind(&["localizer"]).is_none() {
            let at = after(&c, &[&ROBOT_KINDS[..], &[orsa_interfaces::map::NAME]].concat());
            c.system.components.insert(at, crate::system::ComponentSpec::named("localizer"));
        }
        if c.of_kind(&["pathfollow"]).is_none() {
            let at = after(&c, &["localizer", "wallfollow", "centerfollow"]);
            c.system.components.insert(at, crate::system::ComponentSpec::named("pathfollow"));
            if let Some(t) = c.supervision.subtrees.get_mut("behaviours") {
                t.members.push("pathfollow".into());
            }
        }
        // Written out in full first, so that the mode is added to the master's modes and does
        // not replace them.
        c.complete_params().map_err(|(_, m)| invalid(Invalid::new("", m)))?;
        c.navigate_mode().map_err(invalid)?;
        c.complete_params().map_err(|(_, m)| invalid(Invalid::new("", m)))?;
        c.validate().map_err(invalid)?;
        Ok(c)
    }

    /// Adds the master's mode `navigate` (the path follower drives) where the system has a
    /// path follower and a master whose modes (written out in full) lack it; whether it did.
    fn navigate_mode(&mut self) -> Result<bool, Invalid> {
        let Some(follower) = self.of_kind(&["pathfollow"]).map(|s| s.name.clone()) else { return Ok(false) };
        let Some(master) = self.of_kind(&["master"]).map(|s| s.name.clone()) else { return Ok(false) };
        let params = self.params.entry(master.clone()).or_default();
        let modes = params
            .entry("modes")
            .or_insert_with(|| toml::Value::Table(Default::default()))
            .as_table_mut()
            .ok_or_else(|| Invalid::new(format!("params.{master}.modes"), "is not a table"))?;
        if modes.contains_key(orsa_planner::NAVIGATE_MODE) {
            return Ok(false);
        }
        let mode: toml::Table = toml::from_str(&format!(
            "behaviours = [\"{follower}\"]\nrules = [{{ drive = \"{follower}\" }}]\n"
        ))
        .map_err(|e| Invalid::new(format!("params.{master}.modes.navigate"), e.to_string()))?;
        modes.insert(orsa_planner::NAVIGATE_MODE.into(), toml::Value::Table(mode));
        Ok(true)
    }

    /// This configuration with the navigation components and a mission of `targets` (each a
    /// place's name or `X,Y[,HEADING_DEG]`), as `orsa run --goto` makes it.
    pub fn with_goto(&self, targets: &[String]) -> Result<Config, ConfigError> {
        let mut c = self.with_navigation()?;
        let planner =
            c.of_kind(&["planner"]).map(|s| s.name.clone()).ok_or_else(|| ConfigError::Invalid {
                origin: "--goto".into(),
                error: Invalid::new("system.components", "the system has no planner to give the places to"),
            })?;
        let mission: Vec<toml::Value> = targets
            .iter()
            .map(|t| {
                let mut step = toml::Table::new();
                step.insert("goto".into(), toml::Value::String(t.clone()));
                toml::Value::Table(step)
            })
            .collect();
        c.params.entry(planner).or_default().insert("mission".into(), toml::Value::Array(mission));
        let invalid = |error: Invalid| ConfigError::Invalid { origin: "--goto".into(), error };
        c.complete_params().map_err(|(_, m)| invalid(Invalid::new("", m)))?;
        c.validate().map_err(invalid)?;
        Ok(c)
    }

    /// The planner that takes navigation goals (`orsa goto`, ROS 2's and Foxglove's
    /// `/goal_pose`), if the system has one and the map it plans on.
    pub fn navigating_planner(&self) -> Option<&str> {
        self.of_kind(&[orsa_interfaces::map::NAME])?;
        self.of_kind(&["planner"]).map(|c| c.name.as_str())
    }

    /// The map component (kind `map`), if the system has one: it lives in the robot's process.
    pub fn map_server(&self) -> Option<&str> {
        self.of_kind(&[orsa_interfaces::map::NAME]).map(|c| c.name.as_str())
    }

    /// The first component of the system of one of `kinds`.
    fn of_kind(&self, kinds: &[&str]) -> Option<&crate::system::ComponentSpec> {
        self.system.components.iter().find(|c| kinds.contains(&c.kind()))
    }

    /// The parameters of the component `name` as a built-in kind reads them; its defaults if
    /// they do not read (they did at load: only code that edits `params` can break them).
    fn builtin_params<P: serde::de::DeserializeOwned + Default>(&self, name: &str) -> P {
        self.params_of(name).unwrap_or_else(|e| {
            tracing::error!("{e}: taking the defaults");
            P::default()
        })
    }

    /// The robot server's name in the system (the first component of kind `robot` or
    /// `nomad200`; `nomad200` if there is none): every client addresses the robot by it.
    pub fn robot_name(&self) -> &str {
        self.of_kind(&ROBOT_KINDS).map_or("nomad200", |c| c.name.as_str())
    }

    /// The robot server's parameters, named after it.
    pub fn robot(&self) -> ServerParams {
        let name = self.robot_name().to_string();
        ServerParams { name: name.clone(), ..self.builtin_params(&name) }
    }

    /// The master's parameters (the first component of kind `master`; the defaults if the
    /// system has none), addressing the robot server by its name.
    pub fn executive(&self) -> ExecutiveParams {
        let mut p: ExecutiveParams = match self.of_kind(&["master"]) {
            Some(c) => self.builtin_params(&c.name),
            None => ExecutiveParams::default(),
        };
        p.robot = self.robot_name().to_string();
        p
    }

    /// The planner's parameters (the first component of kind `planner`; the defaults if the
    /// system has none).
    pub fn planner(&self) -> PlannerParams {
        match self.of_kind(&["planner"]) {
            Some(c) => self.builtin_params(&c.name),
            None => PlannerParams::default(),
        }
    }

    /// This configuration with `sets` applied, each `table.key=value` (the value in TOML:
    /// `0.3`, `true`, `"text"`, `[1, 2]`; a bare word is taken as a string). `table` is a
    /// process-level table (`sim`, `supervision`, `link`, `ros2`) or a component's name
    /// (`wallfollow.v_max_m_s=0.2` sets `[params.wallfollow]`). The result is checked as a
    /// file is; an error names the `--set` it comes from.
    pub fn with_sets(&self, sets: &[String]) -> Result<Config, ConfigError> {
        let all = || sets.join(" --set ");
        let mut table = toml::Table::try_from(self).map_err(|e| ConfigError::Set {
            set: all(),
            message: format!("cannot write the configuration: {e}"),
        })?;
        for set in sets {
            let err = |message: String| ConfigError::Set { set: set.clone(), message };
            let (path, value) =
                set.split_once('=').ok_or_else(|| err("write it as table.key=value".into()))?;
            let mut keys: Vec<&str> = path.trim().split('.').collect();
            if keys.iter().any(|k| k.is_empty()) {
                return Err(err(format!("'{path}' is not a key path such as wallfollow.target_m")));
            }
            if self.system.has(keys[0]) {
                keys.insert(0, "params");
            }
            let value = value.trim();
            let value = match toml::from_str::<toml::Table>(&format!("v = {value}")) {
                Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(value.into())),
                Err(_) => toml::Value::String(value.into()),
            };
            let (last, parents) = keys.split_last().ok_or_else(|| err("no key".into()))?;
            let mut at = &mut table;
            for (i, k) in parents.iter().enumerate() {
                let entry = at.entry(k.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
                at = entry
                    .as_table_mut()
                    .ok_or_else(|| err(format!("'{}' is a value, not a table", keys[..=i].join("."))))?;
            }
            at.insert(last.to_string(), value);
        }
        let mut config: Config = toml::Value::Table(table).try_into().map_err(|e: toml::de::Error| {
            ConfigError::Set { set: all(), message: e.message().trim().to_string() }
        })?;
        config.complete_params().map_err(|(_, message)| ConfigError::Set { set: all(), message })?;
        config.validate().map_err(|e| ConfigError::Set { set: all(), message: e.to_string() })?;
        Ok(config)
    }

    /// Checks every table, and the parameters of every built-in component against the rest;
    /// the message names the key.
    pub fn validate(&self) -> Result<(), Invalid> {
        self.sim.validate().map_err(|e| Invalid::new(format!("sim.{}", e.key), e.problem))?;
        self.supervision.validate()?;
        self.ros2.validate()?;
        // The simulator's robot is known here; any other robot is checked when it comes up.
        let sim = self.sim.robot_params(self.robot().push_periods());
        self.safety.check_against(&sim, "sim.drive.max_translate_m_s and translate_accel_m_s2")?;
        // Kinds are checked against the catalog when the system starts (a program may add its own).
        self.system.validate(|_| true, &[])?;
        let robot = self.robot();
        let robot_at = format!("params.{}", robot.name);
        let at_robot =
            |reason: &str| reason.replace("robot.cmd_timeout_s", &format!("{robot_at}.cmd_timeout_s"));
        self.link.validate(robot.cmd_timeout_s).map_err(|e| Invalid::new(e.key, at_robot(&e.reason)))?;
        if let Some(master) = self.of_kind(&["master"]) {
            switch_step_fits(&self.executive(), robot.cmd_timeout_s).map_err(|e| {
                Invalid::new(e.key, at_robot(&e.reason)).under(&format!("params.{}", master.name))
            })?;
        }
        // A subtree is a child of the top supervisor beside the components in no subtree: their
        // names must differ. (Members that are not components of the system are left out: a
        // process starts the subtrees of the components it hosts.)
        if let Some(c) = self.system.components.iter().find(|c| {
            self.supervision.subtrees.contains_key(&c.name) && self.supervision.subtree_of(&c.name).is_none()
        }) {
            return Err(Invalid::new(
                format!("supervision.subtrees.{}", c.name),
                format!("the component '{}' is in no subtree and has the subtree's name", c.name),
            ));
        }
        let executive = self.executive();
        let master = self.of_kind(&["master"]).map_or("master", |c| c.name.as_str());
        let modes: Vec<&str> = executive.modes.keys().map(String::as_str).collect();
        if let Some(planner) = self.of_kind(&["planner"]) {
            self.planner().validate(&modes).map_err(|e| {
                let key = e.key.strip_prefix("planner.").unwrap_or(&e.key).to_string();
                Invalid::new(key, e.reason).under(&format!("params.{}", planner.name))
            })?;
        }
        // The behaviours a master arbitrates must be components of the system.
        if self.of_kind(&["master"]).is_some() {
            for (mode, m) in &executive.modes {
                if let Some(b) = m.behaviours.iter().find(|b| !self.system.has(b)) {
                    return Err(Invalid::new(
                        format!("params.{master}.modes.{mode}.behaviours"),
                        format!("'{b}' is not a component of the system (system.components)"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Where the `[params.NAME]` tables of a config file start, to name the line of an error
/// found after parsing.
#[derive(Deserialize, Default)]
#[serde(default)]
struct Places {
    params: BTreeMap<String, toml::Spanned<toml::Value>>,
}

/// Where the top-level table `table` first appears in `text` (its header, or a dotted key).
fn table_offset(text: &str, table: &str) -> usize {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let l = line.trim_start();
        let is_it = [format!("[{table}]"), format!("[{table}."), format!("{table}."), format!("{table} =")]
            .iter()
            .any(|p| l.starts_with(p.as_str()));
        if is_it {
            return offset + (line.len() - l.len());
        }
        offset += line.len();
    }
    0
}

/// The component a moved table's parameters now go under, in the default system.
fn default_name(table: &str) -> &str {
    match table {
        "robot" => "nomad200",
        "executive" => "master",
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_default_file_parses_to_the_defaults() {
        let parsed = Config::from_toml(DEFAULT_CONFIG, "config/orsa.toml").expect("default file parses");
        assert_eq!(parsed, Config::default());
    }

    #[test]
    fn bad_ros2_values_are_named() {
        for (text, key) in [
            ("[ros2.base]\nbeam_width_rad = 2.0\n", "ros2.base.beam_width_rad"),
            ("[ros2]\ncmd_vel_rate_hz = -1.0\n", "ros2.cmd_vel_rate_hz"),
            ("[ros2]\nnode = \"or sa\"\n", "ros2.node"),
        ] {
            let e = Config::from_toml(text, "t.toml").expect_err(text).to_string();
            assert!(e.contains(key), "{text}: {e}");
        }
        assert!(Config::from_toml("[ros2.base]\nwheels = 2\n", "t.toml").is_err(), "unknown keys are errors");
        // The command type: TwistStamped unless the config names Twist; nothing else.
        use orsa_hardware::ros2base::CmdVelType;
        assert_eq!(Config::default().ros2.base.cmd_vel_type, CmdVelType::TwistStamped);
        let twist = Config::from_toml("[ros2.base]\ncmd_vel_type = \"twist\"\n", "t.toml").expect("twist");
        assert_eq!(twist.ros2.base.cmd_vel_type, CmdVelType::Twist);
        let e = Config::from_toml("[ros2.base]\ncmd_vel_type = \"twist_stampd\"\n", "t.toml")
            .expect_err("a type that is not one")
            .to_string();
        assert!(e.contains("t.toml:2") && e.contains("twist_stamped"), "{e}");
    }

    fn wf(c: &Config) -> WallFollowParams {
        c.params_of("wallfollow").expect("wall following's parameters")
    }

    fn cf(c: &Config) -> CenterFollowParams {
        c.params_of("centerfollow").expect("center following's parameters")
    }

    /// `c` with the parameters of `names` taken from `from`.
    fn with_params_of(c: &Config, from: &Config, names: &[&str]) -> Config {
        let mut c = c.clone();
        for n in names {
            c.params.insert(n.to_string(), from.params[*n].clone());
        }
        c
    }

    #[test]
    fn the_previous_default_file_parses_and_differs_only_in_the_behaviours() {
        let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
        let c = Config::load(&root.join("config/previous-default.toml")).expect("parses");
        let d = Config::default();
        assert_ne!(cf(&c), cf(&d));
        assert_ne!(wf(&c), wf(&d));
        assert!(!cf(&c).dead_end_turn && cf(&d).dead_end_turn);
        assert!(!wf(&c).share_gaps && !wf(&c).limit_approach);
        assert_eq!(with_params_of(&c, &d, &["wallfollow", "centerfollow"]), d, "nothing else differs");
    }

    #[test]
    fn the_held_walls_and_the_approach_limit_are_on_by_default_and_checked() {
        let d = Config::default();
        assert!(cf(&d).walls.enabled && wf(&d).limit_approach && wf(&d).share_gaps);
        let e = Config::from_toml("[params.wallfollow]\nshare_gaps = \"yes\"\n", "w.toml")
            .expect_err("not a bool");
        assert!(e.to_string().starts_with("w.toml:1:") && e.to_string().contains("bool"), "{e}");
        let c =
            Config::from_toml("[params.centerfollow.walls]\nenabled = false\n", "w.toml").expect("parses");
        let mut same = c.clone();
        let mut walls = cf(&c);
        walls.walls.enabled = true;
        same.params.insert("centerfollow".into(), toml::Table::try_from(walls).expect("writes"));
        assert_eq!(same, d, "only the one key differs");
        let e =
            Config::from_toml("[params.wallfollow]\nlimit_approach = 1\n", "w.toml").expect_err("not a bool");
        assert!(e.to_string().starts_with("w.toml:1:") && e.to_string().contains("bool"), "{e}");
        let e = Config::from_toml("[params.centerfollow.walls]\nnear = 0.4\n", "w.toml")
            .expect_err("unknown key");
        assert!(e.to_string().starts_with("w.toml:1:") && e.to_string().contains("near"), "{e}");
        let e =
            Config::from_toml("[params.centerfollow.walls]\nhold_s = -1\n", "w.toml").expect_err("bad value");
        assert_eq!(e.to_string(), "w.toml:1:1: params.centerfollow.walls.hold_s: must be a positive number");
    }

    #[test]
    fn a_renamed_behaviour_is_renamed_in_the_masters_modes_too() {
        let mut c = Config::default();
        assert!(c.executive().behaviours().contains(&"wallfollow".to_string()));
        c.rename_component("wallfollow", "hug");
        let behaviours = c.executive().behaviours();
        assert!(behaviours.contains(&"hug".to_string()) && !behaviours.contains(&"wallfollow".to_string()));
        let drives: Vec<String> =
            c.executive().modes.values().flat_map(|m| m.rules.iter().map(|r| r.drive.clone())).collect();
        assert!(
            drives.contains(&"hug".to_string()) && !drives.contains(&"wallfollow".to_string()),
            "{drives:?}"
        );
        c.validate().expect("the master arbitrates components of the system");
    }

    #[test]
    fn a_set_changes_one_key_and_is_checked_as_the_file_is() {
        let base = Config::default();
        let c = base.with_sets(&["wallfollow.v_max_m_s=0.2".into()]).expect("accepted");
        assert_eq!(wf(&c).v_max_m_s, 0.2);
        assert_eq!(with_params_of(&c, &base, &["wallfollow"]), base, "nothing else changed");
        let c = base.with_sets(&["sim.step_s=0.02".into()]).expect("a process-level table");
        assert_eq!(c.sim.step_s, 0.02);
        let e = base.with_sets(&["wallfollow.no_such_key=1".into()]).expect_err("refused");
        let e = e.to_string();
        assert!(e.contains("--set wallfollow.no_such_key=1") && e.contains("no_such_key"), "{e}");
        let e = base.with_sets(&["wallfollow.v_max_m_s=-1".into()]).expect_err("refused").to_string();
        assert!(e.contains("params.wallfollow.v_max_m_s"), "{e}");
        let e = base.with_sets(&["wallfollow".into()]).expect_err("refused");
        assert!(
            matches!(&e, ConfigError::Set { set, message } if set == "wallfollow" && message.contains("table.key=value")),
            "{e}"
        );
        let e = base.with_sets(&["wallfollow.v_max_m_s.x=1".into()]).expect_err("refused").to_string();
        assert!(e.contains("'params.wallfollow.v_max_m_s' is a value"), "{e}");
        let e =
            base.with_sets(&["ghost.x=1".into()]).expect_err("neither a table nor a component").to_string();
        assert!(e.contains("ghost"), "{e}");
    }

    /// Every kind reads its parameters from `[params.NAME]`: two components of one kind have
    /// their own, and a table for a component the system does not have is refused.
    #[test]
    fn each_component_has_its_own_parameters_by_name() {
        let text = "[[system.components]]\nname = \"nomad200\"\n[[system.components]]\nname = \"slow\"\n\
                    kind = \"wallfollow\"\n[[system.components]]\nname = \"fast\"\nkind = \"wallfollow\"\n\
                    [params.slow]\nv_max_m_s = 0.1\n[params.fast]\nv_max_m_s = 0.3\n";
        let c = Config::from_toml(text, "two.toml").expect("parses");
        let (slow, fast): (WallFollowParams, WallFollowParams) =
            (c.params_of("slow").expect("slow"), c.params_of("fast").expect("fast"));
        assert_eq!((slow.v_max_m_s, fast.v_max_m_s), (0.1, 0.3));
        assert_eq!(slow.target_m, WallFollowParams::default().target_m, "written out in full");
        let e = Config::from_toml("[params.ghost]\nx = 1\n", "g.toml").expect_err("no such component");
        assert_eq!(
            e.to_string(),
            "g.toml:1:1: params.ghost: 'ghost' is not a component of the system (system.components)"
        );
        // The old tables say where their keys went.
        let e = Config::from_toml("\n[wallfollow]\ntarget_m = 0.2\n", "old.toml").expect_err("moved");
        assert!(
            e.to_string().starts_with("old.toml:2:") && e.to_string().contains("[params.wallfollow]"),
            "{e}"
        );
        let e = Config::from_toml("[robot]\ncmd_timeout_s = 0.5\n", "old.toml").expect_err("moved");
        assert!(e.to_string().contains("[params.nomad200]"), "{e}");
    }

    #[test]
    fn errors_name_the_place_and_the_key() {
        let e = Config::from_toml("[params.wallfollow]\ntarget_m = 0.2\nk_dd = 3.0\n", "my.toml")
            .expect_err("unknown key");
        let text = e.to_string();
        assert!(text.starts_with("my.toml:1:1: params.wallfollow: unknown field `k_dd`"), "{text}");
        let e =
            Config::from_toml("[params.wallfollow.loops]\nk_alpha = 2.0\n", "my.toml").expect_err("bad sign");
        assert_eq!(e.to_string(), "my.toml:1:1: params.wallfollow.k_alpha: must be a negative number");
        let e =
            Config::from_toml("[params.nomad200]\ncmd_timeout_s = -1\n", "my.toml").expect_err("bad value");
        assert!(e.to_string().contains("params.nomad200.cmd_timeout_s"), "{e}");
        let e = Config::from_toml("[params.planner]\nmission = [{ mode = \"dance\" }]\n", "my.toml")
            .expect_err("bad mode");
        assert!(e.to_string().contains("params.planner.mission[0].mode: 'dance'"), "{e}");
        let e = Config::from_toml("[params.master.modes.x]\nbehaviours = [\"teleop\"]\n", "m.toml")
            .expect_err("unknown");
        assert!(e.to_string().contains("'teleop'"), "{e}");
        let e = Config::from_toml("[link]\nlease_s = 0.8\n", "m.toml").expect_err("lease too long");
        assert!(
            e.to_string()
                .contains("link.lease_s: must be more than 0 and at most params.nomad200.cmd_timeout_s"),
            "{e}"
        );
        let e = Config::from_toml("[link]\nheartbeat_period_s = 0.2\n", "m.toml").expect_err("too slow");
        assert!(e.to_string().contains("at least twice link.heartbeat_period_s"), "{e}");
        let e =
            Config::from_toml("[params.master]\nswitch_step_s = 0.3\n", "m.toml").expect_err("step too long");
        assert!(e.to_string().starts_with("m.toml: params.master.switch_step_s: 0.3 s is too long"), "{e}");
        let e = Config::from_toml(
            "[supervision.subtrees.a]\nmembers = [\"wallfollow\"]\nmax_restarts = 1\nperiod_s = 60\n\
             [supervision.subtrees.b]\nmembers = [\"wallfollow\"]\nmax_restarts = 1\nperiod_s = 60\n",
            "m.toml",
        )
        .expect_err("member twice");
        assert!(
            e.to_string().contains("supervision.subtrees.b.members: 'wallfollow' is in two subtrees"),
            "{e}"
        );
        let e = Config::from_toml(
            "[supervision.subtrees.a]\nmembers = [\"wallfollow\"]\nmax_restarts = 1\nperiod_s = -1\n",
            "m.toml",
        )
        .expect_err("bad period");
        assert!(e.to_string().contains("supervision.subtrees.a.period_s"), "{e}");
        let e = Config::from_toml(
            "[supervision.subtrees.a]\nmembers = [\"wallfollow\"]\nmax_restarts = 1\nperiod_s = 60\nstrategy = \"all\"\n",
            "m.toml",
        )
        .expect_err("bad strategy");
        assert!(e.to_string().starts_with("m.toml:5:") && e.to_string().contains("`one_for_one`"), "{e}");
        let e = Config::from_toml(
            "[supervision.subtrees.master]\nmembers = [\"wallfollow\"]\nmax_restarts = 1\nperiod_s = 60\n",
            "m.toml",
        )
        .expect_err("a subtree named like a component in none");
        assert!(e.to_string().contains("supervision.subtrees.master: the component 'master'"), "{e}");
        let e = Config::load(Path::new("/nonexistent/orsa.toml")).expect_err("missing file");
        assert!(e.to_string().starts_with("/nonexistent/orsa.toml: cannot read"), "{e}");
    }
}
