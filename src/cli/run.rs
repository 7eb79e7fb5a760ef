//! `orsa run`: the corridor mission with a progress bar, then its table, report and plot.

use super::progress_bar;
use super::shared::Shared;
use anyhow::Context as _;
use orsa::config::Config;
use orsa::ending::Outcome;
use orsa::hardware::world::World;
use orsa::mission::{self, RunOptions, RunOutcome};
use orsa::output::{ensure_parent, say};
use orsa::plot::{Bump, PlotData, Targets, TrajectorySample, write_plot};
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `orsa run`.
#[derive(Debug, clap::Args)]
pub(crate) struct RunArgs {
    /// World file (TOML); default: the reference corridor `palazzina`, built in.
    #[arg(long, value_name = "PATH")]
    pub(crate) world: Option<PathBuf>,
    /// Simulated seconds to run.
    #[arg(long, value_name = "SECS", default_value_t = 3600.0, value_parser = positive_secs)]
    pub(crate) duration: f64,
    /// Seed of every noise source: the same seed gives the same run.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub(crate) seed: u64,
    /// Run in real time instead of as fast as possible on a paused clock.
    #[arg(long)]
    pub(crate) realtime: bool,
    /// Record every pattern message and control event here, as MCAP (Foxglove, `mcap` CLI).
    #[arg(long, value_name = "PATH.mcap")]
    pub(crate) record: Option<PathBuf>,
    /// Write the trajectory and the offset and clearance over time here (.svg or .png).
    #[arg(long, value_name = "PATH.svg", default_value = "out/run.svg")]
    pub(crate) plot: PathBuf,
    /// Do not show the progress bar.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Break the stack on purpose as this fault plan says (see config/faults.example.toml); the
    /// report gains a `faults` section.
    #[arg(long, value_name = "PLAN.toml")]
    pub(crate) faults: Option<PathBuf>,
    /// Serve the run's views live to Foxglove (WebSocket) on ADDR (default 127.0.0.1:8765:
    /// this host only); with --realtime only. Anyone who can reach ADDR sees them.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = orsa::live::DEFAULT_ADDR,
          value_parser = orsa::live::parse_addr)]
    pub(crate) foxglove: Option<std::net::SocketAddr>,
    /// Go to this place (a name from the world's [[places]], or X,Y[,HEADING_DEG] in metres
    /// and degrees); repeat for a mission of places, in order. Adds the navigation components
    /// (localizer, path follower, the master's mode `navigate`) and a `navigation` section to
    /// the report. The run ends with the mission: exit code 0 if every place was reached, 4
    /// if one was not (rejected, or given up), the report saying which and why.
    #[arg(long, value_name = "PLACE")]
    pub(crate) goto: Vec<String>,
    /// Go to N places drawn at random from the seed where the robot's body can go on the
    /// world, each with room about it and at least 2 m from the one before: a mission for
    /// measuring navigation anywhere (as --goto, and after its places; the first is drawn 2 m
    /// from the start, not from the last --goto).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=1000))]
    pub(crate) tour: Option<u16>,
    /// The config file and the report (default out/report.json).
    #[command(flatten)]
    pub(crate) shared: Shared,
}

/// Where `orsa run` writes its report unless `--report` says.
const DEFAULT_REPORT: &str = "out/report.json";

fn positive_secs(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e7 => Ok(v),
        Ok(v) => Err(format!("must be a positive number of seconds (at most 1e7), not {v}")),
        Err(_) => Err(format!("'{s}' is not a number of seconds")),
    }
}

pub(crate) fn run_mission(args: RunArgs) -> anyhow::Result<Outcome> {
    let (world, label) = match &args.world {
        Some(p) => (World::from_path(p)?, p.display().to_string()),
        None => (World::palazzina()?, "palazzina (built in)".to_string()),
    };
    let report_path = args.shared.report.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_REPORT));
    let config = match &args.shared.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    let mut goto = args.goto.clone();
    if let Some(n) = args.tour {
        let radius_m = config.sim.robot_params(config.robot().push_periods()).body_radius_m;
        let spec = mission::tour::TourSpec::new(usize::from(n), radius_m);
        let places = mission::tour::tour(&world, spec, args.seed).with_context(|| format!("--tour {n}"))?;
        say(&format!(
            "tour of {n} places drawn from seed {}: {}",
            args.seed,
            places.iter().map(|(x, y)| format!("({x:.2}, {y:.2})")).collect::<Vec<_>>().join(" ")
        ));
        goto.extend(places.iter().map(|(x, y)| format!("{x:.2},{y:.2}")));
    }
    let config = if goto.is_empty() { config } else { config.with_goto(&goto)? };
    for p in [Some(&report_path), Some(&args.plot), args.record.as_ref()].into_iter().flatten() {
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
    let params = orsa::live::params::Pending::default();
    let teleop = Arc::new(
        orsa::live::publish::Teleop::pending(config.robot_name()).with_planner(config.navigating_planner()),
    );
    let live = match args.foxglove {
        Some(addr) => {
            let setup = mission::recording::view_setup(&config, Some(world.clone()), true);
            let live = orsa::live::LiveView::start(
                addr,
                setup,
                Some(Arc::new(params.clone())),
                Some(Arc::clone(&teleop)),
            )?;
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
        Some(p) => Some(orsa::faults::FaultPlan::load(p, &orsa::faults::PlanTargets::for_stack(&config))?),
        None => None,
    };
    // The behaviours' kinds, for the plot's colours.
    let kinds = config.system.kinds();
    let mut opts = RunOptions::new(world.clone(), label, config, args.seed, args.duration);
    opts.faults = plan;
    opts.until_mission_ends = !goto.is_empty();
    let b = bar.clone();
    opts.progress = Some(Arc::new(move |t| b.set_position(t.round() as u64)));
    opts.progress_every_s = (args.duration / 400.0).clamp(1.0, 30.0);
    opts.record = args.record.clone();
    opts.realtime = args.realtime;
    opts.live = live.as_ref().map(orsa::live::LiveView::tap);
    let components: Vec<String> = opts.config.system.components.iter().map(|c| c.name.clone()).collect();
    opts.on_start = Some(Box::new(move |registry| {
        params.ready(orsa::system::live_params::ParamDirectory::new(registry, components));
        teleop.ready(registry);
    }));

    opts.interrupt = Some(orsa::ending::interrupted());

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
        say(&format!("foxglove: {s}"));
    }

    say(&report.table());
    if let Some(nav) = &report.navigation {
        say(&nav.table());
    }
    let json = serde_json::to_string_pretty(&report)?;
    std::fs::write(&report_path, json)
        .with_context(|| format!("{}: cannot write the report", report_path.display()))?;
    let plot = PlotData {
        title: format!("{} · seed {} · {:.0} s", world.name, args.seed, report.sim_seconds),
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
        kinds,
        navigation: metrics.navigation.clone(),
    };
    write_plot(&args.plot, &plot)?;
    say(&format!("report: {}\nplot:   {}", report_path.display(), args.plot.display()));
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
    match Outcome::of(&report.ended)? {
        // A mission of places whose time ran out before it ended did not reach them all.
        Outcome::Completed
            if !goto.is_empty() && matches!(report.ended, orsa::mission::report::Ended::Completed) =>
        {
            say(&format!("the mission of places did not end within --duration {} s", args.duration));
            Ok(Outcome::MissionFailed)
        }
        outcome => Ok(outcome),
    }
}
