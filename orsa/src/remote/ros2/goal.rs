//! `/goal_pose`: navigation goals from ROS 2, as RViz's "2D Goal Pose" tool and Nav2's
//! `bt_navigator` take them (`geometry_msgs/msg/PoseStamped` in the `map` frame), handed to
//! the planner's `navigate` query wherever the planner runs. What the planner answers is
//! logged (and so on `/rosout`) and counted in the report; a goal in another frame, or with
//! numbers that are not finite, is refused here, named and counted.

use orsa_actors::Registry;
use orsa_actors::query::QueryClient;
use orsa_interfaces::navigation::{NAVIGATE, NavGoal, NavReply, NavTarget};
use orsa_net::ros2::msg::PoseStamped;
use orsa_net::ros2::{Qos, Ros2Node, Ros2Subscription};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// The topic goals are taken on (relative: under the node's namespace, `/goal_pose` at the
/// root, as RViz publishes it).
pub const GOAL_POSE: &str = "goal_pose";

/// How long the planner may take to answer a goal.
const ANSWER_WITHIN: Duration = Duration::from_secs(15);

/// The goal a `/goal_pose` message names, or why it names none
/// ([`NavTarget::from_pose`]).
pub fn target_of(msg: &PoseStamped) -> Result<NavTarget, String> {
    let (p, q) = (msg.pose.position, msg.pose.orientation);
    NavTarget::from_pose(&msg.header.frame_id, p.x, p.y, [q.x, q.y, q.z, q.w])
}

/// What became of the goals taken on `/goal_pose`.
#[derive(Debug, Default)]
pub struct GoalCounts {
    /// Accepted by the planner.
    pub accepted: AtomicU64,
    /// Refused: here (frame, numbers), by the planner (its reason is logged), or the planner
    /// could not be reached.
    pub refused: AtomicU64,
}

/// Takes `/goal_pose` on `node` and hands each goal to `planner`'s `navigate` through
/// `registry`, on the runtime this is called on.
pub async fn take_goals(
    node: &Ros2Node,
    registry: &Registry,
    planner: &str,
) -> anyhow::Result<(Ros2Subscription, Arc<GoalCounts>)> {
    let counts = Arc::new(GoalCounts::default());
    let runtime = tokio::runtime::Handle::current();
    let (registry, planner, c) = (registry.clone(), planner.to_string(), Arc::clone(&counts));
    let sub = node
        .subscribe::<PoseStamped>(GOAL_POSE, Qos::Default, move |msg, _| {
            let target = match target_of(&msg) {
                Ok(t) => t,
                Err(why) => {
                    c.refused.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!("ROS 2 /{GOAL_POSE}: refused: {why}");
                    return;
                }
            };
            let (registry, planner, c) = (registry.clone(), planner.clone(), Arc::clone(&c));
            runtime.spawn(async move {
                // Connected per goal: the planner may be in a process that joins later.
                let reply = match QueryClient::connect(&registry, NAVIGATE.on(&planner)) {
                    Ok(q) => q.query(NavGoal { target: target.clone() }, Some(ANSWER_WITHIN)).await,
                    Err(e) => Err(e),
                };
                match reply {
                    Ok(NavReply::Accepted { id }) => {
                        c.accepted.fetch_add(1, Ordering::Relaxed);
                        tracing::info!("ROS 2 /{GOAL_POSE}: goal {id} to {target} accepted by {planner}");
                    }
                    Ok(NavReply::Rejected { reason }) => {
                        c.refused.fetch_add(1, Ordering::Relaxed);
                        tracing::warn!(
                            "ROS 2 /{GOAL_POSE}: goal to {target} rejected by {planner}: {reason}"
                        );
                    }
                    Err(e) => {
                        c.refused.fetch_add(1, Ordering::Relaxed);
                        tracing::warn!("ROS 2 /{GOAL_POSE}: goal to {target}: {planner}/navigate: {e}");
                    }
                }
            });
        })
        .await?;
    Ok((sub, counts))
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_net::ros2::msg::{Header, Pose, Quaternion, Time, Vector3};

    fn goal(frame: &str, x: f64, q: Quaternion) -> PoseStamped {
        PoseStamped {
            header: Header { stamp: Time::default(), frame_id: frame.into() },
            pose: Pose { position: Vector3 { x, y: 2.0, z: 0.0 }, orientation: q },
        }
    }

    #[test]
    fn a_goal_pose_message_is_its_frame_position_and_rotation() {
        let t =
            target_of(&goal("map", 1.5, Quaternion::from_yaw(std::f64::consts::FRAC_PI_2))).expect("a goal");
        let NavTarget::Pose { x_m, y_m, heading_deg: Some(h) } = t else { panic!("{t:?}") };
        assert_eq!((x_m, y_m), (1.5, 2.0));
        assert!((h - 90.0).abs() < 1e-9, "{h}");
        let e = target_of(&goal("odom", 1.0, Quaternion::default())).expect_err("odom");
        assert_eq!(e, "frame 'odom': goals are taken in 'map'");
    }
}
