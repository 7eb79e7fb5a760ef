//! Addresses: what a service is called (`component/service`) and what it is (its pattern and the
//! identifiers of its communication objects).
//!
//! [`ServiceAddr`] is the untyped address, the form a user types and the wire carries;
//! [`crate::service`] builds typed addresses on top of it, so code that names a service gets a
//! compile error, not a run-time one, when it uses it with the wrong pattern or object.
//! The registry's check of a [`ServiceInfo`] against a client's is the run-time half of the same check, for addresses that come from
//! outside the program (a command line, a config file, a peer).

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The address of a service: the component hosting it and the service's name.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct ServiceAddr {
    /// The component's name, e.g. `nomad200`.
    pub component: String,
    /// The service's name within the component, e.g. `distanceir`.
    pub service: String,
}

impl ServiceAddr {
    /// An address from its two parts.
    pub fn new(component: impl Into<String>, service: impl Into<String>) -> Self {
        ServiceAddr { component: component.into(), service: service.into() }
    }
}

impl fmt::Display for ServiceAddr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.component, self.service)
    }
}

/// A string that is not of the form `component/service`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "'{0}' is not a service address: expected 'component/service' (names of letters, digits, '_' or '-')"
)]
pub struct BadAddr(pub String);

/// Whether `name` is a valid component, service or port name.
pub fn valid_name(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

impl FromStr for ServiceAddr {
    type Err = BadAddr;
    fn from_str(s: &str) -> Result<Self, BadAddr> {
        match s.split_once('/') {
            Some((c, sv)) if valid_name(c) && valid_name(sv) => Ok(ServiceAddr::new(c, sv)),
            _ => Err(BadAddr(s.to_string())),
        }
    }
}

/// What a client of service kind `D` (a descriptor type from [`crate::service`]) accepts as its
/// address: a typed [`Addr<D>`](crate::service::Addr), checked by the compiler, or an untyped
/// [`ServiceAddr`] that came from outside the program (a command line, a config file), which
/// the registry checks against `D` when the client connects.
pub trait IntoAddr<D> {
    /// The untyped address.
    fn into_addr(self) -> ServiceAddr;
}

impl<D> IntoAddr<D> for ServiceAddr {
    fn into_addr(self) -> ServiceAddr {
        self
    }
}

impl<D> IntoAddr<D> for &ServiceAddr {
    fn into_addr(self) -> ServiceAddr {
        self.clone()
    }
}

/// The communication patterns, each with fixed semantics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PatternKind {
    /// One-way command.
    Send,
    /// Request/response.
    Query,
    /// Every subscriber gets each new value.
    PushNewest,
    /// The server produces on its own period; subscribers get every n-th value.
    PushTimed,
    /// The server fires to activations whose condition holds.
    Event,
    /// Master/slave configuration by main states and substates.
    State,
    /// Run-time reconnection of a component's client ports.
    Wiring,
}

impl fmt::Display for PatternKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PatternKind::Send => "a send service",
            PatternKind::Query => "a query service",
            PatternKind::PushNewest => "a push-newest service",
            PatternKind::PushTimed => "a push-timed service",
            PatternKind::Event => "an event service",
            PatternKind::State => "a state service",
            PatternKind::Wiring => "a wiring service",
        })
    }
}

/// What a service is: its pattern and the identifiers of its communication objects.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ServiceInfo {
    /// The pattern.
    pub pattern: PatternKind,
    /// The communication object identifiers, in the pattern's order: the sent or pushed object;
    /// request then answer for a query; parameter then event for an event.
    pub types: Vec<String>,
}

impl ServiceInfo {
    /// Info for a pattern over the given identifiers.
    pub fn new(pattern: PatternKind, types: &[&str]) -> Self {
        ServiceInfo { pattern, types: types.iter().map(|t| t.to_string()).collect() }
    }

    /// The identifiers as a person reads them: `a -> b`.
    pub fn types_text(&self) -> String {
        self.types.join(" -> ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse_and_print() {
        let a: ServiceAddr = "nomad200/distanceir".parse().expect("valid");
        assert_eq!(a, ServiceAddr::new("nomad200", "distanceir"));
        assert_eq!(a.to_string(), "nomad200/distanceir");
        for bad in ["", "nomad200", "/x", "x/", "a/b/c", "a b/c"] {
            assert!(bad.parse::<ServiceAddr>().is_err(), "{bad:?} should not parse");
        }
    }
}
