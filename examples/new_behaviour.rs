//! A new behaviour added to the corridor mission: one registration in the catalog, and config.
//!
//! `wander` drives ahead and steers away from whatever its infrared ring sees nearest, slowing
//! down as the way ahead closes in. It is written the way orsa's own behaviours are: a pure
//! controller (`Wander::step`, scan in, velocity out) inside a thin component that subscribes to
//! the robot's infrared push, holds the `compute` substate while it steps, and sends on a
//! wireable `vel` port. It knows the robot only by its interface (`orsa::interfaces`).
//!
//! Adding it to the mission takes the registration in [`catalog`] and the config in [`CONFIG`]:
//! a `[system]` entry (with its own `params`), an executive mode that uses it, and a mission that
//! runs that mode. Nothing in orsa changes. Run it with
//! `cargo run --release --example new_behaviour`; the tests run it too.

use orsa::actors::prelude::*;
use orsa::config::Config;
use orsa::hardware::world::World;
use orsa::interfaces::behaviour::{ACTIVE, COMPUTE, VEL};
use orsa::interfaces::nomad200::{self, DistanceScan, NavigationVelocity};
use orsa::mission::{self, RunOptions};
use orsa::system::{Catalog, ComponentSpec, Parts, Place, params};
use serde::Deserialize;

/// The config that adds `wander` to the corridor mission.
pub const CONFIG: &str = r#"
[[system.components]]
name = "nomad200"
[[system.components]]
name = "wander"
params = { speed_m_s = 0.2 }
[[system.components]]
name = "master"
[[system.components]]
name = "planner"

[executive.modes.wander]
behaviours = ["wander"]
rules = [{ drive = "wander" }]

[planner]
mission = [{ mode = "wander" }]
"#;

/// Wander's parameters (`params` of its `[system]` entry).
#[derive(Debug, Clone, Copy, Deserialize)]
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

/// The pure controller.
#[derive(Debug, Clone, Copy)]
pub struct Wander {
    /// Its parameters.
    pub params: WanderParams,
}

impl Wander {
    /// One step: a command from an infrared scan, stamped with the scan's stamp.
    pub fn step(&self, scan: &DistanceScan) -> NavigationVelocity {
        // Sensors 15, 0, 1 look ahead; 2-6 to the left; 10-14 to the right (orsa's ring layout).
        let nearest =
            |ids: &[usize]| ids.iter().filter_map(|&i| scan.valid_distance_m(i)).fold(0.6_f64, f64::min);
        let ahead = nearest(&[15, 0, 1]);
        let left = nearest(&[2, 3, 4, 5, 6]);
        let right = nearest(&[10, 11, 12, 13, 14]);
        let v = self.params.speed_m_s * ((ahead - 0.25) / 0.35).clamp(0.0, 1.0);
        // Turn towards the side with more room; in place when blocked ahead.
        let omega = self.params.gain_rad_s_m * (left - right) + if ahead < 0.3 { 0.5 } else { 0.0 };
        NavigationVelocity { stamp: scan.stamp, v_m_s: v, omega_rad_s: omega.clamp(-0.6, 0.6) }
    }
}

/// Wander as a component.
pub struct WanderComponent {
    /// The controller.
    pub ctl: Wander,
    /// The robot server's name.
    pub robot: String,
}

impl Component for WanderComponent {
    type Msg = Update<DistanceScan>;
    type State = SendPort<NavigationVelocity>;

    async fn setup(&self, ctx: &Ctx<Self::Msg>) -> Result<Self::State, ComponentError> {
        ctx.declare_states(StateSpec::new().main_state(ACTIVE, &[COMPUTE]))?;
        ctx.subscribe_timed(nomad200::DISTANCEIR.on(&self.robot), 1, |scan| scan)?;
        Ok(ctx.send_port(VEL)?)
    }

    async fn handle(
        &self,
        ctx: &Ctx<Self::Msg>,
        vel: &mut Self::State,
        scan: Self::Msg,
    ) -> Result<(), ComponentError> {
        let Ok(_computing) = ctx.state().try_acquire(COMPUTE) else { return Ok(()) };
        // Unwired, the command is simply not delivered: behaviours compute all the time.
        let _ = vel.send(self.ctl.step(&scan));
        Ok(())
    }
}

/// The built-in kinds and `wander`: the one registration.
pub fn catalog() -> Catalog {
    let mut catalog = Catalog::builtin();
    catalog.register("wander", Place::Robot, |parts: &Parts<'_>, spec: &ComponentSpec| {
        Ok(WanderComponent { ctl: Wander { params: params(spec)? }, robot: parts.robot_name().into() })
    });
    catalog
}

/// Runs the mission with `wander` for `duration_s` simulated seconds on the reference corridor.
pub async fn run(duration_s: f64) -> Result<mission::RunOutcome, Box<dyn std::error::Error>> {
    let config = Config::from_toml(CONFIG, "examples/new_behaviour.rs")?;
    let mut opts = RunOptions::new(World::palazzina()?, "palazzina (built in)", config, 1, duration_s);
    opts.catalog = catalog();
    Ok(mission::run(opts).await?)
}

#[tokio::main(flavor = "current_thread", start_paused = true)]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let report = run(120.0).await?.report;
    println!("behaviour share: {:?}", report.behaviour_share);
    println!(
        "{:.1} m driven in {:.0} simulated s, {} bumps",
        report.distance_m, report.sim_seconds, report.bumps
    );
    Ok(())
}
