//! One Push newest server fanned out to N subscriber components, against N plain ractor actors
//! sent the same value by a loop of casts, on a current-thread runtime (as `orsa run` runs).
//!
//! Each round publishes once and waits until every subscriber's handler has run. Per round:
//! the publisher's cost (how long `put`, or the loop of casts, takes) and the latency to the
//! last subscriber's handler.

use super::inproc::{PushSub, RawSub, RuntimeKind};
use super::probe::{Probe, ns_since};
use super::{FanoutRow, say, stats};
use anyhow::anyhow;
use orsa_actors::Registry;
use orsa_actors::component::{ComponentHandle, spawn};
use orsa_actors::push_newest::PushNewestServer;
use ractor::{Actor, ActorRef};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The service the fan-out rows publish on.
const OUT: orsa_actors::service::PushNewestService<u64> = orsa_actors::service::PushNewestService::new("out");

/// Rounds for `n` subscribers: about `budget` handler runs in all, within bounds.
pub(crate) fn rounds_for(n: usize, budget: usize, min: usize) -> usize {
    (budget / n.max(1)).clamp(min, 2000)
}

struct Measured {
    put_ns: Vec<u64>,
    last_ns: Vec<u64>,
}

/// Latency to the last handler of each round: the largest of each round's `n` latencies.
fn last_of_rounds(lat: &[u64], n: usize) -> Vec<u64> {
    lat.chunks(n.max(1)).map(|c| c.iter().copied().max().unwrap_or(0)).collect()
}

async fn one(n: usize, rounds: usize, warmup: usize) -> anyhow::Result<FanoutRow> {
    let base = Instant::now();
    let registry = Registry::new();
    let server = PushNewestServer::<u64>::register(&registry, OUT.on("fan"))?;
    let orsa_probe = Probe::new(base);
    let mut subs: Vec<ComponentHandle<PushSub>> = Vec::with_capacity(n);
    for i in 0..n {
        let sub = PushSub { probe: Arc::clone(&orsa_probe), addr: OUT.on("fan") };
        subs.push(spawn(&registry, &format!("sub{i}"), sub).await?);
    }
    let raw_probe = Probe::new(base);
    let mut raws: Vec<ActorRef<u64>> = Vec::with_capacity(n);
    for _ in 0..n {
        let (a, _) = Actor::spawn(None, RawSub { probe: Arc::clone(&raw_probe) }, ())
            .await
            .map_err(|e| anyhow!("cannot spawn a ractor actor: {e}"))?;
        raws.push(a);
    }

    let total = warmup + rounds;
    let mut orsa = Measured { put_ns: Vec::with_capacity(total), last_ns: Vec::new() };
    let mut raw = Measured { put_ns: Vec::with_capacity(total), last_ns: Vec::new() };
    // Alternate orsa and raw rounds, so both see the same machine.
    for r in 0..total {
        let target = ((r + 1) * n) as u64;
        orsa_probe.expect(target);
        let t0 = ns_since(base);
        let got = server.put(t0);
        orsa.put_ns.push(ns_since(base) - t0);
        anyhow::ensure!(got == n, "put reached {got} of {n} subscribers");
        orsa_probe.wait(target).await;

        raw_probe.expect(target);
        let t0 = ns_since(base);
        for a in &raws {
            a.cast(t0).map_err(|_| anyhow!("a ractor subscriber is gone"))?;
        }
        raw.put_ns.push(ns_since(base) - t0);
        raw_probe.wait(target).await;
    }
    let skip = warmup * n;
    orsa.last_ns = last_of_rounds(orsa_probe.take().get(skip..).unwrap_or_default(), n);
    raw.last_ns = last_of_rounds(raw_probe.take().get(skip..).unwrap_or_default(), n);
    orsa.put_ns.drain(..warmup);
    raw.put_ns.drain(..warmup);
    let stats_pub = server.stats();
    for s in &subs {
        s.stop().await;
    }
    for a in &raws {
        a.stop(None);
    }
    let (op, ol) = (stats::summarize(orsa.put_ns), stats::summarize(orsa.last_ns));
    let (rp, rl) = (stats::summarize(raw.put_ns), stats::summarize(raw.last_ns));
    Ok(FanoutRow {
        subscribers: n,
        rounds,
        orsa_publish: op,
        orsa_last_handler: ol,
        raw_publish: rp,
        raw_last_handler: rl,
        last_p50_ratio: stats::ratio(ol.p50_ns, rl.p50_ns),
        orsa_ns_per_subscriber: ol.p50_ns / n as f64,
        raw_ns_per_subscriber: rl.p50_ns / n as f64,
        delivered: stats_pub.delivered,
        expected: (total * n) as u64,
        handled: orsa_probe.count(),
    })
}

/// Fan-out to each of `sizes` subscriber counts; rounds per size from `rounds(n)`.
pub(crate) fn run(sizes: &[usize], rounds: impl Fn(usize) -> usize) -> anyhow::Result<Vec<FanoutRow>> {
    let rt = RuntimeKind::CurrentThread.build()?;
    let mut rows = Vec::new();
    for &n in sizes {
        if n == 0 {
            continue;
        }
        let r = rounds(n);
        say(format!("  fan-out to {n} subscribers, {r} rounds"));
        let row = rt.block_on(async {
            tokio::time::timeout(Duration::from_secs(120), one(n, r, (r / 10).max(5)))
                .await
                .map_err(|_| anyhow!("the fan-out to {n} did not finish in 120 s"))?
        })?;
        rows.push(row);
    }
    rt.shutdown_timeout(Duration::from_secs(1));
    Ok(rows)
}
