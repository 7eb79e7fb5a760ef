//! The one place that assembles a system: what it refuses, and that it leaves nothing running
//! when it does.

use orsa::config::Config;
use orsa::system::{AssemblyError, Catalog, RobotSetup, SIM, System};
use orsa_actors::{Clock, Registry};
use orsa_hardware::faulty::BoardFaults;
use orsa_hardware::world::World;

fn config(text: &str) -> Config {
    Config::from_toml(text, "the test's config").expect("config")
}

#[test]
fn a_table_that_names_a_component_twice_or_badly_is_refused_with_the_key() {
    let twice = "[[system.components]]\nname = \"nomad200\"\n[[system.components]]\nname = \"nomad200\"\n";
    let e = Config::from_toml(twice, "twice.toml").expect_err("listed twice").to_string();
    assert!(e.contains("system.components[1].name") && e.contains("listed twice"), "{e}");
    let wire = "[[system.components]]\nname = \"wallfollow\"\nwire = { vel = \"nowhere\" }\n";
    let e = Config::from_toml(wire, "wire.toml").expect_err("bad target").to_string();
    assert!(e.contains("system.components[0].wire.vel") && e.contains("'nowhere'"), "{e}");
    // A mode may name only components of the system, when the system has a master.
    let missing = "[[system.components]]\nname = \"nomad200\"\n[[system.components]]\nname = \"master\"\n";
    let e = Config::from_toml(missing, "missing.toml").expect_err("no behaviours").to_string();
    assert!(e.contains("params.master.modes.") && e.contains("is not a component of the system"), "{e}");
}

/// A wiring its entry asks for that cannot be made stops the system it started and names the
/// component, the port and the target.
#[tokio::test(start_paused = true)]
async fn a_wiring_that_fails_stops_what_was_started_and_names_it() {
    let clock = Clock::simulated();
    let registry = Registry::with_clock(clock);
    let config = config(
        r#"
        [[system.components]]
        name = "nomad200"
        [[system.components]]
        name = "centerfollow"
        wire = { vel = "nomad200/distanceir" }
        "#,
    );
    let world = World::palazzina().expect("world");
    let setup = RobotSetup { config: &config, world: &world, seed: 3, clock };
    let robot = Catalog::builtin().start_robot(SIM, &setup).expect("the simulator");
    let err = System::builder(&config)
        .robot(robot.boards(&BoardFaults::new(3), &config.safety).expect("the boards"))
        .start(&registry)
        .await
        .expect_err("vel sends NavigationVelocity; distanceir is a Push timed DistanceScan");
    match &err {
        AssemblyError::Configure { component, message } => {
            assert_eq!(component, "centerfollow");
            assert!(message.contains("vel") && message.contains("nomad200/distanceir"), "{message}");
        }
        other => panic!("expected a configuration error, got {other}"),
    }
    assert!(registry.components().is_empty(), "left running: {:?}", registry.components());
}

/// `select` hosts only the named components, and refuses a name the system does not have.
#[tokio::test(start_paused = true)]
async fn select_hosts_only_what_it_names() {
    let config = Config::default();
    let names = System::builder(&config).select(&["master", "planner"]).hosted().expect("hosted");
    let names: Vec<&str> = names.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["master", "planner"]);
    let e = System::builder(&config).select(&["ghost"]).hosted().expect_err("not in the system");
    assert!(e.to_string().contains("'ghost'"), "{e}");
    let robot = System::builder(&config).only(orsa::system::Place::Robot).hosted().expect("hosted");
    let robot: Vec<&str> = robot.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(robot, ["nomad200", "wallfollow", "centerfollow"]);
}

/// A motor board of a user's own robot: it counts the velocity commands it is given and
/// passes them to the board it stands in front of.
#[derive(Debug, Clone)]
struct Counting {
    inner: orsa_hardware::any::AnyMotorBoard,
    commands: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

impl orsa_hardware::board::MotorBoard for Counting {
    async fn move_velocity(
        &self,
        v: orsa_hardware::board::AxisVelocities,
    ) -> Result<(), orsa_hardware::board::BoardError> {
        self.commands.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.move_velocity(v).await
    }
    async fn stop(&self) -> Result<(), orsa_hardware::board::BoardError> {
        self.inner.stop().await
    }
    async fn wait_stop(&self, timeout: std::time::Duration) -> Result<(), orsa_hardware::board::BoardError> {
        self.inner.wait_stop(timeout).await
    }
    async fn zero_axes(&self) -> Result<(), orsa_hardware::board::BoardError> {
        self.inner.zero_axes().await
    }
    async fn set_velocity_limits(
        &self,
        limits: orsa_hardware::board::AxisVelocities,
    ) -> Result<(), orsa_hardware::board::BoardError> {
        self.inner.set_velocity_limits(limits).await
    }
    async fn set_accelerations(
        &self,
        accel: orsa_hardware::board::AxisAccelerations,
    ) -> Result<(), orsa_hardware::board::BoardError> {
        self.inner.set_accelerations(accel).await
    }
    async fn read_state(&self) -> Result<orsa_hardware::board::MotorState, orsa_hardware::board::BoardError> {
        self.inner.read_state().await
    }
}

/// A robot kind of a user's own is registered like a component kind: the stack drives it, the
/// robot server serves its boards and tells clients what it is; a kind the catalog does not
/// have is refused, naming the ones it has.
#[tokio::test(start_paused = true)]
async fn a_robot_kind_of_a_users_own_is_driven_through_the_same_stack() {
    use orsa::mission::stack::{Stack, StackError};
    use orsa_interfaces::nomad200::{self, RobotParams};
    let commands = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let mut catalog = Catalog::builtin();
    let counted = std::sync::Arc::clone(&commands);
    catalog.register_robot("counted", move |setup| {
        // The simulator's robot, its motors behind a board of the user's own, told apart by
        // a top speed of its own.
        let mut robot = Catalog::builtin().start_robot(SIM, setup)?;
        robot.motors = orsa_hardware::any::AnyMotorBoard::other(Counting {
            inner: robot.motors.clone(),
            commands: std::sync::Arc::clone(&counted),
        });
        robot.params.max_v_m_s = 0.3;
        Ok(robot)
    });
    let config = config(
        r#"
        [[system.components]]
        name = "nomad200"
        [[system.components]]
        name = "centerfollow"
        state = "active"
        wire = { vel = "nomad200/navigationvelocity" }
        "#,
    );
    let world = World::palazzina().expect("world");

    let e = Stack::builder(&config, world.clone())
        .catalog(catalog.clone())
        .robot("hovercraft")
        .start()
        .await
        .expect_err("no such robot kind");
    assert!(matches!(e, StackError::Robot(_)), "{e}");
    let e = e.to_string();
    assert!(e.contains("'hovercraft'") && e.contains("counted, ros2, sim"), "{e}");

    let stack = Stack::builder(&config, world)
        .catalog(catalog)
        .robot("counted")
        .seed(5)
        .start()
        .await
        .expect("stack");
    assert_eq!(stack.robot.kind, "counted");
    let said: RobotParams =
        orsa_actors::query::QueryClient::connect(&stack.registry, nomad200::ROBOTPARAMS.on("nomad200"))
            .expect("client")
            .query(orsa_actors::Empty {}, Some(std::time::Duration::from_secs(1)))
            .await
            .expect("the robot server says what it is");
    assert_eq!(said.max_v_m_s, 0.3, "the robot server serves the kind's description");
    tokio::time::sleep(std::time::Duration::from_secs(5)).await;
    let n = commands.load(std::sync::atomic::Ordering::Relaxed);
    assert!(n >= 20, "center following drove through the user's board: {n} commands in 5 s");
    let travelled = stack.truth().expect("simulated").truth().travelled_m;
    assert!(travelled > 0.3, "and the robot moved {travelled:.2} m");
    stack.shutdown().await;
}
