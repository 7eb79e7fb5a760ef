//! The distributed system as users run it: the built `orsa` binary started as separate
//! processes (robot, executive, teleop, echo) on loopback ports picked at run time, watched
//! from this test through its own zenoh session with orsa's ordinary clients.
//!
//! These run in real time (zenoh and processes cannot run on a paused clock). Every wait is
//! for a condition with a deadline; no test sleeps to let something happen.

mod chaos;
mod ending;
mod examples;
mod interop;
mod links;
#[cfg(target_os = "linux")]
mod lossy;
#[cfg(target_os = "linux")]
mod memory;
mod navigation;
mod params;
mod processes;
mod replay;
mod ros2;
mod security;
mod stopping;
mod switch;

#[allow(dead_code, unreachable_pub)]
#[path = "../../examples/remote_client.rs"]
mod remote_client;

use orsa::interfaces::nomad200::{self, BaseState};
use orsa_actors::push_timed::PushTimedClient;
use orsa_actors::{Registry, Sink, Update};
use orsa_net::{NetOptions, ZenohTransport};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;
use tokio::sync::mpsc;

/// A child process killed when dropped, its stderr kept in a file.
pub(crate) struct Proc {
    pub(crate) child: Child,
    pub(crate) log: PathBuf,
}

impl Proc {
    /// Sends it `sig` (`-KILL`, `-INT`, `-TERM`, `-STOP`, `-CONT`) with `kill`.
    pub(crate) fn signal(&self, sig: &str) {
        let ok = Command::new("kill").args([sig, &self.child.id().to_string()]).status().expect("run kill");
        assert!(ok.success(), "kill {sig} failed");
    }

    pub(crate) fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub(crate) fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").expect("bind").local_addr().expect("addr").port()
}

/// Starts `orsa ARGS...`, stderr into a temporary file named after `name`.
pub(crate) fn orsa(name: &str, args: &[&str]) -> Proc {
    orsa_with_env(name, args, &[])
}

/// `orsa` with these variables in its environment (and no `ROS_DOMAIN_ID` from the test's own
/// unless given here).
pub(crate) fn orsa_with_env(name: &str, args: &[&str], env: &[(&str, &str)]) -> Proc {
    let log = std::env::temp_dir().join(format!("orsa-test-{}-{name}.log", std::process::id()));
    let file = std::fs::File::create(&log).expect("log file");
    let child = Command::new(env!("CARGO_BIN_EXE_orsa"))
        .args(args)
        .env_remove("ROS_DOMAIN_ID")
        .envs(env.iter().copied())
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(file)
        .spawn()
        .expect("start orsa");
    Proc { child, log }
}

/// A system on a fresh port and prefix: the robot listens, everyone else connects.
pub(crate) struct System {
    pub(crate) port: u16,
    pub(crate) prefix: String,
}

impl System {
    pub(crate) fn new(name: &str) -> Self {
        System { port: free_port(), prefix: format!("t{}{name}", std::process::id()) }
    }

    pub(crate) fn listen_args(&self) -> Vec<String> {
        vec![
            "--listen".into(),
            format!("tcp/127.0.0.1:{}", self.port),
            "--prefix".into(),
            self.prefix.clone(),
        ]
    }

    pub(crate) fn connect_args(&self) -> Vec<String> {
        vec![
            "--connect".into(),
            format!("tcp/127.0.0.1:{}", self.port),
            "--prefix".into(),
            self.prefix.clone(),
        ]
    }

    pub(crate) fn robot(&self, extra: &[&str]) -> Proc {
        self.robot_with_env(extra, &[])
    }

    /// The robot, with these variables in its environment.
    pub(crate) fn robot_with_env(&self, extra: &[&str], env: &[(&str, &str)]) -> Proc {
        let mut args: Vec<String> = vec!["robot".into()];
        args.extend(self.listen_args());
        args.extend(extra.iter().map(|s| s.to_string()));
        orsa_with_env(
            &format!("{}-robot", self.prefix),
            &args.iter().map(String::as_str).collect::<Vec<_>>(),
            env,
        )
    }

    pub(crate) fn run(&self, name: &str, sub: &str, extra: &[&str]) -> Proc {
        let mut args: Vec<String> = vec![sub.into()];
        args.extend(extra.iter().map(|s| s.to_string()));
        args.extend(self.connect_args());
        orsa(&format!("{}-{name}", self.prefix), &args.iter().map(String::as_str).collect::<Vec<_>>())
    }

    /// This test's own session into the system.
    pub(crate) async fn observe(&self) -> (Registry, ZenohTransport) {
        let registry = Registry::new();
        let options = NetOptions {
            connect: vec![format!("tcp/127.0.0.1:{}", self.port)],
            prefix: self.prefix.clone(),
            ..NetOptions::default()
        };
        let t = ZenohTransport::open(&registry, &options, "test").await.expect("observer session");
        (registry, t)
    }
}

pub(crate) const STARTUP: Duration = Duration::from_secs(30);

/// The robot's base state, every update.
pub(crate) async fn base_stream(
    registry: &Registry,
    t: &ZenohTransport,
) -> (PushTimedClient<BaseState>, mpsc::UnboundedReceiver<Update<BaseState>>) {
    // Every robot service the tests use, announced independently of each other.
    let services: Vec<orsa_actors::ServiceAddr> = [
        "nomad200/basestate",
        "nomad200/safety",
        "nomad200/teleop",
        "nomad200/navigationvelocity",
        "wallfollow/wiring",
        "centerfollow/wiring",
    ]
    .iter()
    .map(|s| s.parse().expect("addr"))
    .collect();
    t.wait_for(&services, STARTUP).await.expect("the robot is up");
    let (tx, rx) = mpsc::unbounded_channel();
    let c = PushTimedClient::<BaseState>::connect_to(
        registry,
        nomad200::BASESTATE.on(nomad200::NAME),
        Sink::channel(tx),
    )
    .expect("base state client");
    c.subscribe(1).expect("subscribe");
    (c, rx)
}

/// Reads base states until `pred` holds, at most `within`; the state that satisfied it.
pub(crate) async fn until_base(
    rx: &mut mpsc::UnboundedReceiver<Update<BaseState>>,
    within: Duration,
    what: &str,
    pred: impl Fn(&BaseState) -> bool,
) -> Update<BaseState> {
    let found = tokio::time::timeout(within, async {
        loop {
            let u = rx.recv().await.expect("base state stream ended");
            if pred(&u.value) {
                return u;
            }
        }
    })
    .await;
    found.unwrap_or_else(|_| panic!("{what}: not within {within:?}"))
}

/// Every stream from `sender` that `receiver` followed: the receiver saw no number the sender
/// did not use, and what it counts (first, arrived, missing) adds up to the sender's count with
/// what was still in flight at the end. The streams checked.
pub(crate) fn add_up(
    sender_zid: &str,
    sender: &orsa_net::LinkLedger,
    receiver: &orsa_net::LinkLedger,
    what: &str,
) -> usize {
    let mut checked = 0;
    for i in receiver.incoming.iter().filter(|i| i.from == sender_zid) {
        let o = sender.outgoing(i.outlet).unwrap_or_else(|| panic!("{what}: the sender's outlet {i:?}"));
        assert_eq!(o.key, i.key, "{what}: one outlet, one key");
        let c = i.counts;
        assert!(c.newest <= o.sent, "{what}: received a number never sent: {i:?} {o:?}");
        let in_flight = o.sent - c.newest;
        assert_eq!((c.first - 1) + c.arrived + c.missing + in_flight, o.sent, "{what}: {i:?} {o:?}");
        assert_eq!(c.duplicates, 0, "{what}: {i:?}");
        eprintln!(
            "{what} {}: sent {} arrived {} missing {} late {} before-first {} in-flight {in_flight}",
            i.key,
            o.sent,
            c.arrived,
            c.missing,
            c.late,
            c.first - 1
        );
        checked += 1;
    }
    checked
}

/// The zid of the executive whose ledger this is, from the key its heartbeat is published on
/// (`<prefix>/v1/heartbeat/<zid>/executive`).
pub(crate) fn heartbeat_zid(ledger: &orsa_net::LinkLedger) -> String {
    let key = ledger.outgoing.iter().map(|o| o.key.as_str()).find(|k| k.contains("/heartbeat/"));
    let key = key.unwrap_or_else(|| panic!("an executive publishes its heartbeat: {ledger:#?}"));
    let mut parts = key.split('/').skip_while(|p| *p != "heartbeat");
    parts.nth(1).expect("a zid after heartbeat/").to_string()
}
