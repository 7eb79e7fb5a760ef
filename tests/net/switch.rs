//! `orsa switch`: several wiring and state changes on the robot process's components, made from
//! another process, all or nothing.

use super::*;
use orsa_actors::ServiceAddr;
use orsa_actors::state::StateMaster;
use orsa_actors::wiring::WiringMaster;

/// Where each behaviour's `vel` port points and which state it is in, as the robot's
/// components say over the network.
async fn configuration(registry: &Registry) -> Vec<(String, Option<ServiceAddr>, String)> {
    let wiring = WiringMaster::new(registry);
    let mut out = Vec::new();
    for b in ["wallfollow", "centerfollow"] {
        let ports = wiring.ports(b).await.expect("ports");
        let vel = ports.iter().find(|p| p.port == "vel").expect("a vel port").target.clone();
        let state = StateMaster::connect(registry, b).expect("state").status().await.expect("status").current;
        out.push((b.to_string(), vel, state));
    }
    out
}

fn switch(sys: &System, name: &str, changes: &[&str]) -> (bool, String) {
    let mut args = changes.to_vec();
    args.extend(["--wait", "30"]);
    let mut p = sys.run(name, "switch", &args);
    let status = p.child.wait().expect("orsa switch ends");
    (status.success(), p.log_text())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_switch_from_another_process_is_made_whole_or_not_at_all() {
    let sys = System::new("switch");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let motors: ServiceAddr = "nomad200/navigationvelocity".parse().expect("addr");

    // A whole mode change in one command: center following activated and wired.
    let (ok, log) =
        switch(&sys, "on", &["centerfollow:active", "centerfollow.vel=nomad200/navigationvelocity"]);
    assert!(ok, "{log}");
    let on = configuration(&registry).await;
    assert_eq!(on[1], ("centerfollow".into(), Some(motors.clone()), "active".into()));
    until_base(&mut base, STARTUP, "center following drives", |b| b.v_m_s > 0.05).await;

    // A hand-over whose last change names a state wall following does not have: refused while
    // preparing, so center following was never unwired.
    let (ok, log) = switch(
        &sys,
        "bad-state",
        &["centerfollow.vel=", "wallfollow:flying", "wallfollow.vel=nomad200/navigationvelocity"],
    );
    assert!(!ok);
    assert!(
        log.contains("preparing 'set wallfollow to flying'") && log.contains("nothing was changed"),
        "{log}"
    );
    assert_eq!(configuration(&registry).await, on);

    // A port wired to a service of another type: refused, nothing changed.
    let (ok, log) = switch(&sys, "bad-type", &["centerfollow.vel=", "wallfollow.vel=nomad200/bumpers"]);
    assert!(!ok);
    assert!(log.contains("incompatible service 'nomad200/bumpers'"), "{log}");
    assert_eq!(configuration(&registry).await, on);

    // A change a person mistyped: refused before anything is asked of the robot.
    let (ok, log) = switch(&sys, "typo", &["centerfollow.vel=", "wallfollow-active"]);
    assert!(!ok);
    assert!(log.contains("'wallfollow-active': neither a port nor a state"), "{log}");
    assert_eq!(configuration(&registry).await, on);

    // The same hand-over, well formed, is made whole.
    let (ok, log) = switch(
        &sys,
        "handover",
        &[
            "centerfollow.vel=",
            "centerfollow:neutral",
            "wallfollow:active",
            "wallfollow.vel=nomad200/navigationvelocity",
        ],
    );
    assert!(ok, "{log}");
    let after = configuration(&registry).await;
    assert_eq!(after[0], ("wallfollow".into(), Some(motors), "active".into()));
    assert_eq!(after[1], ("centerfollow".into(), None, "neutral".into()));
    t.close().await;
}
