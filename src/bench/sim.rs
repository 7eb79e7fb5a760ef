//! Simulation speed and scale: the full stack on the reference corridor on a paused clock.
//!
//! - [`mission`] is `orsa run` minus the printing: one robot, with the metrics sampling.
//! - [`scale`] brings up N robots, each with its whole stack (simulator, server, two
//!   behaviours, master, planner under its own supervisor and registry), on one current-thread
//!   runtime with a paused clock (as `orsa run` runs), lets them settle, then measures how many
//!   simulated seconds the whole set covers per wall second.

use super::{MissionRtf, ScaleRow};
use crate::config::Config;
use crate::mission::stack::Stack;
use crate::mission::{self, RunOptions};
use anyhow::Context as _;
use orsa_actors::supervision::SupervisorEventKind;
use orsa_hardware::world::World;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

fn paused_runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .start_paused(true)
        .build()
        .context("cannot start a tokio runtime")
}

/// The corridor mission for `duration_s` simulated seconds, timed as `orsa run` times it
/// (start-up and shutdown included).
pub(crate) fn mission(duration_s: f64) -> anyhow::Result<MissionRtf> {
    let world = World::palazzina()?;
    let opts = RunOptions::new(world, "palazzina (built in)", Config::default(), 1, duration_s);
    let rt = paused_runtime()?;
    let wall = Instant::now();
    let out = rt.block_on(mission::run(opts))?;
    let wall_s = wall.elapsed().as_secs_f64();
    Ok(MissionRtf {
        simulated_s: duration_s,
        wall_s,
        rtf: duration_s / wall_s,
        distance_m: out.report.distance_m,
        restarts: out.report.restarts,
    })
}

/// The resident set of this process now, in MiB (Linux; `None` elsewhere).
fn rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// `n` robots for `warm_s` then `measure_s` simulated seconds; only the second span is timed.
pub(crate) fn scale(n: usize, warm_s: f64, measure_s: f64) -> anyhow::Result<ScaleRow> {
    if n == 0 || !(warm_s >= 0.0 && measure_s > 0.0 && measure_s.is_finite() && warm_s.is_finite()) {
        anyhow::bail!("scale: need at least one robot and a positive duration");
    }
    let world = World::palazzina()?;
    let config = Config::default();
    let rt = paused_runtime()?;
    let rss_before = rss_mib();
    let restarts = Arc::new(AtomicU64::new(0));
    let row = rt.block_on(async {
        let up = Instant::now();
        let mut stacks = Vec::with_capacity(n);
        for i in 0..n {
            let restarts = Arc::clone(&restarts);
            let stack =
                Stack::start(world.clone(), &config, 1 + i as u64, warm_s + measure_s, None, move |e| {
                    if e.kind == SupervisorEventKind::Restarted {
                        restarts.fetch_add(1, Ordering::Relaxed);
                    }
                })
                .await
                .with_context(|| format!("robot {i} of {n}"))?;
            stacks.push(stack);
        }
        let startup_wall_s = up.elapsed().as_secs_f64();
        let rss_after = rss_mib();
        tokio::time::sleep(Duration::from_secs_f64(warm_s)).await;
        let steps0: Vec<u64> = stacks.iter().map(|s| s.sim.steps()).collect();
        let (wall, sim) = (Instant::now(), tokio::time::Instant::now());
        tokio::time::sleep(Duration::from_secs_f64(measure_s)).await;
        let (wall_s, simulated_s) = (wall.elapsed().as_secs_f64(), sim.elapsed().as_secs_f64());
        let steps: Vec<u64> = stacks.iter().zip(&steps0).map(|(s, s0)| s.sim.steps() - s0).collect();
        let distance: f64 = stacks.iter().map(|s| s.truth.truth().travelled_m).sum();
        let down = Instant::now();
        futures::future::join_all(stacks.into_iter().map(Stack::shutdown)).await;
        let shutdown_wall_s = down.elapsed().as_secs_f64();
        let rtf = simulated_s / wall_s;
        Ok::<_, anyhow::Error>(ScaleRow {
            robots: n,
            startup_wall_s,
            simulated_s,
            wall_s,
            rtf,
            robot_seconds_per_wall_s: rtf * n as f64,
            wall_us_per_robot_sim_s: wall_s * 1e6 / (n as f64 * simulated_s),
            min_steps_per_robot: steps.iter().copied().min().unwrap_or(0),
            expected_steps_per_robot: (simulated_s / config.sim.step_s).round() as u64,
            mean_distance_m: distance / n as f64,
            restarts: restarts.load(Ordering::Relaxed),
            rss_mib_per_robot: match (rss_before, rss_after) {
                (Some(a), Some(b)) => Some((b - a).max(0.0) / n as f64),
                _ => None,
            },
            shutdown_wall_s,
        })
    })?;
    // Dropping the runtime ends whatever the shutdown left (nothing, normally).
    drop(rt);
    Ok(row)
}
