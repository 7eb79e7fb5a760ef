//! Intensity and escalation.

use super::*;

#[tokio::test(start_paused = true)]
async fn supervision_intensity_allows_n_restarts_and_the_next_one_fails_the_supervisor() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(3, Duration::from_secs(10))
            .with_child(worker("a"))
            .with_child(worker("b"))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    for n in 1..=3 {
        tell(&sup, "a", Cmd::Fail).await;
        assert_eq!(next(&mut rx).await.kind, Kind::ChildFailed);
        let restarted = next(&mut rx).await;
        assert_eq!(
            (restarted.kind, restarted.restart_count, restarted.restarts_in_period),
            (Kind::Restarted, n, n)
        );
        tokio::time::sleep(Duration::from_secs(3)).await; // 9 s in all: still within the period
    }
    let b = cell(&sup, "b").await;
    tell(&sup, "a", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::GaveUp)]);
    match next(&mut seen).await {
        Seen::Failed(id, Some(gave_up)) => {
            assert_eq!(id, sup.cell().get_id());
            assert_eq!(
                (gave_up.supervisor.as_str(), gave_up.child.as_str(), gave_up.intensity),
                ("s", "a", 3)
            );
        }
        other => panic!("expected the supervisor to fail with GaveUp, saw {other:?}"),
    }
    assert_eq!(b.get_status(), ActorStatus::Stopped, "children are stopped before escalating");
    assert!(drain(&mut rx).is_empty(), "no restart while giving up");
}

#[tokio::test(start_paused = true)]
async fn supervision_escalation_restarts_the_nested_supervisor_in_its_parent() {
    let (sink, mut rx) = event_channel();
    let inner = SupervisorSpec::new("inner", Strategy::OneForOne)
        .with_intensity(2, Duration::from_secs(5))
        .with_child(worker("w"));
    let top = Supervisor::start(
        SupervisorSpec::new("top", Strategy::OneForOne)
            .with_intensity(1, Duration::from_secs(60))
            .with_child(ChildSpec::supervisor("inner", inner))
            .with_child(worker("sibling"))
            .with_event_sink(sink),
    )
    .await
    .expect("start");
    let info = top.which_children().await.expect("which_children");
    let inner_ref = info[0].supervisor().expect("inner is a running supervisor");
    assert_eq!(inner_ref.name(), "inner");
    let sibling = info[1].cell.as_ref().map(|c| c.get_id());
    for _ in 0..2 {
        tell(&inner_ref, "w", Cmd::Fail).await;
        assert_eq!(
            events(&mut rx, 2).await,
            [ev("inner", "w", Kind::ChildFailed), ev("inner", "w", Kind::Restarted)]
        );
    }
    tell(&inner_ref, "w", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("inner", "w", Kind::ChildFailed),
            ev("inner", "w", Kind::GaveUp),
            ev("top", "inner", Kind::ChildFailed),
            ev("top", "inner", Kind::Restarted)
        ]
    );
    let info = top.which_children().await.expect("which_children");
    let new_inner = info[0].supervisor().expect("inner runs again");
    assert_ne!(new_inner.cell().get_id(), inner_ref.cell().get_id());
    assert_eq!(info[0].restart_count, 1);
    assert_eq!(info[1].cell.as_ref().map(|c| c.get_id()), sibling, "one-for-one: sibling untouched");
    let w = new_inner.which_children().await.expect("which_children");
    assert_eq!((w[0].restart_count, w[0].cell.is_some()), (0, true), "a fresh inner supervisor");
    top.shutdown().await;
    assert_eq!(new_inner.cell().get_status(), ActorStatus::Stopped);
}

#[tokio::test(start_paused = true)]
async fn supervision_restarts_spread_beyond_the_period_do_not_escalate() {
    let clock = Clock::simulated();
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(1, Duration::from_secs(5))
            .with_child(worker("a"))
            .with_clock(clock)
            .with_event_sink(sink),
    )
    .await
    .expect("start");
    for n in 1..=4u32 {
        tell(&sup, "a", Cmd::Fail).await;
        assert_eq!(next(&mut rx).await.kind, Kind::ChildFailed);
        let e = next(&mut rx).await;
        assert_eq!((e.kind, e.restart_count, e.restarts_in_period), (Kind::Restarted, n, 1));
        assert_eq!(e.at, Timestamp(u64::from(n - 1) * 5_001_000_000), "stamped with the given clock");
        // Just beyond the period (tokio's timer has millisecond resolution).
        tokio::time::sleep(Duration::from_millis(5001)).await;
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_a_restart_exactly_one_period_later_still_counts() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForOne)
            .with_intensity(1, Duration::from_secs(5))
            .with_child(worker("a"))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    tell(&sup, "a", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::Restarted)]);
    tokio::time::sleep(Duration::from_secs(5)).await;
    tell(&sup, "a", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::GaveUp)]);
    assert!(matches!(next(&mut seen).await, Seen::Failed(_, Some(_))));
}

#[tokio::test(start_paused = true)]
async fn supervision_zero_intensity_gives_up_on_the_first_restart() {
    let (sink, mut rx) = event_channel();
    let (parent, mut seen) = probe().await;
    let sup = Supervisor::start_linked(
        SupervisorSpec::new("s", Strategy::OneForAll)
            .with_intensity(0, Duration::from_secs(5))
            .with_child(worker("a").with_restart(Restart::Transient))
            .with_event_sink(sink),
        parent,
    )
    .await
    .expect("start");
    tell(&sup, "a", Cmd::Exit).await; // a transient normal exit is no restart
    assert_eq!(events(&mut rx, 1).await, [ev("s", "a", Kind::ChildExited)]);
    sup.restart_child("a").await.expect("restart_child");
    assert_eq!(events(&mut rx, 1).await, [ev("s", "a", Kind::Restarted)]);
    tell(&sup, "a", Cmd::Panic).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::ChildFailed), ev("s", "a", Kind::GaveUp)]);
    assert!(matches!(next(&mut seen).await, Seen::Failed(_, Some(_))));
}
