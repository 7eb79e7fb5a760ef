//! The `orsa` command line: argument types and the code each subcommand runs.

use clap::{Parser, Subcommand};

/// orsa: robot control software out of supervised actors.
#[derive(Debug, Parser)]
#[command(name = "orsa", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// Log filter, e.g. `info` or `orsa_actors=debug` (overrides RUST_LOG).
    #[arg(long, global = true, value_name = "FILTER")]
    pub log: Option<String>,

    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the corridor mission on the built-in simulator (the main job).
    Run(RunArgs),
}

/// Arguments of `orsa run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Run(_) => {
            println!(
                "orsa run: the corridor mission (behaviours, executive, planner on the simulated Nomad 200)\n\
                 is not built yet; it lands with the corridor-mission issue. What exists today is the framework\n\
                 core: run `cargo test --workspace --release` to see the patterns and supervision at work."
            );
            Ok(())
        }
    }
}
