//! The `orsa` command line: its argument types, private to the binary, and the code each
//! subcommand runs, which makes them into the library's options and calls it.
//!
//! - [`shared`]: the options several commands share, declared once (config, report, network);
//! - [`run`](mod@run): `orsa run`, the corridor mission, with its progress bar, table and plot;
//! - [`args`]: the arguments of the processes and the tools (`orsa robot`, `orsa executive`,
//!   `orsa teleop`, `orsa list`, `orsa echo`, `orsa wire`, `orsa state`, `orsa switch`,
//!   `orsa param`);
//! - [`replay`]: `orsa replay`.

mod args;
mod replay;
mod run;
mod shared;

use clap::{Parser, Subcommand};
use orsa::ending::Outcome;

/// orsa: robot control software out of supervised actors.
#[derive(Debug, Parser)]
#[command(name = "orsa", version, about, long_about = None, propagate_version = true)]
pub(crate) struct Cli {
    /// Log filter, e.g. `info` or `orsa_actors=debug` (overrides RUST_LOG).
    #[arg(long, global = true, value_name = "FILTER")]
    pub(crate) log: Option<String>,

    /// What to do.
    #[command(subcommand)]
    pub(crate) command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub(crate) enum Command {
    /// Run the corridor mission on the built-in simulator and report it against the original
    /// experiment (the main job).
    Run(run::RunArgs),
    /// The simulated robot in real time (server and behaviours), reachable over zenoh.
    Robot(args::RobotArgs),
    /// The master and the planner in their own process, driving a robot over zenoh.
    Executive(args::ExecutiveArgs),
    /// Drive the robot by hand (keyboard), or scripted with --send V,OMEGA --for SECS.
    Teleop(args::TeleopArgs),
    /// Components, services, wiring, states and liveness of the processes on the network.
    List(args::ListArgs),
    /// Print the updates of a push service.
    Echo(args::EchoArgs),
    /// Connect or disconnect a component's port (a master command).
    Wire(args::WireArgs),
    /// Show or set a component's main state (a master command).
    State(args::StateArgs),
    /// Several wiring and state changes at once, all or nothing (a master command).
    Switch(args::SwitchArgs),
    /// Show or set a running component's parameters (gains, targets, speeds, the master's rules).
    Param(args::ParamArgs),
    /// Send the robot to a place through the planner: shows the goal's feedback, exits with
    /// 0 when it is reached, 4 when it is rejected, aborted or canceled (the reason is printed).
    Goto(args::GotoArgs),
    /// Run a recording's deciding components again on its recorded inputs: bit for bit, or
    /// with another configuration (--config, --set) to see what would have changed.
    Replay(replay::ReplayArgs),
}

/// Runs a parsed command line.
pub(crate) fn run(cli: Cli) -> anyhow::Result<Outcome> {
    let done = |r: anyhow::Result<()>| r.map(|()| Outcome::Completed);
    match cli.command {
        Command::Run(args) => run::run_mission(args),
        Command::Robot(args) => orsa::remote::robot(args.try_into()?),
        Command::Executive(args) => orsa::remote::executive(args.into()),
        Command::Teleop(args) => done(orsa::remote::teleop(args.into())),
        Command::List(args) => done(orsa::remote::list(args.into())),
        Command::Echo(args) => done(orsa::remote::echo(args.into())),
        Command::Wire(args) => done(orsa::remote::wire(args.into())),
        Command::State(args) => done(orsa::remote::state(args.into())),
        Command::Switch(args) => done(orsa::remote::switch(args.into())),
        Command::Param(args) => done(orsa::remote::param(args.into())),
        Command::Goto(args) => orsa::remote::goto(args.into()),
        Command::Replay(args) => done(replay::run(args)),
    }
}

/// A progress bar over `len_s` seconds of `what` time (`simulated`, `replayed`), or a hidden
/// one when `quiet`.
fn progress_bar(len_s: f64, quiet: bool, what: &str) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len_s.round() as u64);
    let template = format!(
        "{{spinner}} {what} {{pos}}/{{len}} s [{{bar:40}}] {{percent}}% ({{elapsed}} wall, eta {{eta}})"
    );
    bar.set_style(
        indicatif::ProgressStyle::with_template(&template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}
