//! What a run lost and whether the stack held together: the framework's delivery ledger per
//! service, and watches kept while the run samples it (motors driven with nothing wired or on
//! a command older than the velocity timeout, subscriptions that went missing, wiring that does
//! not match the master's last decision).

use orsa_actors::ledger::DeliveryCounts;
use orsa_actors::wiring::WiringMaster;
use orsa_actors::{PatternKind, Registry, ServiceAddr};
use orsa_hardware::faulty::BoardFaults;
use orsa_interfaces::behaviour::VEL;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::Duration;

/// One service's figures in the report.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ServiceDelivery {
    /// The service's pattern (`send`, `query`, `push_newest`, ...).
    pub pattern: String,
    /// Its figures (see `orsa_actors::ledger`).
    #[serde(flatten)]
    pub counts: DeliveryCounts,
    /// Not settled when the run ended (queued, or held back by a delay fault).
    pub in_flight: u64,
}

/// The `delivery` section of a run's report.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DeliveryReport {
    /// Per service (`component/service`), every service that carried a message.
    pub services: BTreeMap<String, ServiceDelivery>,
    /// All services together.
    pub total: DeliveryCounts,
    /// Messages that must arrive (Send, Query, Event) and vanished without their sender being
    /// told. Push updates are superseded by the next one by design; their losses are in
    /// `services` and `total`.
    pub lost_must_arrive: u64,
}

impl DeliveryReport {
    /// The section from `registry`'s ledger now.
    pub fn from_ledger(registry: &Registry) -> Self {
        let mut report = DeliveryReport::default();
        for (addr, kind, counts) in registry.ledger().counts() {
            if counts == DeliveryCounts::default() {
                continue;
            }
            report.total.add(&counts);
            if matches!(kind, PatternKind::Send | PatternKind::Query | PatternKind::Event) {
                report.lost_must_arrive += counts.lost;
            }
            let pattern = serde_json::to_value(kind)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_else(|| format!("{kind:?}"));
            report
                .services
                .insert(addr.to_string(), ServiceDelivery { pattern, in_flight: counts.in_flight(), counts });
        }
        report
    }
}

/// The `integrity` section of a run's report.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct IntegrityReport {
    /// Simulated seconds the robot moved with no behaviour wired to the motors, beyond the
    /// velocity timeout after the unwiring (the time it may take to stop).
    pub driven_unwired_s: f64,
    /// Simulated seconds the robot moved on a command the motors got longer ago than the
    /// velocity timeout, seen from the motors' side.
    pub driven_on_stale_command_s: f64,
    /// Times the subscriptions and event activations were compared with those at the start.
    pub client_checks: u64,
    /// Checks at which some service had another number of subscribers or activations.
    pub client_mismatches: u64,
    /// The first mismatch seen (service, clients at the start, clients then, time in s).
    pub first_client_mismatch: Option<(String, usize, usize, f64)>,
    /// Times the behaviours' wiring was compared with the master's last decision (each
    /// second).
    pub wiring_checks: u64,
    /// Checks at which the wiring differed from the master's decision, as it had at the check
    /// before: a difference lasting a second or more (a switch in progress lasts microseconds).
    pub wiring_mismatches: u64,
    /// The first lasting mismatch (the behaviour the master reported driving, the behaviours
    /// wired, time in s).
    pub first_wiring_mismatch: Option<(Option<String>, Vec<String>, f64)>,
    /// Each behaviour's `vel` port at the end of the run, and where it was connected.
    pub wiring_at_end: BTreeMap<String, Option<String>>,
    /// Whether exactly the behaviour the master last reported driving was wired to the motors
    /// at the end (nothing wired if it reported none).
    pub wiring_matches_master: bool,
}

/// Keeps the integrity watches while a run samples its stack.
pub struct Watch {
    boards: BoardFaults,
    cmd_timeout: Duration,
    baseline: Option<BTreeMap<ServiceAddr, usize>>,
    unwired_since: Option<f64>,
    mismatched_before: bool,
    report: IntegrityReport,
}

/// Each behaviour's `vel` target.
async fn vel_targets(registry: &Registry, behaviours: &[&str]) -> BTreeMap<String, Option<String>> {
    let master = WiringMaster::new(registry);
    let mut out = BTreeMap::new();
    for b in behaviours {
        let target = match master.ports(b).await {
            Ok(ports) => ports.into_iter().find(|p| p.port == VEL.name()).and_then(|p| p.target),
            Err(_) => None,
        };
        out.insert(b.to_string(), target.map(|t| t.to_string()));
    }
    out
}

/// Whether exactly `driving` (or nothing) is wired.
fn agrees(targets: &BTreeMap<String, Option<String>>, driving: Option<&str>) -> bool {
    targets.iter().all(|(b, t)| t.is_some() == (driving == Some(b.as_str())))
}

/// Whether the robot is moving (beyond numerical dust).
fn moving(v_m_s: f64, omega_rad_s: f64) -> bool {
    v_m_s.abs() > 1e-3 || omega_rad_s.abs() > 1e-2
}

impl Watch {
    /// Watches for a robot whose motors are `boards` and whose velocity timeout is
    /// `cmd_timeout`.
    pub fn new(boards: BoardFaults, cmd_timeout: Duration) -> Self {
        Watch {
            boards,
            cmd_timeout,
            baseline: None,
            unwired_since: None,
            mismatched_before: false,
            report: IntegrityReport::default(),
        }
    }

    /// One sample at `t_s`, `dt_s` after the last: the robot's true velocity and whether a
    /// behaviour is wired.
    pub fn sample(&mut self, t_s: f64, dt_s: f64, v_m_s: f64, omega_rad_s: f64, wired: bool) {
        let moves = moving(v_m_s, omega_rad_s);
        if wired {
            self.unwired_since = None;
        } else {
            let since = *self.unwired_since.get_or_insert(t_s);
            if moves && t_s - since > self.cmd_timeout.as_secs_f64() {
                self.report.driven_unwired_s += dt_s;
            }
        }
        if moves
            && let Some((age, true)) = self.boards.last_command()
            && age > self.cmd_timeout
        {
            self.report.driven_on_stale_command_s += dt_s;
        }
    }

    /// Compares the subscriptions and activations of `registry` with the first ones seen.
    pub fn check_clients(&mut self, registry: &Registry, t_s: f64) {
        let now = registry.clients();
        let Some(baseline) = &self.baseline else {
            self.baseline = Some(now);
            return;
        };
        self.report.client_checks += 1;
        let differs = baseline
            .iter()
            .map(|(a, n)| (a, *n, now.get(a).copied().unwrap_or(0)))
            .chain(now.iter().filter(|(a, _)| !baseline.contains_key(*a)).map(|(a, n)| (a, 0, *n)))
            .find(|(_, before, after)| before != after);
        if let Some((addr, before, after)) = differs {
            self.report.client_mismatches += 1;
            if self.report.first_client_mismatch.is_none() {
                self.report.first_client_mismatch = Some((addr.to_string(), before, after, t_s));
            }
        }
    }

    /// Compares the wiring of `behaviours` with `driving`, the behaviour the master last
    /// reported wired.
    pub async fn check_wiring(
        &mut self,
        registry: &Registry,
        behaviours: &[&str],
        driving: Option<&str>,
        t_s: f64,
    ) {
        let targets = vel_targets(registry, behaviours).await;
        self.report.wiring_checks += 1;
        let mismatched = !agrees(&targets, driving);
        if mismatched && self.mismatched_before {
            self.report.wiring_mismatches += 1;
            if self.report.first_wiring_mismatch.is_none() {
                let wired = targets.iter().filter(|(_, t)| t.is_some()).map(|(b, _)| b.clone()).collect();
                self.report.first_wiring_mismatch = Some((driving.map(str::to_string), wired, t_s));
            }
        }
        self.mismatched_before = mismatched;
    }

    /// The section, after checking the wiring of `behaviours` against `driving`, the
    /// behaviour the master last reported wired.
    pub async fn finish(
        mut self,
        registry: &Registry,
        behaviours: &[&str],
        driving: Option<&str>,
    ) -> IntegrityReport {
        let targets = vel_targets(registry, behaviours).await;
        self.report.wiring_matches_master = agrees(&targets, driving);
        self.report.wiring_at_end = targets;
        self.report
    }
}
