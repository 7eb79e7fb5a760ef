//! The registry: the directory of one orsa system, which resolves service addresses.
//!
//! Every service is addressed as `component/service` ([`ServiceAddr`], in [`crate::addr`]). A [`Registry`] is the
//! directory of one orsa system: the components and services hosted in this process, and behind
//! them the [`crate::transport::Transport`] seam for services hosted elsewhere. A
//! client resolves an address once; the registry answers with the service's pattern and
//! communication object identifiers, and the client checks them against its own before it
//! sends a byte, answering [`PatternError::IncompatibleService`] on a mismatch.

use crate::addr::{PatternKind, ServiceAddr, ServiceInfo, valid_name};
use crate::clock::{Clock, Timestamp};
use crate::error::{PatternError, PatternResult};
use crate::transport::{Served, Transport};
use parking_lot::RwLock;
use std::any::Any;
use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

/// A service registered in this process: its info and its typed endpoint, type-erased.
#[derive(Clone)]
pub struct LocalService {
    /// Pattern and communication objects.
    pub info: ServiceInfo,
    /// The endpoint clients downcast to the pattern's typed endpoint.
    pub endpoint: Arc<dyn Any + Send + Sync>,
    /// The service's byte-level face, for peers in other processes.
    pub served: Arc<dyn Served>,
}

/// A service resolved for a client: in this process, or through the transport.
pub(crate) enum Resolved<E> {
    /// Hosted here: the typed endpoint.
    Local(Arc<E>),
    /// Hosted by a peer.
    Remote(Remote),
}

/// A service hosted by a peer, as a client reaches it.
#[derive(Clone)]
pub(crate) struct Remote {
    pub(crate) addr: ServiceAddr,
    pub(crate) transport: Arc<dyn Transport>,
    pub(crate) registry: Registry,
}

impl Remote {
    /// Counts and logs a message from this service that did not decode.
    pub(crate) fn bad_message(&self, e: &crate::wire::WireError) {
        self.registry.note_decode_error(&self.addr, e);
    }

    /// Passes a decoded reply through, counting it if it did not decode.
    pub(crate) fn counted<T>(&self, r: PatternResult<T>) -> PatternResult<T> {
        if let Err(PatternError::Decode(m)) = &r {
            self.registry.note_decode_error(&self.addr, m);
        }
        r
    }
}

impl fmt::Debug for LocalService {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LocalService").field("info", &self.info).finish_non_exhaustive()
    }
}

struct Inner {
    clock: Clock,
    tap: crate::tap::TapSlot,
    services: RwLock<BTreeMap<ServiceAddr, LocalService>>,
    components: RwLock<BTreeMap<String, ()>>,
    transport: RwLock<Option<Arc<dyn Transport>>>,
    decode_errors: std::sync::atomic::AtomicU64,
    /// Lines about undecodable messages: a few a second, the rest counted.
    decode_log: crate::logbudget::LogBudget,
    faults: crate::fault::Faults,
    ledger: crate::ledger::Ledger,
    /// The switches other processes prepared or committed here (`crate::switch` keeps its
    /// own type in it; the registry only holds it).
    switches: parking_lot::Mutex<std::collections::HashMap<String, Box<dyn Any + Send>>>,
}

/// The directory of one orsa system; cheap to clone, shared by all its components.
///
/// Every service is addressed as `component/service` ([`ServiceAddr`]). A registry holds the
/// components and services hosted in this process, and behind them the
/// [`Transport`](crate::transport::Transport) seam for services hosted elsewhere. A client
/// resolves an address once; the registry answers with the service's pattern and communication
/// object identifiers, and the client checks them against its own before it sends a byte,
/// answering [`PatternError::IncompatibleService`] on a mismatch. It also owns what one system
/// shares: its [`Clock`], its [fault switchboard](crate::fault), its [tap](crate::tap) and its
/// [delivery ledger](crate::ledger).
#[derive(Clone)]
pub struct Registry {
    inner: Arc<Inner>,
}

impl fmt::Debug for Registry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Registry")
            .field("services", &self.inner.services.read().keys().collect::<Vec<_>>())
            .finish_non_exhaustive()
    }
}

impl Registry {
    /// A registry on a live clock ([`Clock::start`]: its stamps are UNIX time). A simulation that
    /// must repeat stamp for stamp uses [`Registry::with_clock`] with [`Clock::simulated`]. Must
    /// be called inside a tokio runtime.
    pub fn new() -> Self {
        Self::with_clock(Clock::start())
    }

    /// A registry on a given clock (to share it with a simulator, or to run on simulated time).
    pub fn with_clock(clock: Clock) -> Self {
        Registry {
            inner: Arc::new(Inner {
                clock,
                tap: crate::tap::TapSlot::default(),
                services: RwLock::new(BTreeMap::new()),
                components: RwLock::new(BTreeMap::new()),
                transport: RwLock::new(None),
                decode_errors: std::sync::atomic::AtomicU64::new(0),
                decode_log: crate::logbudget::LogBudget::hostile_input(),
                faults: crate::fault::Faults::new(clock),
                ledger: crate::ledger::Ledger::default(),
                switches: parking_lot::Mutex::new(std::collections::HashMap::new()),
            }),
        }
    }

    /// The system's clock.
    pub fn clock(&self) -> Clock {
        self.inner.clock
    }

    /// The current time on the system's clock.
    pub fn now(&self) -> Timestamp {
        self.inner.clock.now()
    }

    /// The fault switchboard of this system (see [`crate::fault`]).
    pub fn faults(&self) -> crate::fault::Faults {
        self.inner.faults.clone()
    }

    /// For every push and event service hosted here, how many clients hold a subscription or
    /// an activation now (a restart must leave these as they were).
    pub fn clients(&self) -> BTreeMap<ServiceAddr, usize> {
        self.inner
            .services
            .read()
            .iter()
            .filter_map(|(a, s)| s.served.clients().map(|n| (a.clone(), n)))
            .collect()
    }

    /// The delivery accounting of this system (see [`crate::ledger`]); off until enabled.
    pub fn ledger(&self) -> crate::ledger::Ledger {
        self.inner.ledger.clone()
    }

    pub(crate) fn account(&self, addr: &ServiceAddr, kind: PatternKind) -> crate::ledger::Account {
        self.inner.ledger.account(addr, kind)
    }

    /// Installs (or, with `None`, removes) the tap that sees every message (see
    /// [`crate::tap`]).
    pub fn set_tap(&self, tap: Option<Arc<dyn crate::tap::Tap>>) {
        self.inner.tap.set(tap);
    }

    pub(crate) fn tap_slot(&self) -> crate::tap::TapSlot {
        self.inner.tap.clone()
    }

    /// Installs the transport that resolves services not hosted in this process, and offers it
    /// every service hosted here (and, from now on, each new one).
    pub fn set_transport(&self, transport: Arc<dyn Transport>) {
        *self.inner.transport.write() = Some(Arc::clone(&transport));
        let services: Vec<(ServiceAddr, LocalService)> =
            self.inner.services.read().iter().map(|(a, s)| (a.clone(), s.clone())).collect();
        for (addr, s) in services {
            transport.service_added(&addr, &s.info, s.served);
        }
    }

    /// Counts and logs a message from another process that did not decode (at most 10 lines a
    /// second; the next line logged says how many were left out). Nothing else happens: the
    /// message is dropped and the receiver goes on.
    pub fn note_decode_error(&self, from: &dyn fmt::Display, e: &dyn fmt::Display) {
        self.inner.decode_errors.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.decode_log.warn(|| format!("dropped an undecodable message from {from}: {e}"));
    }

    /// How many messages from other processes failed to decode so far.
    pub fn decode_errors(&self) -> u64 {
        self.inner.decode_errors.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// The installed transport, if any.
    pub fn transport(&self) -> Option<Arc<dyn Transport>> {
        self.inner.transport.read().clone()
    }

    /// Reserves a component name.
    pub fn register_component(&self, name: &str) -> PatternResult<()> {
        if !valid_name(name) {
            return Err(PatternError::InvalidArgument(format!(
                "'{name}' is not a valid component name (letters, digits, '_' or '-')"
            )));
        }
        let mut comps = self.inner.components.write();
        if comps.contains_key(name) {
            return Err(PatternError::AlreadyRegistered(name.to_string()));
        }
        comps.insert(name.to_string(), ());
        Ok(())
    }

    /// Removes a component and all its services.
    pub fn unregister_component(&self, name: &str) {
        self.inner.components.write().remove(name);
        let mut removed = Vec::new();
        self.inner.services.write().retain(|addr, _| {
            let keep = addr.component != name;
            if !keep {
                removed.push(addr.clone());
            }
            keep
        });
        if let Some(t) = self.transport() {
            for addr in removed {
                t.service_removed(&addr);
            }
        }
    }

    /// Whether a component of this name is hosted here.
    pub fn has_component(&self, name: &str) -> bool {
        self.inner.components.read().contains_key(name)
    }

    /// The names of the components hosted here.
    pub fn components(&self) -> Vec<String> {
        self.inner.components.read().keys().cloned().collect()
    }

    /// Registers a service endpoint hosted here.
    pub fn register_service(
        &self,
        addr: ServiceAddr,
        info: ServiceInfo,
        endpoint: Arc<dyn Any + Send + Sync>,
        served: Arc<dyn Served>,
    ) -> PatternResult<()> {
        if !valid_name(&addr.service) {
            return Err(PatternError::InvalidArgument(format!(
                "'{}' is not a valid service name (letters, digits, '_' or '-')",
                addr.service
            )));
        }
        let mut services = self.inner.services.write();
        if services.contains_key(&addr) {
            return Err(PatternError::AlreadyRegistered(addr.to_string()));
        }
        services
            .insert(addr.clone(), LocalService { info: info.clone(), endpoint, served: Arc::clone(&served) });
        drop(services);
        if let Some(t) = self.transport() {
            t.service_added(&addr, &info, served);
        }
        Ok(())
    }

    /// The services hosted here with their info.
    pub fn services(&self) -> Vec<(ServiceAddr, ServiceInfo)> {
        self.inner.services.read().iter().map(|(a, s)| (a.clone(), s.info.clone())).collect()
    }

    /// Looks up a service hosted here.
    pub fn local(&self, addr: &ServiceAddr) -> Option<LocalService> {
        self.inner.services.read().get(addr).cloned()
    }

    /// Resolves a service hosted here to its typed endpoint `E`, checking its pattern and
    /// communication objects against `expected`.
    pub(crate) fn resolve_local<E: Any + Send + Sync>(
        &self,
        addr: &ServiceAddr,
        expected: &ServiceInfo,
    ) -> PatternResult<Option<Arc<E>>> {
        // Under the read lock, checked in place: only the endpoint's Arc is cloned.
        let endpoint = {
            let services = self.inner.services.read();
            let Some(service) = services.get(addr) else {
                return Ok(None);
            };
            check(&service.info, addr, expected)?;
            Arc::clone(&service.endpoint)
        };
        match endpoint.downcast::<E>() {
            Ok(e) => Ok(Some(e)),
            // Same identifiers but another Rust type: two types claim one identifier.
            Err(_) => Err(PatternError::IncompatibleService {
                addr: addr.clone(),
                expected_pattern: expected.pattern,
                expected: format!(
                    "{} (another Rust type with the same identifier)",
                    expected.types.join(" -> ")
                ),
                found_pattern: expected.pattern,
                found: expected.types.join(" -> "),
            }),
        }
    }

    /// Resolves a service for a client: hosted here (typed endpoint `E`), or by a peer the
    /// installed transport knows, checking its pattern and communication objects against
    /// `expected` either way.
    pub(crate) fn resolve<E: Any + Send + Sync>(
        &self,
        addr: &ServiceAddr,
        expected: &ServiceInfo,
    ) -> PatternResult<Resolved<E>> {
        if let Some(local) = self.resolve_local::<E>(addr, expected)? {
            return Ok(Resolved::Local(local));
        }
        if let Some(transport) = self.transport()
            && let Some(info) = transport.lookup(addr)
        {
            check(&info, addr, expected)?;
            return Ok(Resolved::Remote(Remote { addr: addr.clone(), transport, registry: self.clone() }));
        }
        Err(self.not_found(addr))
    }

    /// This process's side of the switches other processes make on its components.
    pub(crate) fn switches(
        &self,
    ) -> &parking_lot::Mutex<std::collections::HashMap<String, Box<dyn Any + Send>>> {
        &self.inner.switches
    }

    /// What the service at `addr` is, hosted here or by a peer the transport knows.
    pub fn service_info(&self, addr: &ServiceAddr) -> PatternResult<ServiceInfo> {
        if let Some(local) = self.local(addr) {
            return Ok(local.info);
        }
        self.transport().and_then(|t| t.lookup(addr)).ok_or_else(|| self.not_found(addr))
    }

    /// Checks that the service at `addr` (hosted here or by a peer) is what `expected` says.
    pub(crate) fn check_service(&self, addr: &ServiceAddr, expected: &ServiceInfo) -> PatternResult<()> {
        if let Some(service) = self.inner.services.read().get(addr) {
            return check(&service.info, addr, expected);
        }
        match self.transport().and_then(|t| t.lookup(addr)) {
            Some(found) => check(&found, addr, expected),
            None => Err(self.not_found(addr)),
        }
    }

    /// The error for an address that resolves nowhere.
    pub(crate) fn not_found(&self, addr: &ServiceAddr) -> PatternError {
        let hosts_something = self.has_component(&addr.component)
            || self.inner.services.read().keys().any(|a| a.component == addr.component);
        if hosts_something || self.transport().is_some() {
            PatternError::UnknownService(addr.clone())
        } else {
            PatternError::UnknownComponent(addr.component.clone())
        }
    }
}

impl Default for Registry {
    fn default() -> Self {
        Self::new()
    }
}
/// Checks that a client expecting `expected` may use the service `found` at `addr`.
pub(crate) fn check(found: &ServiceInfo, addr: &ServiceAddr, expected: &ServiceInfo) -> PatternResult<()> {
    if found == expected {
        Ok(())
    } else {
        Err(PatternError::IncompatibleService {
            addr: addr.clone(),
            expected_pattern: expected.pattern,
            expected: expected.types_text(),
            found_pattern: found.pattern,
            found: found.types_text(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::addr::PatternKind;

    #[test]
    fn info_mismatch_names_both_sides() {
        let addr = ServiceAddr::new("a", "b");
        let found = ServiceInfo::new(PatternKind::Send, &["x/1"]);
        let expected = ServiceInfo::new(PatternKind::Send, &["y/1"]);
        let err = check(&found, &addr, &expected).expect_err("must mismatch");
        let text = err.to_string();
        assert!(text.contains("a/b") && text.contains("x/1") && text.contains("y/1"), "{text}");
    }
}
