//! The recording's views: channels in Foxglove's well-known schemas (protobuf, from the
//! `foxglove` crate), beside the JSON channels, so that Foxglove draws the run.
//!
//! They are made on the recorder's thread from what is recorded anyway (the robot server's
//! scans and odometry, the master's `driving`) and from ground-truth samples the run gives the
//! recording ([`TruthSample`]); nothing in them is read back by `orsa replay`.
//!
//! The same code makes them for a live viewer (`--foxglove`, see [`crate::live`]): `Views`
//! writes to a [`ViewSink`], which is the MCAP [`Recorder`] or the live server's channels.
//!
//! | topic | schema | what |
//! |---|---|---|
//! | [`WORLD_TOPIC`] | `foxglove.SceneUpdate` | walls (`walls`: a line per wall of the world file), boxes, discs; once |
//! | [`MAP_TOPIC`] | `foxglove.Grid` | the world's walls, boxes and discs as the map's occupancy grid ([`MAP_RESOLUTION_M`] cells: occupied dark, free light, unknown not drawn); once |
//! | [`PEOPLE_TOPIC`] | `foxglove.SceneUpdate` | the people (`person/i`), at every truth sample |
//! | [`ROBOT_TOPIC`] | `foxglove.SceneUpdate` | the robot's body at its truth and (faint) at its odometry, coloured by the behaviour driving |
//! | [`TF_TOPIC`] | `foxglove.FrameTransforms` | `world` -> `odom` -> `base_link`, at every `basestate` |
//! | [`TRUTH_TF_TOPIC`] | `foxglove.FrameTransforms` | `world` -> `base_link_truth`, at every truth sample |
//! | [`INFRARED_TOPIC`], [`SONAR_TOPIC`] | `foxglove.LaserScan` | every `distanceir` and `distanceson` scan, in `base_link`; a sensor with no valid return at range 0, intensity 0 (a return: intensity 1), never an infinite range |
//! | [`TRAJECTORY_TOPIC`] | `foxglove.PosesInFrame` | the true path so far, in `world`, every 2 s |
//! | [`DRIVING_TOPIC`] | `foxglove.Log` | which behaviour drives, at every change |
//! | [`EVENTS_TOPIC`] | `foxglove.Log` | every wiring and state change, parameter set, supervisor and link event (named by its topic, its JSON as the message) |
//! | [`ESTIMATE_TF_TOPIC`] | `foxglove.FrameTransforms` | `world` -> `base_link_estimate`: the localizer's estimate (the map's frame is the world's), at every `pose` it publishes; the robot's body is drawn there too (blue outline) |
//! | [`PLAN_TOPIC`] | `foxglove.PosesInFrame` | the path the path follower was given, in `world`, at every new one (empty: none) |
//! | [`HEALTH_TOPIC`] | `foxglove.Log` | the sensors' health at every change (the robot pushes it every second too; the view logs only changes): a warning naming each sensor not trusted and why, info when all are healthy again |

mod grid;
mod shapes;

pub use grid::{CELL_STRIDE, grid_view};

use super::{RecordError, Recorder};
use foxglove::schemas::{FrameTransforms, Log, Pose, PosesInFrame, SceneUpdate, log};
use orsa_actors::{Stamped, Timestamp};
use orsa_hardware::world::World;
use orsa_interfaces::executive::WiringChange;
use orsa_interfaces::health::{Health, Verdict};
use orsa_interfaces::navigation::{FollowPath, PoseEstimate};
use orsa_interfaces::nomad200::{BaseState, DistanceScan};

/// The fixed frame: the world file's coordinates.
pub const WORLD_FRAME: &str = "world";
/// Odometry's frame: where the robot's odometry started (its start pose in the world).
pub const ODOM_FRAME: &str = "odom";
/// The robot's body as its odometry places it; +x is its front (sensor 0).
pub const BASE_FRAME: &str = "base_link";
/// The robot's body where it really is (the simulator's ground truth).
pub const TRUTH_BASE_FRAME: &str = "base_link_truth";
/// The robot's body where the localizer estimates it (in the map, whose frame is the world's).
pub const ESTIMATE_BASE_FRAME: &str = "base_link_estimate";

/// Walls, boxes and discs.
pub const WORLD_TOPIC: &str = "/world";
/// The world as the map's occupancy grid.
pub const MAP_TOPIC: &str = "/map";
/// The side of the map's cells, m.
pub const MAP_RESOLUTION_M: f64 = 0.05;
/// The people.
pub const PEOPLE_TOPIC: &str = "/people";
/// The robot's body.
pub const ROBOT_TOPIC: &str = "/robot";
/// The odometry chain.
pub const TF_TOPIC: &str = "/tf";
/// The ground truth's frame.
pub const TRUTH_TF_TOPIC: &str = "/truth/tf";
/// The infrared ring's scans.
pub const INFRARED_TOPIC: &str = "/infrared";
/// The sonar ring's scans.
pub const SONAR_TOPIC: &str = "/sonar";
/// The true path.
pub const TRAJECTORY_TOPIC: &str = "/trajectory";
/// Which behaviour drives.
pub const DRIVING_TOPIC: &str = "/driving";
/// Wiring and state changes, supervisor and link events.
pub const EVENTS_TOPIC: &str = "/events";
/// The sensors' health, at every change.
pub const HEALTH_TOPIC: &str = "/health";
/// The localizer's estimate, as a frame.
pub const ESTIMATE_TF_TOPIC: &str = "/estimate/tf";
/// The path being followed.
pub const PLAN_TOPIC: &str = "/plan";

/// The kind of component whose `pose` is the localizer's estimate.
const LOCALIZER_KIND: &str = "localizer";
/// The kind of component whose `path` is the path it follows.
const PATH_FOLLOWER_KIND: &str = "pathfollow";

/// Poses the trajectory holds at most; past that every other one is dropped (the oldest
/// first is kept), so that a message stays under 11 kB however long the run. (The whole path
/// is written every time, so that Foxglove shows it after a seek: its size is what the
/// recording pays for, about 15 MB an hour before compression.)
pub const TRAJECTORY_MAX_POSES: usize = 256;
/// How often the trajectory gets a pose and is written, ns.
pub const TRAJECTORY_PERIOD_NS: u64 = 2_000_000_000;

/// What the views need to know of the recorded system.
#[derive(Debug, Clone)]
pub struct ViewSetup {
    /// The robot server's name: its `distanceir`, `distanceson` and `basestate` become scans
    /// and the odometry chain.
    pub robot: String,
    /// The master's name: its `driving` says which behaviour drives.
    pub master: String,
    /// The world simulated, if any: its shapes, and the start pose that places `odom`.
    pub world: Option<World>,
    /// The robot's radius, which is also the radius on which its sensors sit, m.
    pub body_radius_m: f64,
    /// Whether the process hands the views ground-truth samples ([`TruthSample`]): without
    /// them there is no `base_link_truth`, and the robot is drawn at its odometry only.
    pub truth: bool,
    /// Each component's kind by its name: the robot is coloured by the kind of the behaviour
    /// driving (a `wallfollow` is orange whatever it is named).
    pub kinds: std::collections::BTreeMap<String, String>,
}

impl ViewSetup {
    /// What a recorded `topic` is to the views, if anything.
    pub(crate) fn input_of(&self, topic: &str) -> Option<Input> {
        if topic == super::events::LINK_EVENTS || topic == super::events::SUPERVISION_EVENTS {
            return Some(Input::Event);
        }
        let (component, service) = topic.split_once('/')?;
        if service == "wiring" || service == "state" || service == orsa_actors::param::CHANGES {
            return Some(Input::Event);
        }
        if component == self.robot {
            return match service {
                "distanceir" => Some(Input::Infrared),
                "distanceson" => Some(Input::Sonar),
                "basestate" => Some(Input::Base),
                "health" => Some(Input::Health),
                _ => None,
            };
        }
        match (self.kinds.get(component).map(String::as_str), service) {
            (Some(LOCALIZER_KIND), "pose") => return Some(Input::Estimate),
            (Some(PATH_FOLLOWER_KIND), "path") => return Some(Input::Plan),
            _ => {}
        }
        (component == self.master && service == "driving").then_some(Input::Driving)
    }

    /// Whether the system has a localizer, whose estimate the views draw.
    fn localizes(&self) -> bool {
        self.kinds.values().any(|k| k == LOCALIZER_KIND)
    }
}

/// A person of the simulated world, as ground truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Person {
    /// Centre x in the world, m.
    pub x_m: f64,
    /// Centre y in the world, m.
    pub y_m: f64,
    /// Radius, m.
    pub radius_m: f64,
    /// Whether they stood still for the robot.
    pub yielding: bool,
}

/// Where the robot and the people really are at one instant (the simulator's truth).
#[derive(Debug, Clone, PartialEq)]
pub struct TruthSample {
    /// When.
    pub at: Timestamp,
    /// The robot's centre x in the world, m.
    pub x_m: f64,
    /// The robot's centre y in the world, m.
    pub y_m: f64,
    /// Where the robot's front faces, rad counter-clockwise from the world's +x.
    pub heading_rad: f64,
    /// The people.
    pub people: Vec<Person>,
}

/// Where views go: an MCAP recording, or a live server's channels.
pub trait ViewSink {
    /// What may go wrong writing one.
    type Error;

    /// Writes `msg`, a message of one of Foxglove's well-known schemas, on `topic` at robot
    /// time `at` (a topic's first message gives it its channel and schema).
    fn view<T: foxglove::Encode>(&mut self, topic: &str, at: Timestamp, msg: &T) -> Result<(), Self::Error>;

    /// Makes `topic`'s channel, for messages of `T`, before its first message (a recording
    /// makes a channel at its first message: by default, nothing).
    fn declare<T: foxglove::Encode>(&mut self, topic: &str) -> Result<(), Self::Error> {
        let _ = topic;
        Ok(())
    }
}

impl ViewSink for Recorder {
    type Error = RecordError;

    fn view<T: foxglove::Encode>(&mut self, topic: &str, at: Timestamp, msg: &T) -> Result<(), RecordError> {
        self.write_view(topic, at, msg)
    }
}

/// A recorded topic the views are made from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Input {
    Infrared,
    Sonar,
    Base,
    Driving,
    /// A wiring or state change, a supervisor's or the link watchdog's event.
    Event,
    /// The sensors' health.
    Health,
    /// The localizer's estimate.
    Estimate,
    /// The path the path follower is given.
    Plan,
}

/// The views' state on the recorder's thread.
pub(crate) struct Views {
    setup: ViewSetup,
    /// The robot's start pose in the world: where `odom` is.
    start: (f64, f64, f64),
    /// Whether the world and the robot were written.
    began: bool,
    driving: Option<String>,
    mode: Option<String>,
    /// The last `driving` view written, for a live viewer that subscribes after it.
    last_driving: Option<(Timestamp, Log)>,
    trajectory: Vec<Pose>,
    last_pose_ns: Option<u64>,
    /// The last health message logged: the robot pushes its health every second, and the
    /// view logs it only when it changes.
    last_health: Option<String>,
    /// Inputs that did not decode, warned about once each.
    warned: [bool; 8],
    /// The world's map, made once.
    map: Option<foxglove::schemas::Grid>,
}

impl Views {
    pub(crate) fn new(setup: ViewSetup) -> Views {
        let start =
            setup.world.as_ref().map_or((0.0, 0.0, 0.0), |w| (w.robot.x, w.robot.y, w.robot.heading_rad()));
        let map = setup.world.as_ref().and_then(|w| match w.occupancy_grid(MAP_RESOLUTION_M) {
            Ok(g) => Some(grid_view(&g, WORLD_FRAME, Timestamp::ZERO)),
            Err(e) => {
                tracing::warn!("views: the world is not drawn as a map: {e}");
                None
            }
        });
        Views {
            setup,
            map,
            start,
            began: false,
            driving: None,
            mode: None,
            last_driving: None,
            trajectory: Vec::new(),
            last_pose_ns: None,
            last_health: None,
            warned: [false; 8],
        }
    }

    /// What a recorded `topic` is to the views, if anything.
    pub(crate) fn input_of(&self, topic: &str) -> Option<Input> {
        self.setup.input_of(topic)
    }

    /// Declares the channels this process's views may write, so that a live viewer lists them
    /// before their first message: the scans and the odometry chain where the world is
    /// simulated, the truth's channels where truth is given, and the robot, the driving
    /// behaviour and the events everywhere.
    pub(crate) fn declare<S: ViewSink>(&self, sink: &mut S) -> Result<(), S::Error> {
        use foxglove::schemas::LaserScan;
        sink.declare::<SceneUpdate>(ROBOT_TOPIC)?;
        sink.declare::<Log>(DRIVING_TOPIC)?;
        sink.declare::<Log>(EVENTS_TOPIC)?;
        if self.setup.world.is_some() {
            sink.declare::<SceneUpdate>(WORLD_TOPIC)?;
            sink.declare::<foxglove::schemas::Grid>(MAP_TOPIC)?;
            sink.declare::<LaserScan>(INFRARED_TOPIC)?;
            sink.declare::<LaserScan>(SONAR_TOPIC)?;
            sink.declare::<FrameTransforms>(TF_TOPIC)?;
            sink.declare::<Log>(HEALTH_TOPIC)?;
        }
        if self.setup.localizes() {
            sink.declare::<FrameTransforms>(ESTIMATE_TF_TOPIC)?;
            sink.declare::<PosesInFrame>(PLAN_TOPIC)?;
        }
        if self.setup.truth {
            sink.declare::<SceneUpdate>(PEOPLE_TOPIC)?;
            sink.declare::<FrameTransforms>(TRUTH_TF_TOPIC)?;
            sink.declare::<PosesInFrame>(TRAJECTORY_TOPIC)?;
        }
        Ok(())
    }

    /// Writes the world and the robot, once, at `at`.
    fn begin<S: ViewSink>(&mut self, rec: &mut S, at: Timestamp) -> Result<(), S::Error> {
        if self.began {
            return Ok(());
        }
        self.began = true;
        if let Some(world) = &self.setup.world {
            let scene = SceneUpdate { deletions: Vec::new(), entities: shapes::world_entities(world, at) };
            rec.view(WORLD_TOPIC, at, &scene)?;
        }
        self.write_map(rec, at)?;
        self.write_robot(rec, at)
    }

    /// Writes again what is written once or seldom (the world, the robot, which behaviour
    /// drives, the path so far), at `at`: for a live viewer that subscribed after they were
    /// written.
    pub(crate) fn rewrite_latched<S: ViewSink>(
        &mut self,
        sink: &mut S,
        at: Timestamp,
    ) -> Result<(), S::Error> {
        if !self.began {
            return self.begin(sink, at);
        }
        if let Some(world) = &self.setup.world {
            let scene = SceneUpdate { deletions: Vec::new(), entities: shapes::world_entities(world, at) };
            sink.view(WORLD_TOPIC, at, &scene)?;
        }
        self.write_map(sink, at)?;
        self.write_robot(sink, at)?;
        if let Some((when, log)) = &self.last_driving {
            sink.view(DRIVING_TOPIC, *when, log)?;
        }
        if self.trajectory.is_empty() {
            return Ok(());
        }
        let poses = PosesInFrame {
            timestamp: Some(shapes::stamp(at)),
            frame_id: WORLD_FRAME.to_owned(),
            poses: self.trajectory.clone(),
        };
        sink.view(TRAJECTORY_TOPIC, at, &poses)
    }

    /// Writes the map, if the world gives one, stamped `at`.
    fn write_map<S: ViewSink>(&mut self, sink: &mut S, at: Timestamp) -> Result<(), S::Error> {
        let Some(map) = &mut self.map else { return Ok(()) };
        map.timestamp = Some(shapes::stamp(at));
        sink.view(MAP_TOPIC, at, map)
    }

    fn write_robot<S: ViewSink>(&mut self, rec: &mut S, at: Timestamp) -> Result<(), S::Error> {
        let (driving, mode) = (self.driving.as_deref(), self.mode.as_deref());
        let kind = driving.map(|d| self.setup.kinds.get(d).map_or(d, String::as_str));
        let who = shapes::Driving { name: driving, kind, mode };
        let r = self.setup.body_radius_m;
        let mut entities = if self.setup.truth {
            vec![
                shapes::robot_entity("robot", TRUTH_BASE_FRAME, at, r, who, 1.0),
                shapes::robot_entity("robot/odometry", BASE_FRAME, at, r, who, 0.3),
            ]
        } else {
            vec![shapes::robot_entity("robot/odometry", BASE_FRAME, at, r, who, 1.0)]
        };
        if self.setup.localizes() {
            entities.push(shapes::estimate_entity("robot/estimate", ESTIMATE_BASE_FRAME, at, r));
        }
        rec.view(ROBOT_TOPIC, at, &SceneUpdate { deletions: Vec::new(), entities })
    }

    /// Makes the views of one recorded message (`json`, logged at `at`) on an input topic. A
    /// message that does not decode is left out of the views (with a warning, once per input).
    pub(crate) fn message<S: ViewSink>(
        &mut self,
        rec: &mut S,
        input: Input,
        topic: &str,
        at: Timestamp,
        json: &[u8],
    ) -> Result<(), S::Error> {
        self.begin(rec, at)?;
        let undecoded = |views: &mut Views, e: serde_json::Error| -> Result<(), S::Error> {
            let warned = &mut views.warned[input as usize];
            if !*warned {
                *warned = true;
                tracing::warn!(
                    "recording: a message of {input:?} does not decode; its views are left out: {e}"
                );
            }
            Ok(())
        };
        match input {
            Input::Event => {
                let log = Log {
                    timestamp: Some(shapes::stamp(at)),
                    level: log::Level::Info as i32,
                    message: String::from_utf8_lossy(json).into_owned(),
                    name: topic.to_owned(),
                    file: String::new(),
                    line: 0,
                };
                rec.view(EVENTS_TOPIC, at, &log)
            }
            Input::Health => {
                let h = match serde_json::from_slice::<Stamped<Health>>(json) {
                    Ok(s) => s.value,
                    Err(e) => return undecoded(self, e),
                };
                let bad: Vec<String> = h
                    .sensors
                    .iter()
                    .filter(|s| s.verdict != Verdict::Healthy)
                    .map(|s| format!("{} {}: {}", s.sensor, s.verdict.name(), s.why))
                    .collect();
                let (level, message) = if bad.is_empty() {
                    (log::Level::Info, "every sensor healthy".to_owned())
                } else {
                    (log::Level::Warning, bad.join("; "))
                };
                if self.last_health.as_ref() == Some(&message) {
                    return Ok(());
                }
                self.last_health = Some(message.clone());
                let log = Log {
                    timestamp: Some(shapes::stamp(h.stamp)),
                    level: level as i32,
                    message,
                    name: topic.to_owned(),
                    file: String::new(),
                    line: 0,
                };
                rec.view(HEALTH_TOPIC, at, &log)
            }
            Input::Infrared | Input::Sonar => {
                let scan = match serde_json::from_slice::<Stamped<DistanceScan>>(json) {
                    Ok(s) => s.value,
                    Err(e) => return undecoded(self, e),
                };
                let topic = if input == Input::Infrared { INFRARED_TOPIC } else { SONAR_TOPIC };
                rec.view(topic, at, &shapes::laser_scan(&scan, self.setup.body_radius_m))
            }
            Input::Base => {
                let b = match serde_json::from_slice::<Stamped<BaseState>>(json) {
                    Ok(s) => s.value,
                    Err(e) => return undecoded(self, e),
                };
                let transforms =
                    shapes::odometry_transforms(self.start, b.stamp, b.x_m, b.y_m, b.heading_rad);
                rec.view(TF_TOPIC, at, &FrameTransforms { transforms })
            }
            Input::Driving => {
                let change = match serde_json::from_slice::<Stamped<WiringChange>>(json) {
                    Ok(s) => s.value,
                    Err(e) => return undecoded(self, e),
                };
                self.driving = change.driving;
                self.mode = change.mode;
                let message = match (&self.driving, &self.mode) {
                    (Some(d), Some(m)) => format!("{d} drives (mode {m})"),
                    (Some(d), None) => format!("{d} drives"),
                    (None, Some(m)) => format!("no behaviour drives (mode {m})"),
                    (None, None) => "no behaviour drives".to_owned(),
                };
                let log = Log {
                    timestamp: Some(shapes::stamp(change.stamp)),
                    level: log::Level::Info as i32,
                    message,
                    name: self.setup.master.clone(),
                    file: String::new(),
                    line: 0,
                };
                rec.view(DRIVING_TOPIC, at, &log)?;
                self.last_driving = Some((at, log));
                self.write_robot(rec, at)
            }
            Input::Estimate => {
                let e = match serde_json::from_slice::<Stamped<PoseEstimate>>(json) {
                    Ok(s) => s.value,
                    Err(e) => return undecoded(self, e),
                };
                let t =
                    shapes::transform(WORLD_FRAME, ESTIMATE_BASE_FRAME, e.stamp, e.x_m, e.y_m, e.heading_rad);
                rec.view(ESTIMATE_TF_TOPIC, at, &FrameTransforms { transforms: vec![t] })
            }
            Input::Plan => {
                let path = match serde_json::from_slice::<Stamped<FollowPath>>(json) {
                    Ok(s) => s.value,
                    Err(e) => return undecoded(self, e),
                };
                // Each pose faces the next point (the last one, the goal's heading if given).
                let n = path.points.len();
                let poses = (0..n)
                    .map(|i| {
                        let [x, y] = path.points[i];
                        let yaw = match path.points.get(i + 1) {
                            Some([nx, ny]) => (ny - y).atan2(nx - x),
                            None => path.heading_rad.unwrap_or_else(|| {
                                i.checked_sub(1)
                                    .map_or(0.0, |j| (y - path.points[j][1]).atan2(x - path.points[j][0]))
                            }),
                        };
                        shapes::pose(x, y, 0.0, yaw)
                    })
                    .collect();
                let plan = PosesInFrame {
                    timestamp: Some(shapes::stamp(at)),
                    frame_id: WORLD_FRAME.to_owned(),
                    poses,
                };
                rec.view(PLAN_TOPIC, at, &plan)
            }
        }
    }

    /// Makes the views of one ground-truth sample: the truth frame, the people and, every
    /// [`TRAJECTORY_PERIOD_NS`], the trajectory.
    pub(crate) fn truth<S: ViewSink>(&mut self, rec: &mut S, s: &TruthSample) -> Result<(), S::Error> {
        self.begin(rec, s.at)?;
        let transforms = vec![shapes::truth_transform(s.at, s.x_m, s.y_m, s.heading_rad)];
        rec.view(TRUTH_TF_TOPIC, s.at, &FrameTransforms { transforms })?;
        if !s.people.is_empty() {
            let entities = s
                .people
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let mut e = shapes::entity(&format!("person/{i}"), WORLD_FRAME, s.at);
                    let colour = if p.yielding {
                        shapes::rgb(0xd6, 0x27, 0x28)
                    } else {
                        shapes::rgb(0x8c, 0x56, 0x4b)
                    };
                    e.cylinders =
                        vec![shapes::cylinder(p.x_m, p.y_m, p.radius_m, shapes::PERSON_HEIGHT_M, colour)];
                    e
                })
                .collect();
            rec.view(PEOPLE_TOPIC, s.at, &SceneUpdate { deletions: Vec::new(), entities })?;
        }
        let ns = s.at.as_nanos();
        if self.last_pose_ns.is_some_and(|last| ns < last.saturating_add(TRAJECTORY_PERIOD_NS)) {
            return Ok(());
        }
        self.last_pose_ns = Some(ns);
        if self.trajectory.len() >= TRAJECTORY_MAX_POSES {
            let mut keep = false;
            self.trajectory.retain(|_| {
                keep = !keep;
                keep
            });
        }
        self.trajectory.push(shapes::pose(s.x_m, s.y_m, 0.0, s.heading_rad));
        let poses = PosesInFrame {
            timestamp: Some(shapes::stamp(s.at)),
            frame_id: WORLD_FRAME.to_owned(),
            poses: self.trajectory.clone(),
        };
        rec.view(TRAJECTORY_TOPIC, s.at, &poses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keeps every view written, encoded as it would be sent.
    #[derive(Default)]
    struct Kept(Vec<(String, Vec<u8>)>);

    impl ViewSink for Kept {
        type Error = std::convert::Infallible;

        fn view<T: foxglove::Encode>(
            &mut self,
            topic: &str,
            _: Timestamp,
            msg: &T,
        ) -> Result<(), Self::Error> {
            let mut buf = Vec::new();
            msg.encode(&mut buf).expect("a view encodes into a growing buffer");
            self.0.push((topic.to_owned(), buf));
            Ok(())
        }
    }

    fn setup(kinds: &[(&str, &str)]) -> ViewSetup {
        ViewSetup {
            robot: "nomad200".into(),
            master: "master".into(),
            world: None,
            body_radius_m: 0.25,
            truth: false,
            kinds: kinds.iter().map(|(n, k)| (n.to_string(), k.to_string())).collect(),
        }
    }

    /// The colour of the robot's body in the last `/robot` view written after `driving` drove.
    fn body_colour(setup: ViewSetup, driving: &str) -> foxglove::schemas::Color {
        let mut views = Views::new(setup);
        let mut sink = Kept::default();
        let change = WiringChange { stamp: Timestamp(1), driving: Some(driving.into()), mode: None };
        let json =
            serde_json::to_vec(&Stamped { seq: 1, sent_at: Timestamp(1), value: change }).expect("json");
        views.message(&mut sink, Input::Driving, "master/driving", Timestamp(1), &json).expect("infallible");
        let (_, bytes) = sink.0.iter().rev().find(|(t, _)| t == ROBOT_TOPIC).expect("a robot view");
        let scene = <SceneUpdate as prost::Message>::decode(bytes.as_slice()).expect("a SceneUpdate");
        let body = &scene.entities[0];
        assert_eq!(body.texts[0].text, driving, "the robot names who drives");
        body.cylinders[0].color.expect("a colour")
    }

    /// In Foxglove the robot takes the colour of the kind of behaviour driving, whatever it is
    /// named: a `wallfollow` named `hug` is orange like `wallfollow`, a `centerfollow` named
    /// `middle` blue, and a behaviour of a kind the thesis did not have green.
    #[test]
    fn the_robot_is_coloured_by_the_kind_of_behaviour_driving() {
        let kinds = [("hug", "wallfollow"), ("middle", "centerfollow"), ("roam", "wander")];
        let orange = shapes::rgb(0xff, 0x7f, 0x0e);
        let blue = shapes::rgb(0x1f, 0x77, 0xb4);
        assert_eq!(body_colour(setup(&kinds), "hug"), orange);
        assert_eq!(body_colour(setup(&[]), "wallfollow"), orange, "a built-in named after its kind");
        assert_eq!(body_colour(setup(&kinds), "middle"), blue);
        assert_eq!(body_colour(setup(&kinds), "roam"), shapes::rgb(0x2c, 0xa0, 0x2c));
        // Without its kind the name is all there is: `hug` is then no kind orsa knows.
        assert_ne!(body_colour(setup(&[]), "hug"), orange);
    }
}
