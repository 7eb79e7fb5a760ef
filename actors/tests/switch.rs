//! Switch: several wiring and state changes, all or nothing. Each test runs on tokio's paused
//! clock; the property test applies random switches with failures injected at every step and
//! checks, after each, that the configuration is the old one or the new one, against a model.

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

fn system() -> System {
    let registry = Registry::new();
    let mut keep: Vec<Box<dyn std::any::Any>> = Vec::new();
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    keep.push(Box::new(rx));
    SendServer::register(&registry, MOTORS.on("robot"), Sink::channel(tx.clone())).expect("motors");
    SendServer::register(&registry, OTHER.on("robot"), Sink::channel(tx)).expect("other");
    let (ttx, trx) = tokio::sync::mpsc::unbounded_channel();
    keep.push(Box::new(trx));
    SendServer::register(&registry, TEXT.on("robot"), Sink::channel(ttx)).expect("text");
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
    // The connect comes first in the list: the commit still disconnects b0 before it wires b1.
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
    // One control event for the switch, with its changes in commit order; and the wiring
    // slaves' own events show b0 unwired before b1 was wired.
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
        ["disconnect b0.vel", "set b1 to active", "set b0 to neutral", "connect b1.vel to robot/motors"]
    );
    assert_eq!(switches[0].failed, None);
    let wiring: Vec<&str> =
        events.iter().filter(|(t, _)| t.ends_with("/wiring")).map(|(t, _)| t.as_str()).collect();
    assert_eq!(wiring, ["b0/wiring", "b1/wiring"]);
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
    assert_eq!(undone, ["set b2 to neutral", "set b1 to active", "set b0 to neutral", "disconnect b0.vel"]);
    assert_eq!(observe(&s).await, before);
    // One step timeout for the hung step; the others and the undo take no time in process.
    assert_eq!(t0.elapsed(), Duration::from_millis(100));
}

#[derive(Default)]
struct Recorded(parking_lot::Mutex<Vec<(String, serde_json::Value)>>);

impl Recorded {
    fn events(&self) -> Vec<(String, serde_json::Value)> {
        self.0.lock().clone()
    }
}

impl Tap for Recorded {
    fn record(&self, topic: &str, _type_id: &str, _stamp: orsa_actors::Timestamp, json: &[u8]) {
        if let Ok(v) = serde_json::from_slice(json) {
            self.0.lock().push((topic.to_string(), v));
        }
    }
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
