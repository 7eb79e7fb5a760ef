//! The `orsa` command line: argument types and the code each subcommand runs.

use crate::config::Config;
use crate::mission::{self, RunOptions, RunOutcome};
use crate::plot::{Bump, PlotData, Targets, TrajectorySample, write_plot};
use anyhow::Context as _;
use clap::{Parser, Subcommand};
use orsa_hardware::world::World;
use std::path::PathBuf;
use std::sync::Arc;

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
    /// Run the corridor mission on the built-in simulator and report it against the original
    /// experiment (the main job).
    Run(RunArgs),
    /// The simulated robot in real time (server and behaviours), reachable over zenoh.
    Robot(crate::remote::RobotArgs),
    /// The master and the planner in their own process, driving a robot over zenoh.
    Executive(crate::remote::ExecutiveArgs),
    /// Drive the robot by hand (keyboard), or scripted with --send V,OMEGA --for SECS.
    Teleop(crate::remote::TeleopArgs),
    /// Components, services, wiring, states and liveness of the processes on the network.
    List(crate::remote::ListArgs),
    /// Print the updates of a push service.
    Echo(crate::remote::EchoArgs),
    /// Connect or disconnect a component's port (a master command).
    Wire(crate::remote::WireArgs),
    /// Show or set a component's main state (a master command).
    State(crate::remote::StateArgs),
    /// Several wiring and state changes at once, all or nothing (a master command).
    Switch(crate::remote::SwitchArgs),
    /// Show or set a running component's parameters (gains, targets, speeds, the master's rules).
    Param(crate::remote::ParamArgs),
    /// Run a recording's deciding components again on its recorded inputs: bit for bit, or
    /// with another configuration (--config, --set) to see what would have changed.
    Replay(crate::replay::command::ReplayArgs),
}

/// Arguments of `orsa run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// World file (TOML); default: the reference corridor `palazzina`, built in.
    #[arg(long, value_name = "PATH")]
    pub world: Option<PathBuf>,
    /// Simulated seconds to run.
    #[arg(long, value_name = "SECS", default_value_t = 3600.0, value_parser = positive_secs)]
    pub duration: f64,
    /// Seed of every noise source: the same seed gives the same run.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Run in real time instead of as fast as possible on a paused clock.
    #[arg(long)]
    pub realtime: bool,
    /// Configuration file for the whole stack (see config/orsa.toml); default: built-in defaults.
    #[arg(long, value_name = "PATH")]
    pub config: Option<PathBuf>,
    /// Write the report as JSON here.
    #[arg(long, value_name = "PATH.json", default_value = "out/report.json")]
    pub report: PathBuf,
    /// Record every pattern message and control event here, as MCAP (Foxglove, `mcap` CLI).
    #[arg(long, value_name = "PATH.mcap")]
    pub record: Option<PathBuf>,
    /// Write the trajectory and the offset and clearance over time here (.svg or .png).
    #[arg(long, value_name = "PATH.svg", default_value = "out/run.svg")]
    pub plot: PathBuf,
    /// Do not show the progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Break the stack on purpose as this fault plan says (see config/faults.example.toml); the
    /// report gains a `faults` section.
    #[arg(long, value_name = "PLAN.toml")]
    pub faults: Option<PathBuf>,
    /// Serve the run's views live to Foxglove (WebSocket) on ADDR (default 127.0.0.1:8765:
    /// this host only); with --realtime only. Anyone who can reach ADDR sees them.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = crate::live::DEFAULT_ADDR,
          value_parser = crate::live::parse_addr)]
    pub foxglove: Option<std::net::SocketAddr>,
}

fn positive_secs(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e7 => Ok(v),
        Ok(v) => Err(format!("must be a positive number of seconds (at most 1e7), not {v}")),
        Err(_) => Err(format!("'{s}' is not a number of seconds")),
    }
}

/// How a command ended, when it did not fail: each has its exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// It did what it was asked (exit code 0).
    Completed,
    /// The system gave up: its top supervisor went over its restart intensity; the motors were
    /// stopped and the report written (exit code 3).
    GaveUp,
    /// Ctrl-C or SIGTERM ended it early; the report was written (exit code 130).
    Interrupted,
}

impl Outcome {
    /// The outcome of a command that ended so; a fatal error (whose report was written) is the
    /// command's error (exit code 1).
    pub fn of(ended: &mission::report::Ended) -> anyhow::Result<Outcome> {
        use mission::report::Ended;
        match ended {
            Ended::Completed => Ok(Outcome::Completed),
            Ended::GaveUp { .. } => Ok(Outcome::GaveUp),
            Ended::Interrupted { .. } => Ok(Outcome::Interrupted),
            Ended::Failed { at_s, error } => Err(anyhow::anyhow!("failed at {at_s:.1} s: {error}")),
        }
    }

    /// The process's exit code (an error is 1, a command line error 2).
    pub fn exit_code(self) -> u8 {
        match self {
            Outcome::Completed => 0,
            Outcome::GaveUp => 3,
            Outcome::Interrupted => 130,
        }
    }
}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<Outcome> {
    let done = |r: anyhow::Result<()>| r.map(|()| Outcome::Completed);
    match cli.command {
        Command::Run(args) => run_mission(args),
        Command::Robot(args) => crate::remote::robot(args),
        Command::Executive(args) => crate::remote::executive(args),
        Command::Teleop(args) => done(crate::remote::teleop(args)),
        Command::List(args) => done(crate::remote::list(args)),
        Command::Echo(args) => done(crate::remote::echo(args)),
        Command::Wire(args) => done(crate::remote::wire(args)),
        Command::State(args) => done(crate::remote::state(args)),
        Command::Switch(args) => done(crate::remote::switch(args)),
        Command::Param(args) => done(crate::remote::param(args)),
        Command::Replay(args) => done(crate::replay::command::run(args)),
    }
}

/// Creates the folder `path` will be written in, if it is missing; the error names it.
pub fn ensure_parent(path: &std::path::Path) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the folder", dir.display()))?;
    }
    Ok(())
}

/// Ctrl-C or SIGTERM, by name (on systems without SIGTERM, Ctrl-C only).
pub(crate) fn interrupted() -> futures::future::BoxFuture<'static, String> {
    Box::pin(async {
        #[cfg(unix)]
        let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()).ok();
        #[cfg(unix)]
        let term = async move {
            match term.as_mut() {
                Some(t) => {
                    t.recv().await;
                }
                None => std::future::pending::<()>().await,
            }
        };
        #[cfg(not(unix))]
        let term = std::future::pending::<()>();
        tokio::select! {
            r = tokio::signal::ctrl_c() => match r {
                Ok(()) => "SIGINT (Ctrl-C)".to_string(),
                Err(_) => std::future::pending().await,
            },
            () = term => "SIGTERM".to_string(),
        }
    })
}

fn run_mission(args: RunArgs) -> anyhow::Result<Outcome> {
    let (world, label) = match &args.world {
        Some(p) => (World::from_path(p)?, p.display().to_string()),
        None => (World::palazzina()?, "palazzina (built in)".to_string()),
    };
    let config = match &args.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    for p in [Some(&args.report), Some(&args.plot), args.record.as_ref()].into_iter().flatten() {
        ensure_parent(p)?;
    }
    let ext = args.plot.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("svg" | "png")) {
        anyhow::bail!("--plot {}: the file must end in .svg or .png", args.plot.display());
    }

    if args.foxglove.is_some() && !args.realtime {
        anyhow::bail!(
            "--foxglove needs --realtime: a run on a paused clock ends in seconds, too fast to watch"
        );
    }
    // The live server starts before the run; its parameters are the run's once it is up.
    let params = crate::live::params::Pending::default();
    let live = match args.foxglove {
        Some(addr) => {
            let setup = mission::recording::view_setup(&config, Some(world.clone()), true);
            let live = crate::live::LiveView::start(addr, setup, Some(Arc::new(params.clone())))?;
            say(&format!(
                "foxglove: serving the run's views on ws://{} (Foxglove: Open connection, Foxglove WebSocket)",
                live.addr()
            ));
            Some(live)
        }
        None => None,
    };
    let bar = progress_bar(args.duration, args.quiet, "simulated");
    let plan = match &args.faults {
        Some(p) => Some(crate::faults::FaultPlan::load(p, &crate::faults::PlanTargets::for_stack(&config))?),
        None => None,
    };
    let mut opts = RunOptions::new(world.clone(), label, config, args.seed, args.duration);
    opts.faults = plan;
    let b = bar.clone();
    opts.progress = Some(Arc::new(move |t| b.set_position(t.round() as u64)));
    opts.progress_every_s = (args.duration / 400.0).clamp(1.0, 30.0);
    opts.record = args.record.clone();
    opts.realtime = args.realtime;
    opts.live = live.as_ref().map(crate::live::LiveView::tap);
    let components: Vec<String> = opts.config.system.components.iter().map(|c| c.name.clone()).collect();
    opts.on_start = Some(Box::new(move |registry| {
        params.ready(crate::system::live_params::ParamDirectory::new(registry, components));
    }));

    opts.interrupt = Some(interrupted());

    // The signal handlers need the I/O driver; the paused clock still advances only when every
    // task waits.
    let mut rt = tokio::runtime::Builder::new_current_thread();
    rt.enable_all();
    if !args.realtime {
        rt.start_paused(true);
    }
    let rt = rt.build().context("cannot start the tokio runtime")?;
    let wall = std::time::Instant::now();
    let RunOutcome { mut report, metrics, recording, .. } = rt.block_on(mission::run(opts))?;
    report.wall_seconds = wall.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if let Some(live) = live {
        let s = live.finish();
        say(&format!(
            "foxglove: {} messages made into views, {} dropped (the viewer was behind)",
            s.handed, s.dropped
        ));
    }

    say(&report.table());
    let json = serde_json::to_string_pretty(&report)?;
    std::fs::write(&args.report, json)
        .with_context(|| format!("{}: cannot write the report", args.report.display()))?;
    let plot = PlotData {
        title: format!("{} · seed {} · {:.0} s", world.name, args.seed, args.duration),
        world: &world,
        trajectory: metrics
            .trajectory
            .iter()
            .map(|(t, x, y, b)| TrajectorySample { t_s: *t, x_m: *x, y_m: *y, behaviour: b.clone() })
            .collect(),
        offset: metrics.offset_series.clone(),
        clearance: metrics.clearance_series.clone(),
        bumps: metrics.bump_points.iter().map(|&(t_s, x_m, y_m)| Bump { t_s, x_m, y_m }).collect(),
        targets: Targets::default(),
    };
    write_plot(&args.plot, &plot)?;
    say(&format!("report: {}\nplot:   {}", args.report.display(), args.plot.display()));
    match recording {
        Some(Ok(r)) => {
            let topics = r.messages.len();
            let total: u64 = r.messages.values().sum();
            say(&format!("record: {} ({total} messages on {topics} topics)", r.path.display()));
        }
        Some(Err(e)) => {
            anyhow::bail!("the run finished and its report was written, but its recording failed: {e}")
        }
        None => {}
    }
    Outcome::of(&report.ended)
}

/// A progress bar over `len_s` seconds of `what` time (`simulated`, `replayed`), or a hidden
/// one when `quiet`.
pub(crate) fn progress_bar(len_s: f64, quiet: bool, what: &str) -> indicatif::ProgressBar {
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

/// Prints a line to stdout; a reader that went away (`orsa run | head`) is not an error.
pub(crate) fn say(text: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}
