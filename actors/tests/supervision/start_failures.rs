//! Start failures.

use super::*;

#[tokio::test(start_paused = true)]
async fn supervision_start_failure_during_restart_is_retried_and_counted() {
    let (sink, mut rx) = event_channel();
    let refuse = Arc::new(AtomicU32::new(0));
    let flaky = Worker { id: "f", refuse_starts: Some(refuse.clone()), ..Worker::default() };
    let sup = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(3, Duration::from_secs(5))
            .with_child(ChildSpec::actor("f", flaky, || ()))
            .with_event_sink(sink),
    )
    .await
    .expect("start");
    refuse.store(2, Ordering::SeqCst);
    tell(&sup, "f", Cmd::Fail).await;
    let mut got = Vec::new();
    for _ in 0..4 {
        let e = next(&mut rx).await;
        got.push((e.kind, e.restarts_in_period));
    }
    assert_eq!(
        got,
        [(Kind::ChildFailed, 0), (Kind::StartFailed, 1), (Kind::StartFailed, 2), (Kind::Restarted, 3)]
    );
    assert!(sup.child("f").await.expect("which_children").is_some());
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_a_child_that_never_starts_again_exhausts_the_intensity() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let refuse = Arc::new(AtomicU32::new(0));
    let flaky = Worker { id: "f", refuse_starts: Some(refuse.clone()), ..Worker::default() };
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(2, Duration::from_secs(5))
            .with_child(ChildSpec::actor("f", flaky, || ()))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    refuse.store(u32::MAX, Ordering::SeqCst);
    tell(&sup, "f", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("s", "f", Kind::ChildFailed),
            ev("s", "f", Kind::StartFailed),
            ev("s", "f", Kind::StartFailed),
            ev("s", "f", Kind::GaveUp)
        ]
    );
    assert!(matches!(next(&mut seen).await, Seen::Failed(id, Some(_)) if id == sup.cell().get_id()));
}

#[tokio::test(start_paused = true)]
async fn supervision_initial_start_failure_stops_the_children_already_started() {
    let (log, mut lines) = unbounded_channel();
    let refusing = Worker { refuse_starts: Some(Arc::new(AtomicU32::new(1))), ..Worker::logging("b", &log) };
    let result = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_child(logged("a", &log))
            .with_child(ChildSpec::actor("b", refusing, || ()))
            .with_child(logged("c", &log)),
    )
    .await;
    match result {
        Err(StartError::ChildStart { supervisor, child, reason }) => {
            assert_eq!((supervisor.as_str(), child.as_str()), ("s", "b"));
            assert!(reason.contains("refusing to start"), "{reason}");
        }
        other => panic!("expected a child start error, got {other:?}"),
    }
    assert_eq!(drain(&mut lines), ["start a", "stop a"]);
    let dup = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne).with_child(worker("a")).with_child(worker("a")),
    )
    .await;
    assert!(matches!(dup, Err(StartError::DuplicateChild { child, .. }) if child == "a"));
}

#[tokio::test(start_paused = true)]
async fn supervision_a_failed_start_is_retried_after_a_delay_that_doubles_and_resets_once_it_starts() {
    let (sink, mut rx) = event_channel();
    let refuse = Arc::new(AtomicU32::new(0));
    let flaky = Worker { id: "f", refuse_starts: Some(refuse.clone()), ..Worker::default() };
    let sup = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(10, Duration::from_secs(60))
            .with_retry_delay(Duration::from_millis(100))
            .with_child(ChildSpec::actor("f", flaky, || ()))
            .with_event_sink(sink),
    )
    .await
    .expect("start");
    for round in 0..2 {
        refuse.store(3, Ordering::SeqCst);
        tell(&sup, "f", Cmd::Fail).await;
        let failed = next(&mut rx).await;
        assert_eq!(failed.kind, Kind::ChildFailed);
        let t0 = tokio::time::Instant::now();
        let mut at = Vec::new();
        for _ in 0..4 {
            let e = next(&mut rx).await;
            at.push((e.kind, t0.elapsed().as_millis()));
        }
        // Started at once and failed; retried after 100, then 200, then 400 ms more.
        assert_eq!(
            at,
            [
                (Kind::StartFailed, 0),
                (Kind::StartFailed, 100),
                (Kind::StartFailed, 300),
                (Kind::Restarted, 700)
            ],
            "round {round}: the delay starts again from 100 ms after a start that worked"
        );
    }
    sup.shutdown().await;
}
