//! What a mode switch costs: the master's hand-over of the motors from one behaviour to the
//! other (unwire the old, set both states, wire the new) made as one all-or-nothing switch
//! (`orsa_actors::switch`), against the same four calls made one by one, alternated round by
//! round so that the machine's drift hits both. In process (two behaviours' wiring and state
//! slaves and a motor service in one registry) and across processes (the behaviours in the
//! peer process, after the sense-to-act bench, with the master stopped).

use super::stats;
use super::{SwitchPair, say};
use orsa_actors::service::{SendPortDesc, SendService};
use orsa_actors::state::{StateMaster, StateSlave, StateSpec};
use orsa_actors::switch::{Switch, SwitchMaster};
use orsa_actors::wiring::{WiringMaster, WiringSlave};
use orsa_actors::{Registry, ServiceAddr, Sink, send::SendServer};
use std::time::{Duration, Instant};

const VEL: SendPortDesc<f64> = SendPortDesc::new("vel");
const MOTORS: SendService<f64> = SendService::new("motors");

/// The hand-over from `from` to `to`, as one switch.
fn handover(from: &str, to: &str, motors: &ServiceAddr) -> Switch {
    Switch::new()
        .disconnect_named(from, "vel")
        .state(from, "neutral")
        .state(to, "active")
        .connect_named(to, "vel", motors.clone())
        .step_timeout(Duration::from_secs(5))
}

/// The same hand-over, call by call.
async fn one_by_one(
    wiring: &WiringMaster,
    states: &[(String, StateMaster); 2],
    from: usize,
    motors: &ServiceAddr,
) -> anyhow::Result<()> {
    let to = 1 - from;
    wiring.disconnect_named(&states[from].0, "vel").await?;
    states[from].1.set_state("neutral").await?;
    states[to].1.set_state("active").await?;
    wiring.connect_named(&states[to].0, "vel", motors).await?;
    Ok(())
}

/// `rounds` hand-overs each way between behaviours `names`, alternating the two methods.
pub(crate) async fn measure(
    registry: &Registry,
    names: [&str; 2],
    motors: &ServiceAddr,
    rounds: usize,
) -> anyhow::Result<SwitchPair> {
    let master = SwitchMaster::new(registry, "bench");
    let wiring = WiringMaster::new(registry);
    let states = [
        (names[0].to_string(), StateMaster::connect(registry, names[0])?),
        (names[1].to_string(), StateMaster::connect(registry, names[1])?),
    ];
    let first = Switch::new()
        .disconnect_named(names[1], "vel")
        .state(names[1], "neutral")
        .state(names[0], "active")
        .connect_named(names[0], "vel", motors.clone());
    master.apply(&first).await?;
    let (mut switched, mut called) = (Vec::with_capacity(rounds), Vec::with_capacity(rounds));
    let mut from = 0;
    for _ in 0..rounds {
        let t = Instant::now();
        master.apply(&handover(names[from], names[1 - from], motors)).await?;
        switched.push(u64::try_from(t.elapsed().as_nanos()).unwrap_or(u64::MAX));
        from = 1 - from;
        let t = Instant::now();
        one_by_one(&wiring, &states, from, motors).await?;
        called.push(u64::try_from(t.elapsed().as_nanos()).unwrap_or(u64::MAX));
        from = 1 - from;
    }
    let switch = stats::summarize(switched);
    let calls = stats::summarize(called);
    let p50_ratio = switch.p50_ns / calls.p50_ns.max(1.0);
    Ok(SwitchPair { rounds, switch, one_by_one: calls, p50_ratio })
}

/// In process: two behaviours and a motor service in one registry, current-thread runtime.
pub(crate) fn in_process(rounds: usize) -> anyhow::Result<SwitchPair> {
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    rt.block_on(async {
        let registry = Registry::new();
        let (tx, _rx) = tokio::sync::mpsc::unbounded_channel();
        SendServer::register(&registry, MOTORS.on("robot"), Sink::channel(tx))?;
        let mut keep = Vec::new();
        for b in ["b0", "b1"] {
            let w = WiringSlave::register(&registry, b)?;
            w.send_port::<f64>(VEL.name())?;
            keep.push(w);
            StateSlave::register(&registry, b, StateSpec::new().main_state("active", &["drive"]))?;
        }
        say(format!("  mode switch in process: {rounds} hand-overs each way"));
        measure(&registry, ["b0", "b1"], &MOTORS.on("robot").untyped(), rounds).await
    })
}
