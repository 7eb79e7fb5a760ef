//! Robot kinds: how a process gets the robot it drives.
//!
//! A robot kind is registered in the [`Catalog`](super::Catalog) like a component kind, under a
//! name (`orsa robot --hardware NAME`, [`Stack`'s](../../orsa/mission/stack/index.html) robot).
//! Its maker gets what the process knows ([`RobotSetup`]: the config, the world, the seed, the
//! clock) and brings up a [`Robot`]: its two boards, what it is ([`RobotParams`]: geometry, drive,
//! range sensors with their poses and fields of view), the simulator's ground truth if it has
//! one, and a handle that keeps whatever runs it (a simulator task, a link to a ROS 2 base) and
//! stops it at the end. The robot server component (kind `robot`) then serves those boards to
//! every behaviour, whatever the robot.
//!
//! Built in:
//! - `sim`: the simulator, building the robot its `[sim]` table describes (the Nomad 200 by
//!   default, or a differential-drive robot with a planar laser: `config/diffbot.toml`);
//! - `ros2`: a ROS 2 robot that publishes a laser scan and odometry and takes velocity
//!   commands, described by `[ros2.base]`; it drives nothing until its command publisher is
//!   set ([`Ros2Robot::connect_publisher`]), which the robot process does once on the network.
//!
//! A user's own robot is one [`Catalog::register_robot`](super::Catalog::register_robot) (see
//! `examples/new_robot.rs`).

use crate::config::Config;
use orsa_actors::Clock;
use orsa_hardware::any::{AnyMotorBoard, AnySensorBoard};
use orsa_hardware::board::MotorBoard;
use orsa_hardware::faulty::{BoardFaults, FaultyMotorBoard, FaultySensorBoard};
use orsa_hardware::ros2base::Ros2Base;
use orsa_hardware::safety::{Guarded, SafetyParams};
use orsa_hardware::sim::{SimNomad200, SimRobot, SimTruth};
use orsa_hardware::world::World;
use orsa_interfaces::nomad200::RobotParams;
use orsa_net::ros2::Ros2Publisher;
use orsa_net::ros2::msg::{Header, Time, Twist, TwistStamped};
use std::any::Any;
use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, OnceLock};
use std::time::Duration;

/// What a robot kind's maker has to bring its robot up from.
#[derive(Debug, Clone, Copy)]
pub struct RobotSetup<'a> {
    /// The configuration of the whole system (`[sim]`, `[ros2.base]`, the push periods).
    pub config: &'a Config,
    /// The world a simulated robot lives in.
    pub world: &'a World,
    /// The seed of a simulated robot's noise.
    pub seed: u64,
    /// The process's clock.
    pub clock: Clock,
}

/// Why a robot could not be brought up.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RobotError {
    /// No robot kind of that name in the catalog.
    #[error("no robot kind '{kind}' in the catalog (known: {known})")]
    Unknown {
        /// The kind asked for.
        kind: String,
        /// The kinds the catalog has, comma-separated.
        known: String,
    },
    /// The kind's maker refused.
    #[error("robot kind '{kind}': {message}")]
    Make {
        /// The kind.
        kind: String,
        /// What went wrong.
        message: String,
    },
}

/// A future a robot's handle returns when it stops.
pub type StopFuture = Pin<Box<dyn Future<Output = ()> + Send>>;

/// What keeps a robot running: the simulator's task, a link to a ROS 2 base, a user's driver.
/// Dropped or stopped at the end of the process.
pub trait RobotHandle: Send + Sync + 'static {
    /// Stops whatever runs the robot (the motors have been stopped on the board before).
    fn stop(self: Box<Self>) -> StopFuture;
    /// The handle as [`Any`], for [`Robot::handle`].
    fn as_any(&self) -> &dyn Any;
}

impl RobotHandle for SimRobot {
    fn stop(self: Box<Self>) -> StopFuture {
        Box::pin(async move {
            if let Err(e) = self.shutdown().await {
                tracing::warn!("simulator task ended badly: {e}");
            }
        })
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// A handle with nothing to stop (a robot whose boards need nothing running behind them).
impl RobotHandle for () {
    fn stop(self: Box<Self>) -> StopFuture {
        Box::pin(async {})
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// A robot brought up by its kind.
pub struct Robot {
    /// The kind that made it.
    pub kind: String,
    /// Its sensor board.
    pub sensors: AnySensorBoard,
    /// Its motor board.
    pub motors: AnyMotorBoard,
    /// What it is, as behaviours should know it (with the robot server's push periods).
    pub params: RobotParams,
    /// Ground truth, if the robot is simulated (for metrics; never for control).
    pub truth: Option<SimTruth>,
    handle: Box<dyn RobotHandle>,
}

impl std::fmt::Debug for Robot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Robot")
            .field("kind", &self.kind)
            .field("simulated", &self.truth.is_some())
            .finish_non_exhaustive()
    }
}

impl Robot {
    /// A robot of `sensors` and `motors`, described by `params`; `handle` keeps what runs it.
    pub fn new(
        sensors: AnySensorBoard,
        motors: AnyMotorBoard,
        params: RobotParams,
        handle: impl RobotHandle,
    ) -> Self {
        Robot { kind: String::new(), sensors, motors, params, truth: None, handle: Box::new(handle) }
    }

    /// The simulated robot `sim`, its boards, what `config` says it is, and its truth.
    pub fn simulated(sim: SimRobot, config: &Config) -> Self {
        let mut robot = Robot::new(
            AnySensorBoard::Sim(sim.sensor_board()),
            AnyMotorBoard::Sim(sim.motor_board()),
            config.sim.robot_params(config.robot().push_periods()),
            (),
        );
        robot.truth = Some(sim.truth());
        robot.handle = Box::new(sim);
        robot
    }

    /// With ground truth (a user's simulator that has one).
    pub fn with_truth(mut self, truth: SimTruth) -> Self {
        self.truth = Some(truth);
        self
    }

    /// Its boards behind the fault switch `faults`, the motors guarded by a safety monitor
    /// with `safety` (refused, naming the key, if its zones cannot stop this robot), for the
    /// robot server. Must run inside a tokio runtime (the monitor has a task of its own).
    pub fn boards(
        &self,
        faults: &BoardFaults,
        safety: &SafetyParams,
    ) -> Result<super::RobotBoards, RobotError> {
        // What the robot's own figures are called where they come from.
        let keys = if self.kind == super::SIM {
            "sim.drive.max_translate_m_s and translate_accel_m_s2"
        } else {
            "as the robot describes itself"
        };
        safety
            .check_against(&self.params, keys)
            .map_err(|e| RobotError::Make { kind: self.kind.clone(), message: e.to_string() })?;
        let sensors = FaultySensorBoard::new(self.sensors.clone(), faults.clone());
        let motors = Guarded::new(
            sensors.clone(),
            FaultyMotorBoard::new(self.motors.clone(), faults.clone()),
            self.params.clone(),
            safety.clone(),
        );
        Ok(super::RobotBoards { sensors: motors.clone(), motors, params: self.params.clone() })
    }

    /// The handle of its kind, if it is a `T` (e.g. [`SimRobot`], [`Ros2Robot`]).
    pub fn handle<T: 'static>(&self) -> Option<&T> {
        self.handle.as_any().downcast_ref()
    }

    /// Stops the motors on the board itself, past every fault switch and component; how long
    /// they took to come to rest (None: they did not within `wait`), on the board's own clock
    /// (its readings' stamps: a simulator's time, which a loaded host can hold back, or a real
    /// board's), else on the host's.
    pub async fn stop_on_board(&self, wait: Duration) -> Option<f64> {
        let t0 = tokio::time::Instant::now();
        let stamp = async || self.motors.read_state().await.ok().map(|s| s.stamp);
        let from = stamp().await;
        if let Err(e) = self.motors.stop().await {
            tracing::error!("cannot stop the motors: {e}");
        }
        match self.motors.wait_stop(wait).await {
            Ok(()) => Some(match (from, stamp().await) {
                (Some(from), Some(to)) if to >= from => (to.0 - from.0) as f64 / 1e9,
                _ => t0.elapsed().as_secs_f64(),
            }),
            Err(e) => {
                tracing::error!("the robot is still moving {wait:?} after the motors were stopped: {e}");
                None
            }
        }
    }

    /// Stops whatever runs the robot (once nothing drives it any more).
    pub async fn shutdown(self) {
        self.handle.stop().await;
    }
}

/// A robot kind's maker.
pub(crate) type MakeRobot = dyn Fn(&RobotSetup<'_>) -> Result<Robot, super::catalog::BoxError> + Send + Sync;

/// The simulator, building the robot the config's `[sim]` table describes.
pub(crate) fn simulated(setup: &RobotSetup<'_>) -> Result<Robot, super::catalog::BoxError> {
    let sim = SimNomad200::new(setup.world.clone(), setup.config.sim.clone(), setup.seed)
        .map_err(|e| format!("simulator: {e}"))?;
    Ok(Robot::simulated(SimRobot::spawn(sim, setup.clock), setup.config))
}

/// A ROS 2 robot (`--hardware ros2`): its boards read the base's scan and odometry and send
/// its commands through a publisher set once the process is on the network.
#[derive(Debug, Clone)]
pub struct Ros2Robot {
    /// The base the boards stand for.
    pub base: Ros2Base,
    publisher: Arc<OnceLock<CmdVelPublisher>>,
}

/// Where a ROS 2 base's velocity commands go, in the type its config names
/// ([`CmdVelType`](orsa_hardware::ros2base::CmdVelType)).
#[derive(Debug)]
pub enum CmdVelPublisher {
    /// As `geometry_msgs/msg/Twist`.
    Twist(Ros2Publisher<Twist>),
    /// As `geometry_msgs/msg/TwistStamped`, stamped when sent, in `base_link`.
    TwistStamped(Ros2Publisher<TwistStamped>),
}

impl CmdVelPublisher {
    /// Sends `v` m/s and `w` rad/s, at `now` (ns, UNIX time).
    fn send(&self, v: f64, w: f64, now: u64) {
        let mut twist = Twist::default();
        twist.linear.x = v;
        twist.angular.z = w;
        match self {
            CmdVelPublisher::Twist(p) => p.publish(&twist, now),
            CmdVelPublisher::TwistStamped(p) => {
                let header = Header { stamp: Time::from_nanos(now), frame_id: "base_link".into() };
                p.publish(&TwistStamped { header, twist }, now);
            }
        }
    }
}

impl Ros2Robot {
    /// Sends the base's commands through `publisher` from now on (once: a second is refused).
    pub fn connect_publisher(&self, publisher: CmdVelPublisher) -> Result<(), AlreadySet> {
        self.publisher.set(publisher).map_err(|_| AlreadySet)
    }
}

/// A ROS 2 base's command publisher was set already.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the base's command publisher is already set")]
pub struct AlreadySet;

impl RobotHandle for Ros2Robot {
    fn stop(self: Box<Self>) -> StopFuture {
        // The server has stopped the base; nothing drives it from here on.
        self.base.close();
        Box::pin(async {})
    }
    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// A ROS 2 base described by the config's `[ros2.base]`.
pub(crate) fn ros2(setup: &RobotSetup<'_>) -> Result<Robot, super::catalog::BoxError> {
    let publisher: Arc<OnceLock<CmdVelPublisher>> = Arc::default();
    let (slot, clock) = (Arc::clone(&publisher), setup.clock);
    let send: orsa_hardware::ros2base::SendCommand = Arc::new(move |v, w| {
        if let Some(p) = slot.get() {
            p.send(v, w, clock.now().0);
        }
    });
    let config = setup.config;
    let base = Ros2Base::new(config.ros2.base.clone(), setup.clock, send);
    let (sensors, motors) = base.boards();
    Ok(Robot::new(
        AnySensorBoard::Ros2(sensors),
        AnyMotorBoard::Ros2(motors),
        config.ros2.base.robot_params(config.robot().push_periods()),
        Ros2Robot { base, publisher },
    ))
}
