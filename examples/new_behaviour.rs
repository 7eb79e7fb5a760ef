//! A new behaviour added to the corridor mission: one file, one registration, and config.
//!
//! `wander` drives ahead and steers away from whatever the robot's near view (the infrared ring
//! on a Nomad 200) sees nearest, slowing down as the way ahead closes in. It is written the way
//! orsa's own behaviours are: a pure controller (`Wander`: ranges in, velocity out) and its
//! `impl Controller`, which says what it reads and how it steps. The behaviour harness
//! (`orsa::reactive::Behaviour`) makes it a component with everything wall following and center
//! following have: its `active` state and `compute` substate, a live `param` service
//! (`orsa param get wander`, Foxglove's Parameters panel), the robot's geometry, odometry and
//! contact, a wireable `vel` port and a `status` push. It knows the robot only by its interface.
//!
//! Adding it to the mission takes the registration in [`catalog`] and the config in [`CONFIG`]:
//! a `[system]` entry, its parameters in `[params.wander]` (read the way every kind reads its own),
//! an executive mode that uses it, and a mission that
//! runs that mode. Nothing in orsa changes. Run it with
//! `cargo run --release --example new_behaviour`; the tests run it too.

use orsa::actors::Registry;
use orsa::actors::param::{Invalid, PARAM, ParamReply, ParamRequest};
use orsa::actors::query::QueryClient;
use orsa::config::Config;
use orsa::hardware::world::World;
use orsa::interfaces::nomad200::{NavigationVelocity, RobotParams};
use orsa::mission::{self, RunOptions};
use orsa::reactive::harness::{Behaviour, Controller, Scan, Seen, Step};
use orsa::system::{Catalog, ComponentSpec, Parts, Place};
use parking_lot::Mutex;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The config that adds `wander` to the corridor mission.
pub const CONFIG: &str = r#"
[[system.components]]
name = "nomad200"
[[system.components]]
name = "wander"
[[system.components]]
name = "master"
[[system.components]]
name = "planner"

[params.wander]
speed_m_s = 0.2

[params.master.modes.wander]
behaviours = ["wander"]
rules = [{ drive = "wander" }]

[params.planner]
mission = [{ mode = "wander" }]
"#;

/// Wander's parameters (its `[params.wander]` table).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WanderParams {
    /// Top speed, m/s.
    pub speed_m_s: f64,
    /// Turn rate per metre of difference between the nearest readings left and right, rad/s/m.
    pub gain_rad_s_m: f64,
}

impl Default for WanderParams {
    fn default() -> Self {
        WanderParams { speed_m_s: 0.15, gain_rad_s_m: 3.0 }
    }
}

impl orsa::actors::param::Parameters for WanderParams {
    fn validate(&self) -> Result<(), Invalid> {
        if !(self.speed_m_s > 0.0 && self.speed_m_s <= 1.0) {
            return Err(Invalid::new(
                "wander.speed_m_s",
                format!("must be > 0 and at most 1 m/s, not {}", self.speed_m_s),
            ));
        }
        if !(self.gain_rad_s_m.is_finite() && self.gain_rad_s_m >= 0.0) {
            return Err(Invalid::new(
                "wander.gain_rad_s_m",
                format!("must be finite and >= 0, not {}", self.gain_rad_s_m),
            ));
        }
        Ok(())
    }
}

/// The pure controller.
#[derive(Debug, Clone, Copy)]
pub struct Wander {
    /// Its parameters.
    pub params: WanderParams,
}

impl Controller for Wander {
    type Params = WanderParams;
    const READS: &'static [Scan] = &[Scan::Infrared];

    fn new(params: WanderParams, _robot: &RobotParams) -> Self {
        Wander { params }
    }

    fn set_params(&mut self, params: WanderParams) {
        self.params = params;
    }

    /// One step: a command from the near view, stamped with the scan's stamp.
    fn step(&mut self, seen: &Seen<'_>) -> Step {
        // Sectors 15, 0, 1 look ahead; 2-6 to the left; 10-14 to the right (orsa's ring layout).
        let nearest = |ids: &[usize]| ids.iter().filter_map(|&i| seen.infrared[i]).fold(0.6_f64, f64::min);
        let ahead = nearest(&[15, 0, 1]);
        let left = nearest(&[2, 3, 4, 5, 6]);
        let right = nearest(&[10, 11, 12, 13, 14]);
        let v = self.params.speed_m_s * ((ahead - 0.25) / 0.35).clamp(0.0, 1.0);
        // Turn towards the side with more room; in place when blocked ahead.
        let omega = self.params.gain_rad_s_m * (left - right) + if ahead < 0.3 { 0.5 } else { 0.0 };
        let cmd = NavigationVelocity { stamp: seen.stamp, v_m_s: v, omega_rad_s: omega.clamp(-0.6, 0.6) };
        Step { cmd, wall_m: None, offset_m: None, alpha_rad: 0.0 }
    }
}

/// The built-in kinds and `wander`: the one registration.
pub fn catalog() -> Catalog {
    let mut catalog = Catalog::builtin();
    catalog.register("wander", Place::Robot, |parts: &Parts<'_>, spec: &ComponentSpec| {
        Ok(Behaviour::<Wander> { params: parts.params(spec)?, robot: parts.robot_name().into() })
    });
    catalog
}

/// What a run showed.
pub struct Ran {
    /// The mission's outcome.
    pub outcome: mission::RunOutcome,
    /// What `wander/param` answered to a get of everything as the mission started (what
    /// `orsa param get wander` asks).
    pub params: ParamReply,
    /// What it answered to a set of `speed_m_s` to 5 m/s, which its `validate()` refuses.
    pub refused: ParamReply,
}

/// Runs the mission with `wander` for `duration_s` simulated seconds on the reference corridor,
/// asking its `param` service as the mission starts.
pub async fn run(duration_s: f64) -> Result<Ran, Box<dyn std::error::Error>> {
    let config = Config::from_toml(CONFIG, "examples/new_behaviour.rs")?;
    let mut opts = RunOptions::new(World::palazzina()?, "palazzina (built in)", config, 1, duration_s);
    opts.catalog = catalog();
    type Asked = Option<(ParamReply, ParamReply)>;
    let asked: Arc<Mutex<Option<tokio::task::JoinHandle<Asked>>>> = Arc::default();
    let slot = asked.clone();
    opts.on_start = Some(Box::new(move |registry: &Registry| {
        let client = QueryClient::connect(registry, PARAM.on("wander")).ok();
        *slot.lock() = Some(tokio::spawn(async move {
            let client = client?;
            let within = Some(std::time::Duration::from_secs(2));
            let all = client.query(ParamRequest::Get { name: String::new() }, within).await.ok()?;
            let set = ParamRequest::Set { name: "speed_m_s".into(), value: 5.0.into() };
            let refused = client.query(set, within).await.ok()?;
            Some((all, refused))
        }));
    }));
    let outcome = mission::run(opts).await?;
    let task = asked.lock().take().ok_or("the mission never started")?;
    let (params, refused) = task.await?.ok_or("wander/param did not answer")?;
    Ok(Ran { outcome, params, refused })
}

#[tokio::main(flavor = "current_thread", start_paused = true)]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seen = run(120.0).await?;
    for p in &seen.params.params {
        println!("wander.{} = {}", p.name, p.value);
    }
    println!("speed_m_s = 5: {}", seen.refused.refused.as_deref().unwrap_or("accepted"));
    let report = seen.outcome.report;
    println!("behaviour share: {:?}", report.behaviour_share);
    println!(
        "{:.1} m driven in {:.0} simulated s, {} bumps",
        report.distance_m, report.sim_seconds, report.bumps
    );
    Ok(())
}
