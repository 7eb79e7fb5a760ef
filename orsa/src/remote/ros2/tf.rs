//! The robot's transforms in the plane, from `/tf_static` and `/tf`: where its laser is on
//! its base (`orsa robot --hardware ros2`).
//!
//! Each transform is kept as its child's pose in its parent's frame (x, y and the yaw of its
//! rotation; z, roll and pitch do not move a planar scan's points). A frame's pose in another
//! is found through their nearest common ancestor, so the laser may hang under the base frame
//! (`base_link` -> `base_scan`) or beside it under a common parent (`base_footprint` ->
//! `base_link`, `base_footprint` -> `laser`).

use orsa_hardware::ros2base::LaserPose;
use orsa_net::ros2::msg::TfMessage;
use std::collections::HashMap;

/// At most this many frames up a chain (a loop in a peer's transforms ends there).
const MAX_DEPTH: usize = 32;

/// The transforms heard so far, by child frame.
#[derive(Debug, Default)]
pub(crate) struct TfTree {
    parent_of: HashMap<String, (String, LaserPose)>,
}

fn frame(name: &str) -> &str {
    name.trim_start_matches('/')
}

/// `a` then `b`: the pose `b` (in `a`'s frame) in `a`'s parent's frame.
fn compose(a: LaserPose, b: LaserPose) -> LaserPose {
    let (s, c) = a.yaw_rad.sin_cos();
    let yaw = (a.yaw_rad + b.yaw_rad + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
        - std::f64::consts::PI;
    LaserPose { x_m: a.x_m + c * b.x_m - s * b.y_m, y_m: a.y_m + s * b.x_m + c * b.y_m, yaw_rad: yaw }
}

fn inverse(a: LaserPose) -> LaserPose {
    let (s, c) = a.yaw_rad.sin_cos();
    LaserPose { x_m: -(c * a.x_m + s * a.y_m), y_m: s * a.x_m - c * a.y_m, yaw_rad: -a.yaw_rad }
}

impl TfTree {
    /// Takes every transform of `msg` whose values are finite (the newest one of a child wins).
    pub(crate) fn add(&mut self, msg: &TfMessage) {
        for t in &msg.transforms {
            let (tr, q) = (&t.transform.translation, &t.transform.rotation);
            let pose = LaserPose { x_m: tr.x, y_m: tr.y, yaw_rad: q.yaw() };
            let child = frame(&t.child_frame_id);
            let parent = frame(&t.header.frame_id);
            if child.is_empty() || parent.is_empty() || child == parent {
                continue;
            }
            if [pose.x_m, pose.y_m, pose.yaw_rad].iter().all(|v| v.is_finite()) {
                self.parent_of.insert(child.to_string(), (parent.to_string(), pose));
            }
        }
    }

    /// `name` and its ancestors, each with `name`'s pose in it.
    fn chain<'a>(&'a self, name: &'a str) -> Vec<(&'a str, LaserPose)> {
        let mut out = Vec::new();
        let (mut at, mut pose) = (frame(name), LaserPose::default());
        out.push((at, pose));
        while let Some((parent, t)) = self.parent_of.get(at) {
            if out.len() > MAX_DEPTH || out.iter().any(|(f, _)| f == parent) {
                break;
            }
            pose = compose(*t, pose);
            at = parent;
            out.push((at, pose));
        }
        out
    }

    /// The pose of frame `of` in frame `base`, if the transforms link them.
    pub(crate) fn pose_in(&self, of: &str, base: &str) -> Option<LaserPose> {
        if frame(of).is_empty() || frame(base).is_empty() {
            return None;
        }
        let laser = self.chain(of);
        self.chain(base).into_iter().find_map(|(ancestor, base_in_it)| {
            let (_, laser_in_it) = laser.iter().find(|(f, _)| *f == ancestor)?;
            Some(compose(inverse(base_in_it), *laser_in_it))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_net::ros2::msg::{Header, Quaternion, Transform, TransformStamped, Vector3};
    use std::f64::consts::{FRAC_PI_2, PI};

    fn t(parent: &str, child: &str, x: f64, y: f64, yaw: f64) -> TransformStamped {
        TransformStamped {
            header: Header { frame_id: parent.into(), ..Default::default() },
            child_frame_id: child.into(),
            transform: Transform {
                translation: Vector3 { x, y, z: 0.2 },
                rotation: Quaternion::from_yaw(yaw),
            },
        }
    }

    fn close(a: Option<LaserPose>, x: f64, y: f64, yaw: f64) -> bool {
        // Angles compare on the circle (pi and -pi are one heading).
        let turn = |d: f64| (d + PI).rem_euclid(std::f64::consts::TAU) - PI;
        a.is_some_and(|a| {
            (a.x_m - x).abs() < 1e-9 && (a.y_m - y).abs() < 1e-9 && turn(a.yaw_rad - yaw).abs() < 1e-9
        })
    }

    #[test]
    fn a_laser_is_placed_through_its_chain_or_a_common_parent() {
        let mut tree = TfTree::default();
        // TurtleBot 3's chain: base_footprint -> base_link -> base_scan, the scan turned.
        tree.add(&TfMessage {
            transforms: vec![
                t("base_footprint", "base_link", 0.0, 0.0, 0.0),
                t("/base_link", "base_scan", -0.064, 0.0, PI),
            ],
        });
        let p = tree.pose_in("base_scan", "base_footprint");
        assert!(close(p, -0.064, 0.0, PI), "{p:?}");
        assert!(close(tree.pose_in("base_scan", "base_link"), -0.064, 0.0, PI));
        // A laser beside the base under a common parent, the base itself offset and turned.
        tree.add(&TfMessage {
            transforms: vec![t("root", "base", 1.0, 0.0, FRAC_PI_2), t("root", "laser", 1.0, 0.5, FRAC_PI_2)],
        });
        assert!(close(tree.pose_in("laser", "base"), 0.5, 0.0, 0.0));
        assert_eq!(tree.pose_in("base_scan", "base"), None, "not linked");
        assert_eq!(tree.pose_in("", "base"), None);
        // A loop in a peer's transforms ends the walk.
        tree.add(&TfMessage { transforms: vec![t("b", "a", 0.0, 0.0, 0.0), t("a", "b", 0.0, 0.0, 0.0)] });
        assert_eq!(tree.pose_in("a", "zzz"), None);
    }
}
