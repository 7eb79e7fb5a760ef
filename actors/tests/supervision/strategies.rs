//! Strategies.

use super::*;

#[tokio::test(start_paused = true)]
async fn supervision_one_for_one_restarts_only_the_failed_child() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(worker("a"))
            .with_child(worker("b"))
            .with_child(worker("c")),
    )
    .await
    .expect("start");
    let before = ids(&sup).await;
    tell(&sup, "b", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "b", Kind::ChildFailed), ev("s", "b", Kind::Restarted)]);
    let after = ids(&sup).await;
    assert_eq!(after[0], before[0]);
    assert_ne!(after[1].1, before[1].1);
    assert!(after[1].1.is_some());
    assert_eq!(after[2], before[2]);
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_one_for_all_stops_in_reverse_and_restarts_all_in_order() {
    let (sink, mut rx) = event_channel();
    let (log, mut lines) = unbounded_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForAll, sink)
            .with_child(logged("a", &log))
            .with_child(logged("b", &log))
            .with_child(logged("c", &log)),
    )
    .await
    .expect("start");
    assert_eq!(drain(&mut lines), ["start a", "start b", "start c"]);
    let before = ids(&sup).await;
    tell(&sup, "b", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("s", "b", Kind::ChildFailed),
            ev("s", "a", Kind::Restarted),
            ev("s", "b", Kind::Restarted),
            ev("s", "c", Kind::Restarted)
        ]
    );
    // b failed (no post_stop); c and a were stopped in reverse order, then all started in order.
    assert_eq!(drain(&mut lines), ["stop c", "stop a", "start a", "start b", "start c"]);
    let after = ids(&sup).await;
    for (b, a) in before.iter().zip(&after) {
        assert_ne!(b.1, a.1, "{} was not restarted", b.0);
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_rest_for_one_restarts_the_failed_child_and_those_after_it() {
    let (sink, mut rx) = event_channel();
    let (log, mut lines) = unbounded_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::RestForOne, sink)
            .with_child(logged("a", &log))
            .with_child(logged("b", &log))
            .with_child(logged("c", &log))
            .with_child(logged("d", &log)),
    )
    .await
    .expect("start");
    drain(&mut lines);
    let before = ids(&sup).await;
    tell(&sup, "b", Cmd::Fail).await;
    assert_eq!(
        events(&mut rx, 4).await,
        [
            ev("s", "b", Kind::ChildFailed),
            ev("s", "b", Kind::Restarted),
            ev("s", "c", Kind::Restarted),
            ev("s", "d", Kind::Restarted)
        ]
    );
    assert_eq!(drain(&mut lines), ["stop d", "stop c", "start b", "start c", "start d"]);
    let after = ids(&sup).await;
    assert_eq!(after[0], before[0], "a was started before b: untouched");
    for i in 1..4 {
        assert_ne!(after[i].1, before[i].1);
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_exit_of_a_replaced_instance_is_ignored() {
    // a and b fail together; a's restart (one-for-all) replaces b, whose own exit then
    // belongs to a former instance: one restart, not two.
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForAll, sink).with_child(worker("a")).with_child(worker("b")),
    )
    .await
    .expect("start");
    let (a, b) = (cell(&sup, "a").await, cell(&sup, "b").await);
    ActorRef::<Cmd>::from(a.clone()).cast(Cmd::Fail).expect("cast");
    ActorRef::<Cmd>::from(b.clone()).cast(Cmd::Fail).expect("cast");
    let first = next(&mut rx).await;
    assert_eq!(first.kind, Kind::ChildFailed);
    assert_eq!(events(&mut rx, 2).await, [ev("s", "a", Kind::Restarted), ev("s", "b", Kind::Restarted)]);
    let children = sup.which_children().await.expect("which_children");
    assert!(children.iter().all(|c| c.restart_count == 1 && c.cell.is_some()));
    assert!(drain(&mut rx).is_empty(), "the second exit caused nothing");
    let last = children.last().and_then(|c| c.cell.clone()).expect("b runs");
    assert_ne!(last.get_id(), b.get_id());
    sup.shutdown().await;
}
