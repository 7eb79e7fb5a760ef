//! Switch: several wiring and state changes, all or nothing. Each test runs on tokio's paused
//! clock; the property tests apply random switches with failures injected at every step (an
//! incompatible target, an undeclared state, a port or state named twice, a handler that hangs
//! in its critical section, and, on supervised components, an instance killed and restarted at
//! any moment of the switch) and check, after each, that the configuration is the old one or the
//! new one, against a model. The cross-process cases (a link cut between prepare and commit,
//! a commit past its lease, a lost answer) are in `tests/net/switch.rs`, with real processes.

use orsa_actors::service::{SendPortDesc, SendService};
use orsa_actors::state::{StateSlave, StateSpec, SubstateGuard};
use orsa_actors::switch::{Change, Phase, Switch, SwitchMaster, SwitchRecord};
use orsa_actors::tap::Tap;
use orsa_actors::wiring::{WiringMaster, WiringSlave};
use orsa_actors::{PatternError, Registry, ServiceAddr, Sink, send::SendServer};
use proptest::prelude::*;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

const MOTORS: SendService<f64> = SendService::new("motors");
const OTHER: SendService<f64> = SendService::new("other");
const TEXT: SendService<String> = SendService::new("text");
const VEL: SendPortDesc<f64> = SendPortDesc::new("vel");
const BEHAVIOURS: [&str; 3] = ["b0", "b1", "b2"];

/// A system of three behaviours (a `vel` port of f64 and the states neutral and active, whose
/// activity substate is `drive`) and a robot with two f64 services and one of text.
struct System {
    registry: Registry,
    slaves: BTreeMap<String, Arc<StateSlave>>,
    _keep: Vec<Box<dyn std::any::Any>>,
}

/// The robot's services (two of f64, one of text) on `registry`; what must live as long as
/// they do goes into `keep`.
fn robot_services(registry: &Registry, keep: &mut Vec<Box<dyn std::any::Any>>) {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    keep.push(Box::new(rx));
    SendServer::register(registry, MOTORS.on("robot"), Sink::channel(tx.clone())).expect("motors");
    SendServer::register(registry, OTHER.on("robot"), Sink::channel(tx)).expect("other");
    let (ttx, trx) = tokio::sync::mpsc::unbounded_channel();
    keep.push(Box::new(trx));
    SendServer::register(registry, TEXT.on("robot"), Sink::channel(ttx)).expect("text");
}

fn system() -> System {
    let registry = Registry::new();
    let mut keep: Vec<Box<dyn std::any::Any>> = Vec::new();
    robot_services(&registry, &mut keep);
    let mut slaves = BTreeMap::new();
    for b in BEHAVIOURS {
        let w = WiringSlave::register(&registry, b).expect("wiring");
        w.send_port::<f64>(VEL.name()).expect("port");
        keep.push(Box::new(w));
        let spec = StateSpec::new().main_state("active", &["drive"]);
        slaves.insert(b.to_string(), StateSlave::register(&registry, b, spec).expect("state"));
    }
    System { registry, slaves, _keep: keep }
}

/// Where every behaviour's port points and which state each is in.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
struct Config {
    wired: BTreeMap<String, Option<String>>,
    state: BTreeMap<String, String>,
}

impl Config {
    fn initial() -> Self {
        Config {
            wired: BEHAVIOURS.iter().map(|b| (b.to_string(), None)).collect(),
            state: BEHAVIOURS.iter().map(|b| (b.to_string(), "neutral".to_string())).collect(),
        }
    }
}

async fn observe(s: &System) -> Config {
    let wiring = WiringMaster::new(&s.registry);
    let mut c = Config::default();
    for b in BEHAVIOURS {
        let ports = wiring.ports(b).await.expect("ports");
        c.wired.insert(b.into(), ports[0].target.as_ref().map(ToString::to_string));
        c.state.insert(b.into(), s.slaves[b].handle().current());
    }
    c
}

/// The system with b0 active and wired to the motors, and a switch master for it.
async fn driven_by_b0() -> (System, SwitchMaster) {
    let s = system();
    let master = SwitchMaster::new(&s.registry, "exec");
    let first = Switch::new().state("b0", "active").connect("b0", VEL, MOTORS.on("robot"));
    master.apply(&first).await.expect("b0 drives");
    (s, master)
}

#[tokio::test(start_paused = true)]
async fn switch_a_mode_change_is_made_in_the_safe_order() {
    let (s, master) = driven_by_b0().await;
    // The connect comes first in the list: the commit still activates b1 while it is unwired,
    // disconnects b0 just before it wires b1, and sets b0 neutral once it is unwired.
    let to_b1 = Switch::new()
        .connect("b1", VEL, MOTORS.on("robot"))
        .state("b1", "active")
        .state("b0", "neutral")
        .disconnect("b0", VEL);
    let tap = Arc::new(Recorded::default());
    s.registry.set_tap(Some(tap.clone()));
    master.apply(&to_b1).await.expect("to b1");
    let c = observe(&s).await;
    assert_eq!(c.wired["b0"], None);
    assert_eq!(c.wired["b1"].as_deref(), Some("robot/motors"));
    assert_eq!((c.state["b0"].as_str(), c.state["b1"].as_str()), ("neutral", "active"));
    // One control event for the switch, with its changes in commit order; and the wiring and
    // state slaves' own events show them made in that order.
    let events = tap.events();
    let switches: Vec<SwitchRecord> = events
        .iter()
        .filter(|(t, _)| t == "exec/switch")
        .map(|(_, v)| serde_json::from_value(v.clone()).expect("record"))
        .collect();
    assert_eq!(switches.len(), 1);
    let order: Vec<String> = switches[0].changes.iter().map(ToString::to_string).collect();
    assert_eq!(
        order,
        ["set b1 to active", "disconnect b0.vel", "connect b1.vel to robot/motors", "set b0 to neutral"]
    );
    assert_eq!(switches[0].failed, None);
    let made: Vec<&str> = events
        .iter()
        .filter(|(t, _)| t.ends_with("/wiring") || t.ends_with("/state"))
        .map(|(t, _)| t.as_str())
        .collect();
    assert_eq!(made, ["b1/state", "b0/wiring", "b1/wiring", "b0/state"]);
}

#[tokio::test(start_paused = true)]
async fn switch_prepare_refuses_what_cannot_be_made_and_changes_nothing() {
    let (s, master) = driven_by_b0().await;
    let before = observe(&s).await;
    let text: ServiceAddr = "robot/text".parse().expect("addr");
    let cases: Vec<(Switch, &str)> = vec![
        (
            Switch::new().disconnect("b0", VEL).connect_named("b1", "vel", text),
            "incompatible service 'robot/text'",
        ),
        (
            Switch::new().disconnect("b0", VEL).connect_named(
                "b1",
                "speed",
                "robot/motors".parse().expect("addr"),
            ),
            "component 'b1' has no port 'speed'",
        ),
        (
            Switch::new().disconnect("b0", VEL).connect_named(
                "b1",
                "vel",
                "robot/brakes".parse().expect("addr"),
            ),
            "unknown service 'robot/brakes'",
        ),
        (Switch::new().disconnect("b0", VEL).state("b1", "flying"), "unknown main state 'flying' of 'b1'"),
        (Switch::new().disconnect("b0", VEL).state("ghost", "active"), "ghost"),
        (
            Switch::new().disconnect("b0", VEL).connect("b0", VEL, OTHER.on("robot")),
            "changes this port twice",
        ),
    ];
    for (switch, says) in cases {
        let e = master.apply(&switch).await.expect_err(says);
        assert_eq!(e.phase, Phase::Prepare, "{e}");
        assert!(e.to_string().contains(says) && e.to_string().ends_with("nothing was changed"), "{e}");
        assert!(e.nothing_changed() && e.undone.is_empty());
        assert_eq!(observe(&s).await, before, "after: {e}");
    }
}

#[tokio::test(start_paused = true)]
async fn switch_a_step_that_hangs_is_undone_with_everything_before_it() {
    let (s, master) = driven_by_b0().await;
    master.apply(&Switch::new().state("b2", "active")).await.expect("b2 active");
    // b2's activity is stuck in its critical section: it cannot be set to neutral.
    let _stuck: SubstateGuard = s.slaves["b2"].handle().try_acquire("drive").expect("drive");
    let before = observe(&s).await;
    let switch = Switch::new()
        .disconnect("b0", VEL)
        .state("b0", "neutral")
        .state("b1", "active")
        .state("b2", "neutral")
        .connect("b1", VEL, MOTORS.on("robot"));
    let t0 = tokio::time::Instant::now();
    let e = master.apply(&switch).await.expect_err("b2 hangs");
    assert_eq!(e.phase, Phase::Commit);
    assert_eq!(e.change, Change::State { component: "b2".into(), main: "neutral".into() });
    assert_eq!(e.error, PatternError::Timeout);
    assert!(e.nothing_changed(), "{e}");
    let undone: Vec<String> = e.undone.iter().map(ToString::to_string).collect();
    // b1 was activated first (it is not unwired), then b2 hung: b0 was never touched.
    assert_eq!(undone, ["set b2 to neutral", "set b1 to active"]);
    assert_eq!(observe(&s).await, before);
    // One step timeout for the hung step; the others and the undo take no time in process.
    assert_eq!(t0.elapsed(), Duration::from_millis(100));
}

/// What the tap saw: (topic, message, stamp).
#[derive(Default)]
struct Recorded(parking_lot::Mutex<Vec<(String, serde_json::Value, orsa_actors::Timestamp)>>);

impl Recorded {
    fn events(&self) -> Vec<(String, serde_json::Value)> {
        self.0.lock().iter().map(|(t, v, _)| (t.clone(), v.clone())).collect()
    }

    /// The wiring events, as (component, its port's target or none, when).
    fn wiring(&self) -> Vec<(String, Option<String>, orsa_actors::Timestamp)> {
        self.0
            .lock()
            .iter()
            .filter_map(|(t, v, at)| {
                let component = t.strip_suffix("/wiring")?;
                let target = v["target"]["service"].as_str().map(str::to_string);
                Some((component.to_string(), target, *at))
            })
            .collect()
    }
}

impl Tap for Recorded {
    fn record(&self, topic: &str, _type_id: &str, stamp: orsa_actors::Timestamp, json: &[u8]) {
        if let Ok(v) = serde_json::from_slice(json) {
            self.0.lock().push((topic.to_string(), v, stamp));
        }
    }
}

/// A hand-over whose outgoing behaviour hangs on being set neutral (its activity is in its
/// critical section): the motors are never without a driver while the switch waits on the hung
/// step, only at the instants of the swap and of its undo.
#[tokio::test(start_paused = true)]
async fn switch_the_motors_are_not_left_unwired_while_a_step_hangs() {
    let (s, master) = driven_by_b0().await;
    let _stuck: SubstateGuard = s.slaves["b0"].handle().try_acquire("drive").expect("drive");
    let tap = Arc::new(Recorded::default());
    s.registry.set_tap(Some(tap.clone()));
    let handover = Switch::new().disconnect("b0", VEL).state("b0", "neutral").state("b1", "active").connect(
        "b1",
        VEL,
        MOTORS.on("robot"),
    );
    let e = master.apply(&handover).await.expect_err("b0 hangs");
    assert_eq!(e.change, Change::State { component: "b0".into(), main: "neutral".into() });
    assert!(e.nothing_changed(), "{e}");
    let wiring = tap.wiring();
    let who: Vec<(&str, Option<&str>)> = wiring.iter().map(|(c, t, _)| (c.as_str(), t.as_deref())).collect();
    assert_eq!(
        who,
        [("b0", None), ("b1", Some("motors")), ("b1", None), ("b0", Some("motors"))],
        "swap, then its undo"
    );
    // Each unwiring is followed by a wiring at the same instant: the hung step (100 ms) is
    // spent with b1 driving, not with nobody.
    assert_eq!(wiring[0].2, wiring[1].2);
    assert_eq!(wiring[2].2, wiring[3].2);
    assert_eq!(wiring[2].2.as_nanos() - wiring[1].2.as_nanos(), 100_000_000);
}

/// What a random switch does to one behaviour.
#[derive(Debug, Clone)]
enum Op {
    Connect(usize, &'static str),
    Disconnect(usize),
    State(usize, &'static str),
}

/// A random step: a switch of some ops, and whether a behaviour's activity is stuck holding
/// its substate during it (so setting it to neutral hangs).
#[derive(Debug, Clone)]
struct Step {
    ops: Vec<Op>,
    stuck: Option<usize>,
}

fn op() -> impl Strategy<Value = Op> {
    let target = prop_oneof![4 => Just("robot/motors"), 2 => Just("robot/other"), 1 => Just("robot/text"), 1 => Just("robot/none")];
    let state = prop_oneof![4 => Just("active"), 4 => Just("neutral"), 1 => Just("flying")];
    prop_oneof![
        3 => (0..3usize, target).prop_map(|(b, t)| Op::Connect(b, t)),
        2 => (0..3usize).prop_map(Op::Disconnect),
        3 => (0..3usize, state).prop_map(|(b, m)| Op::State(b, m)),
    ]
}

fn step() -> impl Strategy<Value = Step> {
    (proptest::collection::vec(op(), 1..6), proptest::option::weighted(0.25, 0..3usize))
        .prop_map(|(ops, stuck)| Step { ops, stuck })
}

/// A random step of mostly valid changes (a few components, mostly well-typed targets and
/// declared states), a behaviour stuck with probability `p`.
fn step_stuck(p: f64) -> impl Strategy<Value = Step> {
    let target = prop_oneof![8 => Just("robot/motors"), 2 => Just("robot/other"), 1 => Just("robot/text")];
    let state = prop_oneof![6 => Just("active"), 6 => Just("neutral"), 1 => Just("flying")];
    let op = prop_oneof![
        3 => (0..3usize, target).prop_map(|(b, t)| Op::Connect(b, t)),
        2 => (0..3usize).prop_map(Op::Disconnect),
        4 => (0..3usize, state).prop_map(|(b, m)| Op::State(b, m)),
    ];
    (proptest::collection::vec(op, 1..4), proptest::option::weighted(p, 0..3usize))
        .prop_map(|(ops, stuck)| Step { ops, stuck })
}

/// The model: what a switch should leave, given the configuration before it; `None` when it
/// must fail (and so leave the old configuration).
fn model(before: &Config, step: &Step) -> Option<Config> {
    let mut after = before.clone();
    let mut ports = std::collections::BTreeSet::new();
    let mut states = std::collections::BTreeSet::new();
    for op in &step.ops {
        match *op {
            Op::Connect(b, t) => {
                if !ports.insert(b) || !matches!(t, "robot/motors" | "robot/other") {
                    return None;
                }
                after.wired.insert(BEHAVIOURS[b].into(), Some(t.into()));
            }
            Op::Disconnect(b) => {
                if !ports.insert(b) {
                    return None;
                }
                after.wired.insert(BEHAVIOURS[b].into(), None);
            }
            Op::State(b, m) => {
                if !states.insert(b) || m == "flying" {
                    return None;
                }
                after.state.insert(BEHAVIOURS[b].into(), m.into());
            }
        }
    }
    // A stuck activity holds `drive`: setting its behaviour to neutral hangs (it can stay
    // active, or be set active again).
    if let Some(b) = step.stuck
        && before.state[BEHAVIOURS[b]] == "active"
        && after.state[BEHAVIOURS[b]] == "neutral"
    {
        return None;
    }
    Some(after)
}

fn to_switch(step: &Step) -> Switch {
    step.ops.iter().fold(Switch::new(), |s, op| match *op {
        Op::Connect(b, t) => s.connect_named(BEHAVIOURS[b], "vel", t.parse().expect("addr")),
        Op::Disconnect(b) => s.disconnect_named(BEHAVIOURS[b], "vel"),
        Op::State(b, m) => s.state(BEHAVIOURS[b], m),
    })
}

async fn run_steps(steps: Vec<Step>) -> Result<(), String> {
    let s = system();
    let master = SwitchMaster::new(&s.registry, "exec");
    let mut config = Config::initial();
    for (i, step) in steps.iter().enumerate() {
        let stuck = step.stuck.and_then(|b| s.slaves[BEHAVIOURS[b]].handle().try_acquire("drive").ok());
        let expected = model(&config, step);
        let result = master.apply(&to_switch(step)).await;
        drop(stuck);
        let seen = observe(&s).await;
        match (&result, expected) {
            (Ok(()), Some(new)) if seen == new => config = new,
            (Err(e), None) if seen == config && e.nothing_changed() => {}
            (r, want) => {
                return Err(format!(
                    "step {i} {step:?}: result {r:?}, model {want:?}, before {config:?}, seen {seen:?}"
                ));
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// After every switch the system is in the old configuration or the new one, never a mix.
    #[test]
    fn switch_is_all_or_nothing_under_injected_failures(steps in proptest::collection::vec(step(), 1..12)) {
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().start_paused(true).build().expect("runtime");
        let result = rt.block_on(run_steps(steps));
        prop_assert!(result.is_ok(), "{}", result.err().unwrap_or_default());
    }
}

// ---------------------------------------------------------------------------------------------
// Components restarting mid-switch

/// Holds (`true`) or lets go of (`false`) the behaviour's `drive` substate; answers whether it
/// holds it.
const STICK: orsa_actors::service::QueryService<bool, bool> =
    orsa_actors::service::QueryService::new("stick");

/// A supervised behaviour: a `vel` port, the states neutral and active (whose activity
/// substate is `drive`), and `stick` to make its activity hold `drive` (so that setting it to
/// neutral hangs until the instance lets go or dies).
struct Behaviour;

struct Held {
    _vel: orsa_actors::wiring::SendPort<f64>,
    drive: Option<SubstateGuard>,
}

impl orsa_actors::Component for Behaviour {
    type Msg = orsa_actors::query::QueryRequest<bool, bool>;
    type State = Held;

    async fn setup(&self, ctx: &orsa_actors::Ctx<Self::Msg>) -> Result<Held, orsa_actors::ComponentError> {
        ctx.declare_states(StateSpec::new().main_state("active", &["drive"]))?;
        ctx.query_server(STICK, |r| r)?;
        Ok(Held { _vel: ctx.send_port(VEL)?, drive: None })
    }

    async fn handle(
        &self,
        ctx: &orsa_actors::Ctx<Self::Msg>,
        held: &mut Held,
        stick: Self::Msg,
    ) -> Result<(), orsa_actors::ComponentError> {
        held.drive = if stick.request.value { ctx.state().try_acquire("drive").ok() } else { None };
        let _ = stick.answer(held.drive.is_some());
        Ok(())
    }
}

/// The robot's services and the three behaviours as components under one supervisor.
struct Supervised {
    registry: Registry,
    behaviours: Vec<orsa_actors::component::ComponentHandle<Behaviour>>,
    _supervisor: orsa_actors::supervision::SupervisorRef,
    _keep: Vec<Box<dyn std::any::Any>>,
}

async fn supervised() -> Supervised {
    use orsa_actors::supervision::{Strategy, Supervisor, SupervisorSpec};
    let registry = Registry::new();
    let mut keep: Vec<Box<dyn std::any::Any>> = Vec::new();
    robot_services(&registry, &mut keep);
    let behaviours: Vec<_> = BEHAVIOURS
        .iter()
        .map(|b| orsa_actors::component::ComponentHandle::new(&registry, b, Behaviour).expect("behaviour"))
        .collect();
    let spec = behaviours.iter().fold(
        SupervisorSpec::new("behaviours", Strategy::OneForOne)
            .with_intensity(1000, Duration::from_secs(1))
            .with_clock(registry.clock()),
        |spec, b| spec.with_child(b.child_spec()),
    );
    let supervisor = Supervisor::start(spec).await.expect("supervisor");
    Supervised { registry, behaviours, _supervisor: supervisor, _keep: keep }
}

async fn observe_supervised(s: &Supervised) -> Config {
    let wiring = WiringMaster::new(&s.registry);
    let mut c = Config::default();
    for (b, handle) in BEHAVIOURS.iter().zip(&s.behaviours) {
        let ports = wiring.ports(b).await.expect("ports");
        c.wired.insert(b.to_string(), ports[0].target.as_ref().map(ToString::to_string));
        c.state.insert(b.to_string(), handle.ctx().state().current());
    }
    c
}

/// Makes behaviour `b`'s instance hold (or let go of) `drive`; whether it holds it.
async fn stick(s: &Supervised, b: usize, hold: bool) -> bool {
    let client =
        orsa_actors::query::QueryClient::connect(&s.registry, STICK.on(BEHAVIOURS[b])).expect("stick");
    client.query(hold, Some(Duration::from_secs(1))).await.expect("stick answered")
}

/// A step with a restart: behaviour `restart.0`'s instance (3: the stuck behaviour's, or b0's
/// if none is stuck) is killed `restart.1` ms after the switch starts (its supervisor starts a
/// new one at once).
async fn run_steps_with_restarts(steps: Vec<(Step, Option<(usize, u64)>)>) -> Result<(), String> {
    let s = supervised().await;
    let master = SwitchMaster::new(&s.registry, "exec");
    let mut config = Config::initial();
    for (i, (step, restart)) in steps.iter().enumerate() {
        // The stuck behaviour is one of the active ones (only an active one can hold `drive`).
        let active: Vec<usize> = (0..3).filter(|&b| config.state[BEHAVIOURS[b]] == "active").collect();
        let stuck = match step.stuck {
            Some(k) if !active.is_empty() && stick(&s, active[k % active.len()], true).await => {
                Some(active[k % active.len()])
            }
            _ => None,
        };
        let restart = restart.map(|(b, ms)| (if b == 3 { stuck.unwrap_or(0) } else { b }, ms));
        let killer = restart.map(|(b, ms)| {
            let instance = s.behaviours[b].instance();
            tokio::spawn(async move {
                tokio::time::sleep(Duration::from_millis(ms)).await;
                if let Some(cell) = instance {
                    cell.kill();
                }
            })
        });
        let result = master.apply(&to_switch(step)).await;
        if let Some(killer) = killer {
            killer.await.map_err(|e| format!("step {i}: the killer failed: {e}"))?;
        }
        if let Some(b) = stuck {
            // The instance that held `drive` (or the one that replaced it) lets go of it.
            stick(&s, b, false).await;
        }
        let seen = observe_supervised(&s).await;
        let new = model(&config, &Step { ops: step.ops.clone(), stuck: None });
        // Setting a stuck behaviour to neutral hangs past the step timeout, unless a restart
        // of that behaviour ends its activity in time; a restart of anything else never
        // decides a switch.
        let hangs = stuck.is_some_and(|b| {
            config.state[BEHAVIOURS[b]] == "active"
                && new.as_ref().is_some_and(|n| n.state[BEHAVIOURS[b]] == "neutral")
        });
        let may_be_freed = hangs && restart.is_some_and(|(b, ms)| Some(b) == stuck && ms <= 100);
        let ok = match (&result, new) {
            (Ok(()), Some(new)) if (!hangs || may_be_freed) && seen == new => {
                config = new;
                true
            }
            (Err(e), None) => seen == config && e.nothing_changed(),
            (Err(e), Some(_)) if hangs => seen == config && e.nothing_changed(),
            _ => false,
        };
        if !ok {
            return Err(format!(
                "step {i} {step:?} restart {restart:?} stuck {stuck:?}: result {result:?}, before {config:?}, seen {seen:?}"
            ));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Supervised components killed and restarted at any moment of a switch (while it waits
    /// on a hung step, or between its steps): the configuration is still the old one or the
    /// new one, a restart never fails a switch that could be made, and the restarted
    /// component comes back in the configuration the switch left.
    #[test]
    fn switch_is_all_or_nothing_while_components_restart(
        steps in proptest::collection::vec(
            (step_stuck(0.7), proptest::option::weighted(0.6, (0..4usize, 0..150u64))),
            1..10,
        )
    ) {
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().start_paused(true).build().expect("runtime");
        let result = rt.block_on(run_steps_with_restarts(steps));
        prop_assert!(result.is_ok(), "{}", result.err().unwrap_or_default());
    }
}

/// The case the property test reaches only now and then, made on purpose: a switch waits on a
/// behaviour whose activity is stuck in its critical section, the behaviour's instance is killed
/// 40 ms in, its activity ends with it, and the switch goes on and is made whole; the restarted
/// instance finds its port wired and its state as the switch left them.
#[tokio::test(start_paused = true)]
async fn switch_waiting_on_a_stuck_behaviour_is_made_when_its_instance_restarts() {
    let s = supervised().await;
    let master = SwitchMaster::new(&s.registry, "exec");
    let first = Switch::new().state("b0", "active").connect("b0", VEL, MOTORS.on("robot"));
    master.apply(&first).await.expect("b0 drives");
    assert!(stick(&s, 0, true).await, "b0 holds drive");
    let old = s.behaviours[0].instance().expect("b0 runs");
    let killer = {
        let old = old.clone();
        tokio::spawn(async move {
            tokio::time::sleep(Duration::from_millis(40)).await;
            old.kill();
        })
    };
    let t0 = tokio::time::Instant::now();
    let handover = Switch::new().disconnect("b0", VEL).state("b0", "neutral").state("b1", "active").connect(
        "b1",
        VEL,
        MOTORS.on("robot"),
    );
    master.apply(&handover).await.expect("made once b0's activity ended");
    assert_eq!(t0.elapsed(), Duration::from_millis(40));
    killer.await.expect("killer");
    let seen = observe_supervised(&s).await;
    assert_eq!(seen.wired["b0"], None);
    assert_eq!(seen.wired["b1"].as_deref(), Some("robot/motors"));
    assert_eq!((seen.state["b0"].as_str(), seen.state["b1"].as_str()), ("neutral", "active"));
    // A new instance of b0 runs, in the state the switch left (it cannot hold `drive`).
    assert!(!stick(&s, 0, true).await);
    assert_ne!(s.behaviours[0].instance().map(|c| c.get_id()), Some(old.get_id()));
}
