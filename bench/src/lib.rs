//! # orsa-bench: what orsa costs, measured side by side with raw baselines in one run
//!
//! The benchmark harness, a workspace member of its own so that the `orsa` binary carries only
//! what a user runs. `cargo run --release -p orsa-bench` (`--quick`, `--json PATH`,
//! `--markdown PATH`) runs it; BENCHMARKS.md has the figures.
//!
//! Every figure comes with the baseline it is judged against, measured in the same run a moment
//! apart (in the same process, or for the simulation parts each in a fresh process of its own,
//! see `part`), because the machine is noisy: a ratio survives a busy neighbour better than
//! a nanosecond count. [`run`] measures, [`render_markdown`] writes the tables; the report is
//! also JSON ([`BenchReport`], with the flat keys `inproc_push_p50_ns`,
//! `raw_ractor_cast_p50_ns`, `zenoh_push_p50_ns`, `raw_zenoh_p50_ns`,
//! `sense_to_act_inproc_p99_ns`, `sense_to_act_xproc_p99_ns`, `rtf_1_robot` and
//! `rtf_100_robots`).
//!
//! | part | what | baseline |
//! |---|---|---|
//! | in process | push publish to the subscriber component's handler; query round trip; back-to-back, at 25 Hz, and throughput | raw ractor cast / call, raw tokio channel, between the same two tasks on the same runtime |
//! | fan-out | one push server to 1..1000 subscriber components | a loop of ractor casts to as many plain actors |
//! | sense to act | sensor update to the motor board, through the wired behaviour, in real time | the 200 µs target |
//! | across processes | push over zenoh between two processes on loopback, back-to-back and at 25 Hz; sense to act with the behaviours in the other process | raw zenoh publish/subscribe of the same payload, same sessions: to a callback, and from a callback to a tokio task or a ractor actor |
//! | simulation | `orsa run`'s real-time factor; N whole stacks in one process | one robot; N skeletons of the stack (its tasks, timers and message flow, none of its work), in raw tokio and with its components as plain ractor actors |
//!
//! The benches on tokio's running clock go first: once any runtime in a process has paused its
//! clock, every later read of tokio's clock takes a slower path (tokio's `test-util`), which
//! would tax orsa's stamps and not the raw baselines. The simulation parts, which pause it, each
//! run in a fresh process of their own (see `part`), as a user's program would.
//!
//! Modules: `inproc` (in-process patterns against raw ractor and tokio), `fanout`, `sense`
//! (sense to act), `net`, `peer` and `protocol` (across processes), `sim` and `part` (simulation speed and
//! scale, each part in a fresh process), `probe` and `stats` (timing), `report` (the figures) and `render` (the tables).

mod fanout;
mod inproc;
mod live;
mod net;
mod part;
mod peer;
mod probe;
mod protocol;
mod render;
mod report;
mod ros2;
mod sense;
use sense::Arm;
mod sim;
mod stats;
mod switch;

pub use render::render_markdown;
pub use report::*;

use std::time::Instant;

/// Runs the peer process of the cross-process bench (`orsa-bench --peer ENDPOINT`, which
/// `orsa-bench` starts by itself) until the bench process tells it to leave or goes away.
pub fn serve_peer(endpoint: &str) -> anyhow::Result<()> {
    peer::run(endpoint)
}

/// Measures only what the ROS 2 publication adds to the cross-process push (`--ros2-only`);
/// the figures are printed as they come.
pub fn ros2_only(samples: usize) -> anyhow::Result<()> {
    ros2::run(samples).map(|_| ())
}

/// Measures only what the safety monitor costs sense to act (`orsa-bench --monitor-only
/// SECONDS`): the stack with the monitor, without it, and with it again, `seconds` each, in
/// this run; prints the figures, the cost and the spread.
pub fn monitor_only(seconds: f64) -> anyhow::Result<()> {
    say("sense to act with the safety monitor");
    let with = sense::run(seconds, Arm::Plain)?;
    say("sense to act without the safety monitor, then with it again (the spread)");
    let without = sense::run(seconds, Arm::NoMonitor)?;
    let again = sense::run(seconds, Arm::Plain)?;
    let m = MonitorCost { without, again };
    println!("| sensor update published | n | p50 us | p99 us | max us |\n|---|---:|---:|---:|---:|");
    for (name, s) in [("with the monitor", &with), ("without it", &m.without), ("with it again", &m.again)] {
        let l = &s.from_update;
        println!(
            "| {name} | {} | {:.1} | {:.1} | {:.1} |",
            l.n,
            l.p50_ns / 1e3,
            l.p99_ns / 1e3,
            l.max_ns / 1e3
        );
    }
    for (name, pick) in MonitorCost::PERCENTILES {
        let (cost, spread) = m.cost_and_spread(&with, pick);
        println!(
            "{name}: the monitor costs {:+.1} us; the spread is {:.1} us: {}",
            cost / 1e3,
            spread / 1e3,
            if cost.abs() <= spread { "within it" } else { "outside it" }
        );
    }
    Ok(())
}

/// Measures only what a Foxglove client's publish and the ROS 2 parameter services cost sense
/// to act (`orsa-bench --interop-only SECONDS`): a live client reading, reading and
/// publishing, reading again; the stack on the robot's runtime alone, with the services
/// called, alone again; `seconds` each, in this run; prints the figures, the costs and the
/// spreads.
pub fn interop_only(seconds: f64) -> anyhow::Result<()> {
    say("sense to act with a live client reading");
    let live = sense::run(seconds, Arm::Live)?;
    let cost = interop(seconds)?;
    print(&render::interop_table(&live, &cost));
    Ok(())
}

/// The interop arms, each between two runs of its baseline, the first run of the live client
/// reading being the caller's.
fn interop(seconds: f64) -> anyhow::Result<InteropCost> {
    say("sense to act with the live client reading and publishing on /cmd_vel, then reading again");
    let publishing = sense::run(seconds, Arm::LivePublishing)?;
    let live_again = sense::run(seconds, Arm::Live)?;
    say(
        "sense to act on the robot's runtime: alone, with its ROS 2 parameter services called back to back, alone again",
    );
    let robot = sense::run(seconds, Arm::RobotRuntime)?;
    let services = sense::run(seconds, Arm::Ros2Services)?;
    let robot_again = sense::run(seconds, Arm::RobotRuntime)?;
    Ok(InteropCost { publishing, live_again, robot, services, robot_again })
}

/// Runs one simulation part of the bench in this process and prints its figures
/// (`orsa-bench --sim-part SPEC`, which `orsa-bench` starts by itself: each simulation part
/// runs in a fresh process).
pub fn serve_sim_part(spec: &str) -> anyhow::Result<()> {
    part::serve(spec)
}

/// How to start one of the bench's helper processes (the cross-process peer, a simulation
/// part) given its argument: this binary in the product, the test harness in tests.
pub(crate) type Launcher = fn(&str) -> anyhow::Result<std::process::Command>;

/// This binary again, `orsa-bench FLAG VALUE` (a hidden flag that makes it a helper process).
pub(crate) fn this_program(flag: &str, value: &str) -> anyhow::Result<std::process::Command> {
    use anyhow::Context as _;
    let exe = std::env::current_exe().context("cannot find this program to start a bench process")?;
    let mut c = std::process::Command::new(exe);
    c.args([flag, value]);
    Ok(c)
}

/// What to run.
#[derive(Debug, Clone, Default)]
pub struct BenchOptions {
    /// A smaller run, under two minutes: fewer samples, shorter simulated spans.
    pub quick: bool,
}

/// Prints a line to stdout; a reader that went away (`orsa-bench | head`) is not an error.
pub fn print(text: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{text}");
}

/// Progress, to stderr.
pub(crate) fn say(msg: impl AsRef<str>) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr().lock(), "bench: {}", msg.as_ref());
}

/// How big each part is.
#[derive(Debug, Clone)]
struct Plan {
    inproc: inproc::InprocSizes,
    inproc_mt: inproc::InprocSizes,
    fanout: Vec<usize>,
    fanout_budget: usize,
    fanout_min_rounds: usize,
    sense_s: f64,
    net: net::NetSizes,
    mission_s: f64,
    /// Simulated seconds recorded and replayed, and how many times.
    replay_s: f64,
    replay_runs: usize,
    scale: Vec<usize>,
    scale_warm_s: f64,
    /// Simulated seconds measured for N robots: this over N, at least `scale_min_s`.
    scale_robot_s: f64,
    scale_min_s: f64,
    /// Rows of up to this many robots are run `scale_repeats` times and the median reported:
    /// each is about a second of wall time, which moves by a fifth between runs on a shared
    /// machine.
    scale_repeat_up_to: usize,
    scale_repeats: usize,
    /// Mode switches of each kind, in process.
    switch_rounds: usize,
    /// Pushes with and without the ROS 2 publication, each.
    ros2_samples: usize,
}

impl Plan {
    fn new(quick: bool) -> Plan {
        if quick {
            Plan {
                inproc: inproc::InprocSizes {
                    warmup: 2_000,
                    back_to_back: 20_000,
                    burst: 100_000,
                    at_25hz: 250,
                },
                inproc_mt: inproc::InprocSizes {
                    warmup: 2_000,
                    back_to_back: 20_000,
                    burst: 100_000,
                    at_25hz: 125,
                },
                fanout: vec![1, 10, 100, 1000],
                fanout_budget: 20_000,
                fanout_min_rounds: 100,
                sense_s: 20.0,
                net: net::NetSizes {
                    warmup: 300,
                    back_to_back: 2_000,
                    at_25hz: 150,
                    sense_s: 10.0,
                    switch_rounds: 200,
                },
                mission_s: 120.0,
                replay_s: 300.0,
                replay_runs: 3,
                scale: vec![1, 10, 100, 1000],
                scale_warm_s: 2.0,
                scale_robot_s: 60.0,
                scale_min_s: 2.0,
                scale_repeat_up_to: 100,
                scale_repeats: 3,
                switch_rounds: 2_000,
                ros2_samples: 500,
            }
        } else {
            Plan {
                inproc: inproc::InprocSizes {
                    warmup: 5_000,
                    back_to_back: 100_000,
                    burst: 500_000,
                    at_25hz: 1_000,
                },
                inproc_mt: inproc::InprocSizes {
                    warmup: 5_000,
                    back_to_back: 100_000,
                    burst: 500_000,
                    at_25hz: 500,
                },
                fanout: vec![1, 10, 100, 1000],
                fanout_budget: 200_000,
                fanout_min_rounds: 300,
                sense_s: 60.0,
                net: net::NetSizes {
                    warmup: 1_000,
                    back_to_back: 10_000,
                    at_25hz: 750,
                    sense_s: 60.0,
                    switch_rounds: 1_000,
                },
                mission_s: 600.0,
                replay_s: 3600.0,
                replay_runs: 3,
                scale: vec![1, 10, 100, 1000],
                scale_warm_s: 2.0,
                scale_robot_s: 300.0,
                scale_min_s: 10.0,
                scale_repeat_up_to: 100,
                scale_repeats: 3,
                switch_rounds: 20_000,
                ros2_samples: 5_000,
            }
        }
    }
}

fn machine() -> Machine {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map_or_else(|| std::env::consts::ARCH.to_string(), |(_, v)| v.trim().to_string());
    let memory_gib = std::fs::read_to_string("/proc/meminfo").ok().and_then(|m| {
        let line = m.lines().find(|l| l.starts_with("MemTotal:"))?.to_string();
        let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib / (1024.0 * 1024.0))
    });
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| std::env::consts::OS.to_string());
    Machine {
        cpu,
        logical_cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
        memory_gib,
        kernel,
        optimized: !cfg!(debug_assertions),
    }
}

/// Runs every bench and returns the report; progress goes to stderr.
pub fn run(opts: &BenchOptions) -> anyhow::Result<BenchReport> {
    let plan = Plan::new(opts.quick);
    let started = Instant::now();
    say(format!("{} run; real-time parts first", if opts.quick { "quick" } else { "full" }));

    say("in process, current-thread runtime");
    let ct = inproc::run(inproc::RuntimeKind::CurrentThread, plan.inproc)?;
    say("in process, multi-thread runtime");
    let mt = inproc::run(inproc::RuntimeKind::MultiThread, plan.inproc_mt)?;
    say("fan-out");
    let (budget, min) = (plan.fanout_budget, plan.fanout_min_rounds);
    let fanout = fanout::run(&plan.fanout, |n| fanout::rounds_for(n, budget, min))?;
    say("sense to act");
    let sense = sense::run(plan.sense_s, Arm::Plain)?;
    say("sense to act without the safety monitor, then with it again (the spread)");
    let without = sense::run(plan.sense_s, Arm::NoMonitor)?;
    let again = sense::run(plan.sense_s, Arm::Plain)?;
    let monitor_cost = Some(MonitorCost { without, again });
    say("sense to act with a live server (--foxglove) and a client subscribed to everything");
    let sense_live = sense::run(plan.sense_s, Arm::Live)?;
    let interop_cost = Some(interop(plan.sense_s)?);
    say("mode switch");
    let switch_in_process = switch::in_process(plan.switch_rounds)?;
    say("across processes (zenoh on loopback)");
    let (net, net_error) = match net::run(plan.net, net::exe_launcher) {
        Ok(n) => (Some(n), None),
        Err(e) => {
            say(format!("  across processes failed: {e:#}"));
            (None, Some(format!("{e:#}")))
        }
    };

    say("ROS 2 publication on the cross-process push");
    let (ros2, ros2_error) = match ros2::run(plan.ros2_samples) {
        Ok(c) => (Some(c), None),
        Err(e) => {
            say(format!("  the ROS 2 bench failed: {e:#}"));
            (None, Some(format!("{e:#}")))
        }
    };

    say(format!("simulation: the corridor mission, {:.0} simulated s", plan.mission_s));
    let mission = part::mission(part::exe_launcher, plan.mission_s)?;
    say(format!("recording and replay: {:.0} simulated s, {} runs each", plan.replay_s, plan.replay_runs));
    let record_replay = part::record_replay(part::exe_launcher, plan.replay_s, plan.replay_runs)?;
    say(format!(
        "  --record {:.2}x a plain run, replay {:.2}x, bit-exact: {}, a live server with no client {:.2}x",
        record_replay.record_ratio,
        record_replay.replay_ratio,
        record_replay.bit_exact,
        record_replay.live_ratio
    ));
    let mut scale = Vec::new();
    for &n in &plan.scale {
        let measure = (plan.scale_robot_s / n as f64).max(plan.scale_min_s);
        let repeats = if n <= plan.scale_repeat_up_to { plan.scale_repeats.max(1) } else { 1 };
        say(format!("simulation: {n} robots, {measure:.0} simulated s measured, {repeats} run(s)"));
        let mut rows = Vec::with_capacity(repeats);
        let (mut raws, mut ractors) = (Vec::with_capacity(repeats), Vec::with_capacity(repeats));
        for _ in 0..repeats {
            rows.push(part::stack(part::exe_launcher, n, plan.scale_warm_s, measure)?);
            for (skeleton, costs) in
                [(sim::Skeleton::Tokio, &mut raws), (sim::Skeleton::Ractor, &mut ractors)]
            {
                let raw = part::raw(part::exe_launcher, skeleton, n, plan.scale_warm_s, measure)?;
                anyhow::ensure!(
                    raw.steps > 0 && raw.commands > 0,
                    "the {skeleton:?} skeleton of {n} robots did not run: {raw:?}"
                );
                costs.push(raw.us_per_robot_sim_s);
            }
        }
        let rtf_runs: Vec<f64> = rows.iter().map(|r| r.rtf).collect();
        rows.sort_by(|a, b| a.rtf.total_cmp(&b.rtf));
        let mut row = rows.swap_remove(rows.len() / 2);
        row.raw_wall_us_per_robot_sim_s = stats::median(raws);
        row.ractor_wall_us_per_robot_sim_s = stats::median(ractors);
        row.rtf_runs = rtf_runs;
        say(format!(
            "  {n} robots: {:.1}x real time, {:.0} wall us per robot per simulated s (skeletons: raw tokio {:.0}, ractor {:.0})",
            row.rtf,
            row.wall_us_per_robot_sim_s,
            row.raw_wall_us_per_robot_sim_s.unwrap_or(f64::NAN),
            row.ractor_wall_us_per_robot_sim_s.unwrap_or(f64::NAN)
        ));
        scale.push(row);
    }

    let mut latency = ct.latency;
    latency.extend(mt.latency);
    let mut throughput = ct.throughput;
    throughput.extend(mt.throughput);
    let find = |path: &str| {
        latency
            .iter()
            .find(|r| {
                r.runtime == inproc::RuntimeKind::CurrentThread.label()
                    && r.mode == "back-to-back"
                    && r.path == path
            })
            .map_or(f64::NAN, |r| r.latency.p50_ns)
    };
    let switch =
        SwitchCosts { in_process: switch_in_process, across: net.as_ref().and_then(|n| n.switch.clone()) };
    let mut report = BenchReport {
        inproc_push_p50_ns: find(inproc::ORSA_PUSH),
        raw_ractor_cast_p50_ns: find(inproc::RACTOR_CAST),
        sense_to_act_inproc_p99_ns: sense.from_update.p99_ns,
        rtf_1_robot: mission.rtf,
        rtf_100_robots: scale.iter().find(|r| r.robots == 100).map_or(f64::NAN, |r| r.rtf),
        zenoh_push_p50_ns: net_p50(net.as_ref(), net::ORSA_COMPONENT),
        raw_zenoh_p50_ns: net_p50(net.as_ref(), net::RAW_CALLBACK),
        sense_to_act_xproc_p99_ns: net
            .as_ref()
            .and_then(|n| n.sense_to_act.as_ref())
            .filter(|s| s.attributed > 0)
            .map(|s| s.from_update.p99_ns),
        quick: opts.quick,
        orsa_version: env!("CARGO_PKG_VERSION").to_string(),
        machine: machine(),
        command: if opts.quick {
            "cargo run --release -p orsa-bench -- --quick"
        } else {
            "cargo run --release -p orsa-bench"
        }
        .to_string(),
        wall_s: 0.0,
        latency,
        throughput,
        fanout,
        sense_to_act: sense,
        sense_to_act_live: sense_live,
        monitor_cost,
        interop_cost,
        net,
        net_error,
        ros2,
        ros2_error,
        mission,
        record_replay,
        switch,
        scale,
        targets: Vec::new(),
    };
    report.targets = judge(&report);
    report.wall_s = started.elapsed().as_secs_f64();
    say(format!("done in {:.0} s", report.wall_s));
    Ok(report)
}

/// A back-to-back p50 across processes.
fn net_p50(net: Option<&NetReport>, path: &str) -> Option<f64> {
    net?.latency
        .iter()
        .find(|r| r.mode == "back-to-back" && r.path == path && r.latency.n > 0)
        .map(|r| r.latency.p50_ns)
}

/// The targets against what the run measured.
fn judge(r: &BenchReport) -> Vec<TargetCheck> {
    let mut t = Vec::new();
    let rr = &r.record_replay;
    t.push(TargetCheck {
        target: format!(
            "orsa replay of {:.0} simulated s takes less wall time than orsa run takes to produce it",
            rr.simulated_s
        ),
        measured: format!("{:.2}x ({}bit-exact)", rr.replay_ratio, if rr.bit_exact { "" } else { "NOT " }),
        met: Some(rr.replay_ratio < 1.0 && rr.bit_exact),
    });
    t.push(TargetCheck {
        target: "orsa run --record costs at most 1.25x a run without it".into(),
        measured: format!("{:.2}x", rr.record_ratio),
        met: Some(rr.record_ratio <= 1.25),
    });
    t.push(TargetCheck {
        target: "the ROS 2 publication adds at most 1.2x to the robot's cross-process push (p50)".into(),
        measured: match &r.ros2 {
            Some(c) => format!(
                "{:.2}x ({:.1} us with it, {:.1} us without)",
                c.p50_ratio.unwrap_or(f64::NAN),
                c.with_ros2.p50_ns / 1e3,
                c.plain.p50_ns / 1e3
            ),
            None => "not measured".into(),
        },
        met: r.ros2.as_ref().and_then(|c| c.p50_ratio).map(|x| x <= 1.2),
    });
    t.push(TargetCheck {
        target: "the ROS 2 parameter services, called back to back, leave that push within its spread (p50)"
            .into(),
        measured: match &r.ros2 {
            Some(c) => format!(
                "{:.2}x ({:.1} us with the calls, {:.1} us without; spread {:.2}; {} calls answered)",
                c.services_p50_ratio.unwrap_or(f64::NAN),
                c.with_services.p50_ns / 1e3,
                c.with_ros2.p50_ns / 1e3,
                c.with_ros2_spread,
                c.service_calls
            ),
            None => "not measured".into(),
        },
        met: r.ros2.as_ref().and_then(|c| c.services_p50_ratio.map(|x| x <= 1.0 + c.with_ros2_spread)),
    });
    t.push(TargetCheck {
        target: "a live server (--foxglove) with no client costs at most 1.05x a run without it".into(),
        measured: format!("{:.2}x", rr.live_ratio),
        met: Some(rr.live_ratio <= 1.05),
    });
    let sw = &r.switch;
    for (place, pair) in [("in process", Some(&sw.in_process)), ("across processes", sw.across.as_ref())] {
        t.push(TargetCheck {
            target: format!("a mode switch {place} costs at most 1.5x the same calls one by one (p50)"),
            measured: pair.map_or_else(|| "not measured".into(), |p| format!("{:.2}x", p.p50_ratio)),
            met: pair.map(|p| p.p50_ratio <= 1.5),
        });
    }
    for row in r.latency.iter().filter(|row| row.path == inproc::ORSA_PUSH) {
        t.push(TargetCheck {
            target: format!("in-process push p50 <= 1.5x raw ractor cast ({}, {})", row.runtime, row.mode),
            measured: match row.p50_ratio {
                Some(x) => format!("{x:.2}x ({:.0} ns)", row.latency.p50_ns),
                None => "no baseline".into(),
            },
            met: row.p50_ratio.map(|x| x <= 1.5),
        });
    }
    match &r.net {
        Some(net) => {
            for row in net.latency.iter().filter(|row| row.path == net::ORSA_COMPONENT) {
                t.push(TargetCheck {
                    target: format!(
                        "zenoh push p50 <= 1.2x raw zenoh ({}; component vs subscriber callback)",
                        row.mode
                    ),
                    measured: match row.p50_ratio {
                        Some(x) => format!("{x:.2}x ({:.1} us)", row.latency.p50_ns / 1e3),
                        None => "no baseline".into(),
                    },
                    met: row.p50_ratio.map(|x| x <= 1.2),
                });
                // Like for like: where the receiving code runs on zenoh's thread in both, and
                // where both hand the sample to a tokio task.
                let p50 = |path: &str| {
                    net.latency
                        .iter()
                        .find(|r| r.mode == row.mode && r.path == path && r.latency.n > 0)
                        .map_or(f64::NAN, |r| r.latency.p50_ns)
                };
                let sink = stats::ratio(p50(net::ORSA_SINK), p50(net::RAW_CALLBACK));
                let task = stats::ratio(p50(net::ORSA_COMPONENT), p50(net::RAW_TASK));
                t.push(TargetCheck {
                    target: format!(
                        "zenoh push p50 <= 1.2x raw zenoh ({}; like for like: client sink vs callback, component vs callback -> tokio task)",
                        row.mode
                    ),
                    measured: match (sink, task) {
                        (Some(a), Some(b)) => format!("{a:.2}x, {b:.2}x"),
                        _ => "not measured".into(),
                    },
                    met: sink.zip(task).map(|(a, b)| a <= 1.2 && b <= 1.2),
                });
                // The component against the raw parts it is made of (a zenoh callback casting
                // to a ractor actor): what orsa adds on top of them.
                let parts = stats::ratio(p50(net::ORSA_COMPONENT), p50(net::RAW_ACTOR));
                t.push(TargetCheck {
                    target: format!(
                        "zenoh push p50 <= 1.2x raw zenoh ({}; component vs callback -> ractor cast -> actor)",
                        row.mode
                    ),
                    measured: match parts {
                        Some(x) => format!("{x:.2}x"),
                        None => "not measured".into(),
                    },
                    met: parts.map(|x| x <= 1.2),
                });
            }
        }
        None => t.push(TargetCheck {
            target: "zenoh push p50 <= 1.2x raw zenoh".into(),
            measured: "not measured (the cross-process bench failed)".into(),
            met: None,
        }),
    }
    let s = &r.sense_to_act;
    t.push(TargetCheck {
        target: "sense to act in process p99 < 200 us".into(),
        measured: format!("{:.1} us ({} commands)", s.from_update.p99_ns / 1e3, s.attributed),
        met: (s.attributed > 0).then_some(s.from_update.p99_ns < 200_000.0),
    });
    match &r.monitor_cost {
        Some(m) => {
            for (name, pick) in MonitorCost::PERCENTILES {
                let (cost, spread) = m.cost_and_spread(&r.sense_to_act, pick);
                t.push(TargetCheck {
                    target: format!("the safety monitor's cost on sense to act {name}: within the run's spread"),
                    measured: format!(
                        "{:.1} us with it ({:.1} us again), {:.1} us without: costs {:+.1} us, spread {:.1} us",
                        pick(&r.sense_to_act.from_update) / 1e3,
                        pick(&m.again.from_update) / 1e3,
                        pick(&m.without.from_update) / 1e3,
                        cost / 1e3,
                        spread / 1e3
                    ),
                    met: (m.without.attributed > 0 && m.again.attributed > 0).then_some(cost.abs() <= spread),
                });
            }
        }
        None => t.push(TargetCheck {
            target: "the safety monitor's cost on sense to act: within the run's spread".into(),
            measured: "not measured".into(),
            met: None,
        }),
    }
    let s = &r.sense_to_act_live;
    let client = s.live_client.as_ref();
    t.push(TargetCheck {
        target: "sense to act in process p99 < 200 us with a live Foxglove client subscribed to everything"
            .into(),
        measured: format!(
            "{:.1} us ({} commands; the client read {} messages on {} channels)",
            s.from_update.p99_ns / 1e3,
            s.attributed,
            client.map_or(0, |c| c.messages),
            client.map_or(0, |c| c.subscribed)
        ),
        met: (s.attributed > 0 && client.is_some_and(|c| c.messages > 0))
            .then_some(s.from_update.p99_ns < 200_000.0),
    });
    match &r.interop_cost {
        Some(ic) => {
            for (name, pick) in MonitorCost::PERCENTILES {
                let arms = [
                    (
                        "the ROS 2 parameter services called back to back",
                        &ic.services,
                        &ic.robot,
                        &ic.robot_again,
                        ic.services.ros2_calls.is_some_and(|c| c.answered > 0),
                    ),
                    (
                        "a Foxglove client publishing on /cmd_vel at 20 Hz",
                        &ic.publishing,
                        &r.sense_to_act_live,
                        &ic.live_again,
                        ic.publishing.live_client.as_ref().is_some_and(|c| c.taken > 0)
                            && ic.publishing.stale_refused > 0,
                    ),
                ];
                for (what, arm, a, b, exercised) in arms {
                    let (cost, spread) = InteropCost::cost_and_spread(arm, a, b, pick);
                    t.push(TargetCheck {
                        target: format!("{what}: cost on sense to act {name} within the run's spread"),
                        measured: format!(
                            "{:.1} us with it, {:.1} and {:.1} us without: costs {:+.1} us, spread {:.1} us",
                            pick(&arm.from_update) / 1e3,
                            pick(&a.from_update) / 1e3,
                            pick(&b.from_update) / 1e3,
                            cost / 1e3,
                            spread / 1e3
                        ),
                        met: (exercised && arm.attributed > 0 && a.attributed > 0 && b.attributed > 0)
                            .then_some(cost <= spread),
                    });
                }
            }
        }
        None => t.push(TargetCheck {
            target: "client publish and the ROS 2 parameter services: cost on sense to act within the run's spread"
                .into(),
            measured: "not measured".into(),
            met: None,
        }),
    }
    t.push(TargetCheck {
        target: "one robot >= 300x real time".into(),
        measured: format!("{:.0}x", r.rtf_1_robot),
        met: r.rtf_1_robot.is_finite().then_some(r.rtf_1_robot >= 300.0),
    });
    t.push(TargetCheck {
        target: "100 robots >= 10x real time".into(),
        measured: format!("{:.1}x", r.rtf_100_robots),
        met: r.rtf_100_robots.is_finite().then_some(r.rtf_100_robots >= 10.0),
    });
    let range = |c: &[f64]| c.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &c| (lo.min(c), hi.max(c)));
    let costs: Vec<f64> = r.scale.iter().map(|row| row.wall_us_per_robot_sim_s).collect();
    let (lo, hi) = range(&costs);
    // The skeletons' spreads over the same robot counts, for the verdict's reader.
    let spread = |of: fn(&ScaleRow) -> Option<f64>, name: &str| -> Option<String> {
        let c: Vec<f64> = r.scale.iter().filter_map(of).collect();
        let (lo, hi) = range(&c);
        (c.len() == costs.len() && lo > 0.0)
            .then(|| format!("{name} {lo:.1} to {hi:.1} us ({:.2}x)", hi / lo))
    };
    let skeletons: Vec<String> = [
        spread(|row| row.raw_wall_us_per_robot_sim_s, "raw tokio skeleton"),
        spread(|row| row.ractor_wall_us_per_robot_sim_s, "ractor skeleton"),
    ]
    .into_iter()
    .flatten()
    .collect();
    t.push(TargetCheck {
        target: "cost per robot roughly constant from 1 to 1000 (largest / smallest <= 1.5)".into(),
        measured: if costs.is_empty() {
            "not measured".into()
        } else {
            let mut m = format!("{lo:.0} to {hi:.0} us per robot per simulated s ({:.2}x)", hi / lo);
            for sk in skeletons {
                m.push_str("; ");
                m.push_str(&sk);
            }
            m
        },
        met: (!costs.is_empty() && lo > 0.0).then(|| hi / lo <= 1.5),
    });
    t
}

#[cfg(test)]
mod tests;
