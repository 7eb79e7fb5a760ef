//! The simulation parts run each in a fresh process of its own (`orsa-bench --sim-part SPEC`,
//! a hidden flag), as a user's `orsa run` or N-robot program would.
//!
//! In the bench process they would run after every other part, in a heap those parts left
//! fragmented (about 170 MiB), and on a tokio whose clock one paused runtime has already put
//! on its slower path. A fresh process of 100 robots with its heap fragmented on purpose ran
//! at 1.24-1.48x the cost of a plain fresh one (BENCHMARKS-history.md): the row measured the
//! harness's history as much as orsa. The raw skeleton runs in a fresh process too, so the
//! pair stays like for like.
//!
//! The child prints [`RESULT_PREFIX`] then the part's figures as JSON, on one line of stdout;
//! everything else it prints is ignored (a test harness standing in for the child prints its
//! own text, some of it on the same line).

use super::sim::{self, RawScale, Skeleton};
use super::{Launcher, MissionRtf, ScaleRow};
use anyhow::{Context as _, anyhow, bail};
use serde::{Deserialize, Serialize};
use std::process::{Command, Stdio};

/// What marks the child's result line.
pub(crate) const RESULT_PREFIX: &str = "orsa-bench-part: ";

/// One simulation part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Part {
    /// `orsa run`'s corridor mission for this many simulated seconds ([`sim::mission`]).
    Mission { duration_s: f64 },
    /// N whole stacks ([`sim::scale`]).
    Stack { robots: usize, warm_s: f64, measure_s: f64 },
    /// `orsa run` without and with `--record`, and `orsa replay`, alternated this many runs
    /// ([`sim::record_replay`]).
    Replay { duration_s: f64, runs: usize },
    /// N skeletons of the stack, of raw tokio or of ractor actors ([`sim::raw_scale`]).
    Raw { skeleton: Skeleton, robots: usize, warm_s: f64, measure_s: f64 },
}

/// What a part measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) enum PartOut {
    Mission(MissionRtf),
    Stack(ScaleRow),
    Raw(RawScale),
    Replay(super::RecordReplay),
}

impl Part {
    /// The part as `--sim-part` takes it: `mission:S`, `stack:N:WARM:MEASURE`,
    /// `raw:N:WARM:MEASURE` or `ractor:N:WARM:MEASURE` (seconds; `f64`'s `Display`, which reads
    /// back exactly).
    pub(crate) fn spec(&self) -> String {
        match *self {
            Part::Mission { duration_s } => format!("mission:{duration_s}"),
            Part::Replay { duration_s, runs } => format!("replay:{duration_s}:{runs}"),
            Part::Stack { robots, warm_s, measure_s } => format!("stack:{robots}:{warm_s}:{measure_s}"),
            Part::Raw { skeleton, robots, warm_s, measure_s } => {
                let kind = match skeleton {
                    Skeleton::Tokio => "raw",
                    Skeleton::Ractor => "ractor",
                };
                format!("{kind}:{robots}:{warm_s}:{measure_s}")
            }
        }
    }

    /// Reads [`Part::spec`]'s form back; the error names the field that is wrong.
    pub(crate) fn parse(spec: &str) -> anyhow::Result<Part> {
        let fields: Vec<&str> = spec.split(':').collect();
        let secs = |i: usize, what: &str| -> anyhow::Result<f64> {
            let text = fields[i];
            let v: f64 = text
                .parse()
                .map_err(|_| anyhow!("--sim-part `{spec}`: {what} `{text}` is not a number of seconds"))?;
            if !v.is_finite() || v < 0.0 {
                bail!("--sim-part `{spec}`: {what} `{text}` is not a finite, non-negative number of seconds");
            }
            Ok(v)
        };
        let robots = |text: &str| -> anyhow::Result<usize> {
            match text.parse::<usize>() {
                Ok(n) if n > 0 => Ok(n),
                _ => bail!("--sim-part `{spec}`: robots `{text}` is not a positive whole number"),
            }
        };
        match fields.as_slice() {
            ["mission", _] => Ok(Part::Mission { duration_s: secs(1, "duration")? }),
            ["replay", _, n] => Ok(Part::Replay { duration_s: secs(1, "duration")?, runs: robots(n)? }),
            ["stack", n, _, _] => Ok(Part::Stack {
                robots: robots(n)?,
                warm_s: secs(2, "warm-up")?,
                measure_s: secs(3, "span")?,
            }),
            [kind @ ("raw" | "ractor"), n, _, _] => Ok(Part::Raw {
                skeleton: if *kind == "raw" { Skeleton::Tokio } else { Skeleton::Ractor },
                robots: robots(n)?,
                warm_s: secs(2, "warm-up")?,
                measure_s: secs(3, "span")?,
            }),
            _ => bail!(
                "--sim-part `{spec}`: expected mission:SECS, replay:SECS:RUNS, stack:N:WARM:SECS, raw:N:WARM:SECS or ractor:N:WARM:SECS"
            ),
        }
    }

    /// Runs the part in this process.
    pub(crate) fn run_here(&self) -> anyhow::Result<PartOut> {
        Ok(match *self {
            Part::Mission { duration_s } => PartOut::Mission(sim::mission(duration_s)?),
            Part::Replay { duration_s, runs } => PartOut::Replay(sim::record_replay(duration_s, runs)?),
            Part::Stack { robots, warm_s, measure_s } => {
                PartOut::Stack(sim::scale(robots, warm_s, measure_s)?)
            }
            Part::Raw { skeleton, robots, warm_s, measure_s } => {
                PartOut::Raw(sim::raw_scale(skeleton, robots, warm_s, measure_s)?)
            }
        })
    }
}

/// The child's side: runs the part and prints its result line.
pub(crate) fn serve(spec: &str) -> anyhow::Result<()> {
    let out = Part::parse(spec)?.run_here()?;
    let json = serde_json::to_string(&out).context("cannot write the part's figures")?;
    crate::print(&format!("{RESULT_PREFIX}{json}"));
    Ok(())
}

/// This binary, `orsa-bench --sim-part SPEC`.
pub(crate) fn exe_launcher(spec: &str) -> anyhow::Result<Command> {
    super::this_program("--sim-part", spec)
}

/// Runs `part` in a fresh child process and returns what it measured.
pub(crate) fn in_child(launcher: Launcher, part: Part) -> anyhow::Result<PartOut> {
    let spec = part.spec();
    let out = launcher(&spec)?
        .env("RUST_LOG", "warn")
        // The reason, not a backtrace, is what the tail of its stderr should hold.
        .env("RUST_BACKTRACE", "0")
        .env("RUST_LIB_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .with_context(|| format!("cannot start the process for simulation part `{spec}`"))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let tail = || {
        let lines: Vec<&str> = stderr.lines().collect();
        lines[lines.len().saturating_sub(15)..].join("\n")
    };
    if !out.status.success() {
        bail!("simulation part `{spec}` failed ({}):\n{}", out.status, tail());
    }
    let line = stdout
        .lines()
        .find_map(|l| l.find(RESULT_PREFIX).map(|at| &l[at + RESULT_PREFIX.len()..]))
        .ok_or_else(|| anyhow!("simulation part `{spec}` printed no result line:\n{}", tail()))?;
    let got: PartOut = serde_json::from_str(line)
        .with_context(|| format!("simulation part `{spec}` printed a result that does not read back"))?;
    Ok(got)
}

/// [`in_child`] for a mission.
pub(crate) fn mission(launcher: Launcher, duration_s: f64) -> anyhow::Result<MissionRtf> {
    match in_child(launcher, Part::Mission { duration_s })? {
        PartOut::Mission(m) => Ok(m),
        other => Err(anyhow!("expected a mission's figures, got {other:?}")),
    }
}

/// [`in_child`] for recording and replaying.
pub(crate) fn record_replay(
    launcher: Launcher,
    duration_s: f64,
    runs: usize,
) -> anyhow::Result<super::RecordReplay> {
    match in_child(launcher, Part::Replay { duration_s, runs })? {
        PartOut::Replay(r) => Ok(r),
        other => Err(anyhow!("expected the recording and replay figures, got {other:?}")),
    }
}

/// [`in_child`] for N stacks.
pub(crate) fn stack(
    launcher: Launcher,
    robots: usize,
    warm_s: f64,
    measure_s: f64,
) -> anyhow::Result<ScaleRow> {
    match in_child(launcher, Part::Stack { robots, warm_s, measure_s })? {
        PartOut::Stack(row) => Ok(row),
        other => Err(anyhow!("expected a scale row, got {other:?}")),
    }
}

/// [`in_child`] for N skeletons.
pub(crate) fn raw(
    launcher: Launcher,
    skeleton: Skeleton,
    robots: usize,
    warm_s: f64,
    measure_s: f64,
) -> anyhow::Result<RawScale> {
    match in_child(launcher, Part::Raw { skeleton, robots, warm_s, measure_s })? {
        PartOut::Raw(raw) => Ok(raw),
        other => Err(anyhow!("expected the raw skeleton's figures, got {other:?}")),
    }
}
