//! The argument types of the process and tool commands (`orsa robot`, `orsa executive`, `orsa
//! teleop`, `orsa list`, `orsa echo`, `orsa wire`, `orsa state`, `orsa switch`, `orsa param`),
//! each made into the library's options for the command.

use super::shared::{Network, Shared};
use orsa::actors::ServiceAddr;
use orsa::actors::switch::Change;
use orsa::remote::parse_change;
use std::path::PathBuf;

/// Arguments of `orsa robot`.
#[derive(Debug, clap::Args)]
pub(crate) struct RobotArgs {
    /// World file (TOML); default: the reference corridor, built in.
    #[arg(long, value_name = "PATH")]
    pub(crate) world: Option<PathBuf>,
    /// Seed of the simulator's noise.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub(crate) seed: u64,
    /// Drive this mode (from the config's executive.modes) with a local master while no
    /// executive is connected; default: stand still.
    #[arg(long, value_name = "MODE")]
    pub(crate) fallback: Option<String>,
    /// Stop after this many seconds (default: run until interrupted).
    #[arg(long, value_name = "SECS")]
    pub(crate) duration: Option<f64>,
    /// Break this process on purpose as this fault plan says (see docs/faults.md): components,
    /// services, sensors, motors, and `link_cut` to the executive, teleop or tools. Its clock
    /// starts when the robot is on the network.
    #[arg(long, value_name = "PLAN.toml")]
    pub(crate) faults: Option<PathBuf>,
    /// Record every pattern message and control event of this process here, as MCAP, with
    /// what `orsa replay` needs to run its behaviours again (see the README).
    #[arg(long, value_name = "PATH.mcap")]
    pub(crate) record: Option<PathBuf>,
    /// Also be a ROS 2 node, as rmw_zenoh (ROS 2 Jazzy) lays one out: publish /scan,
    /// /ir_scan, /odom, /tf and /bumper, and take /cmd_vel as teleoperation (see docs/ros2.md).
    #[arg(long)]
    pub(crate) ros2: bool,
    /// The ROS 2 domain of --ros2 and --hardware ros2 [default: ROS_DOMAIN_ID from the
    /// environment, as every ROS 2 node takes it, else 0]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=MAX_DOMAIN as i64))]
    pub(crate) domain: Option<u32>,
    /// The robot to drive, a robot kind of the catalog: `sim` (the simulator, the robot the
    /// config's [sim] describes) or `ros2` (a ROS 2 robot that publishes a laser scan and
    /// odometry and takes Twist commands, described by the config's [ros2.base]).
    #[arg(long, value_name = "KIND", default_value = orsa::system::SIM)]
    pub(crate) hardware: String,
    /// Serve this process's views live to Foxglove (WebSocket) on ADDR (default
    /// 127.0.0.1:8765: this host only; see the README). Anyone who can reach ADDR sees them.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = orsa::live::DEFAULT_ADDR,
          value_parser = orsa::live::parse_addr)]
    pub(crate) foxglove: Option<std::net::SocketAddr>,
    /// The config file and the report.
    #[command(flatten)]
    pub(crate) shared: Shared,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl TryFrom<RobotArgs> for orsa::remote::RobotOptions {
    type Error = anyhow::Error;

    /// The options, with the domain from `--domain`, else from `ROS_DOMAIN_ID`.
    fn try_from(a: RobotArgs) -> anyhow::Result<Self> {
        let domain = match a.domain {
            Some(d) => d,
            None => domain_from_env(std::env::var_os("ROS_DOMAIN_ID"))?,
        };
        Ok(orsa::remote::RobotOptions {
            world: a.world,
            seed: a.seed,
            fallback: a.fallback,
            duration: a.duration,
            faults: a.faults,
            record: a.record,
            ros2: a.ros2,
            domain,
            hardware: a.hardware,
            catalog: orsa::system::Catalog::builtin(),
            foxglove: a.foxglove,
            net: a.net.into(),
            config: a.shared.config,
            report: a.shared.report,
        })
    }
}

/// Arguments of `orsa executive`.
#[derive(Debug, clap::Args)]
pub(crate) struct ExecutiveArgs {
    /// Seconds of the default mission (patrol) and of the process (default: 3600).
    #[arg(long, value_name = "SECS", default_value_t = 3600.0)]
    pub(crate) duration: f64,
    /// How long to wait for the robot's services to appear.
    #[arg(long, value_name = "SECS", default_value_t = 30.0)]
    pub(crate) wait: f64,
    /// Record this process here, as MCAP: its components' messages, and everything it
    /// exchanged with the robot's services, when it crossed (what `orsa replay` feeds back).
    #[arg(long, value_name = "PATH.mcap")]
    pub(crate) record: Option<PathBuf>,
    /// Break this process on purpose as this fault plan says (see docs/faults.md): the master
    /// and the planner, the master's push, and `link_cut` to the robot, teleop or tools. Its
    /// clock starts when the executive's components are up.
    #[arg(long, value_name = "PLAN.toml")]
    pub(crate) faults: Option<PathBuf>,
    /// Serve this process's views live to Foxglove (WebSocket) on ADDR (default
    /// 127.0.0.1:8765: this host only; see the README). Anyone who can reach ADDR sees them.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = orsa::live::DEFAULT_ADDR,
          value_parser = orsa::live::parse_addr)]
    pub(crate) foxglove: Option<std::net::SocketAddr>,
    /// The config file and the report.
    #[command(flatten)]
    pub(crate) shared: Shared,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<ExecutiveArgs> for orsa::remote::ExecutiveOptions {
    fn from(a: ExecutiveArgs) -> Self {
        orsa::remote::ExecutiveOptions {
            duration: a.duration,
            wait: a.wait,
            record: a.record,
            faults: a.faults,
            foxglove: a.foxglove,
            net: a.net.into(),
            config: a.shared.config,
            report: a.shared.report,
        }
    }
}

/// Arguments of `orsa teleop`.
#[derive(Debug, clap::Args)]
pub(crate) struct TeleopArgs {
    /// The robot component.
    #[arg(long, default_value = "nomad200")]
    pub(crate) robot: String,
    /// Scripted: send this velocity (m/s, rad/s) instead of reading the keyboard.
    #[arg(long, value_name = "V,OMEGA", value_parser = parse_velocity, allow_hyphen_values = true)]
    pub(crate) send: Option<(f64, f64)>,
    /// Scripted: for this many seconds, then stop and quit.
    #[arg(long = "for", value_name = "SECS", default_value_t = 1.0)]
    pub(crate) for_s: f64,
    /// Commands per second.
    #[arg(long, value_name = "HZ", default_value_t = 10.0)]
    pub(crate) rate: f64,
    /// How long to wait for the robot.
    #[arg(long, value_name = "SECS", default_value_t = 30.0)]
    pub(crate) wait: f64,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<TeleopArgs> for orsa::remote::TeleopOptions {
    fn from(a: TeleopArgs) -> Self {
        orsa::remote::TeleopOptions {
            robot: a.robot,
            send: a.send,
            for_s: a.for_s,
            rate: a.rate,
            wait: a.wait,
            net: a.net.into(),
        }
    }
}

/// Arguments of `orsa goto`.
#[derive(Debug, clap::Args)]
pub(crate) struct GotoArgs {
    /// Where to go: a place named in the robot's world (`room-3`), or `X,Y[,HEADING_DEG]` in
    /// the map, metres and degrees.
    #[arg(value_name = "PLACE | X,Y[,HEADING_DEG]", value_parser = parse_target, allow_hyphen_values = true)]
    pub(crate) target: orsa::interfaces::navigation::NavTarget,
    /// The planner that takes the goal.
    #[arg(long, default_value = "planner")]
    pub(crate) planner: String,
    /// Cancel the goal if it has not ended after this many seconds (exit code 4).
    #[arg(long, value_name = "SECS")]
    pub(crate) timeout: Option<f64>,
    /// One JSON object per line: every feedback of the goal, its result last.
    #[arg(long)]
    pub(crate) json: bool,
    /// How long to wait for the planner.
    #[arg(long, value_name = "SECS", default_value_t = 30.0)]
    pub(crate) wait: f64,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

fn parse_target(text: &str) -> Result<orsa::interfaces::navigation::NavTarget, String> {
    orsa::interfaces::navigation::NavTarget::parse(text)
}

impl From<GotoArgs> for orsa::remote::GotoOptions {
    fn from(a: GotoArgs) -> Self {
        orsa::remote::GotoOptions {
            target: a.target,
            planner: a.planner,
            timeout: a.timeout,
            json: a.json,
            wait: a.wait,
            net: a.net.into(),
        }
    }
}

/// Arguments of `orsa list`.
#[derive(Debug, clap::Args)]
pub(crate) struct ListArgs {
    /// Seconds to listen for peers before listing.
    #[arg(long, value_name = "SECS", default_value_t = 1.0)]
    pub(crate) wait: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    pub(crate) json: bool,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<ListArgs> for orsa::remote::ListOptions {
    fn from(a: ListArgs) -> Self {
        orsa::remote::ListOptions { wait: a.wait, json: a.json, net: a.net.into() }
    }
}

/// Arguments of `orsa echo`.
#[derive(Debug, clap::Args)]
pub(crate) struct EchoArgs {
    /// The push service, `component/service`.
    pub(crate) service: ServiceAddr,
    /// Every n-th update (counted at the source).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub(crate) every: u32,
    /// Stop after this many updates.
    #[arg(long, value_name = "N")]
    pub(crate) count: Option<u64>,
    /// One JSON object per line.
    #[arg(long)]
    pub(crate) json: bool,
    /// How long to wait for the service.
    #[arg(long, value_name = "SECS", default_value_t = 10.0)]
    pub(crate) wait: f64,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<EchoArgs> for orsa::remote::EchoOptions {
    fn from(a: EchoArgs) -> Self {
        orsa::remote::EchoOptions {
            service: a.service,
            every: a.every,
            count: a.count,
            json: a.json,
            wait: a.wait,
            net: a.net.into(),
        }
    }
}

/// Arguments of `orsa wire`.
#[derive(Debug, clap::Args)]
pub(crate) struct WireArgs {
    /// The component whose port to rewire.
    pub(crate) component: String,
    /// The port.
    pub(crate) port: String,
    /// The service to connect it to (`component/service`); omit with --disconnect.
    pub(crate) target: Option<ServiceAddr>,
    /// Disconnect the port instead.
    #[arg(long, conflicts_with = "target")]
    pub(crate) disconnect: bool,
    /// How long to wait for the component.
    #[arg(long, value_name = "SECS", default_value_t = 10.0)]
    pub(crate) wait: f64,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<WireArgs> for orsa::remote::WireOptions {
    fn from(a: WireArgs) -> Self {
        orsa::remote::WireOptions {
            component: a.component,
            port: a.port,
            target: a.target,
            disconnect: a.disconnect,
            wait: a.wait,
            net: a.net.into(),
        }
    }
}

/// Arguments of `orsa state`.
#[derive(Debug, clap::Args)]
pub(crate) struct StateArgs {
    /// The component.
    pub(crate) component: String,
    /// The main state to set; omit to show the state.
    pub(crate) main: Option<String>,
    /// How long to wait for the component.
    #[arg(long, value_name = "SECS", default_value_t = 10.0)]
    pub(crate) wait: f64,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<StateArgs> for orsa::remote::StateOptions {
    fn from(a: StateArgs) -> Self {
        orsa::remote::StateOptions { component: a.component, main: a.main, wait: a.wait, net: a.net.into() }
    }
}

/// Arguments of `orsa switch`.
#[derive(Debug, clap::Args)]
pub(crate) struct SwitchArgs {
    /// The changes, made all or nothing: `COMPONENT.PORT=SERVICE` connects a port (SERVICE is
    /// `component/service`), `COMPONENT.PORT=` disconnects it, `COMPONENT:STATE` sets a main
    /// state. For example: `wallfollow.vel= wallfollow:neutral centerfollow:active
    /// centerfollow.vel=nomad200/navigationvelocity`.
    #[arg(required = true, value_name = "CHANGE", value_parser = parse_change)]
    pub(crate) changes: Vec<Change>,
    /// How long each step may take before the whole switch is undone.
    #[arg(long, value_name = "SECS", default_value_t = 1.0)]
    pub(crate) step_timeout: f64,
    /// How long to wait for the components.
    #[arg(long, value_name = "SECS", default_value_t = 10.0)]
    pub(crate) wait: f64,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<SwitchArgs> for orsa::remote::SwitchOptions {
    fn from(a: SwitchArgs) -> Self {
        orsa::remote::SwitchOptions {
            changes: a.changes,
            step_timeout: a.step_timeout,
            wait: a.wait,
            net: a.net.into(),
        }
    }
}

/// Arguments of `orsa param`.
#[derive(Debug, clap::Args)]
#[command(
    allow_negative_numbers = true,
    after_help = "Examples:\n  orsa param get wallfollow\n  orsa param get wallfollow loops\n  \
orsa param set wallfollow target_m 0.25\n  orsa param set master modes.patrol.rules.0.when.0.below_m 0.6"
)]
pub(crate) struct ParamArgs {
    /// `get` shows parameters; `set` sets one while the component runs (checked by the
    /// component as the config file is: a refused value changes nothing, and says why).
    #[arg(value_enum)]
    pub(crate) action: ParamAction,
    /// The component (`wallfollow`, `centerfollow`, `master`).
    pub(crate) component: String,
    /// The parameter (`target_m`, `loops.k_alpha`, `modes.patrol.rules.0.when.0.below_m`) or,
    /// with `get`, a table of them (`loops`); `get` without it shows them all.
    pub(crate) name: Option<String>,
    /// With `set`: the value, as in the config file (`0.25`, `true`, `[3, 4, 5]`, `"left"`);
    /// text that is not TOML is taken as a string.
    pub(crate) value: Option<String>,
    /// How long to wait for the component.
    #[arg(long, value_name = "SECS", default_value_t = 10.0)]
    pub(crate) wait: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    pub(crate) json: bool,
    /// Network.
    #[command(flatten)]
    pub(crate) net: Network,
}

impl From<ParamArgs> for orsa::remote::ParamOptions {
    fn from(a: ParamArgs) -> Self {
        orsa::remote::ParamOptions {
            action: a.action.into(),
            component: a.component,
            name: a.name,
            value: a.value,
            wait: a.wait,
            json: a.json,
            net: a.net.into(),
        }
    }
}

/// What `orsa param` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum ParamAction {
    /// Show parameters.
    Get,
    /// Set one.
    Set,
}

impl From<ParamAction> for orsa::remote::ParamAction {
    fn from(a: ParamAction) -> Self {
        match a {
            ParamAction::Get => orsa::remote::ParamAction::Get,
            ParamAction::Set => orsa::remote::ParamAction::Set,
        }
    }
}

fn parse_velocity(s: &str) -> Result<(f64, f64), String> {
    let (v, w) = s.split_once(',').ok_or_else(|| format!("'{s}' is not V,OMEGA (e.g. 0.1,0.0)"))?;
    let num = |t: &str, what: &str| -> Result<f64, String> {
        t.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{what} '{t}' is not a number"))
    };
    Ok((num(v, "V")?, num(w, "OMEGA")?))
}

/// The highest ROS 2 domain id (ROS 2's own limit for DDS; rmw_zenoh keeps the same range).
const MAX_DOMAIN: u32 = 232;

/// The ROS 2 domain `ROS_DOMAIN_ID` names, as a ROS 2 node reads it: unset or empty means 0;
/// anything else must be a whole number from 0 to 232.
pub(crate) fn domain_from_env(value: Option<std::ffi::OsString>) -> anyhow::Result<u32> {
    let Some(value) = value else { return Ok(0) };
    let text =
        value.to_str().ok_or_else(|| anyhow::anyhow!("ROS_DOMAIN_ID in the environment is not UTF-8"))?;
    let text = text.trim();
    if text.is_empty() {
        return Ok(0);
    }
    match text.parse::<u32>() {
        Ok(d) if d <= MAX_DOMAIN => Ok(d),
        _ => anyhow::bail!(
            "ROS_DOMAIN_ID in the environment is {text:?}: a ROS 2 domain is a whole number from 0 to {MAX_DOMAIN} \
             (or give --domain)"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::domain_from_env;

    #[test]
    fn the_domain_is_read_from_ros_domain_id_as_a_ros_2_node_reads_it() {
        let env = |s: &str| domain_from_env(Some(s.into()));
        assert_eq!(domain_from_env(None).expect("unset"), 0);
        assert_eq!(env("").expect("empty"), 0);
        assert_eq!(env(" 7 ").expect("7"), 7);
        assert_eq!(env("232").expect("232"), 232);
        for bad in ["233", "-1", "seven", "1.5"] {
            let e = env(bad).expect_err(bad).to_string();
            assert!(e.contains("ROS_DOMAIN_ID") && e.contains(bad), "{e}");
        }
    }
}
