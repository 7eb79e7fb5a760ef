//! Shutdown.

use super::*;

#[tokio::test(start_paused = true)]
async fn supervision_child_ignoring_shutdown_is_killed_after_its_timeout() {
    let (log, mut lines) = unbounded_channel();
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(logged("h", &log).with_shutdown(Shutdown::Timeout(Duration::from_millis(2500)))),
    )
    .await
    .expect("start");
    let h = cell(&sup, "h").await;
    tell(&sup, "h", Cmd::Hang).await;
    assert_eq!(next(&mut lines).await, "start h");
    assert_eq!(next(&mut lines).await, "hang h");
    let t0 = Instant::now();
    sup.terminate_child("h").await.expect("terminate_child");
    assert_eq!(t0.elapsed(), Duration::from_millis(2500));
    assert_eq!(h.get_status(), ActorStatus::Stopped);
    assert!(drain(&mut lines).is_empty(), "killed: post_stop never ran");
    assert!(sup.child("h").await.expect("which_children").is_none(), "terminated, not restarted");
    assert!(drain(&mut rx).is_empty());
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_shutdown_stops_children_in_reverse_order_honouring_their_shutdown() {
    let (log, mut lines) = unbounded_channel();
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(logged("a", &log))
            .with_child(logged("b", &log).with_shutdown(Shutdown::Timeout(Duration::from_secs(3))))
            .with_child(logged("c", &log).with_shutdown(Shutdown::Brutal))
            .with_child(logged("d", &log)),
    )
    .await
    .expect("start");
    tell(&sup, "b", Cmd::Hang).await;
    let mut seen = Vec::new();
    for _ in 0..5 {
        seen.push(next(&mut lines).await);
    }
    assert_eq!(seen, ["start a", "start b", "start c", "start d", "hang b"]);
    let children: Vec<ActorCell> =
        sup.which_children().await.expect("which_children").into_iter().filter_map(|c| c.cell).collect();
    let t0 = Instant::now();
    sup.shutdown().await;
    assert_eq!(t0.elapsed(), Duration::from_secs(3), "only b's timeout was waited for");
    // d stops gracefully, c is killed (no post_stop), b is killed after 3 s, a stops.
    assert_eq!(drain(&mut lines), ["stop d", "stop a"]);
    assert!(children.iter().all(|c| c.get_status() == ActorStatus::Stopped));
    assert_eq!(sup.cell().get_status(), ActorStatus::Stopped);
    assert!(drain(&mut rx).is_empty(), "no exits reported, no restarts while shutting down");
}

#[tokio::test(start_paused = true)]
async fn supervision_failures_while_shutting_down_cause_no_restart() {
    let (sink, mut rx) = event_channel();
    let failing = Worker { id: "f", fail_in_post_stop: true, ..Worker::default() };
    let sup = Supervisor::start(
        spec("s", Strategy::OneForAll, sink).with_child(worker("a")).with_child(ChildSpec::actor(
            "f",
            failing,
            || (),
        )),
    )
    .await
    .expect("start");
    let children: Vec<ActorCell> =
        sup.which_children().await.expect("which_children").into_iter().filter_map(|c| c.cell).collect();
    sup.shutdown().await;
    assert!(children.iter().all(|c| c.get_status() == ActorStatus::Stopped));
    assert!(drain(&mut rx).is_empty(), "f's failure in post_stop restarted nothing");
}
