//! The `[system]` table: which components run, in which process, in which state, wired how.
//!
//! ```toml
//! [[system.components]]
//! name = "nomad200"                 # the kind defaults to the name
//! [[system.components]]
//! name = "wanderer"
//! kind = "wander"                   # a kind registered in the catalog (see examples/)
//! place = "robot"                   # which process hosts it when the system is split
//! state = "active"                  # main state set once it is up (for systems without a master)
//! wire = { vel = "nomad200/navigationvelocity" }   # ports connected once it is up
//!
//! [params.wanderer]                 # its parameters, by its name (every kind alike)
//! speed_m_s = 0.2
//! ```

use orsa_actors::ServiceAddr;
use orsa_actors::addr::valid_name;
use orsa_actors::param::Invalid;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which process hosts a component when the system is split over processes (`orsa robot` and
/// `orsa executive`); `orsa run` hosts every place in one process.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Place {
    /// On the robot: the robot server and the behaviours (`orsa robot`).
    Robot,
    /// With the executive: the master and the planner (`orsa executive`).
    Executive,
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Place::Robot => "robot",
            Place::Executive => "executive",
        })
    }
}

/// One component of the system.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComponentSpec {
    /// Its name in the system (how others address it).
    pub name: String,
    /// Its kind in the catalog; default: the name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<String>,
    /// The process that hosts it when the system is split; default: its kind's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub place: Option<Place>,
    /// A main state to set once the system is up (for systems without a master).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<String>,
    /// Ports to connect once the system is up: port name to `component/service`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub wire: BTreeMap<String, String>,
}

impl ComponentSpec {
    /// A component of the kind of its name, with nothing else set.
    pub fn named(name: &str) -> Self {
        ComponentSpec { name: name.into(), kind: None, place: None, state: None, wire: BTreeMap::new() }
    }

    /// Its kind: the one given, or its name.
    pub fn kind(&self) -> &str {
        self.kind.as_deref().unwrap_or(&self.name)
    }

    /// The ports to wire, parsed; an error's key is under `wire`.
    pub fn wiring(&self) -> Result<Vec<(String, ServiceAddr)>, Invalid> {
        self.wire
            .iter()
            .map(|(port, target)| {
                if !valid_name(port) {
                    return Err(Invalid::new("wire", format!("port '{port}' is not a valid name")));
                }
                let addr = target
                    .parse::<ServiceAddr>()
                    .map_err(|e| Invalid::new(format!("wire.{port}"), e.to_string()))?;
                Ok((port.clone(), addr))
            })
            .collect()
    }
}

/// The `[system]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SystemSpec {
    /// The components, in the order they start (each once the one before has set up its
    /// services): servers before their clients.
    pub components: Vec<ComponentSpec>,
}

impl Default for SystemSpec {
    /// The corridor mission: the robot server, both behaviours, the master and the planner.
    fn default() -> Self {
        let names = ["nomad200", "wallfollow", "centerfollow", "master", "planner"];
        SystemSpec { components: names.iter().map(|n| ComponentSpec::named(n)).collect() }
    }
}

impl SystemSpec {
    /// Checks names, duplicates and wiring; `known_kind` says whether a kind is in the catalog
    /// (the message lists `kinds`). Messages name the key.
    pub fn validate(&self, known_kind: impl Fn(&str) -> bool, kinds: &[String]) -> Result<(), Invalid> {
        if self.components.is_empty() {
            return Err(Invalid::new("system.components", "list at least one component"));
        }
        let mut seen = std::collections::BTreeSet::new();
        for (i, c) in self.components.iter().enumerate() {
            let at = format!("system.components[{i}]");
            if !valid_name(&c.name) {
                return Err(Invalid::new(
                    format!("{at}.name"),
                    format!("'{}' is not a valid name (letters, digits, '_' or '-')", c.name),
                ));
            }
            if !seen.insert(c.name.as_str()) {
                return Err(Invalid::new(format!("{at}.name"), format!("'{}' is listed twice", c.name)));
            }
            if !known_kind(c.kind()) {
                return Err(Invalid::new(
                    format!("{at}.kind"),
                    format!("no component kind '{}' (known: {})", c.kind(), kinds.join(", ")),
                ));
            }
            if let Some(s) = &c.state
                && !valid_name(s)
            {
                return Err(Invalid::new(format!("{at}.state"), format!("'{s}' is not a valid state name")));
            }
            c.wiring().map_err(|e| e.under(&at))?;
        }
        Ok(())
    }

    /// Each component's kind, by its name.
    pub fn kinds(&self) -> BTreeMap<String, String> {
        self.components.iter().map(|c| (c.name.clone(), c.kind().to_owned())).collect()
    }

    /// Whether a component of this name is part of the system.
    pub fn has(&self, name: &str) -> bool {
        self.components.iter().any(|c| c.name == name)
    }
}
