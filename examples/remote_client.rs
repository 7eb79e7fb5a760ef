//! A remote client in Rust: it joins a running robot over zenoh, subscribes to its infrared
//! ring and drives it by teleoperation, with the same typed clients a component uses in-process.
//!
//! ```sh
//! orsa robot --listen tcp/127.0.0.1:7447                       # terminal 1
//! cargo run --release --example remote_client -- tcp/127.0.0.1:7447   # terminal 2
//! ```
//!
//! Installing the zenoh transport on a registry is all it takes: a client whose service is not
//! hosted in this process reaches it through zenoh. Every address here is a typed descriptor
//! from `orsa::interfaces::nomad200`, so a wrong service or object type does not compile.

use orsa::actors::prelude::*;
use orsa::interfaces::nomad200::{self, NavigationVelocity};
use orsa_net::{NetOptions, ZenohTransport};
use std::time::Duration;

/// What the client saw.
#[derive(Debug)]
pub struct Seen {
    /// Infrared scans received (every 5th the robot pushed).
    pub scans: usize,
    /// The nearest valid infrared reading ahead (sensors 15, 0, 1) in the last scan, m.
    pub ahead_m: Option<f64>,
    /// The fastest the robot's odometry showed it going while we drove it, m/s.
    pub fastest_m_s: f64,
}

/// Joins the system `options` describes, reads `scans` infrared scans, then drives the robot
/// ahead at 0.1 m/s for `drive` by teleoperation and stops it.
pub async fn run(
    options: &NetOptions,
    scans: usize,
    drive: Duration,
) -> Result<Seen, Box<dyn std::error::Error>> {
    let registry = Registry::new();
    let transport = ZenohTransport::open(&registry, options, "example").await?;
    let robot = nomad200::NAME;
    let needed = [
        nomad200::DISTANCEIR.on(robot).untyped(),
        nomad200::BASESTATE.on(robot).untyped(),
        nomad200::TELEOP.on(robot).untyped(),
    ];
    if let Err(missing) = transport.wait_for(&needed, Duration::from_secs(30)).await {
        return Err(format!("no robot offers {missing:?}: is `orsa robot` running?").into());
    }

    // Every 5th scan, counted at the robot: 200 ms apart, a fifth of the traffic.
    let ir = PushTimedClient::connect(&registry, nomad200::DISTANCEIR.on(robot))?;
    ir.subscribe(5)?;
    let mut ahead_m = None;
    for _ in 0..scans {
        let scan = ir.get_update_wait_timeout(Duration::from_secs(5)).await?;
        ahead_m = [15, 0, 1].iter().filter_map(|&i| scan.valid_distance_m(i)).reduce(f64::min);
    }

    let base = PushTimedClient::connect(&registry, nomad200::BASESTATE.on(robot))?;
    base.subscribe(1)?;
    let teleop = SendClient::connect(&registry, nomad200::TELEOP.on(robot))?;
    let command = |v_m_s: f64| NavigationVelocity { stamp: registry.now(), v_m_s, omega_rad_s: 0.0 };
    let mut fastest_m_s: f64 = 0.0;
    let mut tick = tokio::time::interval(Duration::from_millis(100));
    let until = tokio::time::Instant::now() + drive;
    while tokio::time::Instant::now() < until {
        tick.tick().await;
        // Teleop takes priority while its commands keep coming; the robot stops when they cease.
        teleop.send(command(0.1))?;
        if let Ok(b) = base.get_update() {
            fastest_m_s = fastest_m_s.max(b.v_m_s);
        }
    }
    teleop.send(command(0.0))?;
    transport.close().await;
    Ok(Seen { scans, ahead_m, fastest_m_s })
}

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let endpoint = std::env::args().nth(1).unwrap_or_else(|| "tcp/127.0.0.1:7447".into());
    let options = NetOptions { connect: vec![endpoint], ..NetOptions::default() };
    let seen = run(&options, 10, Duration::from_secs(2)).await?;
    println!("{} infrared scans, nearest ahead {:?} m", seen.scans, seen.ahead_m);
    println!("driven by teleop: up to {:.2} m/s", seen.fastest_m_s);
    Ok(())
}
