//! Restart types.

use super::*;

#[tokio::test(start_paused = true)]
async fn supervision_permanent_child_is_restarted_after_exit_failure_panic_and_kill() {
    let (sink, mut rx) = event_channel();
    let sup =
        Supervisor::start(spec("s", Strategy::OneForOne, sink).with_child(worker("p"))).await.expect("start");
    let mut last = cell(&sup, "p").await.get_id();
    for (cmd, kind, reason) in [
        (Some(Cmd::Exit), Kind::ChildExited, "normal"),
        (Some(Cmd::Fail), Kind::ChildFailed, "told to fail"),
        (Some(Cmd::Panic), Kind::ChildFailed, "told to panic"),
        (None, Kind::ChildFailed, "killed"),
    ] {
        match cmd {
            Some(cmd) => tell(&sup, "p", cmd).await,
            None => cell(&sup, "p").await.kill(),
        }
        let exit = next(&mut rx).await;
        assert_eq!((exit.kind, exit.child.as_str()), (kind, "p"));
        assert!(exit.reason.contains(reason), "{}", exit.reason);
        assert_eq!(next(&mut rx).await.kind, Kind::Restarted);
        let now = cell(&sup, "p").await.get_id();
        assert_ne!(now, last);
        last = now;
    }
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_transient_child_is_restarted_only_after_abnormal_exit() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink).with_child(worker("t").with_restart(Restart::Transient)),
    )
    .await
    .expect("start");
    tell(&sup, "t", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 2).await, [ev("s", "t", Kind::ChildFailed), ev("s", "t", Kind::Restarted)]);
    cell(&sup, "t").await.kill();
    assert_eq!(events(&mut rx, 2).await, [ev("s", "t", Kind::ChildFailed), ev("s", "t", Kind::Restarted)]);
    tell(&sup, "t", Cmd::Exit).await;
    assert_eq!(events(&mut rx, 1).await, [ev("s", "t", Kind::ChildExited)]);
    let children = sup.which_children().await.expect("which_children");
    assert_eq!(children.len(), 1, "a transient child stays listed");
    assert!(children[0].cell.is_none(), "but is not restarted after a normal exit");
    assert_eq!(children[0].restart_count, 2);
    assert!(drain(&mut rx).is_empty());
    sup.shutdown().await;
}

#[tokio::test(start_paused = true)]
async fn supervision_temporary_child_is_never_restarted_and_leaves() {
    let (sink, mut rx) = event_channel();
    let sup = Supervisor::start(
        spec("s", Strategy::OneForOne, sink)
            .with_child(worker("x").with_restart(Restart::Temporary))
            .with_child(worker("y").with_restart(Restart::Temporary))
            .with_child(worker("z").with_restart(Restart::Temporary)),
    )
    .await
    .expect("start");
    tell(&sup, "x", Cmd::Fail).await;
    assert_eq!(events(&mut rx, 1).await, [ev("s", "x", Kind::ChildFailed)]);
    tell(&sup, "y", Cmd::Exit).await;
    assert_eq!(events(&mut rx, 1).await, [ev("s", "y", Kind::ChildExited)]);
    cell(&sup, "z").await.kill();
    assert_eq!(events(&mut rx, 1).await, [ev("s", "z", Kind::ChildFailed)]);
    assert!(sup.which_children().await.expect("which_children").is_empty());
    assert!(drain(&mut rx).is_empty());
    sup.shutdown().await;
}
