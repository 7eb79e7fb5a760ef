//! What `orsa robot --ros2` adds to the robot's cross-process push: the sonar ring pushed to a
//! remote subscriber, back to back, with and without the ROS 2 publication of the same scans
//! (the robot's own conversion to `sensor_msgs/msg/LaserScan`, CDR, and a put on the session,
//! received by a ROS 2 subscriber on the other side), blocks of each in turn, in the same run.
//!
//! Two zenoh sessions over loopback TCP, in this process: the robot's (listening) and the
//! subscriber's (connecting). The push crosses the sessions as it crosses processes (encoding,
//! TCP, decoding), and the ROS 2 path runs as in the robot: an in-process subscriber of the
//! push, subscribed first, whose sink converts, encodes and puts each scan where the push
//! delivers it (the robot's own `scan_sink`). The cost is the time from the push until the
//! remote subscriber's sink has it (p50); the ratio is with the ROS 2 path over without. The
//! ROS 2 path's own time per scan (convert, encode, put) is given beside it.
//!
//! A third arm has the robot node's parameter services (the robot's own `ParamServices`) called
//! back to back by a ROS 2 client on the other session while the push runs with the ROS 2
//! publication: its p50 over the publication alone's, against the spread of the latter's blocks.
//! The bench's robot is a bare push server with no parameter service, so every call is answered
//! with the parameters not set: this arm measures the service layer (query, CDR, reply); the
//! round trip through the components is measured on sense to act (`sense::Arm::Ros2Services`).
//!
//! Handing each scan to a task instead (what the robot did first) measured 1.09-1.21x with the
//! ROS 2 subscriber first, as in the robot; publishing in the sink 1.08-1.15x, with no queue
//! that could grow.

use super::{Ros2Cost, say, stats};
use anyhow::{Context as _, bail};
use orsa_actors::push_newest::{PushNewestClient, PushNewestServer};
use orsa_actors::service::PushNewestService;
use orsa_actors::{Registry, Sink, Timestamp, Update};
use orsa_interfaces::nomad200::{DistanceReading, DistanceScan, RING_SIZE, Ring, RingParams, ring_angle_rad};
use orsa_net::ros2::msg::LaserScan;
use orsa_net::ros2::rcl::{GetParameters, NamesRequest};
use orsa_net::ros2::{Qos, Ros2Options};
use orsa_net::{NetOptions, ZenohTransport};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

const SCAN: PushNewestService<DistanceScan> = PushNewestService::new("distanceson");

fn scan(seq: u64) -> DistanceScan {
    DistanceScan {
        stamp: Timestamp(seq),
        ring: Ring::Sonar,
        readings: (0..RING_SIZE)
            .map(|i| DistanceReading {
                sensor_id: i as u8,
                stamp: Timestamp(seq),
                valid: i % 5 != 0,
                distance_m: 1.0 + i as f64 * 0.1,
            })
            .collect(),
    }
}

fn ring() -> RingParams {
    RingParams {
        angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
        mount_radius_m: 0.25,
        beam_width_rad: 0.44,
        min_range_m: 0.3,
        max_range_m: 6.0,
        fire_period_s: 0.004,
    }
}

/// Measures `samples` pushes each way, in blocks of 50 taking turns.
pub(crate) fn run(samples: usize) -> anyhow::Result<Ros2Cost> {
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?;
    let out = rt.block_on(async move {
        tokio::time::timeout(Duration::from_secs(120 + samples as u64 / 50), bench(samples))
            .await
            .context("the ROS 2 bench did not finish in time")?
    });
    rt.shutdown_timeout(Duration::from_secs(2));
    out
}

async fn bench(samples: usize) -> anyhow::Result<Ros2Cost> {
    let port = std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let prefix = format!("benchros{port}");
    let robot = Registry::new();
    let robot_net = ZenohTransport::open(
        &robot,
        &NetOptions { listen: vec![endpoint.clone()], prefix: prefix.clone(), ..NetOptions::default() },
        "robot",
    )
    .await?;
    let server = PushNewestServer::<DistanceScan>::register(&robot, SCAN.on("robot"))?;
    let other = Registry::new();
    let other_net = ZenohTransport::open(
        &other,
        &NetOptions { connect: vec![endpoint], prefix, ..NetOptions::default() },
        "tool",
    )
    .await?;
    if let Err(missing) = other_net.wait_for(&[SCAN.on("robot").untyped()], Duration::from_secs(30)).await {
        bail!("the robot's scan service did not appear: {missing:?}");
    }
    // The ROS 2 path as the robot runs it (`orsa::remote::ros2::scan_sink`: converted,
    // encoded and put in the push's own delivery), subscribed before the remote subscriber as
    // in the robot, which starts its ROS 2 node before any peer subscribes. Between the blocks
    // with it, its sink is skipped.
    let options = |name: &str| Ros2Options { domain: 0, namespace: "/".into(), name: name.into() };
    let node = robot_net.ros2_node(&options("orsa")).await?;
    let ros2 =
        orsa::remote::ros2::scan_sink(node.publisher::<LaserScan>("scan", Qos::SensorData).await?, ring());
    let ros2_on = Arc::new(AtomicBool::new(false));
    let publish_ns = Arc::new(parking_lot::Mutex::new(Vec::with_capacity(samples)));
    // The node's parameter services (the robot's own code), over a directory of one
    // component; a client on the other session calls them while the services' blocks run.
    let _params = orsa::remote::ros2::ParamServices::serve(
        &node,
        orsa::system::live_params::ParamDirectory::new(&robot, vec!["nomad200".into()]),
    )
    .await?;
    let (on, times) = (Arc::clone(&ros2_on), Arc::clone(&publish_ns));
    let face = PushNewestClient::<DistanceScan>::connect_to(
        &robot,
        SCAN.on("robot"),
        Sink::from_fn(move |u: Update<DistanceScan>| {
            if on.load(Ordering::Relaxed) {
                let t = Instant::now();
                ros2.deliver(u)?;
                times.lock().push(t.elapsed().as_nanos() as u64);
            }
            Ok(())
        }),
    )?;
    face.subscribe()?;
    let (tx, mut got) = tokio::sync::watch::channel(0u64);
    let remote = PushNewestClient::<DistanceScan>::connect_to(
        &other,
        SCAN.on("robot"),
        Sink::from_fn(move |u: Update<DistanceScan>| {
            tx.send_replace(u.value.stamp.0);
            Ok(())
        }),
    )?;
    remote.subscribe()?;
    // A ROS 2 subscriber on the other session.
    let listener = other_net.ros2_node(&options("listener")).await?;
    let received = Arc::new(AtomicU64::new(0));
    let r = Arc::clone(&received);
    let _sub = listener
        .subscribe::<LaserScan>("scan", Qos::SensorData, move |_, _| {
            r.fetch_add(1, Ordering::Relaxed);
        })
        .await?;

    let caller = listener.client::<GetParameters>("/orsa/get_parameters").await?;
    let calling = Arc::new(AtomicBool::new(false));
    let done = Arc::new(AtomicBool::new(false));
    let calls = Arc::new(AtomicU64::new(0));
    let (go, answered, end) = (Arc::clone(&calling), Arc::clone(&calls), Arc::clone(&done));
    let request =
        NamesRequest { names: vec!["nomad200.cmd_timeout_s".into(), "nomad200.max_clock_skew_s".into()] };
    // Back to back while the services' blocks run: the harshest a `ros2 param` user could be.
    let client_task = tokio::spawn(async move {
        while !end.load(Ordering::Relaxed) {
            if !go.load(Ordering::Relaxed) {
                tokio::time::sleep(Duration::from_millis(1)).await;
            } else if caller.call(&request, Duration::from_secs(1)).await.is_ok() {
                answered.fetch_add(1, Ordering::Relaxed);
            }
        }
    });

    let mut seq = 0u64;
    let (mut plain, mut with, mut services, mut lost) = (Vec::new(), Vec::new(), Vec::new(), 0u64);
    let mut with_blocks = Vec::new();
    // The first push of all waits for the subscription to reach the robot.
    let deadline = Instant::now() + Duration::from_secs(10);
    while *got.borrow() == 0 {
        seq += 1;
        server.put(scan(seq));
        if Instant::now() > deadline {
            bail!("the remote subscriber received nothing in 10 s");
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let blocks = samples.div_ceil(50);
    for block in 0..blocks * 3 {
        // Plain, with the ROS 2 publication, and with it while the services are called, in turn.
        let arm = block % 3;
        ros2_on.store(arm > 0, Ordering::Relaxed);
        calling.store(arm == 2, Ordering::Relaxed);
        let mut this_block = Vec::with_capacity(50);
        for _ in 0..50 {
            seq += 1;
            let t = Instant::now();
            server.put(scan(seq));
            let arrived = tokio::time::timeout(Duration::from_secs(1), got.wait_for(|s| *s >= seq)).await;
            match arrived {
                Ok(Ok(_)) => this_block.push(t.elapsed().as_nanos() as u64),
                _ => lost += 1,
            }
        }
        if arm == 1 {
            let mut sorted = this_block.clone();
            sorted.sort_unstable();
            with_blocks.extend(stats::percentile(&sorted, 50.0));
        }
        [&mut plain, &mut with, &mut services][arm].extend(this_block);
    }
    calling.store(false, Ordering::Relaxed);
    // The last call ends (answered, or after its 1 s) before the sessions close.
    done.store(true, Ordering::Relaxed);
    let _ = client_task.await;
    drop(face);
    with_blocks.sort_unstable();
    let spread = match (
        stats::percentile(&with_blocks, 25.0),
        stats::percentile(&with_blocks, 50.0),
        stats::percentile(&with_blocks, 75.0),
    ) {
        (Some(q1), Some(m), Some(q3)) if m > 0 => (q3 - q1) as f64 / m as f64,
        _ => f64::NAN,
    };
    let (plain, with_ros2, with_services) =
        (stats::summarize(plain), stats::summarize(with), stats::summarize(services));
    let mut times = std::mem::take(&mut *publish_ns.lock());
    times.sort_unstable();
    let cost = Ros2Cost {
        p50_ratio: stats::ratio(with_ros2.p50_ns, plain.p50_ns),
        ros2_publish_p50_ns: stats::percentile(&times, 50.0).map_or(f64::NAN, |v| v as f64),
        ros2_received: received.load(Ordering::Relaxed),
        services_p50_ratio: stats::ratio(with_services.p50_ns, with_ros2.p50_ns),
        with_ros2_spread: spread,
        service_calls: calls.load(Ordering::Relaxed),
        plain,
        with_ros2,
        with_services,
        lost,
    };
    say(format!(
        "  ROS 2 publication: push p50 {:.1} us plain, {:.1} us with it ({:.2}x); its own path {:.1} us a scan; {} LaserScans received, {} lost",
        cost.plain.p50_ns / 1e3,
        cost.with_ros2.p50_ns / 1e3,
        cost.p50_ratio.unwrap_or(f64::NAN),
        cost.ros2_publish_p50_ns / 1e3,
        cost.ros2_received,
        cost.lost
    ));
    say(format!(
        "  ROS 2 parameter services called back to back: push p50 {:.1} us ({:.2}x the publication alone, whose spread is {:.2}); {} calls answered",
        cost.with_services.p50_ns / 1e3,
        cost.services_p50_ratio.unwrap_or(f64::NAN),
        cost.with_ros2_spread,
        cost.service_calls
    ));
    drop(remote);
    robot_net.close().await;
    other_net.close().await;
    Ok(cost)
}
