//! # orsa-navigation: where the robot is on its map
//!
//! The navigation components of orsa's deliberative layer, and the algorithms they wrap, for any
//! robot that describes its range sensors: the robot's pose in the map is estimated from its
//! odometry and its range readings against the map's occupancy grid
//! ([`orsa_interfaces::map::OccupancyGrid`]), so that a planner can send it to places although
//! its odometry drifts. The algorithms are pure and synchronous, seeded where they draw at
//! random, so that a seed reproduces a run.
//!
//! Modules:
//! - [`field`]: the distance from every cell of a grid to the nearest occupied one (an exact
//!   Euclidean distance transform), which scores range readings against the map.
//! - [`layer`]: the map's live obstacle layer: what the range sensors see that the known map
//!   does not hold, marked where beams echo and cleared where they pass through.
//! - [`plan`]: the global planner: the shortest path for the body over the grid (A*), kept off
//!   walls where there is room.
//! - [`localizer`]: the localizer component: [`mcl`] on a robot's odometry and range views,
//!   publishing the pose in the map (`orsa_interfaces::navigation::POSE`).
//! - [`mapserver`]: the map component: the known map and its places, pushed on `map` and
//!   answered on `known` to a planner in any process.
//! - [`relocalize`]: noticing that the estimate no longer fits what the sensors see (a robot
//!   carried elsewhere), and finding the robot again by matching what it saw while turning on
//!   the spot against the whole map (correlative scan matching), guessing where two places look
//!   alike until moving tells them apart.
//! - [`mcl`]: Monte Carlo localization (augmented, KLD-free: a fixed number of particles) with
//!   the odometry motion model and the likelihood-field sensor model, and recovery from being
//!   lost or kidnapped by particles injected at random free places while readings fit badly.

pub mod field;
pub mod layer;
pub mod localizer;
pub mod mapserver;
pub mod mcl;
pub mod plan;
pub mod relocalize;
