//! [`SimRobot`]: a simulator stepped on tokio's clock, behind the board traits.
//!
//! [`SimRobot::spawn`] moves a [`SimNomad200`] behind a mutex and starts a task that steps it
//! by its fixed step on a `tokio::time::interval` that bursts to catch up on missed ticks. On a
//! paused clock the simulation therefore runs as fast as the CPU allows while staying in lock
//! step with tokio's time; on a running clock it runs in real time. Simulated time maps onto the
//! given [`Clock`]: every stamp the boards report is a time of that clock.
//!
//! The board handles ([`SimSensorBoard`], [`SimMotorBoard`]) and the ground-truth handle
//! ([`SimTruth`]) are cheap to clone. None of them holds the lock across an `.await`. Once the
//! stepping task has stopped ([`SimRobot::shutdown`], or dropping the [`SimRobot`]), every board
//! operation fails with [`BoardError::Disconnected`]; truth stays readable.

use super::{SimNomad200, Truth};
use crate::board::{
    AxisAccelerations, AxisVelocities, BoardError, CompassReading, MotorBoard, MotorState, SensorBoard,
};
use crate::sim::{MoverTruth, Side};
use orsa_actors::{Clock, Timestamp};
use orsa_interfaces::nomad200::{ContactScan, DistanceScan};
use parking_lot::Mutex;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;
use tokio::sync::{oneshot, watch};
use tokio::task::JoinHandle;
use tokio::time::MissedTickBehavior;

/// What every handle shares: the simulator, and the step counter the stepping task publishes
/// (its sender is dropped when the task ends, which is how handles learn it has).
///
/// The counter changes silently unless someone waits for a step (`waiting`): a notification
/// touches all of tokio's watch notifiers, and the stepping task publishes a hundred times a
/// simulated second while, almost always, nobody waits.
#[derive(Debug, Clone)]
struct Link {
    sim: Arc<Mutex<SimNomad200>>,
    steps: watch::Receiver<u64>,
    waiting: Arc<AtomicUsize>,
}

/// One waiter for the next step, counted while it lives.
struct StepWaiter<'a>(&'a AtomicUsize);

impl<'a> StepWaiter<'a> {
    /// Counts a waiter. Steps taken from now on notify, so a waiter that looks at the simulator
    /// after this misses none.
    fn new(waiting: &'a AtomicUsize) -> Self {
        waiting.fetch_add(1, Ordering::SeqCst);
        StepWaiter(waiting)
    }
}

impl Drop for StepWaiter<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

impl Link {
    /// Runs `f` on the simulator, if the stepping task is still running.
    fn with<T>(&self, f: impl FnOnce(&mut SimNomad200) -> Result<T, BoardError>) -> Result<T, BoardError> {
        if self.steps.has_changed().is_err() {
            return Err(BoardError::Disconnected("the simulator's stepping task has stopped".into()));
        }
        f(&mut self.sim.lock())
    }
}

/// A running simulated robot. Dropping it stops the stepping task.
#[derive(Debug)]
pub struct SimRobot {
    link: Link,
    clock: Clock,
    stop: Option<oneshot::Sender<()>>,
    task: Option<JoinHandle<()>>,
}

impl SimRobot {
    /// Starts stepping `sim` on tokio's clock. Must be called inside a tokio runtime.
    ///
    /// The simulator's time is aligned with `clock`: its current time becomes `clock.now()`
    /// (unless it has already run further than that clock has, in which case the clock's start
    /// is its origin and stepping waits for the clock to catch up). Every step then happens
    /// when the clock reaches its end time.
    pub fn spawn(mut sim: SimNomad200, clock: Clock) -> SimRobot {
        let elapsed = sim.time().0.saturating_sub(sim.origin.0);
        sim.set_time_origin(Timestamp(clock.now().0.saturating_sub(elapsed).max(clock.origin().0)));
        let step = sim.step_period();
        let first = clock.instant_of(sim.time()) + step;
        let (steps_tx, steps_rx) = watch::channel(sim.steps());
        let (stop_tx, mut stop_rx) = oneshot::channel::<()>();
        let shared = Arc::new(Mutex::new(sim));
        let stepped = Arc::clone(&shared);
        let waiting = Arc::new(AtomicUsize::new(0));
        let waiters = Arc::clone(&waiting);
        let task = tokio::spawn(async move {
            let mut ticks = tokio::time::interval_at(first, step);
            ticks.set_missed_tick_behavior(MissedTickBehavior::Burst);
            loop {
                tokio::select! {
                    biased;
                    _ = &mut stop_rx => break,
                    _ = ticks.tick() => {
                        let n = {
                            let mut sim = stepped.lock();
                            sim.step();
                            sim.steps()
                        };
                        // The step is done and its lock released before the waiters are
                        // counted: one counted later looks at the simulator after this step.
                        steps_tx.send_if_modified(|v| {
                            *v = n;
                            waiters.load(Ordering::SeqCst) > 0
                        });
                    }
                }
            }
            tracing::debug!("simulated Nomad 200 stepping task stopped");
        });
        SimRobot {
            link: Link { sim: shared, steps: steps_rx, waiting },
            clock,
            stop: Some(stop_tx),
            task: Some(task),
        }
    }

    /// A handle on the sensor board.
    pub fn sensor_board(&self) -> SimSensorBoard {
        SimSensorBoard { link: self.link.clone() }
    }

    /// A handle on the motor board.
    pub fn motor_board(&self) -> SimMotorBoard {
        SimMotorBoard { link: self.link.clone() }
    }

    /// A handle on the ground truth, for metrics.
    pub fn truth(&self) -> SimTruth {
        SimTruth { sim: Arc::clone(&self.link.sim) }
    }

    /// The clock the simulator's stamps belong to.
    pub fn clock(&self) -> Clock {
        self.clock
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        *self.link.steps.borrow()
    }

    /// Stops the stepping task and waits for it to end. The simulator stays readable through
    /// [`SimTruth`] handles; board handles report [`BoardError::Disconnected`] from now on.
    pub async fn shutdown(mut self) -> Result<(), tokio::task::JoinError> {
        if let Some(stop) = self.stop.take() {
            // The task may already have ended; then there is nobody to tell.
            let _ = stop.send(());
        }
        match self.task.take() {
            Some(task) => task.await,
            None => Ok(()),
        }
    }
}

/// Read access to the simulator's ground truth. Works whether or not it is still stepping.
#[derive(Debug, Clone)]
pub struct SimTruth {
    sim: Arc<Mutex<SimNomad200>>,
}

impl SimTruth {
    /// The robot's true state now.
    pub fn truth(&self) -> Truth {
        self.sim.lock().truth()
    }

    /// See [`SimNomad200::truth_side_nearest`].
    pub fn side_nearest(&self, side: Side) -> Option<f64> {
        self.sim.lock().truth_side_nearest(side)
    }

    /// See [`SimNomad200::truth_side_clearance`].
    pub fn side_clearance(&self, side: Side) -> Option<f64> {
        self.sim.lock().truth_side_clearance(side)
    }

    /// See [`SimNomad200::truth_nearest_obstacle`].
    pub fn nearest_obstacle(&self) -> Option<f64> {
        self.sim.lock().truth_nearest_obstacle()
    }

    /// Where every mover is.
    pub fn movers(&self) -> Vec<MoverTruth> {
        self.sim.lock().truth_movers()
    }

    /// The handle a fault plan changes the world through (a box put down, the robot carried
    /// elsewhere): for fault injection, never for control.
    pub fn stage(&self) -> super::SimStage {
        super::SimStage { sim: Arc::clone(&self.sim) }
    }

    /// Any other read of the simulator, under its lock (keep `f` short: stepping waits).
    pub fn with<T>(&self, f: impl FnOnce(&SimNomad200) -> T) -> T {
        f(&self.sim.lock())
    }
}

/// The simulator's sensor board.
#[derive(Debug, Clone)]
pub struct SimSensorBoard {
    link: Link,
}

impl SensorBoard for SimSensorBoard {
    async fn init(&self) -> Result<(), BoardError> {
        self.link.with(|s| {
            s.sensor_init();
            Ok(())
        })
    }

    async fn set_sonar_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        self.link.with(|s| s.set_sonar_fire_order(order))
    }

    async fn set_sonar_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        self.link.with(|s| s.set_sonar_fire_period(period))
    }

    async fn set_infrared_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        self.link.with(|s| s.set_infrared_fire_order(order))
    }

    async fn set_infrared_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        self.link.with(|s| s.set_infrared_fire_period(period))
    }

    async fn read_sonar(&self) -> Result<DistanceScan, BoardError> {
        self.link.with(|s| Ok(s.sonar()))
    }

    async fn read_infrared(&self) -> Result<DistanceScan, BoardError> {
        self.link.with(|s| Ok(s.infrared()))
    }

    async fn read_bumpers(&self) -> Result<ContactScan, BoardError> {
        self.link.with(|s| Ok(s.bumpers()))
    }

    async fn read_compass(&self) -> Result<CompassReading, BoardError> {
        self.link.with(|s| Ok(s.compass()))
    }
}

/// The simulator's motor board.
#[derive(Debug, Clone)]
pub struct SimMotorBoard {
    link: Link,
}

impl MotorBoard for SimMotorBoard {
    async fn move_velocity(&self, v: AxisVelocities) -> Result<(), BoardError> {
        self.link.with(|s| s.move_velocity(v))
    }

    async fn stop(&self) -> Result<(), BoardError> {
        self.link.with(|s| {
            s.stop();
            Ok(())
        })
    }

    async fn wait_stop(&self, timeout: Duration) -> Result<(), BoardError> {
        let deadline = tokio::time::Instant::now() + timeout;
        let mut steps = self.link.steps.clone();
        let _waiter = StepWaiter::new(&self.link.waiting);
        loop {
            // Mark the current step seen before looking, so no step slips between the two.
            steps.borrow_and_update();
            if self.link.with(|s| Ok(s.is_stopped()))? {
                return Ok(());
            }
            match tokio::time::timeout_at(deadline, steps.changed()).await {
                Ok(Ok(())) => {}
                Ok(Err(_)) => {
                    return Err(BoardError::Disconnected("the simulator's stepping task has stopped".into()));
                }
                Err(_) => return Err(BoardError::Timeout { operation: "wait_stop", waited: timeout }),
            }
        }
    }

    async fn zero_axes(&self) -> Result<(), BoardError> {
        self.link.with(|s| {
            s.zero_axes();
            Ok(())
        })
    }

    async fn set_velocity_limits(&self, limits: AxisVelocities) -> Result<(), BoardError> {
        self.link.with(|s| s.set_velocity_limits(limits))
    }

    async fn set_accelerations(&self, accel: AxisAccelerations) -> Result<(), BoardError> {
        self.link.with(|s| s.set_accelerations(accel))
    }

    async fn read_state(&self) -> Result<MotorState, BoardError> {
        self.link.with(|s| Ok(s.motor_state()))
    }
}
