//! The one place that assembles a system: what it refuses, and that it leaves nothing running
//! when it does.

use orsa::config::Config;
use orsa::system::{AssemblyError, RobotBoards, System};
use orsa_actors::{Clock, Registry};
use orsa_hardware::faulty::BoardFaults;
use orsa_hardware::sim::{SimNomad200, SimRobot};
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
    assert!(e.contains("executive.modes.") && e.contains("is not a component of the system"), "{e}");
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
    let sim = SimRobot::spawn(
        SimNomad200::new(World::palazzina().expect("world"), config.sim.clone(), 3).expect("sim"),
        clock,
    );
    let err = System::builder(&config)
        .robot(RobotBoards::simulated(&sim, &config, &BoardFaults::new(3)))
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
