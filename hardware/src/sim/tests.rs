//! Unit tests of the simulator's stepping.

use super::*;

#[test]
fn palazzina_builds_and_steps() {
    let mut sim = SimNomad200::new(World::palazzina().expect("world"), SimConfig::default(), 7).expect("sim");
    assert_eq!(sim.run_for(Duration::from_secs(1)), 100);
    assert_eq!(sim.time(), Timestamp(1_000_000_000));
}
