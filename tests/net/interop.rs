//! The wire format from outside: Python clients written from `docs/wire-format.md` with
//! eclipse-zenoh and cbor2 only (`tests/python/`), against a robot process.

use super::*;

/// Runs `tests/python/SCRIPT ARGS`; it must succeed (else its output and the robot's log are
/// shown). What it printed.
async fn python(script: &'static str, args: Vec<String>, robot: &Proc) -> String {
    let path = format!("{}/tests/python/{script}", env!("CARGO_MANIFEST_DIR"));
    let out = tokio::task::spawn_blocking(move || Command::new("python3").arg(path).args(args).output())
        .await
        .expect("join")
        .expect("run python3");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}\n{}\nrobot:\n{}",
        String::from_utf8_lossy(&out.stderr),
        robot.log_text()
    );
    stdout
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_python_client_sees_numbered_updates_and_its_own_gaps_and_duplicates_counted_by_the_robot() {
    let sys = System::new("ledgerpy");
    let robot = sys.robot(&[]);
    let connect = format!("tcp/127.0.0.1:{}", sys.port);
    let stdout = python(
        "ledger_client.py",
        vec!["--connect".into(), connect, "--prefix".into(), sys.prefix.clone()],
        &robot,
    )
    .await;
    assert!(stdout.contains("robot counted missing 3 duplicated 1"), "{stdout}");
}

/// `orsa robot --foxglove`, watched by a Foxglove client written from the WebSocket protocol's
/// specification (Python): every message it gets, the latched world and robot sent when it
/// subscribes included, is stamped on the system's time base (UNIX time, as the scans), never
/// at time zero.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robots_live_view_stamps_every_message_on_the_systems_time_base() {
    let sys = System::new("foxstamps");
    let port = free_port();
    let addr = format!("127.0.0.1:{port}");
    let robot = sys.robot(&["--foxglove", &addr]);
    // Its live view listens before the robot joins the network.
    let (registry, t) = sys.observe().await;
    let (_c, _base) = base_stream(&registry, &t).await;
    let args = vec![format!("ws://{addr}"), "--time-base".into(), "--seconds".into(), "2".into()];
    let stdout = python("foxglove_client.py", args, &robot).await;
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("the client prints JSON");
    for topic in ["/world", "/robot", "/tf"] {
        assert!(
            v["topics"][topic]["first_ns"].as_u64().is_some_and(|t| t > 1_700_000_000_000_000_000),
            "{v}"
        );
    }
}
