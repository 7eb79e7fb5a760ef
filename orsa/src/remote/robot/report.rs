//! What `orsa robot --report` writes at exit: the process's figures ([`RobotReport`]) and every
//! stop the robot made by itself when it lost its executive ([`StopReport`]).

use crate::mission::report::Ended;
use orsa_actors::Registry;

/// What `orsa robot --report` writes at exit.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RobotReport {
    /// How the process ended (its figures cover the time up to then).
    #[serde(default)]
    pub ended: Ended,
    /// Seconds the robot ran (its clock at the end).
    pub duration_s: f64,
    /// When the fault plan's clock started (its `at` 0), seconds on the robot's clock.
    pub plan_started_at_s: Option<f64>,
    /// What the robot server did with velocity commands over its whole life (zero when its
    /// supervisor gave up: the server's counts went with it).
    pub safety: orsa_interfaces::nomad200::SafetyCounters,
    /// Restarts by the supervisors, all components together.
    #[serde(default)]
    pub restarts: u64,
    /// What link cuts kept from crossing.
    pub link: orsa_net::LinkCutStats,
    /// The delivery ledger across processes: what the robot put on its links, and what
    /// arrived from each peer (lost and duplicated on the way counted here).
    #[serde(default)]
    pub links: orsa_net::LinkLedger,
    /// Every time the robot stopped itself because it lost its executive: how fast it reacted
    /// and how far it went.
    #[serde(default)]
    pub stops: Vec<StopReport>,
    /// What the fault plan broke and how the robot came back (with `--faults`).
    pub faults: Option<crate::faults::FaultsReport>,
    /// What the ROS 2 node did (with `--ros2` or `--hardware ros2`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ros2: Option<crate::remote::ros2::Ros2Report>,
}

/// One stop the robot made by itself: from the moment it knew it had to stop to the moment it
/// was at rest. Times are seconds on the robot's clock.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StopReport {
    /// Why it stopped.
    pub cause: String,
    /// When the loss was established (a lease expired, a token disappeared).
    pub detected_at_s: f64,
    /// When the zero command was handed to the robot server.
    pub zero_at_s: f64,
    /// Its speed then, from its last base state, m/s.
    pub v_m_s: f64,
    /// When its base state first read at rest (base states come every 100 ms).
    pub at_rest_at_s: Option<f64>,
    /// How far it went from the detection to rest, by odometry, m.
    pub distance_m: f64,
    /// When something drove it again before it came to rest (the executive back, the
    /// fallback): the stop ended there, and `distance_m` counts up to then.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub driven_again_at_s: Option<f64>,
    /// Where it was at the last base state seen (odometry), for the distance.
    #[serde(skip)]
    last: Option<(f64, f64)>,
}

impl StopReport {
    pub(super) fn new(
        registry: &Registry,
        cause: String,
        detected: orsa_actors::Timestamp,
        zero: orsa_actors::Timestamp,
        base: Option<&orsa_interfaces::nomad200::BaseState>,
    ) -> Self {
        let s = |t| registry.clock().since_start(t).as_secs_f64();
        StopReport {
            cause,
            detected_at_s: s(detected),
            zero_at_s: s(zero),
            v_m_s: base.map_or(0.0, |b| b.v_m_s),
            at_rest_at_s: None,
            distance_m: 0.0,
            driven_again_at_s: None,
            last: base.map(|b| (b.x_m, b.y_m)),
        }
    }

    /// A base state at `t_s`: the distance grows until the robot is at rest (or driven again).
    pub(super) fn see(&mut self, t_s: f64, b: &orsa_interfaces::nomad200::BaseState) {
        if self.at_rest_at_s.is_some() || self.driven_again_at_s.is_some() || t_s < self.detected_at_s {
            return;
        }
        if let Some((x, y)) = self.last {
            self.distance_m += (b.x_m - x).hypot(b.y_m - y);
        }
        self.last = Some((b.x_m, b.y_m));
        if b.v_m_s == 0.0 && b.omega_rad_s == 0.0 {
            self.at_rest_at_s = Some(t_s);
        }
    }
}

impl StopReport {
    /// Something drives the robot again: the stops still open end now.
    pub(super) fn driven_again(registry: &Registry, stops: &mut [StopReport]) {
        let t = registry.clock().since_start(registry.now()).as_secs_f64();
        for s in stops.iter_mut().filter(|s| s.at_rest_at_s.is_none() && s.driven_again_at_s.is_none()) {
            s.driven_again_at_s = Some(t);
        }
    }
}

/// What the robot server `robot` did with velocity commands over its whole life, asked of it
/// (zero, said, if it does not answer).
pub(super) async fn safety_counters(
    registry: &Registry,
    robot: &str,
) -> orsa_interfaces::nomad200::SafetyCounters {
    let counters = async {
        orsa_actors::query::QueryClient::<orsa_actors::Empty, orsa_interfaces::nomad200::SafetyCounters>::connect(
            registry,
            orsa_interfaces::nomad200::SAFETY.on(robot),
        )?
        .query(orsa_actors::Empty {}, Some(std::time::Duration::from_secs(1)))
        .await
    };
    counters.await.unwrap_or_else(|e: orsa_actors::PatternError| {
        crate::say!("robot", "cannot read the safety counters: {e}");
        Default::default()
    })
}

/// What the fault `plan` broke over its `plan_end` seconds and how the robot came back: the
/// switchboard's and the boards' faults, the supervisors' restarts, and what the watchdog saw
/// of the link cuts.
pub(super) fn faults_report(
    registry: &Registry,
    plan: &crate::faults::FaultPlan,
    plan_end: f64,
    faults_switch: &orsa_actors::fault::Faults,
    boards: &orsa_hardware::faulty::BoardFaults,
    supervisor_events: &[orsa_actors::supervision::SupervisorEvent],
    watched: &super::watchdog::Watched,
) -> crate::faults::FaultsReport {
    let (link_log, links) = (&watched.link_log, &watched.links);
    let (restarts, restart_ms) = crate::faults::restarts_of(supervisor_events);
    let mut report = crate::faults::FaultsReport::new(
        plan,
        plan_end,
        faults_switch,
        &registry.clock(),
        boards,
        restarts,
        restart_ms,
    );
    for (_, role, what) in link_log {
        if what.starts_with("detected") {
            *report.detected.entry(role.clone()).or_default() += 1;
        }
    }
    report.log.extend(link_log.iter().cloned());
    report.log.sort_by(|a, b| a.0.total_cmp(&b.0));
    report.links = links.clone();
    report
}
