//! The robot's fallback: with `--fallback MODE`, a local executive master drives that mode
//! while no executive is connected (the link watchdog starts it, and stops it when one is back).

use crate::config::Config;
use anyhow::bail;
use orsa_actors::Registry;
use orsa_actors::component::ComponentHandle;
use orsa_executive::Master;
use orsa_interfaces::executive::{Goal, GoalReply};
use std::time::Duration;

/// Starts the fallback master if one is asked for and none runs; whether it started one.
pub(super) async fn start_fallback_if(
    registry: &Registry,
    config: &Config,
    mode: &Option<String>,
    fallback: &mut Option<ComponentHandle<Master>>,
) -> bool {
    if let (Some(mode), None) = (mode, &*fallback) {
        match start_fallback(registry, config, mode).await {
            Ok(f) => {
                crate::say!("robot", "driving fallback mode '{mode}'");
                *fallback = Some(f);
                return true;
            }
            Err(e) => crate::say!("robot", "cannot start the fallback: {e:#}"),
        }
    }
    false
}

/// The component name of the robot's fallback master.
pub const FALLBACK: &str = "fallback";

async fn start_fallback(
    registry: &Registry,
    config: &Config,
    mode: &str,
) -> anyhow::Result<ComponentHandle<Master>> {
    let mut exec = config.executive().clone();
    exec.robot = config.robot_name().to_string();
    let master = orsa_actors::component::spawn(registry, FALLBACK, Master::new(exec)).await?;
    let goals = orsa_actors::query::QueryClient::<Goal, GoalReply>::connect(
        registry,
        orsa_interfaces::executive::GOAL.on(FALLBACK),
    )?;
    let reply = goals.query(Goal { mode: mode.to_string(), for_s: None }, Some(Duration::from_secs(5))).await;
    match reply {
        Ok(GoalReply::Accepted { .. }) => Ok(master),
        Ok(GoalReply::Rejected { reason, .. }) => {
            master.stop().await;
            bail!("fallback goal rejected: {reason}")
        }
        Err(e) => {
            master.stop().await;
            Err(e.into())
        }
    }
}
