//! The simulated Nomad 200: a pure, seeded, fixed-step 2D simulator, and its driver.
//!
//! [`SimNomad200`] holds a world, the robot, the movers and the random streams, and advances
//! by one fixed step (default 10 ms) per [`step`](SimNomad200::step). It never reads a clock:
//! its time is the number of steps taken. The same world, configuration, seed and commands
//! give bit-identical readings.
//!
//! The robot is a Nomad 200: a cylinder 0.50 m across on a synchro drive. Its three wheels
//! steer together, so it translates in the direction they point (its heading) and turns its
//! heading in place; the base itself never rotates. The turret, carrying the sonar and
//! infrared rings, turns on its own axis. Each step the motors advance first; the body then
//! moves as far along their motion as it can without touching anything (swept-circle test
//! against every wall, box, disc and mover, keeping a tiny margin). Blocked translation just
//! does not happen; turning in place always does. Odometry counts the motors, so it drifts
//! from the truth when the robot is blocked.
//!
//! Order within a step: the movers walk (seeing the robot where it was), the motors advance,
//! the body moves, odometry counts, the bumpers are read, and every sensor firing due within
//! the step is taken with the robot and movers where they were at that instant.
//!
//! Ground truth (true pose, velocities, contacts, clearances) is read with
//! [`truth`](SimNomad200::truth) and friends, for metrics; it never goes through the board
//! traits. [`SimRobot`] runs a simulator on tokio's clock behind the board traits.
//!
//! ```
//! use orsa_hardware::board::AxisVelocities;
//! use orsa_hardware::sim::{SimConfig, SimNomad200};
//! use orsa_hardware::world::World;
//! use std::time::Duration;
//!
//! let world = World::palazzina()?;
//! let mut sim = SimNomad200::new(world, SimConfig::default(), 42)?;
//! sim.move_velocity(AxisVelocities::synchro(0.25, 0.0))?;
//! sim.run_for(Duration::from_secs(2));
//! // Sonar 4 faces left: the upper wall is 2.4 - 1.2 - 0.25 m from its face (1 % noise).
//! let left = sim.sonar().valid_distance_m(4).expect("a wall on the left");
//! assert!((left - 0.95).abs() < 0.05, "{left}");
//! assert!(sim.truth().x_m > 2.3);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::geometry::{Circle, Point, unit_at};
use crate::world::{World, WorldError};
use orsa_actors::Timestamp;
use orsa_interfaces::range::DriveKind;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Duration;

mod bumpers;
pub mod config;
mod drive;
mod driver;
mod laser;
mod movers;
mod odometry;
mod rings;
mod scene;
mod sensor_board;
mod stage;
mod truth;

pub use config::{
    BodyConfig, BumperConfig, CompassConfig, ConfigError, DriveConfig, LaserConfig, OdometryConfig,
    RingConfig, SectorViewConfig, SimConfig,
};
pub use driver::{SimMotorBoard, SimRobot, SimSensorBoard, SimTruth};
pub use movers::MoverTruth;
pub use stage::{SimStage, StageError};
pub use truth::{Side, Truth};

use bumpers::Bumpers;
use drive::Drive;
use laser::Laser;
use movers::MoverState;
use odometry::Odometry;
use rings::{Compass, RangeRing, StepMotion};
use scene::Scene;

/// Why a simulator could not be built.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The world breaks a rule of the world format.
    #[error(transparent)]
    World(#[from] WorldError),
    /// A configuration value is out of range.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The configured body does not fit where the world starts the robot.
    #[error(
        "the robot's body (radius {radius_m} m) overlaps an obstacle at its start: nearest is {gap_m:.3} m from its centre"
    )]
    StartOverlap {
        /// The configured radius.
        radius_m: f64,
        /// Distance from the start to the nearest obstacle.
        gap_m: f64,
    },
}

/// Random stream numbers: one per noise source, so that none shifts another.
const SONAR_STREAM: u64 = 1;
const INFRARED_STREAM: u64 = 2;
const COMPASS_STREAM: u64 = 3;
const LASER_STREAM: u64 = 4;

/// A simulated Nomad 200 in a world. See the [module documentation](self).
#[derive(Debug, Clone)]
pub struct SimNomad200 {
    world: World,
    config: SimConfig,
    seed: u64,
    scene: Scene,
    step_ns: u64,
    dt: f64,
    now_ns: u64,
    steps: u64,
    origin: Timestamp,
    radius: f64,
    margin: f64,
    // Ground truth. Angles are in the world frame and unwrapped.
    position: Point,
    steer: f64,
    turret: f64,
    base_heading: f64,
    v_true: f64,
    steer_rate: f64,
    turret_rate: f64,
    blocked: bool,
    travelled_m: f64,
    // Devices.
    drive: Drive,
    odometry: Odometry,
    movers: Vec<MoverState>,
    sonar: RangeRing,
    infrared: RangeRing,
    laser: Option<Laser>,
    compass: Compass,
    bumpers: Bumpers,
    // Reused buffers.
    prev_movers: Vec<Point>,
    scratch: Vec<Circle>,
}

fn stream(seed: u64, n: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(n);
    rng
}

impl SimNomad200 {
    /// A simulator of `world` with `config`, its noise drawn from `seed`. The robot stands at
    /// the world's start pose, steering and turret aligned with its heading, all axes at rest.
    pub fn new(world: World, config: SimConfig, seed: u64) -> Result<Self, SimError> {
        config.validate()?;
        world.check("world")?;
        let scene = Scene::new(&world);
        let movers: Vec<MoverState> = world.movers.iter().map(MoverState::new).collect();
        let start = world.robot.position();
        let mover_circles: Vec<Circle> = movers.iter().map(MoverState::circle).collect();
        let radius = config.body.radius_m;
        if let Some(gap) = scene.nearest(&mover_circles, &start)
            && gap < radius
        {
            return Err(SimError::StartOverlap { radius_m: radius, gap_m: gap });
        }
        let heading = world.robot.heading_rad();
        let step_ns = config::nanos(config.step_s);
        let mut sim = SimNomad200 {
            scene,
            step_ns,
            dt: step_ns as f64 * 1e-9,
            now_ns: 0,
            steps: 0,
            origin: Timestamp::ZERO,
            radius,
            margin: config.body.motion_margin_m,
            position: start,
            steer: heading,
            turret: heading,
            base_heading: heading,
            v_true: 0.0,
            steer_rate: 0.0,
            turret_rate: 0.0,
            blocked: false,
            travelled_m: 0.0,
            drive: Drive::new(&config.drive),
            odometry: Odometry::new(&config.odometry, config.drive.kind == DriveKind::Differential),
            sonar: RangeRing::new(
                orsa_interfaces::nomad200::Ring::Sonar,
                &config.sonar,
                stream(seed, SONAR_STREAM),
                0,
            ),
            infrared: RangeRing::new(
                orsa_interfaces::nomad200::Ring::Infrared,
                &config.infrared,
                stream(seed, INFRARED_STREAM),
                0,
            ),
            laser: config.laser.as_ref().map(|l| Laser::new(l, stream(seed, LASER_STREAM), 0)),
            compass: Compass::new(
                config.compass.period_s,
                config.compass.noise_sd_deg,
                stream(seed, COMPASS_STREAM),
                0,
            ),
            bumpers: Bumpers::new(),
            prev_movers: Vec::with_capacity(movers.len()),
            scratch: mover_circles,
            movers,
            world,
            config,
            seed,
        };
        sim.update_bumpers();
        Ok(sim)
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The configuration.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The seed of the noise.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The fixed step.
    pub fn step_period(&self) -> Duration {
        Duration::from_nanos(self.step_ns)
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Simulated time now: the time origin plus the steps taken times the step.
    pub fn time(&self) -> Timestamp {
        self.stamp(self.now_ns)
    }

    /// Makes every stamp the simulator reports `origin` plus its own elapsed time (default
    /// origin: zero). A driver sets it so stamps match its clock.
    pub fn set_time_origin(&mut self, origin: Timestamp) {
        self.origin = origin;
    }

    fn stamp(&self, ns: u64) -> Timestamp {
        Timestamp(self.origin.0.saturating_add(ns))
    }

    /// Runs whole steps for `d` (rounded down to a whole number of steps); returns how many.
    pub fn run_for(&mut self, d: Duration) -> u64 {
        let n = u64::try_from(d.as_nanos() / u128::from(self.step_ns)).unwrap_or(u64::MAX);
        for _ in 0..n {
            self.step();
        }
        n
    }

    /// Advances the world by one fixed step.
    pub fn step(&mut self) {
        let (t0, t1) = (self.now_ns, self.now_ns.saturating_add(self.step_ns));
        // Movers walk, seeing the robot where it is now.
        self.prev_movers.clear();
        self.prev_movers.extend(self.movers.iter().map(MoverState::position));
        let body = Circle::new(self.position, self.radius);
        for m in &mut self.movers {
            m.step(t0, t1, &body, self.margin);
        }
        // Motors, then the body as far as it can go.
        let [ds, dsteer, dturret] = self.drive.advance(self.dt);
        let (p0, turret0) = (self.position, self.turret);
        let travel = unit_at(self.steer + 0.5 * dsteer).into_inner() * ds;
        self.steer += dsteer;
        self.turret += dturret;
        if self.config.drive.kind == DriveKind::Differential {
            // The base turns with its wheels (a synchro drive's base never turns).
            self.base_heading += dsteer;
        }
        let fraction = self.move_body(&travel);
        self.blocked = ds != 0.0 && fraction < 1.0;
        let motors = self.drive.velocities();
        self.v_true = if self.blocked { 0.0 } else { motors.translate_m_s };
        self.steer_rate = motors.steer_rad_s;
        self.turret_rate = motors.turret_rad_s;
        self.travelled_m += ds.abs() * fraction;
        self.odometry.integrate(ds, dsteer, dturret);
        self.now_ns = t1;
        self.steps += 1;
        self.update_bumpers();
        // Sensors firing within the step.
        let motion = StepMotion {
            scene: &self.scene,
            radius: self.radius,
            t0_ns: t0,
            t1_ns: t1,
            p0,
            p1: self.position,
            turret0,
            turret1: self.turret,
            movers0: &self.prev_movers,
            movers1: &self.movers,
        };
        match &mut self.laser {
            // A laser robot has no rings: its views of the laser's scan take their place.
            Some(laser) => laser.fire(&motion, &mut self.scratch),
            None => {
                self.sonar.fire(&motion, &mut self.scratch);
                self.infrared.fire(&motion, &mut self.scratch);
            }
        }
        self.compass.fire(&motion);
    }

    /// Moves the body along `travel` as far as it can without coming within the margin of
    /// anything; returns the fraction moved. A final check refuses any move that would end
    /// nearer than half the margin to something it was not already nearer to, so that even a
    /// rounding slip can never put the body inside geometry.
    fn move_body(&mut self, travel: &crate::geometry::Vector) -> f64 {
        if travel.norm_squared() == 0.0 {
            return 1.0;
        }
        self.scratch.clear();
        self.scratch.extend(self.movers.iter().map(MoverState::circle));
        let reach = self.radius + self.margin;
        let fraction = self.scene.max_travel_fraction(&self.scratch, &self.position, travel, reach);
        if fraction <= 0.0 {
            return 0.0;
        }
        let next = self.position + travel * fraction;
        let before = self.scene.nearest(&self.scratch, &self.position).unwrap_or(f64::INFINITY);
        let after = self.scene.nearest(&self.scratch, &next).unwrap_or(f64::INFINITY);
        let floor = (self.radius + 0.5 * self.margin).min(before) - 1e-12;
        if after < floor {
            return 0.0;
        }
        self.position = next;
        fraction
    }

    /// Presses the bumpers touched now.
    fn update_bumpers(&mut self) {
        self.scratch.clear();
        self.scratch.extend(self.movers.iter().map(MoverState::circle));
        let within = self.radius + self.config.bumpers.contact_margin_m;
        let base = self.base_heading;
        let p = self.position;
        let contacts = self.scene.touching(&self.scratch, &p, within);
        self.bumpers.update(self.now_ns, contacts.iter().map(|q| (q.y - p.y).atan2(q.x - p.x) - base));
    }
}

#[cfg(test)]
mod tests;
