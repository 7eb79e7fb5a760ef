//! `examples/remote_client.rs` against a robot process: it subscribes and drives over zenoh.

use super::*;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_remote_client_example_reads_scans_and_drives_the_robot() {
    let sys = System::new("example");
    let robot = sys.robot(&[]);
    let options = NetOptions {
        connect: vec![format!("tcp/127.0.0.1:{}", sys.port)],
        prefix: sys.prefix.clone(),
        ..NetOptions::default()
    };
    let seen = remote_client::run(&options, 5, Duration::from_secs(2)).await.expect("the example runs");
    assert_eq!(seen.scans, 5);
    // The robot starts in the corridor: something is within the infrared's 0.6 m or nothing is.
    assert!(seen.ahead_m.is_none_or(|d| (0.0..=0.6).contains(&d)), "{:?}", seen.ahead_m);
    // 0.1 m/s commanded, 0.5 m/s^2: at full speed within 0.2 s of the 2 s.
    assert!(seen.fastest_m_s > 0.09, "teleop drove it at {} m/s\n{}", seen.fastest_m_s, robot.log_text());
}
