//! The peer process of the cross-process bench (`orsa-bench --peer ENDPOINT`, a hidden flag):
//! it connects to the bench process, offers two Push newest services and two raw zenoh
//! publishers, and sends one sample whenever a go arrives (see [`super::net`]). On request it
//! also runs both behaviours, traced, against the robot in the bench process (sense to act
//! across processes, see [`super::sense::across`]).
//!
//! It leaves on `Quit`, when the bench process's zenoh session disappears, when its stdin
//! closes (the bench process died without saying so), or after an hour at most.

use super::net::{
    BENCH_ROLE, CONTROL, Go, PATHS, PEER, PEER_ROLE, PeerReply, PeerRequest, RawKeys, SAMPLE, SAMPLE_SINK,
    Sample, cbor, prefix_for, runtime, uncbor, unix_ns,
};
use anyhow::{Context as _, anyhow};
use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::{QueryRequest, QueryServer};
use orsa_actors::{Clock, Registry, Sink};
use orsa_net::{NetOptions, ZenohTransport};
use std::future::IntoFuture as _;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// The longest a peer lives.
const LIFETIME: Duration = Duration::from_secs(3600);

/// Runs the peer until it is told to leave.
pub(crate) fn main(endpoint: &str) -> anyhow::Result<()> {
    // The bench process holds our stdin: end of file means it is gone.
    std::thread::spawn(|| {
        use std::io::Read as _;
        let mut buf = [0u8; 64];
        let mut stdin = std::io::stdin();
        loop {
            match stdin.read(&mut buf) {
                Ok(0) | Err(_) => std::process::exit(0),
                Ok(_) => {}
            }
        }
    });
    let rt = runtime()?;
    let endpoint = endpoint.to_string();
    let out = rt.block_on(async move {
        match tokio::spawn(tokio::time::timeout(LIFETIME, serve(endpoint))).await {
            Ok(Ok(result)) => result,
            Ok(Err(_)) => Ok(()),
            Err(e) => Err(anyhow!("the bench peer failed: {e}")),
        }
    });
    rt.shutdown_timeout(Duration::from_secs(1));
    out
}

async fn serve(endpoint: String) -> anyhow::Result<()> {
    let prefix = prefix_for(&endpoint);
    let clock = Clock::start();
    let registry = Registry::with_clock(clock);
    let to_component = PushNewestServer::<Sample>::register(&registry, SAMPLE.on(PEER))?;
    let to_sink = PushNewestServer::<Sample>::register(&registry, SAMPLE_SINK.on(PEER))?;
    let (ctl_tx, mut ctl_rx) = mpsc::unbounded_channel::<QueryRequest<PeerRequest, PeerReply>>();
    let _control =
        QueryServer::<PeerRequest, PeerReply>::register(&registry, CONTROL.on(PEER), Sink::channel(ctl_tx))?;
    let options = NetOptions { connect: vec![endpoint], prefix: prefix.clone(), ..NetOptions::default() };
    let transport = ZenohTransport::open(&registry, &options, PEER_ROLE).await?;
    let (lost_tx, mut lost_rx) = mpsc::unbounded_channel::<()>();
    transport.on_process_lost(move |p| {
        if p.role == BENCH_ROLE {
            let _ = lost_tx.send(());
        }
    });

    let keys = RawKeys::new(&prefix);
    let session = transport.session();
    let raw_callback = session
        .declare_publisher(keys.callback.clone())
        .express(true)
        .await
        .map_err(|e| anyhow!("raw publisher: {e}"))?;
    let raw_task = session
        .declare_publisher(keys.task.clone())
        .express(true)
        .await
        .map_err(|e| anyhow!("raw publisher: {e}"))?;
    let raw_actor = session
        .declare_publisher(keys.actor.clone())
        .express(true)
        .await
        .map_err(|e| anyhow!("raw publisher: {e}"))?;
    let (go_tx, mut go_rx) = mpsc::unbounded_channel::<Go>();
    let _go = session
        .declare_subscriber(keys.go.clone())
        .callback(move |s| {
            if let Some(g) = uncbor::<Go>(&s.payload().to_bytes()) {
                let _ = go_tx.send(g);
            }
        })
        .await
        .map_err(|e| anyhow!("go subscriber: {e}"))?;

    let padding = Sample::padding();
    // One sample on one path; the send time is taken after the sample is built, just before
    // orsa's `put` or the raw path's encoding. Notes how long sending took.
    let mut put_ns: Vec<Vec<u64>> = vec![Vec::new(); PATHS.len()];
    let send = |g: Go, put_ns: &mut Vec<Vec<u64>>| {
        let mut s = Sample { seq: g.seq, sent_unix_ns: 0, readings: padding.clone() };
        let t0 = Instant::now();
        let ok = match g.path {
            0 | 1 => {
                let server = if g.path == 0 { &to_component } else { &to_sink };
                s.sent_unix_ns = unix_ns();
                server.put(s);
                true
            }
            2..=4 => {
                let publisher = match g.path {
                    2 => &raw_callback,
                    3 => &raw_task,
                    _ => &raw_actor,
                };
                s.sent_unix_ns = unix_ns();
                publisher.put(cbor(&s)).into_future().into_inner().is_ok()
            }
            _ => false,
        };
        let took = u64::try_from(t0.elapsed().as_nanos()).unwrap_or(u64::MAX);
        match put_ns.get_mut(usize::from(g.path)) {
            Some(v) if ok => v.push(took),
            _ => tracing::warn!("bench peer: could not send {g:?}"),
        }
    };
    let mut behaviours: Option<super::sense::PeerBehaviours> = None;
    loop {
        tokio::select! {
            Some(g) = go_rx.recv() => send(g, &mut put_ns),
            Some(q) = ctl_rx.recv() => {
                let request = q.request.value.clone();
                let reply = match request {
                    PeerRequest::Ping => PeerReply::Ok,
                    PeerRequest::StartBehaviours { robot } => {
                        if let Some(b) = behaviours.take() {
                            b.stop().await;
                        }
                        match super::sense::PeerBehaviours::start(&registry, &transport, &robot).await {
                            Ok(b) => {
                                behaviours = Some(b);
                                PeerReply::Ok
                            }
                            Err(e) => PeerReply::Failed { reason: format!("{e:#}") },
                        }
                    }
                    PeerRequest::StopBehaviours => match behaviours.take() {
                        Some(b) => {
                            let (steps, restarts) = b.stop().await;
                            PeerReply::Steps { steps, restarts }
                        }
                        None => PeerReply::Failed { reason: "no behaviours are running".into() },
                    },
                    PeerRequest::Stream { per_path, first_seq, spacing_us } => {
                        let mut tick = tokio::time::interval(Duration::from_micros(spacing_us.max(100)));
                        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
                        let paths = first_seq.len() as u64;
                        for k in 0..per_path * paths {
                            tick.tick().await;
                            let path = (k % paths) as usize;
                            let seq = first_seq[path] + k / paths;
                            send(Go { path: u8::try_from(path).unwrap_or(u8::MAX), seq }, &mut put_ns);
                        }
                        PeerReply::Ok
                    }
                    PeerRequest::TakePutCosts => PeerReply::PutCosts {
                        per_path: put_ns.iter_mut().map(|v| super::stats::summarize(std::mem::take(v))).collect(),
                    },
                    PeerRequest::Quit => {
                        let _ = q.answer(PeerReply::Ok);
                        break;
                    }
                };
                let _ = q.answer(reply);
            }
            _ = lost_rx.recv() => break,
            else => break,
        }
    }
    if let Some(b) = behaviours.take() {
        b.stop().await;
    }
    // Let the last answer leave before the session closes.
    tokio::time::sleep(Duration::from_millis(100)).await;
    transport.close().await;
    Ok(())
}

/// Runs `main` for `endpoint`, reporting failures with context (used by `orsa-bench --peer`).
pub(crate) fn run(endpoint: &str) -> anyhow::Result<()> {
    main(endpoint).with_context(|| format!("bench peer for {endpoint}"))
}
