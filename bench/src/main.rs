//! `orsa-bench`: measures orsa against the raw parts it is built on (BENCHMARKS.md).
//!
//! Thin: arguments, logging, then [`orsa_bench::run`].

use anyhow::Context as _;
use clap::Parser;
use std::path::PathBuf;

/// Measure orsa against the raw parts it is built on (ractor, tokio, zenoh), and how it scales.
#[derive(Debug, Parser)]
#[command(name = "orsa-bench", version)]
struct Args {
    /// A smaller run, under two minutes: fewer samples, shorter simulated spans.
    #[arg(long)]
    quick: bool,
    /// Write every figure as JSON here.
    #[arg(long, value_name = "PATH.json")]
    json: Option<PathBuf>,
    /// Write the tables as Markdown here (as in BENCHMARKS.md); they are printed either way.
    #[arg(long, value_name = "PATH.md")]
    markdown: Option<PathBuf>,
    /// Internal: run as the peer process of the cross-process bench, connecting to this
    /// endpoint (the bench starts it by itself).
    #[arg(long, hide = true, value_name = "ENDPOINT", conflicts_with = "sim_part")]
    peer: Option<String>,
    /// Internal: run one simulation part in this process and print its figures (the bench
    /// starts one process per part by itself).
    #[arg(long, hide = true, value_name = "SPEC")]
    sim_part: Option<String>,
    /// Measure only what the ROS 2 publication adds to the cross-process push, with this many
    /// pushes each way, and print it (the full run measures it with 5000).
    #[arg(long, value_name = "SAMPLES", conflicts_with_all = ["quick", "peer", "sim_part"])]
    ros2_only: Option<usize>,
    /// Measure only what the safety monitor costs sense to act: the stack with it, without it
    /// and with it again, this many seconds each, and print it (the full run does it too).
    #[arg(long, value_name = "SECONDS", conflicts_with_all = ["quick", "peer", "sim_part", "ros2_only"])]
    monitor_only: Option<f64>,
    /// Measure only what a Foxglove client publishing on /cmd_vel and a ROS 2 client calling
    /// the parameter services cost sense to act, each beside its baseline run twice, this many
    /// seconds a run, and print it (the full run does it too).
    #[arg(long, value_name = "SECONDS", conflicts_with_all = ["quick", "peer", "sim_part", "ros2_only", "monitor_only"])]
    interop_only: Option<f64>,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    if let Some(endpoint) = &args.peer {
        return orsa_bench::serve_peer(endpoint);
    }
    if let Some(spec) = &args.sim_part {
        return orsa_bench::serve_sim_part(spec);
    }
    if let Some(samples) = args.ros2_only {
        anyhow::ensure!(samples > 0, "--ros2-only {samples}: give at least one sample");
        return orsa_bench::ros2_only(samples);
    }
    if let Some(seconds) = args.monitor_only {
        anyhow::ensure!(
            seconds.is_finite() && seconds > 0.0,
            "--monitor-only {seconds}: give a positive number of seconds"
        );
        return orsa_bench::monitor_only(seconds);
    }
    if let Some(seconds) = args.interop_only {
        anyhow::ensure!(
            seconds.is_finite() && seconds > 0.0,
            "--interop-only {seconds}: give a positive number of seconds"
        );
        return orsa_bench::interop_only(seconds);
    }
    for p in [args.json.as_ref(), args.markdown.as_ref()].into_iter().flatten() {
        orsa::output::ensure_parent(p)?;
    }
    let report = orsa_bench::run(&orsa_bench::BenchOptions { quick: args.quick })?;
    let markdown = orsa_bench::render_markdown(&report);
    orsa_bench::print(&markdown);
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("{}: cannot write the figures", p.display()))?;
    }
    if let Some(p) = &args.markdown {
        std::fs::write(p, &markdown).with_context(|| format!("{}: cannot write the tables", p.display()))?;
    }
    Ok(())
}
