use orsa_actors::push_newest::{PushNewestClient, PushNewestServer};
use orsa_actors::service::PushNewestService;
use orsa_actors::state::{StateMaster, StateSlave, StateSpec};
use orsa_actors::{PatternError, Registry};
use std::time::Duration;

/// The ir sensor's readings.
const IR: PushNewestService<u64> = PushNewestService::new("ir");

fn slave(registry: &Registry) -> std::sync::Arc<StateSlave> {
    let spec = StateSpec::new().main_state("active", &["drive", "sense"]).main_state("sensing", &["sense"]);
    StateSlave::register(registry, "wallfollow", spec).expect("register")
}

#[tokio::test(start_paused = true)]
async fn state_acquire_waits_until_the_main_state_contains_the_substate() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    assert_eq!(master.status().await.expect("status").current, "neutral");
    let handle = slave.handle();
    let waiter = tokio::spawn(async move {
        let _g = handle.acquire("drive").await?;
        Ok::<_, PatternError>(tokio::time::Instant::now())
    });
    tokio::time::sleep(Duration::from_millis(300)).await;
    let set_at = tokio::time::Instant::now();
    master.set_state("active").await.expect("set");
    assert_eq!(waiter.await.expect("task"), Ok(set_at));
}

#[tokio::test(start_paused = true)]
async fn state_change_takes_effect_once_excluded_substates_are_released() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    master.set_state("active").await.expect("set");
    let drive = slave.handle().acquire("drive").await.expect("acquire");
    let sense = slave.handle().acquire("sense").await.expect("acquire");
    // "sensing" excludes "drive" only: the change waits for drive's release, not sense's.
    tokio::spawn(async move {
        tokio::time::sleep(Duration::from_millis(150)).await;
        drop(drive);
    });
    let start = tokio::time::Instant::now();
    master.set_state("sensing").await.expect("set");
    assert_eq!(start.elapsed(), Duration::from_millis(150));
    let status = master.status().await.expect("status");
    assert_eq!((status.current.as_str(), status.held.get("sense")), ("sensing", Some(&1)));
    drop(sense);
}

#[tokio::test(start_paused = true)]
async fn state_pending_change_blocks_new_acquires_of_excluded_substates() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    master.set_state("active").await.expect("set");
    let held = slave.handle().acquire("drive").await.expect("acquire");
    let m = master.clone();
    let change = tokio::spawn(async move { m.set_state("neutral").await });
    tokio::task::yield_now().await;
    assert_eq!(master.status().await.expect("status").pending.as_deref(), Some("neutral"));
    assert!(slave.handle().try_acquire("drive").is_err(), "no new critical section during a pending change");
    drop(held);
    assert_eq!(change.await.expect("task"), Ok(()));
    assert_eq!(master.status().await.expect("status").current, "neutral");
}

/// A substate held by two activities stays held until both let go, however often it was held
/// and released before; the status lists only what is held now.
#[tokio::test(start_paused = true)]
async fn state_a_substate_is_held_until_its_last_holder_releases_it() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    master.set_state("active").await.expect("set");
    for _ in 0..3 {
        drop(slave.handle().try_acquire("drive").expect("acquire"));
    }
    assert!(master.status().await.expect("status").held.is_empty(), "released is not held");
    let first = slave.handle().try_acquire("drive").expect("acquire");
    let second = slave.handle().try_acquire("drive").expect("acquire");
    assert_eq!(master.status().await.expect("status").held.get("drive"), Some(&2));
    let m = master.clone();
    let change = tokio::spawn(async move { m.set_state("sensing").await });
    tokio::time::sleep(Duration::from_millis(100)).await;
    drop(first);
    tokio::time::sleep(Duration::from_millis(100)).await;
    assert!(!change.is_finished(), "one holder of drive is left");
    drop(second);
    assert_eq!(change.await.expect("task"), Ok(()));
    let status = master.status().await.expect("status");
    assert_eq!((status.current.as_str(), status.held.len()), ("sensing", 0));
}

/// Main states declared again (a restarted component's new spec): a substate the new spec
/// drops is unknown to new holders but stays held, and blocks, until its holder lets go; one
/// it adds can be held at once.
#[tokio::test(start_paused = true)]
async fn state_declaring_again_keeps_what_is_held_until_it_is_released() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    master.set_state("active").await.expect("set");
    let drive = slave.handle().try_acquire("drive").expect("acquire");
    slave
        .declare(StateSpec::new().main_state("active", &["sense", "steer"]).main_state("sensing", &["sense"]))
        .expect("declare");
    assert!(matches!(slave.handle().try_acquire("drive"), Err(PatternError::Unknown { .. })));
    let steer = slave.handle().try_acquire("steer").expect("a newly declared substate");
    assert_eq!(
        master.try_set_state("sensing").await,
        Err(PatternError::Busy(vec!["drive".into(), "steer".into()]))
    );
    drop((drive, steer));
    assert!(master.status().await.expect("status").held.is_empty());
    master.try_set_state("sensing").await.expect("nothing held");
    assert!(slave.handle().try_acquire("steer").is_err(), "sensing does not contain steer");
}

#[tokio::test(start_paused = true)]
async fn state_try_set_answers_busy_with_the_held_substates() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    master.try_set_state("active").await.expect("free to change");
    let g = slave.handle().try_acquire("drive").expect("acquire");
    assert_eq!(master.try_set_state("neutral").await, Err(PatternError::Busy(vec!["drive".into()])));
    assert_eq!(master.status().await.expect("status").current, "active", "a refused change changes nothing");
    master.try_set_state("active").await.expect("a state that keeps drive is fine");
    drop(g);
    master.try_set_state("neutral").await.expect("released");
}

#[tokio::test(start_paused = true)]
async fn state_unknown_names_are_errors() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    assert!(matches!(
        master.set_state("flying").await,
        Err(PatternError::Unknown { kind: "main state", .. })
    ));
    assert!(matches!(slave.handle().try_acquire("fly"), Err(PatternError::Unknown { kind: "substate", .. })));
    assert!(matches!(StateMaster::connect(&registry, "ghost"), Err(PatternError::UnknownComponent(_))));
    let bad = StateSpec::new().initial("nowhere");
    assert!(StateSlave::register(&registry, "other", bad).is_err());
}

#[tokio::test(start_paused = true)]
async fn state_deactivation_aborts_blocking_calls_with_cancelled() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    let _server = PushNewestServer::<u64>::register(&registry, IR.on("nomad200")).expect("register");
    // An activity waiting for a substate, and one waiting for data: both blocking calls.
    let h = slave.handle();
    let acquiring = tokio::spawn(async move { h.acquire("drive").await.map(|_| ()) });
    let cancel = slave.cancel_token();
    let registry2 = registry.clone();
    let waiting = tokio::spawn(async move {
        let c = PushNewestClient::<u64>::connect(&registry2, IR.on("nomad200"))?;
        c.subscribe()?;
        cancel.guard(c.get_update_wait()).await.map(|_| ())
    });
    tokio::time::sleep(Duration::from_secs(5)).await;
    master.deactivate().await.expect("deactivate");
    assert_eq!(acquiring.await.expect("task"), Err(PatternError::Cancelled));
    assert_eq!(waiting.await.expect("task"), Err(PatternError::Cancelled));
    assert_eq!(master.status().await.expect("status").current, "neutral");
    // Calls made after the deactivation block normally again.
    master.set_state("active").await.expect("set");
    assert!(slave.handle().acquire("drive").await.is_ok());
}

#[tokio::test(start_paused = true)]
async fn state_a_change_the_master_stops_waiting_for_is_withdrawn() {
    let registry = Registry::new();
    let slave = slave(&registry);
    let master = StateMaster::connect(&registry, "wallfollow").expect("master");
    master.set_state("active").await.expect("set");
    let held = slave.handle().acquire("drive").await.expect("acquire");
    assert_eq!(
        master.set_state_timeout("neutral", Duration::from_millis(100)).await,
        Err(PatternError::Timeout)
    );
    let status = master.status().await.expect("status");
    assert_eq!((status.current.as_str(), status.pending), ("active", None));
    drop(held);
    // Nothing is left pending: drive can be taken again.
    let again = slave.handle().try_acquire("drive");
    assert!(again.is_ok(), "{:?}", again.err());
}
