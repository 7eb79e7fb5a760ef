//! `orsa switch`: several wiring and state changes on the robot process's components, made from
//! another process, all or nothing.

use super::*;
use orsa_actors::ServiceAddr;
use orsa_actors::state::StateMaster;
use orsa_actors::wiring::WiringMaster;

/// Where each behaviour's `vel` port points and which state it is in, as the robot's
/// components say over the network.
async fn configuration(registry: &Registry) -> Vec<(String, Option<ServiceAddr>, String)> {
    let wiring = WiringMaster::new(registry);
    let mut out = Vec::new();
    for b in ["wallfollow", "centerfollow"] {
        let ports = wiring.ports(b).await.expect("ports");
        let vel = ports.iter().find(|p| p.port == "vel").expect("a vel port").target.clone();
        let state = StateMaster::connect(registry, b).expect("state").status().await.expect("status").current;
        out.push((b.to_string(), vel, state));
    }
    out
}

fn switch(sys: &System, name: &str, changes: &[&str]) -> (bool, String) {
    let mut args = changes.to_vec();
    args.extend(["--wait", "30"]);
    let mut p = sys.run(name, "switch", &args);
    let status = p.child.wait().expect("orsa switch ends");
    (status.success(), p.log_text())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_switch_from_another_process_is_made_whole_or_not_at_all() {
    let sys = System::new("switch");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let motors: ServiceAddr = "nomad200/navigationvelocity".parse().expect("addr");

    // A whole mode change in one command: center following activated and wired.
    let (ok, log) =
        switch(&sys, "on", &["centerfollow:active", "centerfollow.vel=nomad200/navigationvelocity"]);
    assert!(ok, "{log}");
    let on = configuration(&registry).await;
    assert_eq!(on[1], ("centerfollow".into(), Some(motors.clone()), "active".into()));
    until_base(&mut base, STARTUP, "center following drives", |b| b.v_m_s > 0.05).await;

    // A hand-over whose last change names a state wall following does not have: refused while
    // preparing, so center following was never unwired.
    let (ok, log) = switch(
        &sys,
        "bad-state",
        &["centerfollow.vel=", "wallfollow:flying", "wallfollow.vel=nomad200/navigationvelocity"],
    );
    assert!(!ok);
    assert!(
        log.contains("preparing 'set wallfollow to flying'") && log.contains("nothing was changed"),
        "{log}"
    );
    assert_eq!(configuration(&registry).await, on);

    // A port wired to a service of another type: refused, nothing changed.
    let (ok, log) = switch(&sys, "bad-type", &["centerfollow.vel=", "wallfollow.vel=nomad200/bumpers"]);
    assert!(!ok);
    assert!(log.contains("incompatible service 'nomad200/bumpers'"), "{log}");
    assert_eq!(configuration(&registry).await, on);

    // A change a person mistyped: refused before anything is asked of the robot.
    let (ok, log) = switch(&sys, "typo", &["centerfollow.vel=", "wallfollow-active"]);
    assert!(!ok);
    assert!(log.contains("'wallfollow-active': neither a port nor a state"), "{log}");
    assert_eq!(configuration(&registry).await, on);

    // The same hand-over, well formed, is made whole.
    let (ok, log) = switch(
        &sys,
        "handover",
        &[
            "centerfollow.vel=",
            "centerfollow:neutral",
            "wallfollow:active",
            "wallfollow.vel=nomad200/navigationvelocity",
        ],
    );
    assert!(ok, "{log}");
    let after = configuration(&registry).await;
    assert_eq!(after[0], ("wallfollow".into(), Some(motors), "active".into()));
    assert_eq!(after[1], ("centerfollow".into(), None, "neutral".into()));
    t.close().await;
}

/// What the test's side of the link does to a switch's commit.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    /// Nothing: everything goes through.
    None,
    /// The link is cut between prepare and commit: the commit (and the undo) never leave.
    BeforeCommit,
    /// The commit is held back past the robot's lease, then delivered.
    LateCommit(Duration),
    /// The commit arrives and is made, but its answer is lost; the undo goes through.
    ReplyLost,
    /// The commit arrives and is made, its answer is lost, and then the undo cannot leave.
    ReplyLostThenCut,
}

/// The test's transport: zenoh, with a link cut injected into switch commits and undos.
struct Cutting {
    inner: std::sync::Arc<dyn orsa_actors::transport::Transport>,
    cut: std::sync::Arc<parking_lot::Mutex<Fault>>,
}

fn op_of(payload: &[u8]) -> Option<String> {
    let v: ciborium::Value = ciborium::from_reader(payload).ok()?;
    let map = v.as_map()?;
    map.iter().find(|(k, _)| k.as_text() == Some("op")).and_then(|(_, v)| v.as_text().map(str::to_string))
}

impl orsa_actors::transport::Transport for Cutting {
    fn name(&self) -> &str {
        "cutting"
    }
    fn lookup(&self, addr: &ServiceAddr) -> Option<orsa_actors::ServiceInfo> {
        self.inner.lookup(addr)
    }
    fn send(&self, addr: &ServiceAddr, payload: Vec<u8>) -> orsa_actors::PatternResult<()> {
        self.inner.send(addr, payload)
    }
    fn request(
        &self,
        addr: &ServiceAddr,
        payload: Vec<u8>,
        timeout: Duration,
    ) -> futures::future::BoxFuture<'static, orsa_actors::PatternResult<Vec<u8>>> {
        let cut = *self.cut.lock();
        let op = op_of(&payload);
        let inner = std::sync::Arc::clone(&self.inner);
        let addr = addr.clone();
        let link = |what: &str| Err(orsa_actors::PatternError::Link(format!("cut by the test: {what}")));
        Box::pin(async move {
            match (op.as_deref(), cut) {
                (Some("switch_commit" | "switch_undo"), Fault::BeforeCommit) => {
                    link("the request never left")
                }
                (Some("switch_commit"), Fault::LateCommit(d)) => {
                    tokio::time::sleep(d).await;
                    inner.request(&addr, payload, timeout).await
                }
                (Some("switch_commit"), Fault::ReplyLost | Fault::ReplyLostThenCut) => {
                    let _made = inner.request(&addr, payload, timeout).await;
                    link("the answer was lost")
                }
                (Some("switch_undo"), Fault::ReplyLostThenCut) => link("the request never left"),
                _ => inner.request(&addr, payload, timeout).await,
            }
        })
    }
    fn subscribe(
        &self,
        addr: &ServiceAddr,
        every: std::num::NonZeroU32,
        sink: orsa_actors::transport::ByteSink,
    ) -> orsa_actors::PatternResult<orsa_actors::transport::Subscription> {
        self.inner.subscribe(addr, every, sink)
    }
    fn activate(
        &self,
        addr: &ServiceAddr,
        mode: orsa_actors::transport::EventMode,
        params: Vec<u8>,
        sink: orsa_actors::transport::ByteSink,
    ) -> orsa_actors::PatternResult<orsa_actors::transport::Subscription> {
        self.inner.activate(addr, mode, params, sink)
    }
    fn service_added(
        &self,
        addr: &ServiceAddr,
        info: &orsa_actors::ServiceInfo,
        served: std::sync::Arc<dyn orsa_actors::transport::Served>,
    ) {
        self.inner.service_added(addr, info, served);
    }
    fn service_removed(&self, addr: &ServiceAddr) {
        self.inner.service_removed(addr);
    }
}

/// What a step of the random sequence asks for: a hand-over, or one a participant must refuse
/// while preparing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Ask {
    /// The other behaviour takes the motors.
    Handover,
    /// A hand-over that also sets a state the behaviour does not have.
    UnknownState,
    /// A hand-over that wires the port to a service of another type.
    Incompatible,
}

/// A small deterministic generator (xorshift64*), so the sequence is the same on every run.
struct Dice(u64);

impl Dice {
    fn pick<T: Copy>(&mut self, from: &[T]) -> T {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        from[(r >> 33) as usize % from.len()]
    }
}

/// A random sequence of switches made from this test's process on the robot process's
/// behaviours, with a fault at every step: the link cut between prepare and commit, a commit
/// held past the robot's lease, a commit whose answer is lost (with the undo delivered or not),
/// and switches a participant must refuse while preparing. After each, the robot's components
/// are in the configuration before the switch or the one after it, never a mix, as a model says.
/// The robot's process makes its part of a switch on one commit message, so a cut can only
/// decide whether that message came.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_link_cut_during_a_switch_leaves_the_old_or_the_new_configuration() {
    use orsa_actors::switch::{Phase, Switch, SwitchMaster};
    let sys = System::new("switchcut");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, _base) = base_stream(&registry, &t).await;
    let cut = std::sync::Arc::new(parking_lot::Mutex::new(Fault::None));
    let zenoh = registry.transport().expect("the test's zenoh transport");
    registry.set_transport(std::sync::Arc::new(Cutting { inner: zenoh, cut: std::sync::Arc::clone(&cut) }));
    let lease = Duration::from_millis(300);
    let master = SwitchMaster::new(&registry, "test").lease(lease);
    let step = Duration::from_secs(2);
    let motors: ServiceAddr = "nomad200/navigationvelocity".parse().expect("addr");
    let bumpers: ServiceAddr = "nomad200/bumpers".parse().expect("addr");
    let drive = |who: &str, other: &str, ask: Ask| {
        let s = Switch::new().disconnect_named(other, "vel").state(other, "neutral");
        let s = match ask {
            Ask::UnknownState => s.state(who, "flying"),
            _ => s.state(who, "active"),
        };
        let target = if ask == Ask::Incompatible { bumpers.clone() } else { motors.clone() };
        s.connect_named(who, "vel", target).step_timeout(step)
    };
    master.apply(&drive("centerfollow", "wallfollow", Ask::Handover)).await.expect("center following drives");
    let mut config = configuration(&registry).await;
    let mut driver = "centerfollow";
    let faults = [
        Fault::None,
        Fault::BeforeCommit,
        Fault::LateCommit(lease * 2),
        Fault::ReplyLost,
        Fault::ReplyLostThenCut,
    ];
    let asks = [Ask::Handover, Ask::Handover, Ask::Handover, Ask::UnknownState, Ask::Incompatible];
    let mut dice = Dice(0x5a_2026);
    let mut tried = std::collections::BTreeSet::new();
    for i in 0..16 {
        let (c, ask) = (dice.pick(&faults), dice.pick(&asks));
        tried.insert(format!("{c:?}").split('(').next().unwrap_or_default().to_string());
        tried.insert(format!("{ask:?}"));
        let other = if driver == "centerfollow" { "wallfollow" } else { "centerfollow" };
        *cut.lock() = c;
        let result = master.apply(&drive(other, driver, ask)).await;
        *cut.lock() = Fault::None;
        let seen = configuration(&registry).await;
        // The model: a hand-over gives the other behaviour the motors and makes it the only
        // active one; a switch a participant refuses leaves everything as it was.
        let new = {
            let mut n = config.clone();
            for entry in &mut n {
                let on = entry.0 == other;
                entry.1 = on.then(|| motors.clone());
                entry.2 = if on { "active".into() } else { "neutral".into() };
            }
            n
        };
        match (ask, c, &result) {
            (Ask::UnknownState | Ask::Incompatible, _, Err(e)) => {
                assert_eq!(e.phase, Phase::Prepare, "step {i} {ask:?} {c:?}: {e}");
                assert!(e.nothing_changed() && e.undone.is_empty(), "step {i} {ask:?} {c:?}: {e}");
                assert_eq!(seen, config, "step {i} {ask:?} {c:?}: {e}");
            }
            (Ask::Handover, Fault::None, Ok(())) => assert_eq!(seen, new, "step {i}"),
            (Ask::Handover, Fault::LateCommit(_) | Fault::ReplyLost, Err(e)) => {
                // Refused for its lease, or made and undone: the robot says so.
                assert!(e.nothing_changed(), "step {i} {c:?}: {e}");
                assert_eq!(seen, config, "step {i} {c:?}: {e}");
            }
            (Ask::Handover, Fault::BeforeCommit | Fault::ReplyLostThenCut, Err(e)) => {
                // No answer to the commit nor to the undo: this side cannot know, and the error
                // says so for every change. The robot made all of it (the commit came) or none.
                let want = if c == Fault::BeforeCommit { &config } else { &new };
                assert_eq!(&seen, want, "step {i} {c:?}: {e}");
                assert_eq!(e.not_undone.len(), 4, "{e}");
                assert!(e.to_string().contains("whether the change is made there is unknown"), "{e}");
            }
            (a, c, r) => panic!("step {i}: {a:?} with {c:?} gave {r:?}"),
        }
        if seen == new {
            driver = other;
        }
        config = seen;
    }
    // The sequence went through every fault and every kind of switch.
    assert_eq!(tried.len(), faults.len() + 3, "{tried:?}");
    t.close().await;
}
