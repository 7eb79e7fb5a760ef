//! The report as Markdown tables.

use super::{BenchReport, InteropCost, Latency, MonitorCost, SenseToAct, SwitchPair};
use std::fmt::Write as _;

/// A duration in nanoseconds, in the unit that reads best.
fn dur(ns: f64) -> String {
    if !ns.is_finite() {
        "-".into()
    } else if ns < 1e3 {
        format!("{ns:.0} ns")
    } else if ns < 1e6 {
        format!("{:.2} µs", ns / 1e3)
    } else if ns < 1e9 {
        format!("{:.2} ms", ns / 1e6)
    } else {
        format!("{:.2} s", ns / 1e9)
    }
}

fn ratio(r: Option<f64>) -> String {
    r.map_or_else(|| "-".into(), |x| format!("{x:.2}x"))
}

fn rate(per_s: f64) -> String {
    if per_s >= 1e6 { format!("{:.2} M/s", per_s / 1e6) } else { format!("{:.0} k/s", per_s / 1e3) }
}

fn lat_cells(l: &Latency) -> String {
    format!("{} | {} | {} | {}", l.n, dur(l.p50_ns), dur(l.p99_ns), dur(l.max_ns))
}

fn met(m: Option<bool>) -> &'static str {
    match m {
        Some(true) => "met",
        Some(false) => "**missed**",
        None => "not measured",
    }
}

/// The report's figures as Markdown: the machine and command, the targets, then one table per
/// part with each figure beside its baseline.
pub fn render_markdown(r: &BenchReport) -> String {
    let mut s = String::new();
    let m = &r.machine;
    let _ = writeln!(
        s,
        "Run: `{}` ({} run, {:.0} s wall, orsa {}).\n",
        r.command,
        if r.quick { "quick" } else { "full" },
        r.wall_s,
        r.orsa_version
    );
    let _ = writeln!(
        s,
        "Machine: {}, {} logical CPUs, {} memory, Linux {}{}.\n",
        m.cpu,
        m.logical_cpus,
        m.memory_gib.map_or_else(|| "unknown".into(), |g| format!("{g:.0} GiB")),
        m.kernel,
        if m.optimized { "" } else { ", **debug build: figures are not representative**" }
    );

    let _ = writeln!(s, "## Targets\n\n| target | measured | |\n|---|---|---|");
    for t in &r.targets {
        let _ = writeln!(s, "| {} | {} | {} |", t.target, t.measured, met(t.met));
    }

    let _ = writeln!(
        s,
        "\n## In process: latency\n\nFrom just before the send to the first line of the receiving handler (push), \
         or around the awaited call (query). Ratios are against the baseline named, same runtime, same mode.\n"
    );
    let _ = writeln!(
        s,
        "| runtime | mode | path | n | p50 | p99 | max | baseline | p50 ratio | p99 ratio |\n|---|---|---|---:|---:|---:|---:|---|---:|---:|"
    );
    for row in &r.latency {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            row.runtime,
            row.mode,
            row.path,
            lat_cells(&row.latency),
            row.baseline.as_deref().unwrap_or("-"),
            ratio(row.p50_ratio),
            ratio(row.p99_ratio)
        );
    }

    let _ = writeln!(s, "\n## In process: throughput\n");
    let _ = writeln!(
        s,
        "| runtime | path | how | messages | rate | baseline | ratio |\n|---|---|---|---:|---:|---|---:|"
    );
    for row in &r.throughput {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            row.runtime,
            row.path,
            row.how,
            row.messages,
            rate(row.per_s),
            row.baseline.as_deref().unwrap_or("-"),
            ratio(row.ratio)
        );
    }

    let _ = writeln!(
        s,
        "\n## Fan-out: one push server, N subscriber components\n\nCurrent-thread runtime. *publish*: how long \
         `put` (raw: the loop of casts) takes; *last handler*: from before the publish to the last subscriber's \
         handler. Raw: N plain ractor actors, one cast each.\n"
    );
    let _ = writeln!(
        s,
        "| subscribers | rounds | orsa publish p50 | orsa last handler p50 | p99 | raw publish p50 | raw last handler p50 | p99 | orsa / raw (p50) | orsa per subscriber | raw per subscriber | delivered |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
    );
    for f in &r.fanout {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} of {} |",
            f.subscribers,
            f.rounds,
            dur(f.orsa_publish.p50_ns),
            dur(f.orsa_last_handler.p50_ns),
            dur(f.orsa_last_handler.p99_ns),
            dur(f.raw_publish.p50_ns),
            dur(f.raw_last_handler.p50_ns),
            dur(f.raw_last_handler.p99_ns),
            ratio(f.last_p50_ratio),
            dur(f.orsa_ns_per_subscriber),
            dur(f.raw_ns_per_subscriber),
            f.delivered,
            f.expected
        );
    }

    let st = &r.sense_to_act;
    let _ = writeln!(
        s,
        "\n## Sense to act, in process\n\nThe whole stack in real time for {:.0} s (current-thread runtime, default \
         configuration, patrol). {} velocity commands reached the motor board; {} were attributed to the wired \
         behaviour's step that computed them ({}), {} were not (the master's zero commands while nothing is wired). \
         Stale commands refused: {}; restarts: {}.\n",
        st.duration_s,
        st.commands_received,
        st.attributed,
        st.by_behaviour.iter().map(|(b, n)| format!("{b} {n}")).collect::<Vec<_>>().join(", "),
        st.unattributed,
        st.stale_refused,
        st.restarts
    );
    let _ = writeln!(s, "| from | n | p50 | p99 | max |\n|---|---:|---:|---:|---:|");
    let _ = writeln!(s, "| sensor update published (the target's figure) | {} |", lat_cells(&st.from_update));
    let _ = writeln!(
        s,
        "| newest sensor firing (adds the simulator's sampling) | {} |",
        lat_cells(&st.from_sensor_firing)
    );
    leg_rows(&mut s, st);
    if let Some(m) = &r.monitor_cost {
        let _ = writeln!(
            s,
            "\nThe safety monitor's cost: the same run without it (`safety.enabled = false`), then with it again, \
             right after the one above. Its cost is the mean of the two runs with it less the run without; the \
             spread is how far the two runs with it are apart.\n"
        );
        let _ = writeln!(s, "| sensor update published | n | p50 | p99 | max |\n|---|---:|---:|---:|---:|");
        let _ = writeln!(s, "| with the monitor | {} |", lat_cells(&st.from_update));
        let _ = writeln!(s, "| without it | {} |", lat_cells(&m.without.from_update));
        let _ = writeln!(s, "| with it again | {} |", lat_cells(&m.again.from_update));
        for (name, pick) in MonitorCost::PERCENTILES {
            let (cost, spread) = m.cost_and_spread(st, pick);
            let _ = writeln!(
                s,
                "\n{name}: the monitor costs {:+.1} us; the spread is {:.1} us: {}.",
                cost / 1e3,
                spread / 1e3,
                if cost.abs() <= spread { "within it" } else { "outside it" }
            );
        }
    }
    let lv = &r.sense_to_act_live;
    if let Some(c) = &lv.live_client {
        let _ = writeln!(
            s,
            "\nThe same, right after, with a live server (`--foxglove`) serving the views to a Foxglove WebSocket \
             client in this process (tokio-tungstenite, its own thread) subscribed to all {} channels: it read {} \
             messages; the control loop handed the views {} and dropped {}.\n",
            c.subscribed, c.messages, c.handed, c.dropped
        );
        let _ = writeln!(s, "| from | n | p50 | p99 | max |\n|---|---:|---:|---:|---:|");
        let _ = writeln!(s, "| sensor update published, live client | {} |", lat_cells(&lv.from_update));
    }
    if let Some(ic) = &r.interop_cost {
        s.push_str(&interop_table(lv, ic));
    }

    render_net(&mut s, r);

    let mi = &r.mission;
    let _ = writeln!(
        s,
        "\n## Simulation speed and scale\n\n`orsa run` (the corridor mission, one robot, paused clock, start-up and \
         shutdown included, in a fresh process): {:.0} simulated s in {:.2} wall s, **{:.0}x real time** ({:.1} m driven, {} restarts).\n",
        mi.simulated_s, mi.wall_s, mi.rtf, mi.distance_m, mi.restarts
    );
    let rr = &r.record_replay;
    let runs = |v: &[f64]| v.iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", ");
    let _ = writeln!(
        s,
        "Recording and replay ({:.0} simulated s, seed 1, in a fresh process; plain run, recorded run and replay \
         alternated, {} runs each, medians): `orsa run --record` takes **{:.2}x** a plain run ({} vs {} wall s) and \
         writes {} messages in {:.1} MB; `orsa replay` of that file, reading and checking it included, takes \
         **{:.2}x** the plain run ({} wall s) and compares {} messages: {}. With a live server (`--foxglove`) and no \
         client, a run takes **{:.2}x** a plain run ({} wall s).\n",
        rr.simulated_s,
        rr.run_wall_s.len(),
        rr.record_ratio,
        runs(&rr.record_wall_s),
        runs(&rr.run_wall_s),
        rr.messages,
        rr.file_bytes as f64 / 1e6,
        rr.replay_ratio,
        runs(&rr.replay_wall_s),
        rr.compared,
        if rr.bit_exact { "bit-exact every time" } else { "NOT bit-exact" },
        rr.live_ratio,
        runs(&rr.live_wall_s)
    );
    let sw = &r.switch;
    let pair = |p: &SwitchPair| {
        format!(
            "one switch p50 {:.1} µs (p99 {:.1}), the four calls one by one p50 {:.1} µs (p99 {:.1}): **{:.2}x** ({} rounds each)",
            p.switch.p50_ns / 1e3,
            p.switch.p99_ns / 1e3,
            p.one_by_one.p50_ns / 1e3,
            p.one_by_one.p99_ns / 1e3,
            p.p50_ratio,
            p.rounds
        )
    };
    let _ = writeln!(
        s,
        "Mode switch (hand the motors from one behaviour to the other: unwire it, set both states, wire the other), \
         made as one all-or-nothing switch against the same four calls one by one, alternated. In process: {}. \
         Across processes (the behaviours in the peer, the master stopped): {}.\n",
        pair(&sw.in_process),
        sw.across.as_ref().map_or_else(|| "not measured (the cross-process bench failed)".to_string(), pair)
    );
    let _ = writeln!(
        s,
        "N robots, each with its whole stack (simulator, server, two behaviours, master, planner, supervisor, \
         registry), on one current-thread runtime with a paused clock, in a fresh process of its own; measured \
         after a 2 s simulated warm-up. *Cost per robot*: wall µs per robot per simulated second. *Raw skeleton*: the baseline, as many \
         robots' skeletons in raw tokio on the same kind of runtime (per robot the stack's 13 tasks, its \
         timers at the same periods and its message flow, about 580 wake-ups per simulated second, none of \
         its work), measured right after in a fresh process too. *Ractor skeleton*: the same with the \
         stack's six actors (five components, one supervisor) as plain ractor actors, what the actor runtime adds, still none of the work. Rows of up to 100 robots are the median of three runs (a \
         run is about a second of wall time, which moves by a fifth between runs on a shared machine); \
         *x real time* gives every run's figure after the median.\n"
    );
    let _ = writeln!(
        s,
        "| robots | start-up | simulated | wall | x real time | robot-s per wall s | cost per robot | vs 1 robot | raw skeleton | raw vs 1 robot | ractor skeleton | ractor vs 1 robot | steps per robot | memory per robot | restarts |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|"
    );
    let one = r.scale.iter().find(|x| x.robots == 1).map(|x| x.wall_us_per_robot_sim_s);
    let raw_one = r.scale.iter().find(|x| x.robots == 1).and_then(|x| x.raw_wall_us_per_robot_sim_s);
    let ractor_one = r.scale.iter().find(|x| x.robots == 1).and_then(|x| x.ractor_wall_us_per_robot_sim_s);
    let cost = |c: Option<f64>| c.map_or_else(|| "-".into(), |c| format!("{c:.1} µs"));
    let against =
        |one: Option<f64>, c: Option<f64>| ratio(one.zip(c).and_then(|(o, c)| super::stats::ratio(c, o)));
    for row in &r.scale {
        let _ = writeln!(
            s,
            "| {} | {:.2} s | {:.0} s | {:.2} s | {} | {:.0} | {:.0} µs | {} | {} | {} | {} | {} | {} of {} | {} | {} |",
            row.robots,
            row.startup_wall_s,
            row.simulated_s,
            row.wall_s,
            rtf_cell(row),
            row.robot_seconds_per_wall_s,
            row.wall_us_per_robot_sim_s,
            ratio(one.and_then(|o| super::stats::ratio(row.wall_us_per_robot_sim_s, o))),
            cost(row.raw_wall_us_per_robot_sim_s),
            against(raw_one, row.raw_wall_us_per_robot_sim_s),
            cost(row.ractor_wall_us_per_robot_sim_s),
            against(ractor_one, row.ractor_wall_us_per_robot_sim_s),
            row.min_steps_per_robot,
            row.expected_steps_per_robot,
            row.rss_mib_per_robot.map_or_else(|| "-".into(), |m| format!("{m:.2} MiB")),
            row.restarts
        );
    }
    s
}

/// A row's real-time factor, and every run's after it when there were several.
fn rtf_cell(row: &super::ScaleRow) -> String {
    if row.rtf_runs.len() > 1 {
        let runs: Vec<String> = row.rtf_runs.iter().map(|r| format!("{r:.1}")).collect();
        format!("{:.1}x (runs {})", row.rtf, runs.join(", "))
    } else {
        format!("{:.1}x", row.rtf)
    }
}

/// The legs of the figure from the update, one row each.
fn leg_rows(s: &mut String, st: &super::SenseToAct) {
    for l in &st.legs {
        let _ = writeln!(s, "| leg: {} | {} |", l.leg, lat_cells(&l.latency));
    }
}

/// The cross-process tables.
fn render_net(s: &mut String, r: &BenchReport) {
    let Some(net) = &r.net else {
        let _ = writeln!(
            s,
            "\n## Across processes\n\nNot measured: {}.",
            r.net_error.as_deref().unwrap_or("the cross-process bench did not run")
        );
        return;
    };
    let _ = writeln!(
        s,
        "\n## Across processes: latency\n\nTwo processes on this host, {}; {} ({:.2} s from opening the \
         session to the first sample on every path). One-way: the receiver's UNIX time minus the send time \
         in the sample (one kernel clock). The sample is a sequence number, the send time and 16 readings \
         like a `DistanceScan`'s; raw paths send it as CBOR, orsa's paths in orsa's stamped envelope. Ratios \
         are against the raw subscriber callback, same mode.\n",
        net.runtime, net.transport, net.startup_s
    );
    let _ = writeln!(
        s,
        "| mode | path | sent | received | in order | n | p50 | p99 | max | baseline | p50 ratio | p99 ratio | sender's put p50 |\n\
         |---|---|---:|---:|---|---:|---:|---:|---:|---|---:|---:|---:|"
    );
    for row in &net.latency {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            row.mode,
            row.path,
            row.sent,
            row.received,
            if row.in_order { "yes" } else { "**no**" },
            lat_cells(&row.latency),
            row.baseline.as_deref().unwrap_or("-"),
            ratio(row.p50_ratio),
            ratio(row.p99_ratio),
            dur(row.sender_put.p50_ns)
        );
    }
    let c = &net.codec;
    let _ = writeln!(
        s,
        "\nEncoding the sample, in one process (mean per call): raw CBOR {} bytes, encode {}, decode {}; \
         orsa's stamped envelope {} bytes, `encode_stamped` {}, `decode_stamped` {}.",
        c.raw_bytes,
        dur(c.raw_encode_ns),
        dur(c.raw_decode_ns),
        c.orsa_bytes,
        dur(c.orsa_encode_ns),
        dur(c.orsa_decode_ns)
    );
    match &net.sense_to_act {
        Some(st) => {
            let _ = writeln!(
                s,
                "\n## Sense to act, across processes\n\nSimulator, robot server, master and planner in the bench \
                 process, both behaviours in the other, over zenoh, in real time for {:.0} s ({}). {} velocity \
                 commands reached the motor board; {} were attributed to the wired behaviour's step ({}), {} were \
                 not. Stale commands refused: {}; restarts (both processes): {}.\n",
                st.duration_s,
                net.runtime,
                st.commands_received,
                st.attributed,
                st.by_behaviour.iter().map(|(b, n)| format!("{b} {n}")).collect::<Vec<_>>().join(", "),
                st.unattributed,
                st.stale_refused,
                st.restarts
            );
            let _ = writeln!(s, "| from | n | p50 | p99 | max |\n|---|---:|---:|---:|---:|");
            let _ = writeln!(s, "| sensor update published | {} |", lat_cells(&st.from_update));
            let _ = writeln!(
                s,
                "| newest sensor firing (adds the simulator's sampling) | {} |",
                lat_cells(&st.from_sensor_firing)
            );
            leg_rows(s, st);
        }
        None => {
            let _ = writeln!(s, "\nSense to act across processes: not measured in this run.");
        }
    }
}

/// The interop arms' section: each arm beside its baseline's two runs, its cost and the spread.
pub(crate) fn interop_table(live: &SenseToAct, ic: &InteropCost) -> String {
    let mut s = String::new();
    let calls = ic.services.ros2_calls.unwrap_or_default();
    let client = ic.publishing.live_client.as_ref();
    let _ = writeln!(
        s,
        "\nWhat the interop costs sense to act, each arm between two runs of its baseline in this run. The ROS 2 \
         parameter services: the robot's node (`orsa robot --ros2`'s own services over the components with live parameters) with a \
         ROS 2 client on a zenoh session of its own calling `get_parameters` back to back for a parameter of each \
         behaviour and of the master ({} calls answered, {} incomplete, {} failed); baseline: the stack \
         alone, on the robot's runtime (`orsa robot`'s: multi-thread, two workers; zenoh needs one). Client publish: the live client also publishing `TwistStamped` on `/cmd_vel` at 20 Hz, each \
         stamped 10 s ago so that it takes the whole path and is refused by the robot as stale ({} published, {} \
         handed to teleop, {} refused as stale); baseline: the live client only reading.\n",
        calls.answered,
        calls.incomplete,
        calls.failed,
        client.map_or(0, |c| c.published),
        client.map_or(0, |c| c.taken),
        ic.publishing.stale_refused
    );
    let _ = writeln!(
        s,
        "| sensor update published | n | p50 | p99 | max | the push (update published -> handler starts) p50 | p99 |\n|---|---:|---:|---:|---:|---:|---:|"
    );
    for (name, st) in [
        ("live client reading", live),
        ("reading and publishing", &ic.publishing),
        ("reading again", &ic.live_again),
        ("the stack alone, robot's runtime", &ic.robot),
        ("parameter services called", &ic.services),
        ("the stack alone again", &ic.robot_again),
    ] {
        let push = st.legs.first().map_or_else(
            || "- | -".to_string(),
            |l| format!("{} | {}", dur(l.latency.p50_ns), dur(l.latency.p99_ns)),
        );
        let _ = writeln!(s, "| {name} | {} | {push} |", lat_cells(&st.from_update));
    }
    for (what, arm, a, b) in [
        ("client publish", &ic.publishing, live, &ic.live_again),
        ("the services", &ic.services, &ic.robot, &ic.robot_again),
    ] {
        for (name, pick) in MonitorCost::PERCENTILES {
            let (cost, spread) = InteropCost::cost_and_spread(arm, a, b, pick);
            let _ = writeln!(
                s,
                "\n{what}, {name}: {:+.1} us; the spread is {:.1} us: {}.",
                cost / 1e3,
                spread / 1e3,
                if cost <= spread { "within it" } else { "outside it" }
            );
        }
    }
    s
}
