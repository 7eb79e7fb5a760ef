//! Boards that fail on purpose: decorators over any [`SensorBoard`] and [`MotorBoard`] that
//! inject the hardware faults of a fault plan while a [`BoardFaults`] handle says so.
//!
//! | fault | what the robot server then reads or does |
//! |---|---|
//! | `sensor_stuck` | the ring repeats the values it read when the fault began, with fresh stamps (the insidious way: it looks alive) |
//! | `sensor_dropout` | every reading of the ring invalid (bumpers: none pressed) |
//! | `sensor_noise` | Gaussian noise of the given standard deviation added to every valid distance |
//! | `motor_stall` | the motors do not turn: velocity commands are accepted and the axes brake to rest |
//!
//! With no fault set a read costs one uncontended lock.

use crate::board::{
    AxisAccelerations, AxisVelocities, BoardError, CompassReading, MotorBoard, MotorState, SensorBoard,
};
use orsa_interfaces::nomad200::{ContactScan, DistanceScan};
use parking_lot::Mutex;
use rand::SeedableRng as _;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Duration;

/// A ring of sensors that can fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultRing {
    /// The 16 sonar transducers.
    Sonar,
    /// The 16 infrared sensors.
    Infrared,
    /// The bumper ring.
    Bumpers,
}

impl FaultRing {
    /// The ring's name in fault plans.
    pub fn name(self) -> &'static str {
        match self {
            FaultRing::Sonar => "sonar",
            FaultRing::Infrared => "infrared",
            FaultRing::Bumpers => "bumpers",
        }
    }

    /// The ring of this name.
    pub fn from_name(name: &str) -> Option<Self> {
        [FaultRing::Sonar, FaultRing::Infrared, FaultRing::Bumpers].into_iter().find(|r| r.name() == name)
    }
}

/// How a ring fails.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorFault {
    /// Repeats its values.
    Stuck,
    /// Reads nothing valid.
    Dropout,
    /// Reads with extra Gaussian noise of this standard deviation, in metres.
    Noise(f64),
}

#[derive(Debug)]
struct State {
    sonar: Option<SensorFault>,
    infrared: Option<SensorFault>,
    bumpers: Option<SensorFault>,
    last_sonar: Option<DistanceScan>,
    last_infrared: Option<DistanceScan>,
    last_bumpers: Option<ContactScan>,
    stalled: bool,
    rng: ChaCha8Rng,
    /// Reads altered and commands swallowed so far.
    altered: u64,
    /// When the motors last got a command (on tokio's clock), and whether it moves them.
    last_command: Option<(tokio::time::Instant, bool)>,
}

/// The switch for the faults of one robot's boards; cheap to clone.
#[derive(Debug, Clone)]
pub struct BoardFaults(Arc<Mutex<State>>);

impl BoardFaults {
    /// No fault set; noise drawn from `seed`.
    pub fn new(seed: u64) -> Self {
        BoardFaults(Arc::new(Mutex::new(State {
            sonar: None,
            infrared: None,
            bumpers: None,
            last_sonar: None,
            last_infrared: None,
            last_bumpers: None,
            stalled: false,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x6661_756c_7479),
            altered: 0,
            last_command: None,
        })))
    }

    /// How long ago the motors got their last command, and whether it moves them (`None`
    /// before the first). A watch on the motors' side of the robot server: a robot driving on
    /// a command older than the velocity timeout shows here, whatever the server believes.
    pub fn last_command(&self) -> Option<(Duration, bool)> {
        self.0.lock().last_command.map(|(at, moving)| (at.elapsed(), moving))
    }

    fn commanded(&self, moving: bool) {
        self.0.lock().last_command = Some((tokio::time::Instant::now(), moving));
    }

    /// Sets (or with `None` clears) the fault of `ring`.
    pub fn set_sensor(&self, ring: FaultRing, fault: Option<SensorFault>) {
        let mut s = self.0.lock();
        match ring {
            FaultRing::Sonar => s.sonar = fault,
            FaultRing::Infrared => s.infrared = fault,
            FaultRing::Bumpers => s.bumpers = fault,
        }
    }

    /// Stalls (or frees) the motors.
    pub fn set_motor_stall(&self, stalled: bool) {
        self.0.lock().stalled = stalled;
    }

    /// Reads altered and commands swallowed so far.
    pub fn altered(&self) -> u64 {
        self.0.lock().altered
    }

    fn scan(&self, ring: FaultRing, mut scan: DistanceScan) -> DistanceScan {
        let mut guard = self.0.lock();
        let s = &mut *guard;
        let (fault, last) = match ring {
            FaultRing::Sonar => (s.sonar, &mut s.last_sonar),
            _ => (s.infrared, &mut s.last_infrared),
        };
        match fault {
            // Kept in place: the buffer of the scan before is reused, not reallocated.
            None => match last {
                Some(last) => last.clone_from(&scan),
                None => *last = Some(scan.clone()),
            },
            Some(SensorFault::Stuck) => {
                if let Some(old) = last {
                    for (r, o) in scan.readings.iter_mut().zip(&old.readings) {
                        r.valid = o.valid;
                        r.distance_m = o.distance_m;
                    }
                }
                s.altered += 1;
            }
            Some(SensorFault::Dropout) => {
                scan.readings.iter_mut().for_each(|r| r.valid = false);
                s.altered += 1;
            }
            Some(SensorFault::Noise(sigma)) => {
                if let Ok(normal) = Normal::new(0.0, sigma.abs()) {
                    for r in scan.readings.iter_mut().filter(|r| r.valid) {
                        r.distance_m = (r.distance_m + normal.sample(&mut s.rng)).max(0.0);
                    }
                }
                s.altered += 1;
            }
        }
        scan
    }

    fn contacts(&self, mut scan: ContactScan) -> ContactScan {
        let mut s = self.0.lock();
        match s.bumpers {
            None => match &mut s.last_bumpers {
                Some(last) => last.clone_from(&scan),
                None => s.last_bumpers = Some(scan.clone()),
            },
            Some(SensorFault::Stuck) => {
                if let Some(old) = &s.last_bumpers {
                    scan.pressed.clone_from(&old.pressed);
                }
                s.altered += 1;
            }
            // A bumper ring cannot be noisy: it drops out or it sticks.
            Some(SensorFault::Dropout | SensorFault::Noise(_)) => {
                scan.pressed.iter_mut().for_each(|p| *p = false);
                s.altered += 1;
            }
        }
        scan
    }

    fn stalled(&self) -> bool {
        let mut s = self.0.lock();
        if s.stalled {
            s.altered += 1;
        }
        s.stalled
    }
}

/// A sensor board whose readings pass through [`BoardFaults`].
#[derive(Debug, Clone)]
pub struct FaultySensorBoard<S> {
    inner: S,
    faults: BoardFaults,
}

impl<S> FaultySensorBoard<S> {
    /// `inner`, failing as `faults` says.
    pub fn new(inner: S, faults: BoardFaults) -> Self {
        FaultySensorBoard { inner, faults }
    }
}

impl<S: SensorBoard> SensorBoard for FaultySensorBoard<S> {
    async fn init(&self) -> Result<(), BoardError> {
        self.inner.init().await
    }
    async fn set_sonar_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        self.inner.set_sonar_fire_order(order).await
    }
    async fn set_sonar_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        self.inner.set_sonar_fire_period(period).await
    }
    async fn set_infrared_fire_order(&self, order: &[u8]) -> Result<(), BoardError> {
        self.inner.set_infrared_fire_order(order).await
    }
    async fn set_infrared_fire_period(&self, period: Duration) -> Result<(), BoardError> {
        self.inner.set_infrared_fire_period(period).await
    }
    async fn read_sonar(&self) -> Result<DistanceScan, BoardError> {
        Ok(self.faults.scan(FaultRing::Sonar, self.inner.read_sonar().await?))
    }
    async fn read_infrared(&self) -> Result<DistanceScan, BoardError> {
        Ok(self.faults.scan(FaultRing::Infrared, self.inner.read_infrared().await?))
    }
    async fn read_bumpers(&self) -> Result<ContactScan, BoardError> {
        Ok(self.faults.contacts(self.inner.read_bumpers().await?))
    }
    async fn read_compass(&self) -> Result<CompassReading, BoardError> {
        self.inner.read_compass().await
    }
}

/// A motor board that stalls while [`BoardFaults`] says so.
#[derive(Debug, Clone)]
pub struct FaultyMotorBoard<M> {
    inner: M,
    faults: BoardFaults,
}

impl<M> FaultyMotorBoard<M> {
    /// `inner`, failing as `faults` says.
    pub fn new(inner: M, faults: BoardFaults) -> Self {
        FaultyMotorBoard { inner, faults }
    }
}

impl<M: MotorBoard> MotorBoard for FaultyMotorBoard<M> {
    async fn move_velocity(&self, v: AxisVelocities) -> Result<(), BoardError> {
        self.faults.commanded(v.translate_m_s != 0.0 || v.steer_rad_s != 0.0 || v.turret_rad_s != 0.0);
        if self.faults.stalled() {
            // The command is taken; the wheels do not turn.
            return self.inner.stop().await;
        }
        self.inner.move_velocity(v).await
    }
    async fn stop(&self) -> Result<(), BoardError> {
        self.faults.commanded(false);
        self.inner.stop().await
    }
    async fn wait_stop(&self, timeout: Duration) -> Result<(), BoardError> {
        self.inner.wait_stop(timeout).await
    }
    async fn zero_axes(&self) -> Result<(), BoardError> {
        self.inner.zero_axes().await
    }
    async fn set_velocity_limits(&self, limits: AxisVelocities) -> Result<(), BoardError> {
        self.inner.set_velocity_limits(limits).await
    }
    async fn set_accelerations(&self, accel: AxisAccelerations) -> Result<(), BoardError> {
        self.inner.set_accelerations(accel).await
    }
    async fn read_state(&self) -> Result<MotorState, BoardError> {
        self.inner.read_state().await
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_actors::Timestamp;
    use orsa_interfaces::nomad200::{DistanceReading, Ring};

    fn scan(d: f64, t: u64) -> DistanceScan {
        DistanceScan {
            stamp: Timestamp(t),
            ring: Ring::Infrared,
            readings: (0..16)
                .map(|i| DistanceReading { sensor_id: i, stamp: Timestamp(t), valid: true, distance_m: d })
                .collect(),
        }
    }

    #[test]
    fn stuck_repeats_values_with_fresh_stamps_dropout_invalidates_noise_perturbs() {
        let f = BoardFaults::new(1);
        assert_eq!(f.scan(FaultRing::Infrared, scan(0.4, 1)), scan(0.4, 1), "no fault: untouched");
        f.set_sensor(FaultRing::Infrared, Some(SensorFault::Stuck));
        let stuck = f.scan(FaultRing::Infrared, scan(0.1, 2));
        assert!(stuck.readings.iter().all(|r| r.distance_m == 0.4 && r.stamp == Timestamp(2)));
        f.set_sensor(FaultRing::Infrared, Some(SensorFault::Dropout));
        assert!(f.scan(FaultRing::Infrared, scan(0.1, 3)).readings.iter().all(|r| !r.valid));
        f.set_sensor(FaultRing::Infrared, Some(SensorFault::Noise(0.05)));
        let noisy = f.scan(FaultRing::Infrared, scan(0.5, 4));
        let mean = noisy.readings.iter().map(|r| r.distance_m).sum::<f64>() / 16.0;
        assert!(noisy.readings.iter().any(|r| r.distance_m != 0.5), "noise changes readings");
        assert!((mean - 0.5).abs() < 0.05, "zero-mean noise: {mean}");
        f.set_sensor(FaultRing::Infrared, None);
        assert_eq!(f.scan(FaultRing::Infrared, scan(0.3, 5)), scan(0.3, 5));
        assert_eq!(f.altered(), 3);
        // The sonar ring was never faulted.
        assert_eq!(f.scan(FaultRing::Sonar, scan(1.0, 6)), scan(1.0, 6));
    }

    #[test]
    fn bumpers_stick_or_drop_out() {
        let f = BoardFaults::new(1);
        let pressed = ContactScan { stamp: Timestamp(1), pressed: vec![true; 20] };
        assert_eq!(f.contacts(pressed.clone()), pressed);
        f.set_sensor(FaultRing::Bumpers, Some(SensorFault::Dropout));
        assert!(!f.contacts(pressed.clone()).any());
        f.set_sensor(FaultRing::Bumpers, Some(SensorFault::Stuck));
        let free = ContactScan { stamp: Timestamp(2), pressed: vec![false; 20] };
        assert!(f.contacts(free).any(), "stuck pressed");
        assert_eq!(FaultRing::from_name("sonar"), Some(FaultRing::Sonar));
        assert_eq!(FaultRing::from_name("lidar"), None);
    }
}
