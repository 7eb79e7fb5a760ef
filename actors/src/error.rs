//! The status values of the patterns: every failure is a [`PatternError`], never a panic.

use crate::addr::{PatternKind, ServiceAddr};
use thiserror::Error;

/// What went wrong in a pattern operation.
///
/// Each variant is a distinct status a caller can match on, as the original system's
/// `SMART_*` status codes were.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum PatternError {
    /// No component registers a service under this address.
    #[error("unknown service '{0}'")]
    UnknownService(ServiceAddr),
    /// No component with this name is registered.
    #[error("unknown component '{0}'")]
    UnknownComponent(String),
    /// The service exists but its pattern or communication objects differ from the client's.
    #[error(
        "incompatible service '{addr}': it is {found_pattern} of {found}, the client expects {expected_pattern} of {expected}"
    )]
    IncompatibleService {
        /// The service asked for.
        addr: ServiceAddr,
        /// The pattern the client expects.
        expected_pattern: PatternKind,
        /// The communication object identifiers the client expects.
        expected: String,
        /// The pattern the service has.
        found_pattern: PatternKind,
        /// The communication object identifiers the service has.
        found: String,
    },
    /// A name (component or service) is already taken.
    #[error("'{0}' is already registered")]
    AlreadyRegistered(String),
    /// The component has no wireable port of this name.
    #[error("component '{component}' has no port '{port}'")]
    UnknownPort {
        /// The component asked.
        component: String,
        /// The port asked for.
        port: String,
    },
    /// A send or query on a wireable port that is not connected to any service.
    #[error("port '{0}' is disconnected")]
    Disconnected(String),
    /// The server component exists but has no running instance (it is restarting or stopped).
    #[error("service '{0}' is unavailable: its component is not running")]
    Unavailable(ServiceAddr),
    /// The server dropped a query without answering it.
    #[error("service '{0}' dropped the query without an answer")]
    NoAnswer(ServiceAddr),
    /// A blocking call did not complete within its timeout.
    #[error("timed out")]
    Timeout,
    /// A blocking call was aborted because the master deactivated the component.
    #[error("cancelled: the component was deactivated")]
    Cancelled,
    /// `get_update` before any update arrived.
    #[error("no data yet")]
    NoData,
    /// The push server is stopped, or the client is not subscribed.
    #[error("not active: {0}")]
    NotActive(String),
    /// A state change cannot take effect now (substates it excludes are held) and the master
    /// asked not to wait.
    #[error("busy: substates {0:?} are held")]
    Busy(Vec<String>),
    /// A main state, substate or event activation that was not declared.
    #[error("unknown {kind} '{name}'")]
    Unknown {
        /// What kind of thing (main state, substate, activation).
        kind: &'static str,
        /// Its name.
        name: String,
    },
    /// A malformed argument, such as a zero `every` for a subscription.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A message from another process could not be decoded.
    #[error("undecodable message: {0}")]
    Decode(String),
    /// A peer in another process answered with an error that has no variant here.
    #[error("remote error: {0}")]
    Remote(String),
    /// The transport to another process failed (no route, session closed).
    #[error("link error: {0}")]
    Link(String),
}

/// Shorthand for results of pattern operations.
pub type PatternResult<T> = Result<T, PatternError>;
