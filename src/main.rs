//! The `orsa` binary: parse arguments, set up logging, run.
//!
//! The command line is this crate's alone ([`cli`]): its argument types are private, and each
//! command makes them into the `orsa` library's options and calls it.

use clap::Parser;
use tracing_subscriber::EnvFilter;
use tracing_subscriber::prelude::*;

mod cli;

fn main() -> std::process::ExitCode {
    // Panics a fault plan injects are expected: they print one line, not a backtrace.
    orsa::ending::quiet_injected_panics();
    let cli = cli::Cli::parse();
    let filter = match &cli.log {
        Some(f) => EnvFilter::try_new(f),
        None => Ok(EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("warn"))),
    };
    let filter = match filter {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: --log: {e}");
            return std::process::ExitCode::from(2);
        }
    };
    // Warnings and errors also go where orsa's log lines are routed (`/rosout` of the robot's
    // ROS 2 node), whatever --log shows on stderr.
    tracing_subscriber::registry()
        .with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr).with_filter(filter))
        .with(orsa::logline::RouteLayer.with_filter(tracing_subscriber::filter::LevelFilter::WARN))
        .init();
    match cli::run(cli) {
        Ok(outcome) => std::process::ExitCode::from(outcome.exit_code()),
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
