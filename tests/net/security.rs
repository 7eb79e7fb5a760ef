//! User/password authentication between processes (docs/security.md): a peer without
//! credentials cannot reach the robot, so it cannot command it; one with credentials can.

use super::*;
use orsa_actors::Empty;
use orsa_actors::query::QueryClient;

fn write(dir: &std::path::Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_peer_without_credentials_cannot_command_the_robot() {
    let sys = System::new("auth");
    let dir = std::env::temp_dir().join(format!("orsa-auth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let dict = write(&dir, "users.txt", "robot:robot-secret\nexecutive:exec-secret\n");
    let robot_cfg = write(
        &dir,
        "robot.json5",
        &format!(
            r#"{{ mode: "peer", transport: {{ auth: {{ usrpwd: {{ user: "robot", password: "robot-secret", dictionary_file: "{}" }} }} }} }}"#,
            dict.display()
        ),
    );
    let exec_cfg = write(
        &dir,
        "executive.json5",
        r#"{ mode: "peer", transport: { auth: { usrpwd: { user: "executive", password: "exec-secret" } } } }"#,
    );
    let _robot = sys.robot(&["--zenoh-config", robot_cfg.to_str().expect("utf-8")]);

    // With credentials: the robot's services are visible and answer.
    let authorised = Registry::new();
    let options = NetOptions {
        connect: vec![format!("tcp/127.0.0.1:{}", sys.port)],
        config_file: Some(exec_cfg.clone()),
        prefix: sys.prefix.clone(),
        ..NetOptions::default()
    };
    let t = ZenohTransport::open(&authorised, &options, "test").await.expect("authorised session");
    t.wait_for(&["nomad200/safety".parse().expect("addr")], STARTUP)
        .await
        .expect("an authorised peer sees the robot");
    let safety = QueryClient::<Empty, orsa::interfaces::nomad200::SafetyCounters>::connect(
        &authorised,
        orsa::interfaces::nomad200::SAFETY.on(orsa::interfaces::nomad200::NAME),
    )
    .expect("client");

    // Without credentials: teleop cannot find the robot and gives up; nothing reached the motors.
    let mut intruder = sys.run("intruder", "teleop", &["--send", "0.3,0", "--for", "1", "--wait", "4"]);
    let status = tokio::task::block_in_place(|| intruder.child.wait()).expect("teleop ends");
    assert!(!status.success(), "an unauthenticated teleop must fail");
    assert!(intruder.log_text().contains("no peer offers nomad200/teleop"), "{}", intruder.log_text());
    let counters = safety.query(Empty {}, Some(Duration::from_secs(5))).await.expect("counters");
    assert_eq!(counters.applied, 0, "no command reached the motors: {counters:?}");

    // The same teleop with credentials drives.
    let mut allowed = sys.run(
        "allowed",
        "teleop",
        &["--send", "0.1,0", "--for", "1", "--zenoh-config", exec_cfg.to_str().expect("utf-8")],
    );
    let status = tokio::task::block_in_place(|| allowed.child.wait()).expect("teleop ends");
    assert!(status.success(), "{}", allowed.log_text());
    let counters = safety.query(Empty {}, Some(Duration::from_secs(5))).await.expect("counters");
    assert!(counters.applied > 0, "the authenticated teleop drove: {counters:?}");
}
