//! A slow, lossy link between the robot's and the executive's processes: every process of the
//! system runs in a network namespace this test makes for itself, where nftables drops a share
//! of the TCP packets on loopback (real loss: TCP retransmits, zenoh's queues back up) and a
//! relay adds latency between the executive and the robot (`tests/python/slow_link.py`: the
//! kernel here has no netem). The robot must drive under latency alone, stay safe while packets
//! are lost (stopping if its executive goes quiet, never applying a stale command), and drive
//! again by itself once the loss ends; the ledger across processes must add up on both sides.
//!
//! Needs root, `ip` (iproute2) and `nft` (nftables). Without them the test says why and passes,
//! unless `ORSA_REQUIRE_NETNS=1` (set by `.ci/run`, which installs nftables), where it fails.

use super::links::report_path;
use super::*;
use orsa::remote::{ExecutiveReport, RobotReport};
use std::io::BufRead as _;

/// One-way latency the relay adds between the executive and the robot.
const DELAY_MS: u32 = 25;
/// The share of TCP packets dropped while the loss is on, percent.
const LOSS_PERCENT: u32 = 25;
/// How long the loss lasts (the fault's own length).
const LOSS: Duration = Duration::from_secs(8);
/// How long the robot may take to drive again.
const BACK: Duration = Duration::from_secs(20);

/// A network namespace of this test's own, deleted when dropped.
struct Netns {
    name: String,
}

impl Netns {
    /// Makes one, or says why it cannot.
    fn create(name: &str) -> Result<Netns, String> {
        let run = |args: &[&str]| -> Result<(), String> {
            let out =
                Command::new(args[0]).args(&args[1..]).output().map_err(|e| format!("{}: {e}", args[0]))?;
            if out.status.success() {
                Ok(())
            } else {
                Err(format!("{}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim()))
            }
        };
        run(&["nft", "--version"])?;
        run(&["ip", "netns", "add", name])?;
        let ns = Netns { name: name.to_string() };
        run(&["ip", "netns", "exec", name, "ip", "link", "set", "lo", "up"])?;
        Ok(ns)
    }

    fn command(&self, program: &str) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", &self.name, program]);
        c
    }

    /// Drops `percent` % of the TCP packets on the namespace's loopback (0: none, and the
    /// packets dropped so far are returned).
    fn loss(&self, percent: u32) -> u64 {
        let dropped = if percent == 0 { self.dropped() } else { 0 };
        let rules = if percent == 0 {
            "delete table inet orsa_loss\n".to_string()
        } else {
            format!(
                "table inet orsa_loss {{\n  chain out {{\n    type filter hook output priority 0; policy accept;\n    \
                 meta l4proto tcp numgen random mod 100 < {percent} counter drop\n  }}\n}}\n"
            )
        };
        let mut nft = self.command("nft").args(["-f", "-"]).stdin(Stdio::piped()).spawn().expect("run nft");
        use std::io::Write as _;
        nft.stdin.take().expect("stdin").write_all(rules.as_bytes()).expect("write the rules");
        assert!(nft.wait().expect("nft").success(), "nft refused the rules:\n{rules}");
        dropped
    }

    /// The packets the loss rule dropped so far.
    fn dropped(&self) -> u64 {
        let out = self.command("nft").args(["list", "table", "inet", "orsa_loss"]).output().expect("run nft");
        let text = String::from_utf8_lossy(&out.stdout);
        let at = text.find("counter packets ").unwrap_or_else(|| panic!("no counter in:\n{text}"));
        let n = text[at + "counter packets ".len()..].split_whitespace().next().expect("a count");
        n.parse().unwrap_or_else(|_| panic!("a packet count: {n}"))
    }

    /// Starts `orsa ARGS...` in the namespace, stderr into a file named after `name`.
    fn orsa(&self, name: &str, args: &[&str]) -> Proc {
        let log = std::env::temp_dir().join(format!("orsa-test-{}-{name}.log", std::process::id()));
        let file = std::fs::File::create(&log).expect("log file");
        // `ip netns exec` execs the program: the child's pid is orsa's, and signals reach it.
        let child = self
            .command(env!("CARGO_BIN_EXE_orsa"))
            .args(args)
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(file)
            .spawn()
            .expect("start orsa");
        Proc { child, log }
    }
}

impl Drop for Netns {
    fn drop(&mut self) {
        let _ = Command::new("ip").args(["netns", "delete", &self.name]).status();
    }
}

/// The speeds of the robot's base states, from `orsa echo --json` in the namespace.
fn speeds(echo: &mut Proc) -> mpsc::UnboundedReceiver<f64> {
    let (tx, rx) = mpsc::unbounded_channel();
    let out = echo.child.stdout.take().expect("echo's stdout");
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(out).lines() {
            let Ok(line) = line else { return };
            let v: serde_json::Value = serde_json::from_str(&line).expect("a JSON line");
            let speed = v["value"]["v_m_s"].as_f64().unwrap_or_else(|| panic!("a base state: {line}"));
            if tx.send(speed).is_err() {
                return;
            }
        }
    });
    rx
}

async fn until_speed(rx: &mut mpsc::UnboundedReceiver<f64>, what: &str, pred: impl Fn(f64) -> bool) {
    let found = tokio::time::timeout(BACK, async {
        while let Some(v) = rx.recv().await {
            if pred(v) {
                return true;
            }
        }
        false
    })
    .await;
    assert!(matches!(found, Ok(true)), "{what}: not within {BACK:?}");
}

async fn terminate(p: Proc) -> Proc {
    p.signal("-TERM");
    tokio::task::spawn_blocking(move || {
        let mut p = p;
        let s = p.child.wait().expect("wait");
        assert_eq!(s.code(), Some(130), "{}", p.log_text());
        p
    })
    .await
    .expect("join")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn on_a_slow_lossy_link_the_robot_stays_safe_drives_again_and_the_counts_add_up() {
    let ns = match Netns::create(&format!("orsa-lossy-{}", std::process::id())) {
        Ok(ns) => ns,
        Err(why) => {
            assert!(
                std::env::var("ORSA_REQUIRE_NETNS").is_err(),
                "ORSA_REQUIRE_NETNS is set, and this machine cannot make a lossy network namespace: {why}"
            );
            eprintln!("skipped: this machine cannot make a lossy network namespace: {why}");
            return;
        }
    };
    let (robot_port, relay_port) = (7447, 7448);
    let prefix = format!("t{}lossy", std::process::id());
    let robot_json = report_path("lossy-robot");
    let exec_json = report_path("lossy-exec");
    let robot = ns.orsa(
        "lossy-robot",
        &[
            "robot",
            "--listen",
            &format!("tcp/127.0.0.1:{robot_port}"),
            "--prefix",
            &prefix,
            "--report",
            robot_json.to_str().expect("utf-8"),
        ],
    );
    let relay_script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/slow_link.py");
    let mut relay = Proc {
        child: ns
            .command("python3")
            .args([
                relay_script,
                "--listen",
                &format!("127.0.0.1:{relay_port}"),
                "--to",
                &format!("127.0.0.1:{robot_port}"),
                "--delay-ms",
                &DELAY_MS.to_string(),
            ])
            .stdout(Stdio::piped())
            .spawn()
            .expect("start the relay"),
        log: PathBuf::new(),
    };
    let mut ready = String::new();
    std::io::BufReader::new(relay.child.stdout.as_mut().expect("relay's stdout"))
        .read_line(&mut ready)
        .expect("the relay starts");
    assert_eq!(ready.trim(), "ready");
    let mut echo = ns.orsa(
        "lossy-echo",
        &[
            "echo",
            "nomad200/basestate",
            "--json",
            "--wait",
            "30",
            "--connect",
            &format!("tcp/127.0.0.1:{robot_port}"),
            "--prefix",
            &prefix,
        ],
    );
    let mut speed = speeds(&mut echo);
    let exec = ns.orsa(
        "lossy-exec",
        &[
            "executive",
            "--connect",
            &format!("tcp/127.0.0.1:{relay_port}"),
            "--prefix",
            &prefix,
            "--report",
            exec_json.to_str().expect("utf-8"),
        ],
    );
    until_speed(&mut speed, "the executive drives across the slow link", |v| v > 0.15).await;

    ns.loss(LOSS_PERCENT);
    tokio::time::sleep(LOSS).await; // the fault's own length, not a wait for something
    let dropped = ns.loss(0);
    assert!(dropped > 0, "the loss dropped packets");
    // Whatever the loss did (a stop on a late heartbeat, a link lost and found again), the
    // robot patrols again by itself.
    while speed.try_recv().is_ok() {}
    until_speed(&mut speed, "patrols again after the loss", |v| v > 0.15).await;

    let exec = terminate(exec).await;
    let robot = terminate(robot).await;
    drop((echo, relay));
    let e: ExecutiveReport =
        serde_json::from_str(&std::fs::read_to_string(&exec_json).expect("the executive's report"))
            .expect("json");
    let r: RobotReport =
        serde_json::from_str(&std::fs::read_to_string(&robot_json).expect("the robot's report"))
            .expect("json");
    assert_eq!(r.safety.stale_applied, 0, "no stale command applied: {:?}", r.safety);
    assert!(r.safety.applied > 0);
    for s in &r.stops {
        eprintln!("stop: {s:?}");
        let reaction = s.zero_at_s - s.detected_at_s;
        assert!(
            (0.0..=0.1).contains(&reaction),
            "zero {reaction} s after the loss: {s:?}\n{}",
            robot.log_text()
        );
    }
    // The robot's and the executive's zids, as each saw the other.
    let exec_zid = heartbeat_zid(&e.links);
    let robot_zid =
        e.links.incoming.iter().find(|i| i.role.as_deref() == Some("robot")).map(|i| i.from.clone());
    let robot_zid = robot_zid.expect("the executive heard the robot");
    let to_robot = add_up(&exec_zid, &e.links, &r.links, "executive -> robot");
    let to_exec = add_up(&robot_zid, &r.links, &e.links, "robot -> executive");
    assert!(to_robot >= 1, "the heartbeat at least: {:#?}", r.links);
    assert!(to_exec >= 1, "the infrared scans at least: {:#?}", e.links);
    eprintln!(
        "{dropped} packets dropped; lost on the way: to the robot {}, to the executive {}; stops {}",
        r.links.missing(),
        e.links.missing(),
        r.stops.len()
    );
    drop(exec);
}
