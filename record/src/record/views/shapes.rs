//! Pure conversions from orsa's objects to Foxglove's well-known messages: the world as a
//! scene, poses as frame transforms, a sensor ring's scan as a laser scan.

use super::{BASE_FRAME, ODOM_FRAME, TRUTH_BASE_FRAME, WORLD_FRAME};
use foxglove::schemas::{
    Color, CubePrimitive, CylinderPrimitive, FrameTransform, KeyValuePair, LaserScan, LinePrimitive, Point3,
    Pose, Quaternion, SceneEntity, TextPrimitive, Timestamp as FoxTimestamp, Vector3, line_primitive,
};
use orsa_actors::Timestamp;
use orsa_hardware::world::World;
use orsa_interfaces::nomad200::{DistanceScan, RING_SIZE, ring_angle_rad};

/// How tall walls, boxes and discs are drawn, m (the world is flat: this is for the eye only).
pub(crate) const OBSTACLE_HEIGHT_M: f64 = 0.5;
/// How tall people are drawn, m.
pub(crate) const PERSON_HEIGHT_M: f64 = 1.7;
/// How tall the robot is drawn, m (the Nomad 200 is about 0.8 m).
pub(crate) const ROBOT_HEIGHT_M: f64 = 0.8;

/// A robot-clock instant as a Foxglove timestamp (seconds past the clock's origin; a live
/// clock's origin is the UNIX epoch).
pub(crate) fn stamp(t: Timestamp) -> FoxTimestamp {
    let ns = t.as_nanos();
    // Past 2106 on a live clock: the latest instant Foxglove can say.
    u32::try_from(ns / 1_000_000_000)
        .ok()
        .and_then(|sec| FoxTimestamp::new_checked(sec, (ns % 1_000_000_000) as u32))
        .unwrap_or(FoxTimestamp::MAX)
}

/// The rotation by `yaw_rad` about +z.
pub(crate) fn yaw(yaw_rad: f64) -> Quaternion {
    let half = 0.5 * yaw_rad;
    Quaternion { x: 0.0, y: 0.0, z: half.sin(), w: half.cos() }
}

/// The pose at (`x`, `y`, `z`) turned by `yaw_rad`.
pub(crate) fn pose(x: f64, y: f64, z: f64, yaw_rad: f64) -> Pose {
    Pose { position: Some(Vector3 { x, y, z }), orientation: Some(yaw(yaw_rad)) }
}

/// `child` placed in `parent` at (`x`, `y`), turned by `yaw_rad`, at `at`.
pub(crate) fn transform(
    parent: &str,
    child: &str,
    at: Timestamp,
    x: f64,
    y: f64,
    yaw_rad: f64,
) -> FrameTransform {
    FrameTransform {
        timestamp: Some(stamp(at)),
        parent_frame_id: parent.to_owned(),
        child_frame_id: child.to_owned(),
        translation: Some(Vector3 { x, y, z: 0.0 }),
        rotation: Some(yaw(yaw_rad)),
    }
}

/// An opaque colour from 0-255 components.
pub(crate) fn rgb(r: u8, g: u8, b: u8) -> Color {
    Color { r: f64::from(r) / 255.0, g: f64::from(g) / 255.0, b: f64::from(b) / 255.0, a: 1.0 }
}

/// The colour of the kind of behaviour driving (the same as `out/run.svg`'s).
pub(crate) fn driving_colour(kind: Option<&str>) -> Color {
    match kind {
        None => rgb(0x9a, 0x9a, 0x9a),
        Some("centerfollow") => rgb(0x1f, 0x77, 0xb4),
        Some("wallfollow") => rgb(0xff, 0x7f, 0x0e),
        Some(_) => rgb(0x2c, 0xa0, 0x2c),
    }
}

/// An entity in `frame` with no primitives yet, that lives until replaced.
pub(crate) fn entity(id: &str, frame: &str, at: Timestamp) -> SceneEntity {
    SceneEntity {
        timestamp: Some(stamp(at)),
        frame_id: frame.to_owned(),
        id: id.to_owned(),
        ..Default::default()
    }
}

/// The world's static shapes, in the `world` frame: entity `walls` holds one line per wall of
/// the world file, in its order, through its points (a loop where the wall is `closed`);
/// `boxes` a cube per box, `discs` a cylinder per disc.
pub(crate) fn world_entities(world: &World, at: Timestamp) -> Vec<SceneEntity> {
    let grey = rgb(0x55, 0x55, 0x55);
    let light = rgb(0xd9, 0xd9, 0xd9);
    let mut walls = entity("walls", WORLD_FRAME, at);
    walls.lines = world
        .walls
        .iter()
        .map(|w| LinePrimitive {
            r#type: if w.closed { line_primitive::Type::LineLoop } else { line_primitive::Type::LineStrip }
                as i32,
            pose: Some(pose(0.0, 0.0, 0.0, 0.0)),
            thickness: 0.05,
            scale_invariant: false,
            points: w.points.iter().map(|&[x, y]| Point3 { x, y, z: 0.0 }).collect(),
            color: Some(grey),
            ..Default::default()
        })
        .collect();
    let mut boxes = entity("boxes", WORLD_FRAME, at);
    boxes.cubes = world
        .boxes
        .iter()
        .map(|b| CubePrimitive {
            pose: Some(pose(
                0.5 * (b.min[0] + b.max[0]),
                0.5 * (b.min[1] + b.max[1]),
                0.5 * OBSTACLE_HEIGHT_M,
                0.0,
            )),
            size: Some(Vector3 { x: b.max[0] - b.min[0], y: b.max[1] - b.min[1], z: OBSTACLE_HEIGHT_M }),
            color: Some(light),
        })
        .collect();
    let mut discs = entity("discs", WORLD_FRAME, at);
    discs.cylinders = world
        .discs
        .iter()
        .map(|d| cylinder(d.center[0], d.center[1], d.radius, OBSTACLE_HEIGHT_M, light))
        .collect();
    vec![walls, boxes, discs]
}

/// An upright cylinder standing on the floor at (`x`, `y`).
pub(crate) fn cylinder(x: f64, y: f64, radius_m: f64, height_m: f64, color: Color) -> CylinderPrimitive {
    CylinderPrimitive {
        pose: Some(pose(x, y, 0.5 * height_m, 0.0)),
        size: Some(Vector3 { x: 2.0 * radius_m, y: 2.0 * radius_m, z: height_m }),
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: Some(color),
    }
}

/// Who drives the robot: the behaviour (by name), its kind, and the master's mode.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Driving<'a> {
    pub(crate) name: Option<&'a str>,
    pub(crate) kind: Option<&'a str>,
    pub(crate) mode: Option<&'a str>,
}

/// The robot's body in `frame` (its truth or its odometry), coloured by the kind of the
/// behaviour driving, which it also names above itself and in its metadata (`driving`,
/// `mode`; empty when none).
pub(crate) fn robot_entity(
    id: &str,
    frame: &str,
    at: Timestamp,
    radius_m: f64,
    who: Driving<'_>,
    alpha: f64,
) -> SceneEntity {
    let Driving { name: driving, kind, mode } = who;
    let mut e = entity(id, frame, at);
    e.frame_locked = true;
    let mut colour = driving_colour(kind);
    colour.a = alpha;
    e.cylinders = vec![cylinder(0.0, 0.0, radius_m, ROBOT_HEIGHT_M, colour)];
    // Where sensor 0 faces: the robot's front.
    e.cubes = vec![CubePrimitive {
        pose: Some(pose(radius_m, 0.0, ROBOT_HEIGHT_M, 0.0)),
        size: Some(Vector3 { x: 0.12, y: 0.04, z: 0.04 }),
        color: Some(Color { a: alpha, ..rgb(0x20, 0x20, 0x20) }),
    }];
    e.texts = vec![TextPrimitive {
        pose: Some(pose(0.0, 0.0, ROBOT_HEIGHT_M + 0.3, 0.0)),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: Some(Color { a: alpha, ..rgb(0, 0, 0) }),
        text: driving.unwrap_or("no behaviour").to_owned(),
    }];
    e.metadata = vec![
        KeyValuePair { key: "driving".into(), value: driving.unwrap_or_default().to_owned() },
        KeyValuePair { key: "mode".into(), value: mode.unwrap_or_default().to_owned() },
    ];
    e
}

/// The robot's body where the localizer puts it: a blue outline (a circle at floor level and a
/// tick to the front), frame-locked to `frame`, so that it is told apart from the solid body at
/// the truth and the faint one at odometry.
pub(crate) fn estimate_entity(id: &str, frame: &str, at: Timestamp, radius_m: f64) -> SceneEntity {
    let mut e = entity(id, frame, at);
    e.frame_locked = true;
    let blue = rgb(0x1f, 0x77, 0xb4);
    let n = 36;
    let circle = (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / f64::from(n);
            Point3 { x: radius_m * a.cos(), y: radius_m * a.sin(), z: 0.02 }
        })
        .collect();
    e.lines = vec![
        LinePrimitive {
            r#type: line_primitive::Type::LineLoop as i32,
            pose: Some(pose(0.0, 0.0, 0.0, 0.0)),
            thickness: 0.03,
            scale_invariant: false,
            points: circle,
            color: Some(blue),
            ..Default::default()
        },
        LinePrimitive {
            r#type: line_primitive::Type::LineStrip as i32,
            pose: Some(pose(0.0, 0.0, 0.0, 0.0)),
            thickness: 0.03,
            scale_invariant: false,
            points: vec![Point3 { x: 0.0, y: 0.0, z: 0.02 }, Point3 { x: radius_m, y: 0.0, z: 0.02 }],
            color: Some(blue),
            ..Default::default()
        },
    ];
    e
}

/// A ring's scan in the robot's frame: one range per sensor, sensor `i` at
/// [`ring_angle_rad`]`(i)`, measured from the robot's centre (the reading plus the ring's
/// `mount_radius_m`), its intensity 1. A sensor without a valid reading (nothing seen, or a
/// reading refused) has range 0 and intensity 0: `foxglove.LaserScan` has no mark for a missing
/// return, and an infinite range is drawn at infinity by Foxglove's 3D panel, where a range of
/// 0 is the scan's origin, inside the robot (no real return is nearer than the ring). ROS 2's
/// `/scan` keeps REP 117's `+inf` for no return.
pub(crate) fn laser_scan(scan: &DistanceScan, mount_radius_m: f64) -> LaserScan {
    let (mut ranges, mut intensities) = (vec![0.0; RING_SIZE], vec![0.0; RING_SIZE]);
    for r in &scan.readings {
        let i = usize::from(r.sensor_id);
        if i < RING_SIZE && r.valid && r.distance_m.is_finite() {
            ranges[i] = mount_radius_m + r.distance_m;
            intensities[i] = 1.0;
        }
    }
    LaserScan {
        timestamp: Some(stamp(scan.stamp)),
        frame_id: BASE_FRAME.to_owned(),
        pose: Some(pose(0.0, 0.0, 0.0, 0.0)),
        start_angle: ring_angle_rad(0),
        end_angle: ring_angle_rad(RING_SIZE - 1),
        ranges,
        intensities,
    }
}

/// The odometry chain at `at`: `world` -> `odom` (where odometry started: the robot's start
/// pose) and `odom` -> `base_link` (the odometry pose).
pub(crate) fn odometry_transforms(
    start: (f64, f64, f64),
    at: Timestamp,
    x_m: f64,
    y_m: f64,
    heading_rad: f64,
) -> Vec<FrameTransform> {
    vec![
        transform(WORLD_FRAME, ODOM_FRAME, at, start.0, start.1, start.2),
        transform(ODOM_FRAME, BASE_FRAME, at, x_m, y_m, heading_rad),
    ]
}

/// The ground truth at `at`: `world` -> `base_link_truth`.
pub(crate) fn truth_transform(at: Timestamp, x_m: f64, y_m: f64, heading_rad: f64) -> FrameTransform {
    transform(WORLD_FRAME, TRUTH_BASE_FRAME, at, x_m, y_m, heading_rad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::nomad200::{DistanceReading, Ring};

    #[test]
    fn a_scan_has_a_range_per_sensor_at_the_ring_angles_from_the_centre() {
        let readings = (0..RING_SIZE as u8)
            .map(|i| DistanceReading {
                sensor_id: i,
                stamp: Timestamp(5),
                valid: i != 3,
                distance_m: 0.1 * f64::from(i),
            })
            .collect();
        let s = laser_scan(&DistanceScan { stamp: Timestamp(7), ring: Ring::Infrared, readings }, 0.25);
        assert_eq!(s.ranges.len(), RING_SIZE);
        assert_eq!(s.frame_id, BASE_FRAME);
        assert!((s.ranges[4] - 0.65).abs() < 1e-12);
        assert_eq!((s.ranges[3], s.intensities[3]), (0.0, 0.0), "no return: at the origin, dark");
        assert_eq!(s.intensities[4], 1.0);
        assert!(s.ranges.iter().all(|r| r.is_finite()));
        // Evenly spread from the start to the end angle: sensor 4 is at 90 degrees (left).
        let step = (s.end_angle - s.start_angle) / (RING_SIZE - 1) as f64;
        assert!((s.start_angle + 4.0 * step - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((s.start_angle + 12.0 * step - 3.0 * std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn stamps_split_into_seconds_and_nanoseconds() {
        let s = stamp(Timestamp(3_250_000_000));
        assert_eq!((s.sec(), s.nsec()), (3, 250_000_000));
        assert_eq!(stamp(Timestamp(u64::MAX)), FoxTimestamp::MAX);
    }

    #[test]
    fn yaw_turns_about_z() {
        let q = yaw(std::f64::consts::PI);
        assert!(q.z > 0.999_999 && q.w.abs() < 1e-9 && q.x == 0.0 && q.y == 0.0);
    }

    #[test]
    fn the_world_scene_has_the_world_files_walls() {
        let world = World::palazzina().expect("the reference world");
        let entities = world_entities(&world, Timestamp(0));
        let walls = &entities[0];
        assert_eq!(walls.id, "walls");
        assert_eq!(walls.lines.len(), world.walls.len());
        for (line, wall) in walls.lines.iter().zip(&world.walls) {
            assert_eq!(line.points.len(), wall.points.len());
            assert_eq!((line.points[0].x, line.points[0].y), (wall.points[0][0], wall.points[0][1]));
        }
        assert_eq!(entities[1].cubes.len(), world.boxes.len());
        assert_eq!(entities[2].cylinders.len(), world.discs.len());
    }
}
