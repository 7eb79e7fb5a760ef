//! A new robot on the corridor mission: a differential-drive base with a planar laser.
//!
//! The robot is the config in [`CONFIG`] (`config/diffbot.toml`): a round body 0.35 m in
//! radius on two wheels (top speed 1.0 m/s, shared by translation and turning), a 270 degree
//! laser of 271 beams, 0.05-10 m at 10 Hz, mounted 0.1 m ahead of the centre, and bumpers. The
//! simulator builds it from that description; the robot server (kind `robot`, named `diffbot`)
//! serves its boards; it tells every client what it is through its `robotparams` Query (the
//! drive, the laser as it is, and the two sector views of its scan that the behaviours read in
//! place of the Nomad 200's infrared and sonar rings). Wall following, center following, the
//! master and the planner run unchanged: they know the robot by its name and its parameters.
//! Nothing in orsa changes.
//!
//! Run it with `cargo run --release --example new_robot` (one simulated hour; the tests run a
//! shorter one), or the mission itself with `cargo run --release -- run --config
//! config/diffbot.toml`.

use orsa::actors::query::QueryClient;
use orsa::actors::{Empty, Registry};
use orsa::config::Config;
use orsa::hardware::world::World;
use orsa::interfaces::nomad200::{self, RobotParams};
use orsa::mission::{self, RunOptions};
use parking_lot::Mutex;
use std::sync::Arc;

/// The robot and the mission's components, as a user writes them.
pub const CONFIG: &str = include_str!("../config/diffbot.toml");

/// What the run showed.
pub struct Seen {
    /// The mission's outcome.
    pub outcome: mission::RunOutcome,
    /// What the robot server answered to `robotparams` at the start.
    pub params: RobotParams,
}

/// Runs the corridor mission on the differential-drive robot for `duration_s` simulated
/// seconds with `seed`, asking the robot server what it is as the mission starts.
pub async fn run(seed: u64, duration_s: f64) -> Result<Seen, Box<dyn std::error::Error>> {
    let config = Config::from_toml(CONFIG, "config/diffbot.toml")?;
    let robot = config.robot_name().to_string();
    let mut opts = RunOptions::new(World::palazzina()?, "palazzina (built in)", config, seed, duration_s);
    let asked: Arc<Mutex<Option<tokio::task::JoinHandle<Option<RobotParams>>>>> = Arc::default();
    let slot = asked.clone();
    opts.on_start = Some(Box::new(move |registry: &Registry| {
        let client = QueryClient::connect(registry, nomad200::ROBOTPARAMS.on(&robot)).ok();
        *slot.lock() = Some(tokio::spawn(async move {
            client?.query(Empty {}, Some(std::time::Duration::from_secs(2))).await.ok()
        }));
    }));
    let outcome = mission::run(opts).await?;
    let task = asked.lock().take().ok_or("the mission never started")?;
    let params = task.await?.ok_or("the robot server did not say what it is")?;
    Ok(Seen { outcome, params })
}

#[tokio::main(flavor = "current_thread", start_paused = true)]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seen = run(1, 3600.0).await?;
    let (p, report) = (&seen.params, &seen.outcome.report);
    let laser = p.range_sensors.first().ok_or("no range sensor described")?;
    println!(
        "{:?} drive, body radius {} m, top speed {} m/s; {} '{}' of {} beams, {}-{} m",
        p.drive,
        p.body_radius_m,
        p.max_v_m_s,
        match laser.layout {
            orsa::interfaces::range::RangeLayout::Laser => "a laser",
            orsa::interfaces::range::RangeLayout::Ring => "a ring",
        },
        laser.name,
        laser.angles_rad.len(),
        laser.min_range_m,
        laser.max_range_m,
    );
    println!("behaviour share: {:?}", report.behaviour_share);
    println!(
        "{:.1} m driven in {:.0} simulated s, {} bumps, {:.1} cm from the wall (target 20)",
        report.distance_m,
        report.sim_seconds,
        report.bumps,
        100.0 * report.wallfollow.mean_clearance_m.unwrap_or(f64::NAN),
    );
    Ok(())
}
