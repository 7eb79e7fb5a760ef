//! The figures the bench reports: one type per table, and [`BenchReport`], all of them (also
//! written as JSON by `--json`).

use serde::Serialize;
use std::collections::BTreeMap;

/// A latency distribution, in nanoseconds (nearest-rank percentiles).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct Latency {
    /// Samples.
    pub n: usize,
    /// Median.
    pub p50_ns: f64,
    /// 99th percentile.
    pub p99_ns: f64,
    /// Largest.
    pub max_ns: f64,
    /// Mean.
    pub mean_ns: f64,
}

/// One path's latency in one mode on one runtime.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LatencyRow {
    /// The tokio runtime (`current-thread`, `multi-thread (2 workers)`).
    pub runtime: String,
    /// `back-to-back` (one in flight) or `25 Hz`.
    pub mode: String,
    /// What was measured.
    pub path: String,
    /// The path this one is compared with, if any.
    pub baseline: Option<String>,
    /// The distribution.
    pub latency: Latency,
    /// p50 over the baseline's p50.
    pub p50_ratio: Option<f64>,
    /// p99 over the baseline's p99.
    pub p99_ratio: Option<f64>,
}

/// One path's throughput on one runtime.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThroughputRow {
    /// The tokio runtime.
    pub runtime: String,
    /// What was measured.
    pub path: String,
    /// How: a burst of pushes until the last is handled, or round trips one at a time.
    pub how: String,
    /// Messages (or round trips).
    pub messages: u64,
    /// Wall time they took, s.
    pub wall_s: f64,
    /// Messages per second.
    pub per_s: f64,
    /// The path this one is compared with, if any.
    pub baseline: Option<String>,
    /// Rate over the baseline's rate.
    pub ratio: Option<f64>,
}

/// One push server fanned out to N subscribers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FanoutRow {
    /// Subscribers.
    pub subscribers: usize,
    /// Rounds measured (one publish each).
    pub rounds: usize,
    /// How long `put` takes (the publisher's cost).
    pub orsa_publish: Latency,
    /// From before `put` to the last subscriber component's handler.
    pub orsa_last_handler: Latency,
    /// How long the loop of casts takes.
    pub raw_publish: Latency,
    /// From before the loop of casts to the last actor's handler.
    pub raw_last_handler: Latency,
    /// orsa's last-handler p50 over raw's.
    pub last_p50_ratio: Option<f64>,
    /// orsa's last-handler p50 divided by the subscribers.
    pub orsa_ns_per_subscriber: f64,
    /// raw's last-handler p50 divided by the subscribers.
    pub raw_ns_per_subscriber: f64,
    /// Deliveries the server counted (warm-up included).
    pub delivered: u64,
    /// Deliveries expected: rounds (warm-up included) times subscribers.
    pub expected: u64,
    /// Handler runs counted.
    pub handled: u64,
}

/// What the safety monitor between the robot server and the motor board costs sense to act:
/// runs with it (`sense_to_act`, then `again`) and without it (`without`, between the two)
/// in one bench run. Its cost is within the run's spread when the figure without it is no
/// further from the mean of the two runs with it than those two are from each other.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MonitorCost {
    /// Sense to act with `safety.enabled = false`.
    pub without: SenseToAct,
    /// Sense to act with the monitor, again, after the run without it.
    pub again: SenseToAct,
}

/// Reads one percentile of a [`Latency`], ns.
pub type Percentile = fn(&Latency) -> f64;

impl MonitorCost {
    /// The percentiles the cost is judged at, with how to read each from a [`Latency`].
    pub const PERCENTILES: [(&'static str, Percentile); 2] = [("p50", |l| l.p50_ns), ("p99", |l| l.p99_ns)];

    /// For `pick` (a percentile of the figure from the update, ns) and the first run with the
    /// monitor `with`: (mean with - without, spread |with - again|), ns.
    pub fn cost_and_spread(&self, with: &SenseToAct, pick: impl Fn(&Latency) -> f64) -> (f64, f64) {
        let (a, b) = (pick(&with.from_update), pick(&self.again.from_update));
        ((a + b) / 2.0 - pick(&self.without.from_update), (a - b).abs())
    }
}

/// What a Foxglove client publishing velocity commands and a ROS 2 client calling the
/// parameter services cost sense to act, side by side with their baselines in one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InteropCost {
    /// A live server and a client subscribed to everything that also publishes velocity
    /// commands on `/cmd_vel` at 20 Hz (each refused by the robot as stale after the whole
    /// path). Its baseline is the same client only reading: `sense_to_act_live` before it and
    /// `live_again` after.
    pub publishing: SenseToAct,
    /// The live client only reading, again, right after `publishing`.
    pub live_again: SenseToAct,
    /// The stack alone on the robot's runtime (`orsa robot`'s: multi-thread, two workers; zenoh
    /// needs one): the services' baseline, before them.
    pub robot: SenseToAct,
    /// The robot's ROS 2 node serving its parameter services on that runtime,
    /// `get_parameters` called back to back by a client with a session of its own.
    pub services: SenseToAct,
    /// The stack alone on the robot's runtime again, after the services.
    pub robot_again: SenseToAct,
}

impl InteropCost {
    /// For `pick` (a percentile of the figure from the update, ns): the cost of `arm` over its
    /// baseline's two runs `a` and `b` (arm less their mean) and the spread (|a - b|), ns.
    pub fn cost_and_spread(
        arm: &SenseToAct,
        a: &SenseToAct,
        b: &SenseToAct,
        pick: impl Fn(&Latency) -> f64,
    ) -> (f64, f64) {
        let (a, b) = (pick(&a.from_update), pick(&b.from_update));
        (pick(&arm.from_update) - (a + b) / 2.0, (a - b).abs())
    }
}

/// Sense to act in process, in real time.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SenseToAct {
    /// Measured span, wall s.
    pub duration_s: f64,
    /// Velocity commands the motor board received.
    pub commands_received: u64,
    /// Of those, attributed to the behaviour step that computed them.
    pub attributed: u64,
    /// Not attributed (the master's zero commands while nothing is wired).
    pub unattributed: u64,
    /// Attributed commands per behaviour.
    pub by_behaviour: BTreeMap<String, u64>,
    /// From the sensor update's publication to the motor board.
    pub from_update: Latency,
    /// From the newest sensor firing in that update to the motor board (includes the
    /// simulator's 10 ms sampling).
    pub from_sensor_firing: Latency,
    /// The figure from the update, in legs (each summarised on its own: the legs' p50s need
    /// not add up to the whole's).
    pub legs: Vec<SenseLeg>,
    /// Commands the server refused as stale.
    pub stale_refused: u64,
    /// Whether a safety monitor guarded the motors (the robot server's counters have one).
    pub monitor: bool,
    /// Supervisor restarts during the run.
    pub restarts: u64,
    /// With a live server (`--foxglove`) serving the views to a client subscribed to
    /// everything: what the client got.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub live_client: Option<LiveClient>,
    /// With the robot's ROS 2 node serving its parameter services to a client calling them
    /// back to back: what the client got.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ros2_calls: Option<ServiceCalls>,
}

/// A live server's client during a sense-to-act run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LiveClient {
    /// Channels it subscribed to.
    pub subscribed: u64,
    /// Messages it read.
    pub messages: u64,
    /// Messages the control loop handed the views.
    pub handed: u64,
    /// Messages dropped because the views' queue was full.
    pub dropped: u64,
    /// Velocity commands it published on `/cmd_vel` (client publish), each stamped long ago.
    pub published: u64,
    /// Of those, what the server handed to the robot's teleop service (which refuses them
    /// as stale: the run's `stale_refused`).
    pub taken: u64,
}

/// What a ROS 2 client calling the robot node's parameter services got during a sense-to-act
/// run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct ServiceCalls {
    /// Calls answered with a value for every parameter asked.
    pub answered: u64,
    /// Calls answered with some parameter missing.
    pub incomplete: u64,
    /// Calls that failed (before the services were discovered, or lost).
    pub failed: u64,
}

/// One path's one-way latency across processes in one mode.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NetLatencyRow {
    /// `back-to-back` (one in flight) or `25 Hz`.
    pub mode: String,
    /// What was measured.
    pub path: String,
    /// The path this one is compared with, if any.
    pub baseline: Option<String>,
    /// The distribution (receiver's UNIX time minus the sender's, same host).
    pub latency: Latency,
    /// p50 over the baseline's p50.
    pub p50_ratio: Option<f64>,
    /// p99 over the baseline's p99.
    pub p99_ratio: Option<f64>,
    /// Samples sent in this mode.
    pub sent: u64,
    /// Samples received.
    pub received: u64,
    /// Whether they arrived in the order sent.
    pub in_order: bool,
    /// How long sending took in the sending process (orsa's `put`; raw: encoding and `put`).
    pub sender_put: Latency,
}

/// What the sample costs to encode and decode, raw and in orsa's envelope (in one process).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CodecCosts {
    /// CBOR bytes of the sample alone (the raw paths).
    pub raw_bytes: usize,
    /// CBOR bytes of the sample in orsa's stamped envelope (the orsa paths).
    pub orsa_bytes: usize,
    /// ns to encode the sample (ciborium).
    pub raw_encode_ns: f64,
    /// ns to decode it.
    pub raw_decode_ns: f64,
    /// ns for orsa's `encode_stamped`.
    pub orsa_encode_ns: f64,
    /// ns for orsa's `decode_stamped`.
    pub orsa_decode_ns: f64,
}

/// Everything measured across processes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NetReport {
    /// The tokio runtimes.
    pub runtime: String,
    /// How the two processes are connected.
    pub transport: String,
    /// Wall seconds from opening the session to the first sample on every path (the peer's
    /// start-up included).
    pub startup_s: f64,
    /// One-way latencies.
    pub latency: Vec<NetLatencyRow>,
    /// Encoding costs.
    pub codec: CodecCosts,
    /// Sense to act with the behaviours in the other process.
    pub sense_to_act: Option<SenseToAct>,
    /// A mode switch of the behaviours in the other process.
    pub switch: Option<SwitchPair>,
}

/// One leg of sense to act.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SenseLeg {
    /// From where to where.
    pub leg: String,
    /// Its distribution over the attributed commands.
    pub latency: Latency,
}

/// `orsa run`'s speed: the corridor mission on a paused clock, start-up and shutdown included.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct MissionRtf {
    /// Simulated seconds.
    pub simulated_s: f64,
    /// Wall seconds.
    pub wall_s: f64,
    /// Simulated seconds per wall second.
    pub rtf: f64,
    /// Distance the robot drove, m (it did patrol).
    pub distance_m: f64,
    /// Supervisor restarts.
    pub restarts: u64,
}

/// What recording costs `orsa run`, and what replaying the recording costs, in one fresh
/// process, runs alternated (plain, recorded, replay) so the machine's drift hits all three.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RecordReplay {
    /// Simulated seconds of each run.
    pub simulated_s: f64,
    /// `orsa run` without `--record`: wall s of each run.
    pub run_wall_s: Vec<f64>,
    /// `orsa run --record`: wall s of each run (the file written and closed).
    pub record_wall_s: Vec<f64>,
    /// `orsa replay` of that recording: wall s of each run (reading and checking the file
    /// included).
    pub replay_wall_s: Vec<f64>,
    /// Median recorded run over median plain run.
    pub record_ratio: f64,
    /// Median replay over median plain run.
    pub replay_ratio: f64,
    /// `orsa run` with a live server (`--foxglove`) and no client: wall s of each run.
    pub live_wall_s: Vec<f64>,
    /// Median run with a live server and no client over median plain run.
    pub live_ratio: f64,
    /// Every replay was bit-exact.
    pub bit_exact: bool,
    /// Messages in the recording.
    pub messages: u64,
    /// Messages a replay compared.
    pub compared: u64,
    /// The recording's size, bytes.
    pub file_bytes: u64,
}

/// A mode switch (hand the motors from one behaviour to the other: unwire, two states, wire)
/// made as one all-or-nothing switch, and the same four calls one by one, alternated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SwitchPair {
    /// Hand-overs of each kind.
    pub rounds: usize,
    /// As one switch (prepare, then commit).
    pub switch: Latency,
    /// Call by call.
    pub one_by_one: Latency,
    /// Median switch over median one-by-one.
    pub p50_ratio: f64,
}

/// What a mode switch costs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SwitchCosts {
    /// Behaviours in the same process as the master.
    pub in_process: SwitchPair,
    /// Behaviours in another process (`None` if the cross-process bench failed).
    pub across: Option<SwitchPair>,
}

/// N whole stacks in one process on one paused clock.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct ScaleRow {
    /// Robots, each with its own simulator, components, supervisor and registry.
    pub robots: usize,
    /// Wall time to bring them all up, s.
    pub startup_wall_s: f64,
    /// Simulated seconds measured (after a warm-up).
    pub simulated_s: f64,
    /// Wall seconds they took.
    pub wall_s: f64,
    /// Simulated seconds per wall second, for the whole set.
    pub rtf: f64,
    /// Robot-seconds simulated per wall second (`rtf` times robots).
    pub robot_seconds_per_wall_s: f64,
    /// Wall microseconds per robot per simulated second: the cost per robot.
    pub wall_us_per_robot_sim_s: f64,
    /// The fewest simulator steps any robot took in the measured span.
    pub min_steps_per_robot: u64,
    /// Steps each robot should have taken.
    pub expected_steps_per_robot: u64,
    /// Mean distance driven per robot over the whole run, m.
    pub mean_distance_m: f64,
    /// Supervisor restarts, all robots.
    pub restarts: u64,
    /// Resident memory added per robot, MiB (Linux).
    pub rss_mib_per_robot: Option<f64>,
    /// Wall time to shut them all down, s.
    pub shutdown_wall_s: f64,
    /// The baseline: the same number of robots as raw tokio skeletons (the stack's tasks,
    /// timers and message flow, none of its work), wall µs per robot per simulated second.
    pub raw_wall_us_per_robot_sim_s: Option<f64>,
    /// The same skeletons with the stack's six actors (its five components and their
    /// supervisor) as plain ractor actors: what the actor runtime adds to the raw skeleton,
    /// still with none of the stack's work.
    #[serde(default)]
    pub ractor_wall_us_per_robot_sim_s: Option<f64>,
    /// The real-time factor of every run of this row, in the order run; the row is the median
    /// run (one run for the largest rows).
    pub rtf_runs: Vec<f64>,
}

/// One target of the issue, judged.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetCheck {
    /// The target.
    pub target: String,
    /// What was measured.
    pub measured: String,
    /// Whether it was met (`None`: not measured).
    pub met: Option<bool>,
}

/// The machine the run was made on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Machine {
    /// CPU model, from `/proc/cpuinfo`.
    pub cpu: String,
    /// Logical CPUs available to the process.
    pub logical_cpus: usize,
    /// Memory, GiB, from `/proc/meminfo`.
    pub memory_gib: Option<f64>,
    /// Kernel release.
    pub kernel: String,
    /// Whether this binary was built with optimisations (`--release`).
    pub optimized: bool,
}

/// Everything one `orsa-bench` run measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BenchReport {
    /// In-process push, publish to handler, p50, ns (current-thread runtime, back-to-back).
    pub inproc_push_p50_ns: f64,
    /// Raw ractor cast, same conditions, p50, ns.
    pub raw_ractor_cast_p50_ns: f64,
    /// Sense to act in process, p99, ns (sensor update to motor board).
    pub sense_to_act_inproc_p99_ns: f64,
    /// `orsa run`'s real-time factor, one robot.
    pub rtf_1_robot: f64,
    /// Real-time factor of 100 robots in one process.
    pub rtf_100_robots: f64,
    /// Push over zenoh to a component in another process, p50, ns (back-to-back; `None` if
    /// the cross-process bench failed).
    pub zenoh_push_p50_ns: Option<f64>,
    /// Raw zenoh publish to a subscriber callback in another process, same payload, p50, ns.
    pub raw_zenoh_p50_ns: Option<f64>,
    /// Sense to act with the behaviours in another process, p99, ns.
    pub sense_to_act_xproc_p99_ns: Option<f64>,
    /// Whether this was a `--quick` run.
    pub quick: bool,
    /// orsa's version.
    pub orsa_version: String,
    /// The machine.
    pub machine: Machine,
    /// The command that made this report.
    pub command: String,
    /// Wall time of the whole run, s.
    pub wall_s: f64,
    /// In-process latencies.
    pub latency: Vec<LatencyRow>,
    /// In-process throughput.
    pub throughput: Vec<ThroughputRow>,
    /// Fan-out.
    pub fanout: Vec<FanoutRow>,
    /// Sense to act.
    pub sense_to_act: SenseToAct,
    /// Sense to act while a live server serves the views to a client subscribed to everything.
    pub sense_to_act_live: SenseToAct,
    /// What the safety monitor costs sense to act: the same run without it, and again with
    /// it (the spread).
    pub monitor_cost: Option<MonitorCost>,
    /// What client publish and the ROS 2 parameter services cost sense to act.
    pub interop_cost: Option<InteropCost>,
    /// Across processes (`None` if that bench failed; see `net_error`).
    pub net: Option<NetReport>,
    /// Why the cross-process bench failed, if it did.
    pub net_error: Option<String>,
    /// What the ROS 2 publication adds to the robot's cross-process push (`None` if that
    /// bench failed; see `ros2_error`).
    pub ros2: Option<Ros2Cost>,
    /// Why the ROS 2 bench failed, if it did.
    pub ros2_error: Option<String>,
    /// `orsa run`'s speed.
    pub mission: MissionRtf,
    /// What recording and replaying cost.
    pub record_replay: RecordReplay,
    /// What a mode switch costs.
    pub switch: SwitchCosts,
    /// N robots in one process.
    pub scale: Vec<ScaleRow>,
    /// The targets, judged.
    pub targets: Vec<TargetCheck>,
}

/// What the ROS 2 publication adds to the robot's cross-process push (`orsa robot --ros2`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Ros2Cost {
    /// Push to the remote subscriber, without the ROS 2 publication.
    pub plain: Latency,
    /// The same, with the ROS 2 publication of every scan.
    pub with_ros2: Latency,
    /// `with_ros2` p50 over `plain` p50.
    pub p50_ratio: Option<f64>,
    /// The ROS 2 path's own time per scan: convert, encode, put (p50, ns).
    pub ros2_publish_p50_ns: f64,
    /// LaserScans the ROS 2 subscriber on the other side received.
    pub ros2_received: u64,
    /// Scans the remote subscriber did not receive within 1 s (not counted in the latencies).
    pub lost: u64,
    /// The same push with the ROS 2 publication while a ROS 2 client on the other session
    /// calls the robot node's `get_parameters` back to back (the parameter services of
    /// `orsa robot --ros2`, its own code).
    pub with_services: Latency,
    /// `with_services` p50 over `with_ros2` p50.
    pub services_p50_ratio: Option<f64>,
    /// The spread of `with_ros2` itself: the interquartile range of its blocks' p50s over their
    /// median (what a ratio within the run's noise stays within).
    pub with_ros2_spread: f64,
    /// Calls answered while the services' blocks ran.
    pub service_calls: u64,
}
