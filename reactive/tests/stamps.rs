//! A behaviour's command carries the stamp of the sensor data it was computed from, not the time
//! the data was published: the robot judges a command's age by it.
//!
//! A stand-in robot publishes infrared scans whose readings are older than the publication (as
//! a real ring's are: the newest reading is a few ms old when the scan goes out). Before the
//! envelope's time was renamed `sent_at`, `scan.stamp` in the behaviour resolved to the
//! envelope's publication time, and this test failed.

use orsa_actors::Sink;
use orsa_actors::component::spawn;
use orsa_actors::prelude::*;
use orsa_interfaces::behaviour::{self, ACTIVE};
use orsa_interfaces::nomad200::{
    self, BaseState, ContactScan, DistanceReading, DistanceScan, NavigationVelocity, PushPeriods, RING_SIZE,
    Ring, RingParams, RobotParams, ring_angle_rad,
};
use orsa_reactive::WallFollow;
use std::time::Duration;
use tokio::sync::mpsc;

/// How much older than its publication each scan's newest reading is.
const AGE: Duration = Duration::from_millis(7);

fn ring(max_range_m: f64) -> RingParams {
    RingParams {
        angles_rad: (0..RING_SIZE).map(ring_angle_rad).collect(),
        mount_radius_m: 0.25,
        beam_width_rad: 25f64.to_radians(),
        min_range_m: 0.0,
        max_range_m,
        fire_period_s: 0.004,
    }
}

/// Publishes the infrared ring only, with a wall 0.3 m to the left; answers `robotparams`;
/// serves `health` and `contact` without ever putting anything.
struct FakeRobot;

enum RobotMsg {
    Ir(#[allow(dead_code)] Tick),
    Params(QueryRequest<Empty, RobotParams>),
    Base(#[allow(dead_code)] Tick),
}

struct RobotState {
    ir: PushTimedServer<DistanceScan>,
}

impl Component for FakeRobot {
    type Msg = RobotMsg;
    type State = RobotState;

    async fn setup(&self, ctx: &Ctx<RobotMsg>) -> Result<RobotState, ComponentError> {
        let ir = ctx.push_timed_server(nomad200::DISTANCEIR, Duration::from_millis(40), RobotMsg::Ir)?;
        let base =
            ctx.push_timed_server::<BaseState>(nomad200::BASESTATE, Duration::from_secs(1), RobotMsg::Base)?;
        ctx.query_server(nomad200::ROBOTPARAMS, RobotMsg::Params)?;
        ctx.event_server(nomad200::CONTACT, |_: &mut Empty, _: &ContactScan| None::<ContactScan>)?;
        // Every robot server says how its sensors are (never pushed here: nothing judged).
        ctx.push_newest_server(orsa_interfaces::health::HEALTH)?;
        ir.start();
        base.stop();
        Ok(RobotState { ir })
    }

    async fn handle(
        &self,
        ctx: &Ctx<RobotMsg>,
        st: &mut RobotState,
        msg: RobotMsg,
    ) -> Result<(), ComponentError> {
        match msg {
            RobotMsg::Ir(_) => {
                let taken = Timestamp(ctx.now().as_nanos() - AGE.as_nanos() as u64);
                let readings = (0..RING_SIZE as u8)
                    .map(|i| {
                        let d = if i == 4 { 0.3 } else { 0.55 };
                        DistanceReading { sensor_id: i, stamp: taken, valid: true, distance_m: d }
                    })
                    .collect();
                st.ir.put(DistanceScan { stamp: taken, ring: Ring::Infrared, readings });
            }
            RobotMsg::Params(q) => {
                let params = RobotParams {
                    body_radius_m: 0.25,
                    max_v_m_s: 0.5,
                    max_omega_rad_s: 45f64.to_radians(),
                    max_turret_omega_rad_s: 45f64.to_radians(),
                    accel_m_s2: 0.5,
                    steer_accel_rad_s2: 90f64.to_radians(),
                    turret_accel_rad_s2: 90f64.to_radians(),
                    sonar: ring(6.0),
                    infrared: ring(0.6),
                    bumper_angles_rad: (0..nomad200::BUMPER_COUNT).map(nomad200::bumper_angle_rad).collect(),
                    odometry_resolution_m: 0.0025,
                    odometry_resolution_rad: 0.1f64.to_radians(),
                    push: PushPeriods::default(),
                    drive: Default::default(),
                    range_sensors: Vec::new(),
                };
                q.answer(params)?;
            }
            RobotMsg::Base(_) => {}
        }
        Ok(())
    }
}

#[tokio::test(start_paused = true)]
async fn a_command_carries_the_stamp_of_the_scan_it_was_computed_from() {
    let registry = Registry::with_clock(orsa_actors::Clock::simulated());
    let _robot = spawn(&registry, "robot", FakeRobot).await.expect("robot");
    let (tx, mut commands) = mpsc::unbounded_channel::<Stamped<NavigationVelocity>>();
    const MOTORS: SendService<NavigationVelocity> = SendService::new("motors");
    let _motors = SendServer::register(&registry, MOTORS.on("sink"), Sink::channel(tx)).expect("motors");
    let wf = WallFollow { params: Default::default(), robot: "robot".into() };
    let _wf = spawn(&registry, behaviour::WALLFOLLOW, wf).await.expect("wallfollow");
    StateMaster::connect(&registry, behaviour::WALLFOLLOW)
        .expect("state")
        .set_state(ACTIVE)
        .await
        .expect("active");
    WiringMaster::new(&registry)
        .connect(behaviour::WALLFOLLOW, behaviour::VEL, MOTORS.on("sink"))
        .await
        .expect("wire");

    tokio::time::sleep(Duration::from_millis(500)).await;
    let mut seen = 0;
    while let Ok(cmd) = commands.try_recv() {
        seen += 1;
        // Scans go out every 40 ms from the start, each 7 ms older than its publication.
        let scan_ns = cmd.value.stamp.as_nanos() + AGE.as_nanos() as u64;
        assert_eq!(
            scan_ns % 40_000_000,
            0,
            "command stamped {} ({} ns after a publication): not a scan's stamp",
            cmd.value.stamp,
            scan_ns % 40_000_000
        );
        assert!(cmd.value.stamp < cmd.sent_at, "the command is older than its sending");
    }
    assert!(seen >= 8, "only {seen} commands in 0.5 s of 40 ms scans");
}
