//! A new component with a service of each pattern kind, and a client of each.
//!
//! `battery` models a robot's battery. Its interface is a list of services, each a pattern plus
//! a communication object, declared once as typed constants (in a real system they would live
//! in an interfaces crate, as `orsa_interfaces::nomad200` does for the robot):
//!
//! | service | pattern | object |
//! |---|---|---|
//! | `load` | Send | the power drawn, W |
//! | `runtime` | Query | `Empty` -> seconds left at the present load |
//! | `charge` | Push newest | the state of charge, each time it changes |
//! | `voltage` | Push timed, every 100 ms | the terminal voltage |
//! | `low` | Event | fires once the charge falls below the client's threshold |
//!
//! State (main states) and Wiring come with every component. Run it with
//! `cargo run --release --example new_component`; the tests run it too.

use orsa::actors::component::spawn;
use orsa::actors::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Duration;

/// The battery's state of charge.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Charge {
    /// Stored energy, Wh.
    pub energy_wh: f64,
    /// Fraction of the capacity, 0 to 1.
    pub fraction: f64,
}
comm_object!(Charge, "orsa.example.Charge/1");

/// Power drawn from the battery, W.
pub const LOAD: SendService<f64> = SendService::new("load");
/// Seconds left at the present load.
pub const RUNTIME: QueryService<Empty, f64> = QueryService::new("runtime");
/// The state of charge, pushed whenever it changes.
pub const CHARGE: PushNewestService<Charge> = PushNewestService::new("charge");
/// The terminal voltage, V, every 100 ms.
pub const VOLTAGE: PushTimedService<f64> = PushTimedService::new("voltage");
/// Fires once the charge fraction falls below the activation's threshold.
pub const LOW: EventService<f64, Charge> = EventService::new("low");

/// The battery component: configuration in `self`, what changes in its state.
pub struct Battery {
    /// Capacity, Wh.
    pub capacity_wh: f64,
}

/// What the battery's services deliver to it.
pub enum BatteryMsg {
    /// A new load.
    Load(Stamped<f64>),
    /// Someone asks how long it will last.
    Runtime(QueryRequest<Empty, f64>),
    /// Time to measure the voltage (and drain the battery for the tick).
    Tick(Tick),
}

/// The battery's running state.
pub struct BatteryState {
    load_w: f64,
    energy_wh: f64,
    charge: PushNewestServer<Charge>,
    voltage: PushTimedServer<f64>,
    low: EventServer<f64, Charge, Charge>,
}

impl Component for Battery {
    type Msg = BatteryMsg;
    type State = BatteryState;

    async fn setup(&self, ctx: &Ctx<BatteryMsg>) -> Result<BatteryState, ComponentError> {
        ctx.send_server(LOAD, BatteryMsg::Load)?;
        ctx.query_server(RUNTIME, BatteryMsg::Runtime)?;
        let charge = ctx.push_newest_server(CHARGE)?;
        let voltage = ctx.push_timed_server(VOLTAGE, Duration::from_millis(100), BatteryMsg::Tick)?;
        // The event's condition: each activation's threshold against the charge.
        let low =
            ctx.event_server(LOW, |threshold: &mut f64, c: &Charge| (c.fraction < *threshold).then_some(*c))?;
        voltage.start();
        Ok(BatteryState { load_w: 0.0, energy_wh: self.capacity_wh, charge, voltage, low })
    }

    async fn handle(
        &self,
        _ctx: &Ctx<BatteryMsg>,
        st: &mut BatteryState,
        msg: BatteryMsg,
    ) -> Result<(), ComponentError> {
        match msg {
            BatteryMsg::Load(w) => st.load_w = w.value.max(0.0),
            BatteryMsg::Runtime(q) => {
                let left = if st.load_w > 0.0 { st.energy_wh * 3600.0 / st.load_w } else { f64::INFINITY };
                q.answer(left)?;
            }
            BatteryMsg::Tick(_) => {
                st.energy_wh = (st.energy_wh - st.load_w * 0.1 / 3600.0).max(0.0);
                let c = Charge { energy_wh: st.energy_wh, fraction: st.energy_wh / self.capacity_wh };
                st.charge.put(c);
                st.low.put(&c);
                st.voltage.put(22.0 + 4.0 * c.fraction);
            }
        }
        Ok(())
    }
}

/// What a client of each pattern saw.
#[derive(Debug)]
pub struct Seen {
    /// The first runtime estimate, s.
    pub runtime_s: f64,
    /// Voltage samples received at every 5th tick.
    pub voltages: Vec<f64>,
    /// The charge when the `low` event fired.
    pub low_at: Charge,
    /// The simulated time it fired, s.
    pub low_after_s: f64,
}

/// Starts a battery of 0.1 Wh, draws 36 W from it (10 s of charge) and watches every service,
/// on whatever clock the runtime has (the tests pause it).
pub async fn run() -> Result<Seen, Box<dyn std::error::Error>> {
    let registry = Registry::new();
    let battery = spawn(&registry, "battery", Battery { capacity_wh: 0.1 }).await?;
    let started = registry.now();

    SendClient::connect(&registry, LOAD.on("battery"))?.send(36.0)?;
    let runtime = QueryClient::connect(&registry, RUNTIME.on("battery"))?;
    let voltage = PushTimedClient::connect(&registry, VOLTAGE.on("battery"))?;
    voltage.subscribe(5)?;
    let charge = PushNewestClient::connect(&registry, CHARGE.on("battery"))?;
    charge.subscribe()?;
    let mut low = EventClient::connect(&registry, LOW.on("battery"))?.activate(EventMode::Single, 0.5)?;

    tokio::time::sleep(Duration::from_millis(50)).await;
    let runtime_s = runtime.query(Empty {}, Some(Duration::from_secs(1))).await?;
    let mut voltages = Vec::new();
    for _ in 0..4 {
        voltages.push(voltage.get_update_wait().await?.value);
    }
    let fired = low.next().await?;
    let low_after_s = fired.event.sent_at.saturating_since(started).as_secs_f64();
    battery.stop().await;
    Ok(Seen { runtime_s, voltages, low_at: fired.event.value, low_after_s })
}

#[tokio::main(flavor = "current_thread", start_paused = true)]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seen = run().await?;
    println!("runtime at 36 W: {:.1} s", seen.runtime_s);
    println!("voltage every 500 ms: {:?}", seen.voltages);
    println!("low (under 50 %) after {:.1} s at {:.0} %", seen.low_after_s, seen.low_at.fraction * 100.0);
    Ok(())
}
