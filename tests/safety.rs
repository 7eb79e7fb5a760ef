//! The protective layer under every driver: the safety monitor between the robot server and
//! the motor board stops the robot short of what its sensors see, whoever drives, and a
//! configuration whose zones cannot stop the robot is refused at load with the key.

use orsa::config::Config;
use orsa::hardware::world::World;
use orsa::mission::stack::Stack;
use orsa_actors::query::QueryClient;
use orsa_actors::send::SendClient;
use orsa_actors::{Empty, Registry};
use orsa_interfaces::nomad200::{self, NavigationVelocity, SafetyCounters};
use std::time::Duration;

async fn safety(registry: &Registry, robot: &str) -> SafetyCounters {
    QueryClient::<Empty, SafetyCounters>::connect(registry, nomad200::SAFETY.on(robot))
        .expect("connect")
        .query(Empty {}, Some(Duration::from_secs(1)))
        .await
        .expect("answer")
}

/// What teleop at top speed straight at the corridor's left wall ends in: the bumps, the
/// nearest the body came to anything (truth), and the robot server's counters.
async fn teleop_at_the_wall(config: &Config) -> (u64, f64, SafetyCounters) {
    let world = World::palazzina().expect("world");
    let stack = Stack::builder(config, world).seed(1).select(&["nomad200"]).start().await.expect("stack");
    let robot = config.robot_name().to_owned();
    let teleop = SendClient::<NavigationVelocity>::connect(&stack.registry, nomad200::TELEOP.on(&robot))
        .expect("teleop");
    let truth = stack.truth().expect("simulated").clone();
    let start = truth.truth().heading_rad;
    let send = |v: f64, w: f64| {
        teleop
            .send(NavigationVelocity { stamp: stack.registry.now(), v_m_s: v, omega_rad_s: w })
            .expect("send");
    };
    // Face the left wall, turning in place...
    while (truth.truth().heading_rad - start).rem_euclid(std::f64::consts::TAU) < std::f64::consts::FRAC_PI_2
    {
        send(0.0, 0.5);
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // ... and drive at it at the top speed for 6 s.
    let mut nearest = f64::INFINITY;
    for _ in 0..120 {
        send(0.5, 0.0);
        tokio::time::sleep(Duration::from_millis(50)).await;
        nearest = nearest.min(truth.nearest_obstacle().unwrap_or(f64::INFINITY));
    }
    let end = truth.truth();
    let bumps = end.contact_onsets;
    if config.safety.enabled {
        assert_eq!(end.v_m_s, 0.0, "held still at the end");
    }
    let counters = safety(&stack.registry, &robot).await;
    stack.shutdown().await;
    (bumps, nearest, counters)
}

/// Teleop at 0.5 m/s straight at a wall: the monitor stops the robot short of it, with no
/// bump, and says it did; without it the robot drives into the wall.
#[tokio::test(start_paused = true)]
async fn teleop_at_a_wall_at_top_speed_stops_short_of_it() {
    let guarded = Config::default();
    let (bumps, nearest, counters) = teleop_at_the_wall(&guarded).await;
    assert_eq!(bumps, 0, "the monitor let the robot touch the wall");
    assert!(nearest > 0.0 && nearest < 0.3, "stopped {nearest:.3} m from the wall");
    let m = counters.monitor.expect("the monitor's counters");
    // It slowed the robot as the wall came closer, then held it: 6 s of commands, of which
    // more than 3 s limited by the stop zone and more than 1 s held still.
    assert!(m.obstacle_s > 3.0 && m.stopped_s > 1.0 && m.interventions >= 1, "{m:?}");
    assert!(m.distance_lost_m > 1.0, "{m:?}");

    let unguarded = Config::default().with_sets(&["safety.enabled=false".into()]).expect("config");
    let (bumps, _, counters) = teleop_at_the_wall(&unguarded).await;
    assert!(bumps >= 1, "without the monitor teleop drives into the wall");
    assert_eq!(counters.monitor, None, "no monitor, no counters");
}

/// A `[safety]` table that cannot stop the robot from its top speed, or counts on braking
/// harder than the robot can, is refused at load, naming the key and its line.
#[test]
fn zones_that_cannot_stop_the_robot_are_refused_at_load() {
    let slow = "[safety]\nlatency_s = 0.1\ndeceleration_m_s2 = 0.01\n";
    let e = Config::from_toml(slow, "slow.toml").expect_err("13 m to stop from 0.5 m/s").to_string();
    assert!(e.contains("safety.latency_s") && e.contains("to stop"), "{e}");
    let hard = "[safety]\ndeceleration_m_s2 = 3.0\n";
    let e = Config::from_toml(hard, "hard.toml").expect_err("harder than the robot brakes").to_string();
    assert!(e.contains("safety.deceleration_m_s2") && e.contains("hard.toml"), "{e}");
    // No client can loosen it at run time: it is no component's parameter.
    let e = Config::from_toml("[params.nomad200]\nsafety = { enabled = false }\n", "p.toml")
        .expect_err("not a parameter of the robot server")
        .to_string();
    assert!(e.contains("safety"), "{e}");
}
