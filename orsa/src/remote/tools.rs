//! The inspection tools: `orsa list`, `orsa echo`, `orsa wire`, `orsa state`, `orsa switch`.

use super::{NetworkOptions, open, runtime, secs, until_stopped, wait_for};
use anyhow::{Context as _, bail};
use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::switch::{Change, Switch, SwitchMaster};
use orsa_actors::transport::Transport as _;
use orsa_actors::wiring::WiringMaster;
use orsa_actors::{CommObject as _, PatternKind, Registry, ServiceAddr};
use orsa_interfaces::health::Health;
use std::sync::Arc;
use std::time::Duration;

/// Options of `orsa list`.
#[derive(Debug)]
pub struct ListOptions {
    /// Seconds to listen for peers before listing.
    pub wait: f64,
    /// Print JSON instead of text.
    pub json: bool,
    /// Network.
    pub net: NetworkOptions,
}

/// Options of `orsa echo`.
#[derive(Debug)]
pub struct EchoOptions {
    /// The push service, `component/service`.
    pub service: ServiceAddr,
    /// Every n-th update (counted at the source).
    pub every: u32,
    /// Stop after this many updates.
    pub count: Option<u64>,
    /// One JSON object per line.
    pub json: bool,
    /// How long to wait for the service.
    pub wait: f64,
    /// Network.
    pub net: NetworkOptions,
}

/// Options of `orsa wire`.
#[derive(Debug)]
pub struct WireOptions {
    /// The component whose port to rewire.
    pub component: String,
    /// The port.
    pub port: String,
    /// The service to connect it to (`component/service`); omit with --disconnect.
    pub target: Option<ServiceAddr>,
    /// Disconnect the port instead.
    pub disconnect: bool,
    /// How long to wait for the component.
    pub wait: f64,
    /// Network.
    pub net: NetworkOptions,
}

/// Options of `orsa switch`.
#[derive(Debug)]
pub struct SwitchOptions {
    /// The changes, made all or nothing: `COMPONENT.PORT=SERVICE` connects a port (SERVICE is
    /// `component/service`), `COMPONENT.PORT=` disconnects it, `COMPONENT:STATE` sets a main
    /// state. For example: `wallfollow.vel= wallfollow:neutral centerfollow:active
    /// centerfollow.vel=nomad200/navigationvelocity`.
    pub changes: Vec<Change>,
    /// How long each step may take before the whole switch is undone.
    pub step_timeout: f64,
    /// How long to wait for the components.
    pub wait: f64,
    /// Network.
    pub net: NetworkOptions,
}

/// A change typed on the command line that does not read (the text, and why).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{text}': {why} (COMPONENT.PORT=SERVICE, COMPONENT.PORT= or COMPONENT:STATE)")]
pub struct BadChange {
    /// The change as typed.
    pub text: String,
    /// What is wrong with it.
    pub why: String,
}

/// One change as typed on the command line (see [`SwitchOptions::changes`]).
pub fn parse_change(text: &str) -> Result<Change, BadChange> {
    let bad = |why: &str| BadChange { text: text.to_string(), why: why.to_string() };
    let name = |s: &str, what: &str| -> Result<String, BadChange> {
        if orsa_actors::addr::valid_name(s) {
            Ok(s.to_string())
        } else {
            Err(bad(&format!("'{s}' is not a valid {what} name")))
        }
    };
    if let Some((left, target)) = text.split_once('=') {
        let (component, port) = left.split_once('.').ok_or_else(|| bad("a port is COMPONENT.PORT"))?;
        let (component, port) = (name(component, "component")?, name(port, "port")?);
        if target.is_empty() {
            return Ok(Change::Disconnect { component, port });
        }
        let target = target.parse::<ServiceAddr>().map_err(|e| bad(&e.to_string()))?;
        return Ok(Change::Connect { component, port, target });
    }
    if let Some((component, main)) = text.split_once(':') {
        return Ok(Change::State { component: name(component, "component")?, main: name(main, "state")? });
    }
    Err(bad("neither a port nor a state"))
}

/// Options of `orsa state`.
#[derive(Debug)]
pub struct StateOptions {
    /// The component.
    pub component: String,
    /// The main state to set; omit to show the state.
    pub main: Option<String>,
    /// How long to wait for the component.
    pub wait: f64,
    /// Network.
    pub net: NetworkOptions,
}

/// What `orsa list` prints as JSON.
#[derive(Debug, serde::Serialize)]
struct Listing {
    processes: Vec<ListedProcess>,
    services: Vec<ListedService>,
}

#[derive(Debug, serde::Serialize)]
struct ListedProcess {
    zid: String,
    role: String,
    stats: Option<orsa_net::NetStats>,
}

#[derive(Debug, serde::Serialize)]
struct ListedService {
    service: String,
    pattern: PatternKind,
    types: Vec<String>,
    host: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    detail: Option<serde_json::Value>,
}

/// `orsa list`.
pub fn list(args: ListOptions) -> anyhow::Result<()> {
    let wait = secs(args.wait, "--wait")?;
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "tool", None).await?;
        // Discovery is asynchronous: listen for a moment, as `ros2 node list` spins.
        tokio::time::sleep(wait).await;
        let roles: std::collections::BTreeMap<String, String> =
            transport.processes().into_iter().map(|p| (p.zid, p.role)).collect();
        let mut services = Vec::new();
        for a in transport.remote_services() {
            let detail = match a.info.pattern {
                PatternKind::Wiring => WiringMaster::new(&registry)
                    .ports(&a.addr.component)
                    .await
                    .ok()
                    .and_then(|p| serde_json::to_value(p).ok()),
                PatternKind::State => {
                    match orsa_actors::state::StateMaster::connect(&registry, &a.addr.component) {
                        Ok(m) => m.status().await.ok().and_then(|s| serde_json::to_value(s).ok()),
                        Err(_) => None,
                    }
                }
                // A robot's sensor health: its newest verdicts.
                PatternKind::PushNewest if a.info.types.iter().any(|t| t == Health::ID) => {
                    newest_health(&registry, &a.addr).await.and_then(|h| serde_json::to_value(h).ok())
                }
                _ => None,
            };
            let host = format!("{} ({})", a.host, roles.get(&a.host).map_or("?", String::as_str));
            services.push(ListedService {
                service: a.addr.to_string(),
                pattern: a.info.pattern,
                types: a.info.types,
                host,
                detail,
            });
        }
        let stats = transport.all_stats(Duration::from_secs(2)).await;
        let processes = roles
            .into_iter()
            .filter(|(z, _)| z != transport.zid())
            .map(|(zid, role)| ListedProcess { stats: stats.get(&zid).copied(), zid, role })
            .collect();
        let listing = Listing { processes, services };
        if args.json {
            crate::output::say(&serde_json::to_string_pretty(&listing)?);
        } else {
            crate::output::say(&render_listing(&listing));
        }
        transport.close().await;
        Ok(())
    })
}

fn render_listing(l: &Listing) -> String {
    let mut out = String::from("processes:\n");
    for p in &l.processes {
        let figures = p.stats.map_or(String::new(), |s| {
            let busy =
                if s.refused_busy > 0 { format!(" refused-busy {}", s.refused_busy) } else { String::new() };
            let lost = if s.missing + s.duplicated > 0 {
                format!(" missing {} duplicated {}", s.missing, s.duplicated)
            } else {
                String::new()
            };
            format!(
                "  published {} received {} undecodable {}{busy}{lost}",
                s.published, s.received, s.decode_errors
            )
        });
        out.push_str(&format!("  {:<10} {}  live{figures}\n", p.role, p.zid));
    }
    out.push_str("services:\n");
    for s in &l.services {
        out.push_str(&format!(
            "  {:<32} {:<12} {}\n",
            s.service,
            orsa_net::pattern_name(s.pattern),
            s.types.join(" -> ")
        ));
        if let Some(d) = &s.detail {
            match s.pattern {
                PatternKind::Wiring => {
                    for p in d.as_array().into_iter().flatten() {
                        let target = p.get("target").and_then(|t| t.as_object()).map_or(
                            "(disconnected)".to_string(),
                            |t| {
                                format!(
                                    "-> {}/{}",
                                    t.get("component").and_then(|c| c.as_str()).unwrap_or("?"),
                                    t.get("service").and_then(|c| c.as_str()).unwrap_or("?")
                                )
                            },
                        );
                        out.push_str(&format!(
                            "      port {} {target}\n",
                            p.get("port").and_then(|x| x.as_str()).unwrap_or("?")
                        ));
                    }
                }
                PatternKind::PushNewest => {
                    if let Ok(h) = serde_json::from_value::<Health>(d.clone()) {
                        for s in &h.sensors {
                            let why = if s.why.is_empty() { String::new() } else { format!(": {}", s.why) };
                            out.push_str(&format!("      {:<9} {}{why}\n", s.sensor, s.verdict.name()));
                        }
                    }
                }
                _ => {
                    let current = d.get("current").and_then(|c| c.as_str()).unwrap_or("?");
                    out.push_str(&format!("      state {current}\n"));
                }
            }
        }
    }
    out
}

/// The newest health a robot pushed on `addr`, if it comes within a little more than the
/// robot's period for it (it pushes its health on every change and every second).
async fn newest_health(registry: &Registry, addr: &ServiceAddr) -> Option<Health> {
    let client = PushNewestClient::<Health>::connect(registry, addr.clone()).ok()?;
    client.subscribe().ok()?;
    let within = orsa_hardware::server::HEALTH_EVERY + Duration::from_millis(500);
    let update = client.get_update_wait_timeout(within).await.ok()?;
    let _ = client.unsubscribe();
    Some(update.value.clone())
}

/// `orsa echo`.
pub fn echo(args: EchoOptions) -> anyhow::Result<()> {
    let every = std::num::NonZeroU32::new(args.every).context("--every must be at least 1")?;
    let wait = secs(args.wait, "--wait")?;
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "tool", None).await?;
        wait_for(&transport, std::slice::from_ref(&args.service), wait).await?;
        let info = transport.lookup(&args.service).context("the service vanished")?;
        if !matches!(info.pattern, PatternKind::PushNewest | PatternKind::PushTimed) {
            bail!("{} is {}: echo shows push services", args.service, info.pattern);
        }
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Vec<u8>>();
        let _sub = transport.subscribe(
            &args.service,
            every,
            Arc::new(move |b: &[u8]| tx.send(b.to_vec()).is_ok()),
        )?;
        let mut seen = 0u64;
        let stop = until_stopped(None);
        tokio::pin!(stop);
        loop {
            tokio::select! {
                () = &mut stop => break,
                Some(bytes) = rx.recv() => {
                    match orsa_actors::wire::decode::<ciborium::Value>(&bytes, &info.types.join(",")) {
                        Ok(v) => {
                            let json = cbor_to_json(v);
                            if args.json {
                                crate::output::say(&serde_json::to_string(&json)?);
                            } else {
                                crate::output::say(&format!("{}\n---", serde_json::to_string_pretty(&json)?));
                            }
                        }
                        Err(e) => eprintln!("echo: {e}"),
                    }
                    seen += 1;
                    if args.count.is_some_and(|c| seen >= c) {
                        break;
                    }
                }
            }
        }
        drop(_sub);
        transport.close().await;
        Ok(())
    })
}

/// A CBOR value as JSON (byte strings as arrays of numbers, non-text keys as text).
fn cbor_to_json(v: ciborium::Value) -> serde_json::Value {
    use ciborium::Value as C;
    use serde_json::Value as J;
    match v {
        C::Integer(i) => {
            let i: i128 = i.into();
            u64::try_from(i).map(J::from).or_else(|_| i64::try_from(i).map(J::from)).unwrap_or(J::Null)
        }
        C::Float(f) => serde_json::Number::from_f64(f).map_or(J::Null, J::Number),
        C::Bool(b) => J::Bool(b),
        C::Null => J::Null,
        C::Text(t) => J::String(t),
        C::Bytes(b) => J::Array(b.into_iter().map(J::from).collect()),
        C::Array(a) => J::Array(a.into_iter().map(cbor_to_json).collect()),
        C::Map(m) => J::Object(
            m.into_iter()
                .map(|(k, v)| {
                    let key = match k {
                        C::Text(t) => t,
                        other => cbor_to_json(other).to_string(),
                    };
                    (key, cbor_to_json(v))
                })
                .collect(),
        ),
        C::Tag(_, inner) => cbor_to_json(*inner),
        _ => J::Null,
    }
}

/// How long `orsa wire` and `orsa state` let their one change take (a state change waits for
/// the component's activities to leave their critical sections) before it is undone.
const TOOL_STEP_TIMEOUT: Duration = Duration::from_secs(5);

/// `orsa wire`.
pub fn wire(args: WireOptions) -> anyhow::Result<()> {
    let wait = secs(args.wait, "--wait")?;
    if args.target.is_none() && !args.disconnect {
        bail!("give a TARGET service (component/service) or --disconnect");
    }
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "tool", None).await?;
        wait_for(&transport, &[ServiceAddr::new(&args.component, "wiring")], wait).await?;
        // One change, made as a switch: checked before it is made, recorded as one switch
        // event by the component's process, and refused with the same typed error.
        let change = match &args.target {
            Some(t) => Switch::new().connect_named(&args.component, &args.port, t.clone()),
            None => Switch::new().disconnect_named(&args.component, &args.port),
        };
        SwitchMaster::new(&registry, "tool").apply(&change.step_timeout(TOOL_STEP_TIMEOUT)).await?;
        let master = WiringMaster::new(&registry);
        for p in master.ports(&args.component).await? {
            let target = p.target.map_or("(disconnected)".to_string(), |t| t.to_string());
            crate::output::say(&format!("{}.{} -> {target}", args.component, p.port));
        }
        transport.close().await;
        Ok(())
    })
}

/// `orsa state`.
pub fn state(args: StateOptions) -> anyhow::Result<()> {
    let wait = secs(args.wait, "--wait")?;
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "tool", None).await?;
        wait_for(&transport, &[ServiceAddr::new(&args.component, "state")], wait).await?;
        if let Some(main) = &args.main {
            let change = Switch::new().state(&args.component, main).step_timeout(TOOL_STEP_TIMEOUT);
            SwitchMaster::new(&registry, "tool").apply(&change).await?;
        }
        let master = orsa_actors::state::StateMaster::connect(&registry, &args.component)?;
        let s = master.status().await?;
        crate::output::say(&format!(
            "{}: {}{}",
            args.component,
            s.current,
            s.pending.map(|p| format!(" (changing to {p})")).unwrap_or_default()
        ));
        transport.close().await;
        Ok(())
    })
}

/// `orsa switch`: several wiring and state changes, on components anywhere on the network, all
/// or nothing.
pub fn switch(args: SwitchOptions) -> anyhow::Result<()> {
    let wait = secs(args.wait, "--wait")?;
    let step = secs(args.step_timeout, "--step-timeout")?;
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "tool", None).await?;
        let mut needed: Vec<ServiceAddr> = args
            .changes
            .iter()
            .map(|c| match c {
                Change::State { component, .. } => ServiceAddr::new(component, "state"),
                Change::Connect { component, .. } | Change::Disconnect { component, .. } => {
                    ServiceAddr::new(component, "wiring")
                }
            })
            .collect();
        needed.sort();
        needed.dedup();
        wait_for(&transport, &needed, wait).await?;
        let master = SwitchMaster::new(&registry, "tool");
        let result = master.apply(&Switch::of(args.changes.clone()).step_timeout(step)).await;
        transport.close().await;
        result?;
        for c in &args.changes {
            crate::output::say(&format!("done: {c}"));
        }
        Ok(())
    })
}
