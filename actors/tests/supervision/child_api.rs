//! The child API.

use super::*;

#[tokio::test(start_paused = true)]
async fn supervision_which_children_terminate_restart_delete_and_start_child() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(worker("a"))
            .with_child(worker("b").with_restart(Restart::Transient))
            .with_child(worker("c").with_restart(Restart::Temporary).with_shutdown(Shutdown::Brutal)),
    )
    .await
    .expect("start");
    let info = sup.which_children().await.expect("which_children");
    let summary: Vec<_> =
        info.iter().map(|c| (c.id.as_str(), c.restart, c.restart_count, c.cell.is_some())).collect();
    assert_eq!(
        summary,
        [
            ("a", Restart::Permanent, 0, true),
            ("b", Restart::Transient, 0, true),
            ("c", Restart::Temporary, 0, true)
        ]
    );
    assert_eq!(info[2].shutdown, Shutdown::Brutal);
    assert!(info[0].supervisor().is_none());

    let b = cell(&sup, "b").await;
    sup.terminate_child("b").await.expect("terminate_child");
    assert_eq!(b.get_status(), ActorStatus::Stopped);
    assert!(sup.child("b").await.expect("which_children").is_none());
    assert!(matches!(sup.delete_child("a").await, Err(ChildError::Running { .. })));
    assert!(matches!(sup.restart_child("a").await, Err(ChildError::Running { .. })));

    let b2 = sup.restart_child("b").await.expect("restart_child");
    assert_ne!(b2.get_id(), b.get_id());
    let e = next(&mut rx).await;
    assert_eq!(
        (e.child.as_str(), e.kind, e.restart_count, e.reason.as_str()),
        ("b", Kind::Restarted, 1, "restart_child")
    );

    sup.terminate_child("c").await.expect("terminate_child");
    sup.terminate_child("b").await.expect("terminate_child");
    sup.delete_child("b").await.expect("delete_child");
    assert_eq!(ids(&sup).await.len(), 1, "c (temporary) left when terminated, b was deleted");
    assert!(matches!(sup.restart_child("b").await, Err(ChildError::NotFound { .. })));
    assert!(matches!(sup.terminate_child("zz").await, Err(ChildError::NotFound { .. })));

    let d = sup.start_child(worker("d")).await.expect("start_child");
    assert_eq!(sup.child("d").await.expect("which_children").map(|c| c.get_id()), Some(d.get_id()));
    assert!(matches!(sup.start_child(worker("a")).await, Err(ChildError::AlreadyPresent { .. })));
    let refusing = Worker { refuse_starts: Some(Arc::new(AtomicU32::new(1))), ..Worker::default() };
    assert!(matches!(
        sup.start_child(ChildSpec::actor("e", refusing, || ())).await,
        Err(ChildError::Start { .. })
    ));
    let order: Vec<_> = ids(&sup).await.into_iter().map(|(id, _)| id).collect();
    assert_eq!(order, ["a", "d"]);
    assert!(drain(&mut rx).is_empty(), "terminations by request are not exits");

    sup.shutdown().await;
    assert!(matches!(sup.which_children().await, Err(ChildError::Unreachable { .. })));
}
