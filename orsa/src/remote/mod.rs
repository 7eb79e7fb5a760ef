//! The processes of a distributed orsa system and the tools to look inside it, over zenoh:
//! `orsa robot`, `orsa executive`, `orsa teleop`, `orsa list`, `orsa echo`, `orsa wire`,
//! `orsa state`, `orsa param`, `orsa goto`.
//!
//! ```text
//!   orsa robot                        orsa executive             orsa teleop
//!   ├── nomad200 (sim, real time)     ├── master  ── wiring, state, distanceir/10 ──▶ robot
//!   ├── wallfollow                    └── planner                ── nomad200/teleop ──▶ robot
//!   └── centerfollow
//! ```
//! The robot watches the executive's liveliness and its heartbeat: when its token disappears
//! (within zenoh's lease, 1 s by default) or no heartbeat came for the lease (`[link]`, 0.3 s by
//! default, at most the velocity timeout), the robot unwires every behaviour and stops its
//! motors at once, keeps its behaviours computing, and, if `--fallback MODE` is given, drives
//! that mode with a local master until an executive is back. An executive heard again after a
//! lost heartbeat (a link that was cut while its session stayed up) gets back the behaviour it
//! had wired.

/// What a process exchanged across processes, recorded: in the recording crate.
pub use orsa_record::exchange;
mod executive;
mod goto;
mod param;
mod robot;
pub mod ros2;
mod tools;

pub use executive::{EXECUTIVE_TOP, ExecutiveOptions, ExecutiveReport, executive};
pub use goto::{GotoOptions, goto};
pub use param::{ParamAction, ParamOptions, param};
pub use robot::{FALLBACK, ROBOT_TOP, RobotOptions, RobotReport, robot};
pub use tools::{
    BadChange, EchoOptions, ListOptions, StateOptions, SwitchOptions, WireOptions, echo, list, parse_change,
    state, switch, wire,
};

use crate::config::Config;
use anyhow::{Context as _, bail};
use orsa_actors::send::SendClient;
use orsa_actors::{Registry, ServiceAddr};
use orsa_interfaces::nomad200::NavigationVelocity;
use orsa_net::{NetOptions, ZenohTransport};
use std::path::PathBuf;
use std::time::Duration;

/// How a process joins the network (every networked process and tool).
#[derive(Debug, Clone)]
pub struct NetworkOptions {
    /// zenoh endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable).
    pub listen: Vec<String>,
    /// zenoh endpoint of a peer to connect to, e.g. `tcp/robot.local:7447` (repeatable).
    pub connect: Vec<String>,
    /// zenoh configuration file (JSON5): TLS, user/password, everything else (see docs/security.md).
    pub zenoh_config: Option<PathBuf>,
    /// Key prefix: systems with different prefixes do not see each other.
    pub prefix: String,
}

impl NetworkOptions {
    fn options(&self, heartbeat: Option<Duration>) -> NetOptions {
        NetOptions {
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            config_file: self.zenoh_config.clone(),
            prefix: self.prefix.clone(),
            heartbeat,
            timestamping: false,
        }
    }
}

/// Options of `orsa teleop`.
#[derive(Debug)]
pub struct TeleopOptions {
    /// The robot component.
    pub robot: String,
    /// Scripted: send this velocity (m/s, rad/s) instead of reading the keyboard.
    pub send: Option<(f64, f64)>,
    /// Scripted: for this many seconds, then stop and quit.
    pub for_s: f64,
    /// Commands per second.
    pub rate: f64,
    /// How long to wait for the robot.
    pub wait: f64,
    /// Network.
    pub net: NetworkOptions,
}

fn secs(s: f64, flag: &str) -> anyhow::Result<Duration> {
    if s.is_finite() && (0.0..=1e7).contains(&s) {
        Ok(Duration::from_secs_f64(s))
    } else {
        bail!("{flag} {s}: must be a number of seconds from 0 to 1e7")
    }
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    // zenoh needs tokio's multi-thread scheduler.
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start the tokio runtime")
}

fn load_config(path: &Option<PathBuf>) -> anyhow::Result<Config> {
    Ok(match path {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    })
}

async fn open(
    registry: &Registry,
    net: &NetworkOptions,
    role: &str,
    heartbeat: Option<Duration>,
) -> anyhow::Result<ZenohTransport> {
    Ok(ZenohTransport::open(registry, &net.options(heartbeat), role).await?)
}

async fn wait_for(t: &ZenohTransport, addrs: &[ServiceAddr], wait: Duration) -> anyhow::Result<()> {
    if let Err(missing) = t.wait_for(addrs, wait).await {
        let names: Vec<String> = missing.iter().map(ToString::to_string).collect();
        bail!(
            "no peer offers {} after {:.1} s (is the robot running, with the same --prefix?)",
            names.join(", "),
            wait.as_secs_f64()
        );
    }
    Ok(())
}

/// Resolves when the process is asked to stop (Ctrl-C) or after `duration`.
async fn until_stopped(duration: Option<Duration>) {
    let limit = async {
        match duration {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        () = limit => {}
    }
}

/// `orsa teleop`.
pub fn teleop(args: TeleopOptions) -> anyhow::Result<()> {
    if !(args.rate.is_finite() && (0.5..=100.0).contains(&args.rate)) {
        bail!("--rate {}: must be from 0.5 to 100 commands per second", args.rate);
    }
    let run_for = secs(args.for_s, "--for")?;
    let wait = secs(args.wait, "--wait")?;
    runtime()?.block_on(async move {
        let registry = Registry::new();
        let transport = open(&registry, &args.net, "teleop", None).await?;
        let addr = ServiceAddr::new(&args.robot, "teleop");
        wait_for(&transport, std::slice::from_ref(&addr), wait).await?;
        let client = SendClient::<NavigationVelocity>::connect(&registry, &addr)?;
        let period = Duration::from_secs_f64(1.0 / args.rate);
        let send = |v: f64, w: f64| {
            client.send(NavigationVelocity { stamp: registry.now(), v_m_s: v, omega_rad_s: w })
        };
        match args.send {
            Some((v, w)) => {
                let mut tick = tokio::time::interval(period);
                let end = tokio::time::Instant::now() + run_for;
                while tokio::time::Instant::now() < end {
                    tick.tick().await;
                    send(v, w)?;
                }
                send(0.0, 0.0)?;
            }
            None => crate::keyboard::drive(period, |v, w| send(v, w).map_err(anyhow::Error::from)).await?,
        }
        // Let the last command leave before the session closes.
        tokio::time::sleep(Duration::from_millis(100)).await;
        transport.close().await;
        Ok(())
    })
}
