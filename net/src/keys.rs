//! Key expressions: where each pattern's messages travel (see `docs/wire-format.md`).

use orsa_actors::addr::{PatternKind, ServiceAddr, ServiceInfo, valid_name};
use std::num::NonZeroU32;

/// The key expressions of one orsa system, under its prefix (`orsa` unless configured).
#[derive(Debug, Clone)]
pub struct Keys {
    root: String,
}

/// The pattern's name in key expressions.
pub fn pattern_name(p: PatternKind) -> &'static str {
    match p {
        PatternKind::Send => "send",
        PatternKind::Query => "query",
        PatternKind::PushNewest => "push_newest",
        PatternKind::PushTimed => "push_timed",
        PatternKind::Event => "event",
        PatternKind::State => "state",
        PatternKind::Wiring => "wiring",
    }
}

fn pattern_from(name: &str) -> Option<PatternKind> {
    Some(match name {
        "send" => PatternKind::Send,
        "query" => PatternKind::Query,
        "push_newest" => PatternKind::PushNewest,
        "push_timed" => PatternKind::PushTimed,
        "event" => PatternKind::Event,
        "state" => PatternKind::State,
        "wiring" => PatternKind::Wiring,
        _ => return None,
    })
}

/// A service announced by a peer's liveliness token.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Announced {
    /// The zenoh id of the process hosting it.
    pub host: String,
    /// Its address.
    pub addr: ServiceAddr,
    /// Its pattern and communication objects.
    pub info: ServiceInfo,
}

/// A process announced by its liveliness token.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Process {
    /// Its zenoh id.
    pub zid: String,
    /// What it is: `robot`, `executive`, `teleop`, `tool`.
    pub role: String,
}

/// A key prefix that is not chunks of letters, digits, `_` or `-` separated by `/`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{0}' is not a valid key prefix (chunks of letters, digits, '_' or '-', separated by '/')")]
pub struct BadPrefix(pub String);

impl Keys {
    /// The keys under `prefix` (one or more chunks of letters, digits, `_`, `-`, separated by `/`).
    pub fn new(prefix: &str) -> Result<Self, BadPrefix> {
        if prefix.is_empty() || !prefix.split('/').all(valid_name) {
            return Err(BadPrefix(prefix.to_string()));
        }
        Ok(Keys { root: format!("{prefix}/v{}", orsa_actors::wire::WIRE_VERSION) })
    }

    fn svc(&self, addr: &ServiceAddr, what: &str) -> String {
        format!("{}/svc/{}/{}/{what}", self.root, addr.component, addr.service)
    }

    /// Send messages to a Send service.
    pub fn send(&self, addr: &ServiceAddr) -> String {
        self.svc(addr, "send")
    }

    /// Requests to a Query, State or Wiring service.
    pub fn request(&self, addr: &ServiceAddr) -> String {
        self.svc(addr, "request")
    }

    /// Subscription control of a push service.
    pub fn subscribe(&self, addr: &ServiceAddr) -> String {
        self.svc(addr, "subscribe")
    }

    /// The stream of every `every`-th update of a push service.
    pub fn stream(&self, addr: &ServiceAddr, every: NonZeroU32) -> String {
        self.svc(addr, &format!("push/{every}"))
    }

    /// Activation control of an event service.
    pub fn activate(&self, addr: &ServiceAddr) -> String {
        self.svc(addr, "activate")
    }

    /// Where the firings of one client activation go.
    pub fn firings(&self, client: &str, id: u64) -> String {
        format!("{}/fire/{client}/{id}", self.root)
    }

    /// The liveliness token of a service.
    pub fn service_token(&self, host: &str, addr: &ServiceAddr, info: &ServiceInfo) -> String {
        let types: Vec<String> = info.types.iter().map(|t| t.replace('/', "@")).collect();
        format!(
            "{}/alive/svc/{host}/{}/{}/{}/{}",
            self.root,
            addr.component,
            addr.service,
            pattern_name(info.pattern),
            types.join(",")
        )
    }

    /// All service tokens.
    pub fn all_services(&self) -> String {
        format!("{}/alive/svc/**", self.root)
    }

    /// Every token of one process: its process token and its services' tokens.
    pub fn tokens_of(&self, host: &str) -> String {
        format!("{}/alive/*/{host}/**", self.root)
    }

    /// Parses a service token.
    pub fn parse_service_token(&self, key: &str) -> Option<Announced> {
        let rest = key.strip_prefix(&format!("{}/alive/svc/", self.root))?;
        let parts: Vec<&str> = rest.split('/').collect();
        let [host, component, service, pattern, types] = parts.as_slice() else { return None };
        let types = types.split(',').map(|t| t.replace('@', "/")).collect();
        Some(Announced {
            host: host.to_string(),
            addr: ServiceAddr::new(*component, *service),
            info: ServiceInfo { pattern: pattern_from(pattern)?, types },
        })
    }

    /// Where a process answers with its traffic figures.
    pub fn stats(&self, zid: &str) -> String {
        format!("{}/stats/{zid}", self.root)
    }

    /// The traffic figures of every process.
    pub fn all_stats(&self) -> String {
        format!("{}/stats/*", self.root)
    }

    /// Where a process publishes its heartbeat.
    pub fn heartbeat(&self, zid: &str, role: &str) -> String {
        format!("{}/heartbeat/{zid}/{role}", self.root)
    }

    /// The heartbeats of every process of `role`.
    pub fn heartbeats(&self, role: &str) -> String {
        format!("{}/heartbeat/*/{role}", self.root)
    }

    /// Parses a heartbeat key: (zid, role).
    pub fn parse_heartbeat(&self, key: &str) -> Option<(String, String)> {
        let rest = key.strip_prefix(&format!("{}/heartbeat/", self.root))?;
        let (zid, role) = rest.split_once('/')?;
        (!zid.is_empty() && !role.is_empty() && !role.contains('/'))
            .then(|| (zid.to_string(), role.to_string()))
    }

    /// The liveliness token of a process.
    pub fn process_token(&self, zid: &str, role: &str) -> String {
        format!("{}/alive/proc/{zid}/{role}", self.root)
    }

    /// All process tokens.
    pub fn all_processes(&self) -> String {
        format!("{}/alive/proc/*/*", self.root)
    }

    /// Parses a process token.
    pub fn parse_process_token(&self, key: &str) -> Option<Process> {
        let rest = key.strip_prefix(&format!("{}/alive/proc/", self.root))?;
        let (zid, role) = rest.split_once('/')?;
        Some(Process { zid: zid.to_string(), role: role.to_string() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn service_tokens_round_trip() {
        let keys = Keys::new("orsa").expect("prefix");
        let addr = ServiceAddr::new("nomad200", "distanceir");
        let info = ServiceInfo::new(PatternKind::Query, &["orsa.Empty/1", "orsa.RobotParams/1"]);
        let key = keys.service_token("abc123", &addr, &info);
        assert_eq!(key, "orsa/v1/alive/svc/abc123/nomad200/distanceir/query/orsa.Empty@1,orsa.RobotParams@1");
        let back = keys.parse_service_token(&key).expect("parses");
        assert_eq!(back, Announced { host: "abc123".into(), addr, info });
        assert!(keys.parse_service_token("orsa/v1/alive/svc/x/y").is_none());
        assert!(keys.parse_service_token("orsa/v1/alive/svc/h/c/s/nonsense/t").is_none());
    }

    #[test]
    fn bad_prefixes_are_refused() {
        for bad in ["", "a//b", "a/*", "a b", "**"] {
            assert!(Keys::new(bad).is_err(), "{bad:?}");
        }
        assert!(Keys::new("lab/robot-1").is_ok());
    }
}
