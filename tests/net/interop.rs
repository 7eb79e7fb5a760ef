//! The wire format from outside: Python clients written from `docs/wire-format.md` with
//! eclipse-zenoh and cbor2 only (`tests/python/`), against a robot process.

use super::*;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_python_client_sees_numbered_updates_and_its_own_gaps_and_duplicates_counted_by_the_robot() {
    let sys = System::new("ledgerpy");
    let robot = sys.robot(&[]);
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/ledger_client.py");
    let connect = format!("tcp/127.0.0.1:{}", sys.port);
    let prefix = sys.prefix.clone();
    let out = tokio::task::spawn_blocking(move || {
        Command::new("python3").args([script, "--connect", &connect, "--prefix", &prefix]).output()
    })
    .await
    .expect("join")
    .expect("run python3");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}\nrobot:\n{}",
        String::from_utf8_lossy(&out.stderr),
        robot.log_text()
    );
    assert!(stdout.contains("robot counted missing 3 duplicated 1"), "{stdout}");
}
