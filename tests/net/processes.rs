//! Robot, executive, teleop and echo as separate processes.

use super::*;
use orsa::interfaces::nomad200::SafetyCounters;
use orsa_actors::query::QueryClient;
use orsa_actors::wiring::WiringMaster;
use orsa_actors::{Empty, ServiceAddr};

const MOTORS: &str = "nomad200/navigationvelocity";

pub(crate) async fn wired(registry: &Registry) -> Vec<String> {
    let master = WiringMaster::new(registry);
    let mut out = Vec::new();
    for b in ["wallfollow", "centerfollow"] {
        let ports = master.ports(b).await.expect("ports");
        if ports.iter().any(|p| p.target == Some(MOTORS.parse::<ServiceAddr>().expect("addr"))) {
            out.push(b.to_string());
        }
    }
    out
}

async fn safety(registry: &Registry) -> SafetyCounters {
    QueryClient::<Empty, SafetyCounters>::connect(registry, nomad200::SAFETY.on(nomad200::NAME))
        .expect("safety client")
        .query(Empty {}, Some(Duration::from_secs(5)))
        .await
        .expect("safety counters")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_executive_process_wires_the_robots_behaviours_and_the_robot_patrols() {
    let sys = System::new("patrol");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let start = base.recv().await.expect("base state").value;
    assert_eq!(start.v_m_s, 0.0, "nothing drives the robot before an executive is there");
    let _exec = sys.run("exec", "executive", &["--duration", "120"]);
    let moved = until_base(&mut base, STARTUP, "the robot patrols", |b| {
        (b.x_m - start.x_m).hypot(b.y_m - start.y_m) > 0.5
    })
    .await;
    assert!(moved.v_m_s > 0.0);
    assert_eq!(wired(&registry).await.len(), 1, "exactly one behaviour drives");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn teleop_takes_the_robot_and_gives_control_back_to_the_behaviours() {
    let sys = System::new("teleop");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let _exec = sys.run("exec", "executive", &["--duration", "120"]);
    until_base(&mut base, STARTUP, "a behaviour drives forward", |b| b.v_m_s > 0.15).await;

    let mut teleop = sys.run("teleop", "teleop", &["--send", "-0.1,0", "--for", "3"]);
    until_base(&mut base, STARTUP, "teleop drives backwards", |b| b.v_m_s < -0.05).await;
    let status = tokio::task::spawn_blocking(move || {
        let s = teleop.child.wait().expect("teleop ends");
        (s, teleop)
    })
    .await
    .expect("join");
    assert!(status.0.success(), "teleop failed: {}", status.1.log_text());
    assert!(safety(&registry).await.overridden > 0, "behaviour commands were overridden while teleop held");
    until_base(&mut base, Duration::from_secs(10), "the behaviour drives again", |b| b.v_m_s > 0.15).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn killing_the_executive_stops_the_robot() {
    let sys = System::new("kill");
    let robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let mut exec = sys.run("exec", "executive", &["--duration", "120"]);
    until_base(&mut base, STARTUP, "a behaviour drives", |b| b.v_m_s > 0.15).await;
    exec.child.kill().expect("kill -9 the executive");
    let killed = registry.now();
    // Unwired and commanded to zero within 1 s; the axes then decelerate at 0.5 m/s^2.
    let stopped = until_base(&mut base, Duration::from_secs(10), "the robot stops", |b| b.v_m_s == 0.0).await;
    let took = stopped.sent_at.saturating_since(killed);
    assert!(took < Duration::from_millis(1600), "stopped {took:?} after the kill (1 s + braking)");
    assert!(wired(&registry).await.is_empty(), "no behaviour stays wired");
    assert!(robot.log_text().contains("lost"), "{}", robot.log_text());
    // And it stays stopped: the behaviours compute but drive nothing.
    let later = until_base(&mut base, Duration::from_secs(5), "a later state", |b| {
        b.stamp > stopped.sent_at.after(Duration::from_secs(1))
    })
    .await;
    assert_eq!(later.v_m_s, 0.0);
}

fn echo_lines(sys: &System, service: &str, every: &str, count: usize) -> Vec<serde_json::Value> {
    let mut p = sys.run(
        &format!("echo-{}", service.replace('/', "-")),
        "echo",
        &[service, "--every", every, "--count", &count.to_string(), "--json", "--wait", "30"],
    );
    let out = p.child.wait_with_output_keep().expect("echo output");
    assert!(out.0.success(), "echo {service} failed: {}", p.log_text());
    out.1.lines().map(|l| serde_json::from_str(l).expect("a JSON line")).collect()
}

trait WaitKeep {
    fn wait_with_output_keep(&mut self) -> std::io::Result<(std::process::ExitStatus, String)>;
}

impl WaitKeep for std::process::Child {
    fn wait_with_output_keep(&mut self) -> std::io::Result<(std::process::ExitStatus, String)> {
        use std::io::Read as _;
        let mut text = String::new();
        if let Some(out) = self.stdout.as_mut() {
            out.read_to_string(&mut text)?;
        }
        Ok((self.wait()?, text))
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn echo_sees_each_stream_at_its_rate() {
    let sys = System::new("echo");
    let _robot = sys.robot(&[]);
    for (service, every, period_ms) in [
        ("nomad200/distanceir", 1u64, 40.0),
        ("nomad200/distanceir", 10, 400.0),
        ("nomad200/distanceson", 1, 64.0),
        ("nomad200/bumpers", 1, 30.0),
        ("nomad200/basestate", 2, 200.0),
    ] {
        let lines = tokio::task::block_in_place(|| echo_lines(&sys, service, &every.to_string(), 6));
        assert_eq!(lines.len(), 6, "{service}");
        let seq: Vec<u64> = lines.iter().map(|l| l["seq"].as_u64().expect("seq")).collect();
        let stamps: Vec<u64> = lines.iter().map(|l| l["stamp_ns"].as_u64().expect("stamp")).collect();
        for w in seq.windows(2) {
            assert_eq!(w[1] - w[0], every, "{service} every {every}: {seq:?}");
        }
        // The server stamps each value when its tick is handled: the mean period is exact
        // to within scheduling jitter.
        let mean_ms = (stamps[5] - stamps[0]) as f64 / 5.0 / 1e6;
        assert!((mean_ms - period_ms).abs() < period_ms * 0.2, "{service} every {every}: {mean_ms} ms");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_corrupted_message_is_rejected_and_counted_and_nothing_else_changes() {
    let sys = System::new("corrupt");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let motors: ServiceAddr = MOTORS.parse().expect("addr");
    let before = safety(&registry).await;
    t.session().put(t.keys().send(&motors), b"\xff\x00 not a command".to_vec()).await.expect("put");
    let teleop: ServiceAddr = "nomad200/teleop".parse().expect("addr");
    let replies = t
        .session()
        .get(t.keys().subscribe(&"nomad200/basestate".parse().expect("addr")))
        .payload(b"\xa1".to_vec())
        .await
        .expect("get");
    let reply = replies.recv_async().await.expect("a reply to the bad request");
    let bytes = reply.result().expect("answered").payload().to_bytes().into_owned();
    let answer = orsa_actors::wire::decode::<orsa_actors::wire::Reply<()>>(&bytes, "reply").expect("a reply");
    assert!(
        matches!(answer.into_result(), Err(orsa_actors::PatternError::Decode(_))),
        "a bad request is answered with a decode error"
    );
    // A good command after the garbage is applied.
    drive_slowly(&registry, &teleop);
    until_base(&mut base, Duration::from_secs(10), "the good command drives", |b| b.v_m_s > 0.0).await;
    let after = safety(&registry).await;
    assert_eq!(after.applied, before.applied + 1, "exactly the good command was applied");
    assert_eq!(
        robot_decode_errors(&t).await,
        2,
        "the robot counted the undecodable command and the bad request"
    );
}

/// Sends one good command, 5 cm/s straight ahead, to `addr`.
fn drive_slowly(registry: &Registry, addr: &ServiceAddr) {
    orsa_actors::send::SendClient::<orsa::interfaces::nomad200::NavigationVelocity>::connect(registry, addr)
        .expect("client")
        .send(orsa::interfaces::nomad200::NavigationVelocity {
            stamp: registry.now(),
            v_m_s: 0.05,
            omega_rad_s: 0.0,
        })
        .expect("send");
}

/// How many undecodable messages the robot's process counted, as its stats say.
async fn robot_decode_errors(t: &ZenohTransport) -> u64 {
    let stats = t.all_stats(Duration::from_secs(5)).await;
    let robot = t.processes().into_iter().find(|p| p.role == "robot").expect("the robot's process token");
    stats.get(&robot.zid).unwrap_or_else(|| panic!("stats keyed by process: {stats:?}")).decode_errors
}

/// A flood of malformed commands is counted one by one but logged at most 10 lines a second:
/// the log stays short, and the robot still takes the good command that follows.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flood_of_malformed_messages_is_counted_whole_and_logged_within_a_budget() {
    let sys = System::new("flood");
    let robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    let motors: ServiceAddr = MOTORS.parse().expect("addr");
    let key = t.keys().send(&motors);
    let flood = 2_000u64;
    let t0 = std::time::Instant::now();
    for i in 0..flood {
        t.session().put(key.clone(), format!("\u{ff} garbage {i}").into_bytes()).await.expect("put");
    }
    // The good command goes on the same key after the flood: once it drives, the robot has
    // taken every message before it.
    drive_slowly(&registry, &motors);
    until_base(&mut base, Duration::from_secs(10), "the good command drives", |b| b.v_m_s > 0.0).await;
    let seconds = t0.elapsed().as_secs_f64();
    assert_eq!(robot_decode_errors(&t).await, flood, "every malformed message counted");
    let lines = robot.log_text().lines().filter(|l| l.contains("undecodable")).count() as f64;
    assert!(lines >= 1.0, "the first ones are logged");
    assert!(lines <= 10.0 * (seconds.ceil() + 1.0), "{lines} lines in {seconds:.1} s");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_drives_its_fallback_mode_without_an_executive_from_the_start_and_hands_back() {
    let sys = System::new("fallback");
    let robot = sys.robot(&["--fallback", "patrol"]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    // No executive ever connected: the fallback drives from the start.
    t.wait_for(&["fallback/goal".parse().expect("addr")], STARTUP).await.expect("the fallback starts alone");
    until_base(&mut base, STARTUP, "the fallback drives from the start", |b| b.v_m_s > 0.15).await;
    let mut exec = sys.run("exec1", "executive", &["--duration", "120"]);
    t.wait_for(&["master/goal".parse().expect("addr")], STARTUP).await.expect("the executive starts");
    assert!(
        t.wait_gone(&"fallback/goal".parse().expect("addr"), Duration::ZERO).await,
        "the fallback stopped before the executive's master started"
    );
    until_base(&mut base, STARTUP, "the executive drives", |b| b.v_m_s > 0.15).await;
    exec.child.kill().expect("kill the executive");
    t.wait_for(&["fallback/goal".parse().expect("addr")], STARTUP).await.expect("the fallback master starts");
    until_base(&mut base, STARTUP, "the fallback drives", |b| b.v_m_s > 0.15).await;
    assert_eq!(wired(&registry).await.len(), 1, "the fallback wires exactly one behaviour");

    let _exec2 = sys.run("exec2", "executive", &["--duration", "120"]);
    t.wait_for(&["master/goal".parse().expect("addr")], STARTUP).await.expect("a new executive starts");
    assert!(
        t.wait_gone(&"fallback/goal".parse().expect("addr"), Duration::ZERO).await,
        "the fallback stopped before the new master started"
    );
    until_base(&mut base, STARTUP, "the new executive drives", |b| b.v_m_s > 0.15).await;
    assert_eq!(wired(&registry).await.len(), 1);
    assert!(robot.log_text().contains("stopping the fallback"), "{}", robot.log_text());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_command_older_than_the_timeout_is_not_acted_on_across_processes() {
    use orsa::interfaces::nomad200::NavigationVelocity;
    use orsa_actors::Timestamp;
    let sys = System::new("stale");
    let _robot = sys.robot(&[]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    // Wait until this process's clock is well past 1.5 s (robot stamps arrive on our clock).
    until_base(&mut base, STARTUP, "time passes", |b| b.stamp > Timestamp::from_secs_f64(1.5)).await;
    let before = safety(&registry).await;
    let teleop = orsa_actors::send::SendClient::<NavigationVelocity>::connect(
        &registry,
        nomad200::TELEOP.on(nomad200::NAME),
    )
    .expect("teleop client");
    // Computed from data 1 s old (older than the 0.5 s timeout): as after a reconnect.
    let old = registry.now().saturating_since(Timestamp::ZERO).as_secs_f64() - 1.0;
    teleop
        .send(NavigationVelocity { stamp: Timestamp::from_secs_f64(old), v_m_s: 0.2, omega_rad_s: 0.0 })
        .expect("send");
    teleop.send(NavigationVelocity { stamp: registry.now(), v_m_s: 0.05, omega_rad_s: 0.0 }).expect("send");
    until_base(&mut base, Duration::from_secs(10), "the fresh command drives", |b| b.v_m_s > 0.0).await;
    let after = safety(&registry).await;
    assert_eq!(after.stale_refused, before.stale_refused + 1, "the old command was refused");
    assert_eq!(after.applied, before.applied + 1, "only the fresh one was applied");
}

/// `orsa list` shows the robot's sensor verdicts whenever it looks, not only while a verdict
/// changes: the robot pushes its health every second too. The sonar ring reads nothing from its
/// first second on (a `sensor_dropout` for the whole test: dead, as it saw walls within its
/// range a moment before); seconds later, long after the verdict changed, two listings four
/// seconds apart both show it, and the other rings healthy. (Before the robot pushed its health
/// every second, neither showed any verdict.)
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn orsa_list_shows_the_sensor_verdicts_whenever_it_looks() {
    let sys = System::new("listhealth");
    let plan = std::env::temp_dir().join(format!("orsa-test-{}-listhealth.toml", std::process::id()));
    std::fs::write(
        &plan,
        "[[fault]]\nat = 1.0\nkind = \"sensor_dropout\"\ntarget = \"sonar\"\nduration = 600.0\n",
    )
    .expect("write the plan");
    let _robot = sys.robot(&["--faults", plan.to_str().expect("utf-8")]);
    let (registry, t) = sys.observe().await;
    let (_c, mut base) = base_stream(&registry, &t).await;
    for listing in 0..2 {
        // Four seconds of base states (one every 100 ms) go by before each listing.
        for _ in 0..40 {
            base.recv().await.expect("base states");
        }
        let mut p = sys.run(&format!("list{listing}"), "list", &["--json", "--wait", "2"]);
        let (status, out) =
            tokio::task::block_in_place(|| p.child.wait_with_output_keep()).expect("list output");
        assert!(status.success(), "orsa list failed: {}", p.log_text());
        let listing: serde_json::Value = serde_json::from_str(&out).expect("JSON");
        let health = listing["services"]
            .as_array()
            .expect("services")
            .iter()
            .find(|s| s["service"] == "nomad200/health")
            .unwrap_or_else(|| panic!("the robot's health service is listed: {listing}"));
        let verdict = |sensor: &str| {
            let sensors =
                health["detail"]["sensors"].as_array().unwrap_or_else(|| panic!("verdicts: {health}"));
            let s = sensors
                .iter()
                .find(|s| s["sensor"] == sensor)
                .unwrap_or_else(|| panic!("{sensor}: {health}"));
            s["verdict"].as_str().expect("a verdict").to_owned()
        };
        assert_eq!(verdict("sonar"), "dead", "{health}");
        assert_eq!(
            (verdict("infrared").as_str(), verdict("bumpers").as_str()),
            ("healthy", "healthy"),
            "{health}"
        );
    }
    let _ = std::fs::remove_file(plan);
}
