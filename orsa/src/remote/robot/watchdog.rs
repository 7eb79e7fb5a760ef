//! The robot's link watchdog: it watches its executives (their process tokens and heartbeats),
//! and when one is lost it stops the motors, unwires the behaviours and drives the fallback
//! mode if one is asked for; when the executive is heard again it gives back what it had wired.
//! It also keeps the figures of the report: the stops, and the link cuts of the fault plan.

use super::fallback::start_fallback_if;
use super::report::StopReport;
use crate::config::Config;
use crate::record::events::{LINK_EVENT, LINK_EVENTS, LinkEvent, LinkEventKind};
use orsa_actors::component::ComponentHandle;
use orsa_actors::send::SendClient;
use orsa_actors::wiring::WiringMaster;
use orsa_actors::{Registry, ServiceAddr};
use orsa_executive::Master;
use orsa_interfaces::behaviour::VEL;
use orsa_interfaces::nomad200::NavigationVelocity;
use std::sync::Arc;
use std::time::Duration;

/// The registry's timestamp of tokio instant `at` (now, minus how long ago `at` was).
fn now_ts(registry: &Registry, at: tokio::time::Instant) -> orsa_actors::Timestamp {
    let ago = tokio::time::Instant::now().saturating_duration_since(at);
    orsa_actors::Timestamp(registry.now().0.saturating_sub(ago.as_nanos() as u64))
}

/// What the robot's main loop hears about.
pub(super) enum RobotEvent {
    /// A process of role executive appeared (its token).
    ExecutiveFound(String),
    /// An executive's token disappeared.
    ExecutiveGone(String),
    /// A heartbeat of an executive, with its period in ms.
    Beat(String, u64),
    /// The fault plan cut (true) or restored (false) the link to a role.
    Link(String, bool),
}

/// An executive as the robot sees it.
struct Executive {
    /// No heartbeat by then: lost.
    deadline: tokio::time::Instant,
    /// Lost (token gone or heartbeat lease expired) and not heard since.
    lost: bool,
    /// The behaviour it had wired to the motors when it was lost, given back when it returns.
    restore: Option<String>,
    /// Whether its heartbeat period was found too slow for the lease (warned once).
    warned: bool,
}

/// What the watchdog leaves for the report when the robot ends (kept outside its loop, so that
/// every way out writes it).
#[derive(Default)]
pub(super) struct Watched {
    /// The fallback master, while it drives.
    pub(super) fallback: Option<ComponentHandle<Master>>,
    /// The link cuts of the fault plan, and how the robot went through each.
    pub(super) links: Vec<crate::faults::LinkCutReport>,
    /// What the watchdog detected and the plan did to the links, for the faults report's log.
    pub(super) link_log: Vec<(f64, String, String)>,
    /// Every stop the robot made by itself.
    pub(super) stops: Vec<StopReport>,
}

/// Sends what the network says about executives (found, gone, heartbeats) to `ev_tx`, for as
/// long as the answer is kept.
pub(super) async fn listen(
    transport: &orsa_net::ZenohTransport,
    ev_tx: &tokio::sync::mpsc::UnboundedSender<RobotEvent>,
) -> anyhow::Result<orsa_net::HeartbeatWatch> {
    let tx = ev_tx.clone();
    transport.on_process_lost(move |p| {
        if p.role == "executive" {
            let _ = tx.send(RobotEvent::ExecutiveGone(p.zid.clone()));
        }
    });
    let tx = ev_tx.clone();
    transport.on_process_found(move |p| {
        if p.role == "executive" {
            let _ = tx.send(RobotEvent::ExecutiveFound(p.zid.clone()));
        }
    });
    let tx = ev_tx.clone();
    let beats = transport
        .on_heartbeat("executive", move |zid, h| {
            let _ = tx.send(RobotEvent::Beat(zid.to_string(), h.period_ms));
        })
        .await?;
    Ok(beats)
}

/// The robot's main loop: its executives, its motors, and what it has seen so far.
pub(super) struct Watchdog<'a> {
    registry: &'a Registry,
    config: &'a Config,
    /// `--fallback`.
    fallback_mode: &'a Option<String>,
    /// No heartbeat for this long: the executive is lost.
    lease: Duration,
    recording: &'a Option<Arc<crate::mission::recording::McapTap>>,
    /// The behaviours the executive's modes name, unwired when an executive is lost.
    behaviours: Vec<String>,
    motors_addr: ServiceAddr,
    motors: SendClient<NavigationVelocity>,
    executives: std::collections::BTreeMap<String, Executive>,
    last_base: Option<orsa_interfaces::nomad200::BaseState>,
    departed: std::collections::BTreeSet<String>,
    /// Whether an executive was ever heard (found or beating), or the fallback was started
    /// for want of one: until then the fallback starts a lease after the robot does.
    heard: bool,
    watched: &'a mut Watched,
}

impl<'a> Watchdog<'a> {
    /// The watchdog of robot `robot`, whose motors it connects to.
    pub(super) fn new(
        registry: &'a Registry,
        config: &'a Config,
        fallback_mode: &'a Option<String>,
        lease: Duration,
        recording: &'a Option<Arc<crate::mission::recording::McapTap>>,
        robot: &str,
        watched: &'a mut Watched,
    ) -> anyhow::Result<Self> {
        let behaviours = config.executive().behaviours();
        let motors_addr = ServiceAddr::new(robot, "navigationvelocity");
        let motors = SendClient::<NavigationVelocity>::connect(registry, &motors_addr)?;
        Ok(Watchdog {
            registry,
            config,
            fallback_mode,
            lease,
            recording,
            behaviours,
            motors_addr,
            motors,
            executives: std::collections::BTreeMap::new(),
            last_base: None,
            departed: std::collections::BTreeSet::new(),
            heard: false,
            watched,
        })
    }

    /// Runs until `stop` resolves, hearing `ev_rx` and the robot's base states `base_rx`;
    /// answers what stopped it.
    pub(super) async fn run(
        mut self,
        stop: impl std::future::Future<Output = crate::ending::Stop>,
        mut ev_rx: tokio::sync::mpsc::UnboundedReceiver<RobotEvent>,
        mut base_rx: tokio::sync::mpsc::UnboundedReceiver<
            orsa_actors::Update<orsa_interfaces::nomad200::BaseState>,
        >,
    ) -> crate::ending::Stop {
        let far = Duration::from_secs(86_400);
        // With no executive at all, the fallback drives a lease after the start, as it does a
        // lease after an executive is lost.
        let unheard = tokio::time::Instant::now() + self.lease;
        tokio::pin!(stop);
        loop {
            let now = tokio::time::Instant::now();
            let next =
                self.executives.values().filter(|e| !e.lost).map(|e| e.deadline).min().unwrap_or(now + far);
            let alone = !self.heard && self.fallback_mode.is_some();
            tokio::select! {
                stop = &mut stop => break stop,
                () = tokio::time::sleep_until(unheard), if alone => self.never_heard().await,
                () = tokio::time::sleep_until(next) => self.expired().await,
                Some(ev) = ev_rx.recv() => match ev {
                    RobotEvent::ExecutiveFound(zid) => self.executive_found(zid).await,
                    RobotEvent::ExecutiveGone(zid) => self.executive_gone(zid).await,
                    RobotEvent::Beat(zid, _) if self.departed.contains(&zid) => {}
                    RobotEvent::Beat(zid, period_ms) => self.beat(zid, period_ms).await,
                    RobotEvent::Link(role, cut) => self.link(role, cut),
                },
                Some(u) = base_rx.recv() => self.base_state(u),
            }
        }
    }

    /// No executive was heard within a lease of the start: the fallback drives.
    async fn never_heard(&mut self) {
        self.heard = true;
        crate::say!("robot", "no executive within {} ms of the start", self.lease.as_millis());
        start_fallback_if(self.registry, self.config, self.fallback_mode, &mut self.watched.fallback).await;
    }

    /// The heartbeat leases that expired: their executives are lost.
    async fn expired(&mut self) {
        let registry = self.registry;
        let now = tokio::time::Instant::now();
        let expired: Vec<(String, tokio::time::Instant)> = self
            .executives
            .iter()
            .filter(|(_, e)| !e.lost && e.deadline <= now)
            .map(|(z, e)| (z.clone(), e.deadline))
            .collect();
        for (zid, deadline) in expired {
            let why = format!("no heartbeat for {} ms", self.lease.as_millis());
            let (restore, commanded) = lose_executive(
                registry,
                &self.behaviours,
                &self.motors,
                &self.motors_addr,
                &zid,
                &why,
                self.recording,
            )
            .await;
            self.watched.stops.push(StopReport::new(
                registry,
                format!("executive lost: {why}"),
                now_ts(registry, deadline),
                commanded,
                self.last_base.as_ref(),
            ));
            if let Some(e) = self.executives.get_mut(&zid) {
                e.lost = true;
                e.restore = restore;
            }
            note_loss(registry, &mut self.watched.links, &mut self.watched.link_log, &zid, &why);
            if start_fallback_if(registry, self.config, self.fallback_mode, &mut self.watched.fallback).await
            {
                StopReport::driven_again(registry, &mut self.watched.stops);
            }
        }
    }

    /// A process of role executive appeared.
    async fn executive_found(&mut self, zid: String) {
        self.heard = true;
        self.departed.remove(&zid);
        // A new executive takes over: the fallback master goes first (the
        // executive waits for its services to disappear before it starts).
        if let Some(f) = self.watched.fallback.take() {
            crate::say!("robot", "executive {zid} is back: stopping the fallback");
            f.stop().await;
        }
        let lease = self.lease;
        let e = self.executives.entry(zid.clone()).or_insert(Executive {
            deadline: tokio::time::Instant::now() + lease,
            lost: false,
            restore: None,
            warned: false,
        });
        if e.lost {
            e.lost = false;
            e.deadline = tokio::time::Instant::now() + lease;
            let restore = e.restore.take();
            self.rejoined(&zid, restore).await;
        }
    }

    /// Executive `zid`, lost, is back (its token appeared again, or its heartbeat was heard
    /// again), with no fallback master running: it gets back `restore`, the behaviour it had
    /// wired, and the stop it caused ends.
    async fn rejoined(&mut self, zid: &str, restore: Option<String>) {
        executive_back(
            self.registry,
            &self.behaviours,
            &self.motors_addr,
            zid,
            restore,
            &mut self.watched.links,
            self.recording,
        )
        .await;
        StopReport::driven_again(self.registry, &mut self.watched.stops);
    }

    /// An executive's process token disappeared.
    async fn executive_gone(&mut self, zid: String) {
        let registry = self.registry;
        // A heartbeat it sent before it left may still arrive: it must not
        // bring it back (zenoh ids are never reused).
        self.departed.insert(zid.clone());
        let was_lost = self.executives.remove(&zid).is_some_and(|e| e.lost);
        if !was_lost {
            let why = "its process token disappeared";
            let detected = registry.now();
            let (_, commanded) = lose_executive(
                registry,
                &self.behaviours,
                &self.motors,
                &self.motors_addr,
                &zid,
                why,
                self.recording,
            )
            .await;
            self.watched.stops.push(StopReport::new(
                registry,
                format!("executive lost: {why}"),
                detected,
                commanded,
                self.last_base.as_ref(),
            ));
            note_loss(registry, &mut self.watched.links, &mut self.watched.link_log, &zid, why);
        }
        if start_fallback_if(registry, self.config, self.fallback_mode, &mut self.watched.fallback).await {
            StopReport::driven_again(registry, &mut self.watched.stops);
        }
    }

    /// A heartbeat of executive `zid` (not departed), which beats every `period_ms`.
    async fn beat(&mut self, zid: String, period_ms: u64) {
        self.heard = true;
        let lease = self.lease;
        let e = self.executives.entry(zid.clone()).or_insert(Executive {
            deadline: tokio::time::Instant::now() + lease,
            lost: false,
            restore: None,
            warned: false,
        });
        e.deadline = tokio::time::Instant::now() + lease;
        if !e.warned && Duration::from_millis(period_ms.saturating_mul(2)) > lease {
            e.warned = true;
            crate::say!(
                "robot",
                "executive {zid} beats every {period_ms} ms: too slow for the {} ms lease \
                 (link.heartbeat_period_s in its config)",
                lease.as_millis()
            );
        }
        if e.lost {
            e.lost = false;
            let restore = e.restore.take();
            if let Some(f) = self.watched.fallback.take() {
                crate::say!("robot", "executive {zid} is heard again: stopping the fallback");
                f.stop().await;
            }
            self.rejoined(&zid, restore).await;
        }
    }

    /// The fault plan cut (`cut`) or restored the link to `role`.
    fn link(&mut self, role: String, cut: bool) {
        let registry = self.registry;
        let (links, link_log) = (&mut self.watched.links, &mut self.watched.link_log);
        let t = registry.clock().since_start(registry.now()).as_secs_f64();
        if cut {
            crate::say!("robot", "[{t:.3} s] fault: link to {role} cut");
            links.push(crate::faults::LinkCutReport {
                role: role.clone(),
                cut_at_s: t,
                ..Default::default()
            });
            link_log.push((t, role, "link cut".into()));
        } else {
            crate::say!("robot", "[{t:.3} s] fault: link to {role} restored");
            if let Some(l) = links.iter_mut().rev().find(|l| l.role == role && l.restored_at_s.is_none()) {
                l.restored_at_s = Some(t);
            }
            link_log.push((t, role, "link restored".into()));
        }
    }

    /// The robot's own base state: when it came to rest and moved again.
    fn base_state(&mut self, u: orsa_actors::Update<orsa_interfaces::nomad200::BaseState>) {
        let t = self.registry.clock().since_start(u.sent_at).as_secs_f64();
        let b = &u.value;
        let at_rest = b.v_m_s == 0.0 && b.omega_rad_s == 0.0;
        for stop in &mut self.watched.stops {
            stop.see(t, b);
        }
        self.last_base = Some(*b);
        for l in &mut self.watched.links {
            if l.at_rest_at_s.is_none() && t >= l.cut_at_s && at_rest {
                l.at_rest_at_s = Some(t);
            }
            if l.moving_again_at_s.is_none() && l.restored_at_s.is_some_and(|r| t >= r) && !at_rest {
                l.moving_again_at_s = Some(t);
            }
        }
    }
}

/// How long the robot waits for each behaviour to be unwired when its executive is lost (the
/// motors were commanded to zero before).
const UNWIRE_WAIT: Duration = Duration::from_millis(250);

/// The executive `zid` is lost (`why`): commands the motors to zero at once, then unwires
/// every behaviour (all at once, each within [`UNWIRE_WAIT`]) and commands zero again, in case
/// a behaviour's command landed in between. Answers the behaviour it had wired to the motors,
/// and when the first zero was handed to the robot server.
async fn lose_executive(
    registry: &Registry,
    behaviours: &[String],
    motors: &SendClient<NavigationVelocity>,
    motors_addr: &ServiceAddr,
    zid: &str,
    why: &str,
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
) -> (Option<String>, orsa_actors::Timestamp) {
    let detected = registry.now();
    let zero = || NavigationVelocity { stamp: registry.now(), v_m_s: 0.0, omega_rad_s: 0.0 };
    let first = zero();
    // Noted first: a replay feeds the note back and sends its command there.
    note_link(registry, recording, zid, LinkEventKind::Lost, why, Some(first));
    if let Err(e) = motors.send(first) {
        tracing::warn!("robot: cannot stop the motors: {e}");
    }
    let commanded = registry.now();
    let t = registry.clock().since_start(detected).as_secs_f64();
    crate::say!(
        "robot",
        "[{t:.3} s] executive {zid} lost ({why}): motors commanded to zero, unwiring the behaviours"
    );
    let wiring = WiringMaster::new(registry);
    let unwire = |b: &str| {
        let (wiring, b) = (wiring.clone(), b.to_string());
        async move {
            let drove = async {
                let ports = wiring.ports(&b).await.ok()?;
                ports
                    .iter()
                    .any(|p| p.port == VEL.name() && p.target.as_ref() == Some(motors_addr))
                    .then_some(())
            };
            let drove = tokio::time::timeout(UNWIRE_WAIT, drove).await.ok().flatten().is_some();
            match tokio::time::timeout(UNWIRE_WAIT, wiring.disconnect(&b, VEL)).await {
                Ok(Ok(())) => {}
                Ok(Err(e)) => tracing::warn!("robot: cannot unwire {b}: {e}"),
                Err(_) => tracing::warn!("robot: {b} was not unwired within {UNWIRE_WAIT:?}"),
            }
            drove.then_some(b)
        }
    };
    let driving =
        futures::future::join_all(behaviours.iter().map(|b| unwire(b))).await.into_iter().flatten().next();
    let again = zero();
    note_link(registry, recording, zid, LinkEventKind::Unwired, "behaviours unwired", Some(again));
    if let Err(e) = motors.send(again) {
        tracing::warn!("robot: cannot stop the motors: {e}");
    }
    (driving, commanded)
}

/// Notes what the link watchdog did in the recording, if there is one (a replay feeds it back).
fn note_link(
    registry: &Registry,
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
    zid: &str,
    event: LinkEventKind,
    why: &str,
    command: Option<NavigationVelocity>,
) {
    if let Some(r) = recording {
        let e = LinkEvent { executive: zid.to_string(), event, why: why.to_string(), command };
        r.note(LINK_EVENTS, LINK_EVENT, registry.now(), &e);
    }
}

/// Records the loss of an executive against the link cut it happened under, if any.
fn note_loss(
    registry: &Registry,
    links: &mut [crate::faults::LinkCutReport],
    log: &mut Vec<(f64, String, String)>,
    zid: &str,
    why: &str,
) {
    let t = registry.clock().since_start(registry.now()).as_secs_f64();
    log.push((
        t,
        "executive".into(),
        format!("detected: executive {zid} lost ({why}); motors commanded to zero"),
    ));
    if let Some(l) = links
        .iter_mut()
        .rev()
        .find(|l| l.role == "executive" && l.restored_at_s.is_none() && l.lost_at_s.is_none())
    {
        l.lost_at_s = Some(t);
        l.stop_commanded_at_s = Some(t);
    }
}

/// The executive `zid`, lost, is heard again: gives it back the behaviour it had wired.
async fn executive_back(
    registry: &Registry,
    behaviours: &[String],
    motors_addr: &ServiceAddr,
    zid: &str,
    restore: Option<String>,
    links: &mut [crate::faults::LinkCutReport],
    recording: &Option<Arc<crate::mission::recording::McapTap>>,
) {
    let t = registry.clock().since_start(registry.now()).as_secs_f64();
    note_link(registry, recording, zid, LinkEventKind::Back, "heard again", None);
    let wiring = WiringMaster::new(registry);
    if let Some(b) = &restore {
        // Whatever a fallback wired goes first: never two behaviours on the motors.
        for other in behaviours.iter().filter(|o| *o != b) {
            if let Err(e) = wiring.disconnect(other, VEL).await {
                tracing::warn!("robot: cannot unwire {other}: {e}");
            }
        }
        match wiring.connect(b, VEL, motors_addr).await {
            Ok(()) => {
                crate::say!("robot", "[{t:.3} s] executive {zid} is back: {b} drives again, as it had wired")
            }
            Err(e) => crate::say!("robot", "executive {zid} is back, but {b} cannot be wired again: {e}"),
        }
    } else {
        crate::say!("robot", "[{t:.3} s] executive {zid} is back (it had nothing wired)");
    }
    if let Some(l) = links
        .iter_mut()
        .rev()
        .find(|l| l.role == "executive" && l.lost_at_s.is_some() && l.back_at_s.is_none())
    {
        l.back_at_s = Some(t);
    }
}
