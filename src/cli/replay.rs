//! `orsa replay`: the command around [`orsa::replay::replay`].

use super::progress_bar;
use super::shared::Shared;
use anyhow::Context as _;
use orsa::config::Config;
use orsa::output::{ensure_parent, say};
use orsa::replay::file::Recording;
use orsa::replay::{ReplayOptions, Replayed, replay};
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `orsa replay`.
#[derive(Debug, clap::Args)]
pub(crate) struct ReplayArgs {
    /// The recording (made with `--record`); several, one per process of a distributed system
    /// (`orsa robot --record`, `orsa executive --record`), are replayed one after the other.
    #[arg(value_name = "PATH.mcap", required = true, num_args = 1..)]
    pub(crate) recordings: Vec<PathBuf>,
    /// What if: change one key of the configuration (`wallfollow.k_v=0.8`); repeatable.
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub(crate) sets: Vec<String>,
    /// What if: draw the recorded and the what-if commands over time here (.svg or .png).
    #[arg(long, value_name = "PATH.svg")]
    pub(crate) plot: Option<PathBuf>,
    /// For a recording made live (`orsa robot --record`, `orsa run --realtime --record`): how
    /// far, in ms, a replayed message may be from its recorded log time (default 250).
    #[arg(long, value_name = "MS")]
    pub(crate) tolerance_ms: Option<f64>,
    /// Do not show the progress bar.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// What if: replay with this configuration instead of the recorded one (--config); write
    /// the result, divergence or what-if figures, as JSON here (--report).
    #[command(flatten)]
    pub(crate) shared: Shared,
}

/// Runs `orsa replay`.
pub(crate) fn run(args: ReplayArgs) -> anyhow::Result<()> {
    if let [one] = args.recordings.as_slice() {
        return run_one(&args, one);
    }
    for (flag, given) in [
        ("--config", args.shared.config.is_some()),
        ("--plot", args.plot.is_some()),
        ("--report", args.shared.report.is_some()),
    ] {
        if given {
            anyhow::bail!(
                "{flag} belongs to one recording: give one (each process's recording has a configuration \
                 of its own; --set applies to each)"
            );
        }
    }
    let mut parted = Vec::new();
    for path in &args.recordings {
        if let Err(e) = run_one(&args, path) {
            let e = e.to_string();
            let named = path.display().to_string();
            say(&if e.contains(&named) { e } else { format!("{named}: {e}") });
            parted.push(path.display().to_string());
        }
    }
    match parted.as_slice() {
        [] => {
            let n = args.recordings.len();
            if args.sets.is_empty() {
                say(&format!("replay: all {n} recordings bit-exact"));
            } else {
                say(&format!("what if: {n} recordings replayed with {}", args.sets.join(", ")));
            }
            Ok(())
        }
        _ => anyhow::bail!(
            "{} of {} recordings did not replay as recorded: {}",
            parted.len(),
            args.recordings.len(),
            parted.join(", ")
        ),
    }
}

/// Replays one recording (see [`run`]).
fn run_one(args: &ReplayArgs, path: &std::path::Path) -> anyhow::Result<()> {
    let rec = Recording::open(path)?;
    let what_if = args.shared.config.is_some() || !args.sets.is_empty();
    if args.plot.is_some() && !what_if {
        anyhow::bail!("--plot draws a what-if: give another configuration with --config or --set");
    }
    if let Some(p) = &args.plot {
        let ext = p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("svg" | "png")) {
            anyhow::bail!("--plot {}: the file must end in .svg or .png", p.display());
        }
    }
    let config = if what_if {
        let base = match &args.shared.config {
            Some(p) => Config::load(p)?,
            None => orsa::replay::recorded_config(&rec)?,
        };
        Some(base.with_sets(&args.sets).map_err(anyhow::Error::msg)?)
    } else {
        None
    };
    let tolerance = match args.tolerance_ms {
        None => None,
        Some(ms) if ms.is_finite() && (0.0..=60_000.0).contains(&ms) => {
            Some(std::time::Duration::from_secs_f64(ms / 1000.0))
        }
        Some(ms) => anyhow::bail!("--tolerance-ms {ms}: must be a number of milliseconds from 0 to 60000"),
    };
    if tolerance.is_some() && !rec.meta.live {
        anyhow::bail!(
            "--tolerance-ms: {} was recorded on a paused clock, and is replayed to the instant",
            rec.path.display()
        );
    }
    for p in [args.plot.as_ref(), args.shared.report.as_ref()].into_iter().flatten() {
        ensure_parent(p)?;
    }
    let m = &rec.meta;
    say(&format!(
        "replay: {} (orsa {} {}, seed {}, {} s, world {}; {} messages)",
        rec.path.display(),
        m.orsa,
        m.process,
        m.seed,
        m.duration_s,
        m.world,
        rec.messages
    ));
    let last = match &rec.ended {
        Some(e) => {
            say(&format!("  the {} {}", m.process, e.how));
            e.at_ns.max(rec.last_log_time)
        }
        None => rec.last_log_time,
    };
    let span_s = orsa_actors::Timestamp(last.saturating_sub(m.clock_origin_ns)).as_secs_f64();
    let bar = progress_bar(span_s, args.quiet, "replayed");
    let b = bar.clone();
    let opts = ReplayOptions {
        config,
        progress: Some(Arc::new(move |t| b.set_position(t.round() as u64))),
        progress_every_s: Some((span_s / 400.0).clamp(1.0, 30.0)),
        tolerance,
    };
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .start_paused(true)
        .build()
        .context("cannot start the tokio runtime")?;
    let wall = std::time::Instant::now();
    let out = rt.block_on(replay(&rec, opts))?;
    let wall_s = wall.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if what_if { report_what_if(args, &rec, &out, wall_s) } else { report_exact(args, &out, wall_s) }
}

fn report_exact(args: &ReplayArgs, out: &Replayed, wall_s: f64) -> anyhow::Result<()> {
    let controls = match out.controls {
        0 => String::new(),
        n => format!(" and {n} control events"),
    };
    let mut summary = format!(
        "{} recorded inputs{controls} fed; {} messages on {} topics compared over {:.1} s (in {wall_s:.2} s)",
        out.fed, out.compared, out.topics, out.replayed_s
    );
    if let orsa::replay::diff::Timing::Within(tolerance) = out.timing {
        summary.push_str(&format!(
            "\n  recorded live: every message in its recorded order with the same content; its log \
             time and the clock readings in it within {:.1} ms of the recording's (largest log time \
             offset {:.3} ms)",
            tolerance as f64 / 1e6,
            out.largest_offset_ns as f64 / 1e6
        ));
    }
    if let Some(path) = &args.shared.report {
        let json = serde_json::json!({
            "bit_exact": out.bit_exact(),
            "timing": out.timing,
            "largest_offset_ms": out.largest_offset_ns as f64 / 1e6,
            "fed": out.fed,
            "controls": out.controls,
            "compared": out.compared,
            "topics": out.topics,
            "replayed_s": out.replayed_s,
            "divergence": out.divergence,
        });
        std::fs::write(path, serde_json::to_string_pretty(&json)?)
            .with_context(|| format!("{}: cannot write the report", path.display()))?;
    }
    match &out.divergence {
        None => {
            say(&format!("bit-exact: {summary}"));
            Ok(())
        }
        Some(d) => {
            say(&format!(
                "DIVERGED at {:.3} s on {} (message {} of the topic):\n  recorded: {}\n  replayed: {}\n{summary}",
                d.at_s,
                d.topic,
                d.index + 1,
                d.recorded.as_deref().unwrap_or("(none)"),
                d.replayed.as_deref().unwrap_or("(none)"),
            ));
            anyhow::bail!(
                "the replay is not bit-exact: it parts from the recording at {:.3} s on {}",
                d.at_s,
                d.topic
            )
        }
    }
}

fn report_what_if(args: &ReplayArgs, rec: &Recording, out: &Replayed, wall_s: f64) -> anyhow::Result<()> {
    let w = out.what_if(rec);
    say(&format!("what if, open loop over {:.1} s (in {wall_s:.2} s):", out.replayed_s));
    if w.topics.is_empty() {
        say(&format!("  no difference: all {} topics replayed as recorded", w.compared_topics));
    } else {
        say(&format!(
            "  {:<32} {:>9} {:>9} {:>9} {:>10}  largest differences",
            "topic", "recorded", "what-if", "differ", "from s"
        ));
        for (topic, d) in &w.topics {
            let largest: Vec<String> = d
                .largest
                .iter()
                .filter(|(k, _)| k.ends_with("v_m_s") || k.ends_with("omega_rad_s"))
                .map(|(k, v)| format!("{k} {v:.4}"))
                .collect();
            say(&format!(
                "  {:<32} {:>9} {:>9} {:>9} {:>10}  {}",
                topic,
                d.recorded,
                d.replayed,
                d.differing,
                d.first_part_s.map_or("-".into(), |t| format!("{t:.3}")),
                largest.join(", ")
            ));
        }
    }
    let names: std::collections::BTreeSet<&String> =
        w.share_recorded.keys().chain(w.share_replayed.keys()).collect();
    for n in names {
        let (a, b) = (
            w.share_recorded.get(n).copied().unwrap_or(0.0),
            w.share_replayed.get(n).copied().unwrap_or(0.0),
        );
        say(&format!(
            "  {n} drives {:.1}% recorded, {:.1}% what-if ({:+.1} points)",
            100.0 * a,
            100.0 * b,
            100.0 * (b - a)
        ));
    }
    if let Some((first, _)) = w.wiring_differs_s.first() {
        let total: f64 = w.wiring_differs_s.iter().map(|(a, b)| b - a).sum();
        say(&format!(
            "  another behaviour drives from {first:.3} s ({} stretches, {total:.1} s in all)",
            w.wiring_differs_s.len()
        ));
    }
    if let Some(path) = &args.shared.report {
        std::fs::write(path, serde_json::to_string_pretty(&w)?)
            .with_context(|| format!("{}: cannot write the report", path.display()))?;
    }
    if let Some(path) = &args.plot {
        orsa::plot::write_what_if(path, &what_if_plot(args, rec, out, &w))?;
        say(&format!("plot: {}", path.display()));
    }
    Ok(())
}

/// The commands that reached the robot, recorded and what-if, and where the wiring differs.
fn what_if_plot(
    args: &ReplayArgs,
    rec: &Recording,
    out: &Replayed,
    w: &orsa::replay::diff::WhatIf,
) -> orsa::plot::WhatIfPlot {
    let topic = format!("{}/{}", rec.meta.robot, orsa_interfaces::nomad200::NAVIGATIONVELOCITY.name());
    let origin = rec.meta.clock_origin_ns;
    let series = |messages: Option<&Vec<orsa::replay::file::Recorded>>| {
        let (mut v, mut omega) = (Vec::new(), Vec::new());
        for m in messages.into_iter().flatten().filter(|m| m.log_time < out.end) {
            #[derive(serde::Deserialize)]
            struct Sent {
                value: orsa_interfaces::nomad200::NavigationVelocity,
            }
            if let Ok(Sent { value }) = serde_json::from_slice::<Sent>(&m.data) {
                let t = orsa_actors::Timestamp(m.log_time.saturating_sub(origin)).as_secs_f64();
                v.push((t, value.v_m_s));
                omega.push((t, value.omega_rad_s));
            }
        }
        (v, omega)
    };
    let (rv, rw) = series(rec.outputs.get(topic.as_str()));
    let (wv, ww) = series(out.replayed.get(topic.as_str()));
    let mut changed: Vec<String> = args.sets.clone();
    if let Some(c) = &args.shared.config {
        changed.insert(0, format!("--config {}", c.display()));
    }
    orsa::plot::WhatIfPlot {
        title: format!("What if · {} · seed {} · {}", rec.path.display(), rec.meta.seed, topic),
        subtitle: format!("recorded vs {}", changed.join(", ")),
        v: [rv, wv],
        omega: [rw, ww],
        wiring_differs: w.wiring_differs_s.clone(),
        span_s: (0.0, out.replayed_s),
    }
}
