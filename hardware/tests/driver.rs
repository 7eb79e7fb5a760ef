//! The simulator behind the board traits, stepped on tokio's (paused) clock.

mod common;

use common::*;
use orsa_actors::{Clock, Timestamp};
use orsa_hardware::board::{AxisVelocities, BoardError, MotorBoard, SensorBoard};
use orsa_hardware::sim::{SimConfig, SimNomad200, SimRobot};
use orsa_hardware::world::World;
use std::time::Duration;
use tokio::time::sleep;

fn palazzina() -> SimNomad200 {
    SimNomad200::new(World::palazzina().expect("world"), SimConfig::noiseless(), 3).expect("sim")
}

#[tokio::test(start_paused = true)]
async fn steps_exactly_with_the_paused_clock() {
    let clock = Clock::simulated();
    let robot = SimRobot::spawn(palazzina(), clock);
    sleep(ms(1005)).await;
    assert_eq!(robot.steps(), 100, "10 ms steps over 1 s");
    assert_eq!(robot.truth().truth().stamp, Timestamp(1_000_000_000));
    sleep(ms(59_000)).await;
    assert_eq!(robot.steps(), 6000, "a simulated minute, no drift");
    robot.shutdown().await.expect("clean stop");
}

#[tokio::test(start_paused = true)]
async fn stamps_are_times_of_the_given_clock() {
    let clock = Clock::simulated();
    sleep(ms(250)).await;
    let robot = SimRobot::spawn(palazzina(), clock);
    let sensors = robot.sensor_board();
    sleep(ms(75)).await;
    let sonar = sensors.read_sonar().await.expect("sonar");
    // Spawned at 250 ms: transducer i first fires at 250 + 4 (i + 1) ms; 0 again at 318.
    assert_eq!(sonar.readings[1].stamp, Timestamp(258_000_000));
    assert_eq!(sonar.readings[15].stamp, Timestamp(314_000_000));
    assert_eq!(sonar.readings[0].stamp, Timestamp(318_000_000));
    let state = robot.motor_board().read_state().await.expect("state");
    assert_eq!(state.stamp, Timestamp(320_000_000), "the last step ended at 320 ms");
    assert!(state.stamp <= clock.now());
}

#[tokio::test(start_paused = true)]
async fn wait_stop_waits_on_tokio_time() {
    let clock = Clock::simulated();
    let robot = SimRobot::spawn(palazzina(), clock);
    let motors = robot.motor_board();
    motors.move_velocity(AxisVelocities::synchro(0.3, 0.0)).await.expect("move");
    let e = motors.wait_stop(ms(250)).await.expect_err("still moving");
    assert_eq!(e, BoardError::Timeout { operation: "wait_stop", waited: ms(250) });
    assert_eq!(clock.now(), Timestamp(250_000_000), "timed out exactly");
    sleep(ms(755)).await;
    motors.stop().await.expect("stop");
    // From 0.3 m/s at 0.5 m/s^2: 60 steps of 10 ms, the first one ending at 1.01 s.
    motors.wait_stop(ms(2000)).await.expect("stops");
    assert_eq!(clock.now(), Timestamp(1_600_000_000));
    let state = motors.read_state().await.expect("state");
    assert!(state.stopped && state.velocities == AxisVelocities::default());
    assert!(state.x_m > 0.2, "it did drive: {}", state.x_m);
}

#[tokio::test(start_paused = true)]
async fn boards_work_from_other_tasks() {
    // The traits' futures are Send: a behaviour's task can own a board.
    let robot = SimRobot::spawn(palazzina(), Clock::simulated());
    let (sensors, motors) = (robot.sensor_board(), robot.motor_board());
    let task = tokio::spawn(async move {
        sensors.set_sonar_fire_order(&[0, 8]).await?;
        sensors.set_sonar_fire_period(ms(20)).await?;
        motors.move_velocity(AxisVelocities::synchro(0.2, 0.1)).await?;
        sleep(ms(105)).await;
        let front = sensors.read_sonar().await?;
        let bumpers = sensors.read_bumpers().await?;
        let compass = sensors.read_compass().await?;
        Ok::<_, BoardError>((front, bumpers, compass))
    });
    let (front, bumpers, compass) = task.await.expect("joined").expect("board calls");
    assert_eq!(front.readings[8].stamp, Timestamp(80_000_000), "0 @ 20, 8 @ 40, 0 @ 60, 8 @ 80 ms");
    assert_eq!(front.readings[0].stamp, Timestamp(100_000_000));
    assert!(!front.readings[4].valid, "sensor 4 never fired");
    assert_eq!(bumpers.pressed.len(), 20);
    assert!(compass.valid && compass.stamp == Timestamp(100_000_000));
    let e = robot.sensor_board().set_infrared_fire_order(&[20]).await.expect_err("no sensor 20");
    assert!(matches!(e, BoardError::InvalidArgument { operation: "set_infrared_fire_order", .. }), "{e}");
}

#[tokio::test(start_paused = true)]
async fn after_shutdown_boards_disconnect_and_truth_stays() {
    let robot = SimRobot::spawn(palazzina(), Clock::simulated());
    let (sensors, motors, truth) = (robot.sensor_board(), robot.motor_board(), robot.truth());
    sleep(ms(105)).await;
    robot.shutdown().await.expect("clean stop");
    assert!(matches!(sensors.read_sonar().await, Err(BoardError::Disconnected(_))));
    assert!(matches!(motors.wait_stop(ms(10)).await, Err(BoardError::Disconnected(_))));
    sleep(ms(100)).await;
    assert_eq!(truth.truth().stamp, Timestamp(100_000_000), "no more steps");
    assert!(truth.nearest_obstacle().expect("walls") > 0.0);
    assert_eq!(truth.movers().len(), 3);
}

#[tokio::test(start_paused = true)]
async fn dropping_the_robot_stops_stepping() {
    let robot = SimRobot::spawn(palazzina(), Clock::simulated());
    let (sensors, truth) = (robot.sensor_board(), robot.truth());
    sleep(ms(55)).await;
    drop(robot);
    sleep(ms(100)).await;
    assert_eq!(truth.truth().stamp, Timestamp(50_000_000));
    assert!(matches!(sensors.read_compass().await, Err(BoardError::Disconnected(_))));
}

#[tokio::test(start_paused = true)]
async fn a_sim_that_ran_ahead_waits_for_the_clock() {
    let mut sim = exact(empty(0.0, 0.0, 0.0));
    sim.run_for(Duration::from_secs(2));
    let clock = Clock::simulated();
    let robot = SimRobot::spawn(sim, clock);
    sleep(ms(1005)).await;
    assert_eq!(robot.steps(), 200, "its time is 2 s; the clock's 1 s");
    sleep(ms(1010)).await;
    assert_eq!(robot.steps(), 201);
    assert_eq!(robot.truth().truth().stamp, Timestamp(2_010_000_000));
}
