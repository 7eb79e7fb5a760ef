//! `/map`: the map component's grid as `nav_msgs/msg/OccupancyGrid`, reliable and transient
//! local with a depth of 1, as Nav2's map_server publishes it: RViz or a ROS 2 planner that
//! joins at any time gets the map at once.
//!
//! The grid is asked of the map component (`map/known`) when the node starts, and every newer
//! grid it pushes on `map/map` (a higher `version`) is published again.

use orsa_actors::push_newest::PushNewestClient;
use orsa_actors::query::QueryClient;
use orsa_actors::{Empty, Registry, Sink, Update};
use orsa_interfaces::map::{self as imap, KnownMap, MAP_FRAME, OccupancyGrid};
use orsa_net::ros2::msg::{self as m, Header, MapMetaData, Pose};
use orsa_net::ros2::{Qos, Ros2Node, Ros2Publisher};
use parking_lot::Mutex;
use std::sync::Arc;
use std::time::Duration;

/// How long the first ask for the map may take.
const ASK_TIMEOUT: Duration = Duration::from_secs(5);

/// Publishes `/map` while it lives.
pub struct MapTopic {
    _pushes: PushNewestClient<OccupancyGrid>,
    ask: tokio::task::JoinHandle<()>,
    /// The version last published (0: none yet).
    published: Arc<Mutex<u64>>,
}

impl Drop for MapTopic {
    fn drop(&mut self) {
        self.ask.abort();
    }
}

impl MapTopic {
    /// Starts publishing the grid of the map component `map` (in this process) on `node`.
    pub async fn start(node: &Ros2Node, registry: &Registry, map: &str) -> anyhow::Result<Self> {
        let publisher: Arc<Ros2Publisher<m::OccupancyGrid>> =
            Arc::new(node.publisher("map", Qos::Map).await?);
        let published = Arc::new(Mutex::new(0));
        let publish = {
            let (publisher, published) = (Arc::clone(&publisher), Arc::clone(&published));
            move |grid: &OccupancyGrid| {
                // Only a newer grid: the push and the answer may bring the same one. Published
                // under the lock, so that an older grid never goes out after a newer one (the
                // topic keeps only the last).
                let mut last = published.lock();
                if *last < grid.version {
                    publisher.publish(&ros_grid(grid), grid.stamp.0);
                    *last = grid.version;
                }
            }
        };
        let on_push = publish.clone();
        let pushes = PushNewestClient::connect_to(
            registry,
            imap::MAP.on(map),
            Sink::from_fn(move |u: Update<OccupancyGrid>| {
                on_push(&u.value);
                Ok(())
            }),
        )?;
        pushes.subscribe()?;
        let known = QueryClient::<Empty, KnownMap>::connect(registry, imap::KNOWN.on(map))?;
        let who = map.to_string();
        let ask = tokio::spawn(async move {
            match known.query(Empty {}, Some(ASK_TIMEOUT)).await {
                Ok(k) => publish(&k.grid),
                Err(e) => tracing::warn!("ROS 2 /map: the map component '{who}' did not give its map: {e}"),
            }
        });
        Ok(MapTopic { _pushes: pushes, ask, published })
    }

    /// The version of the grid last published (0: none yet).
    pub fn published(&self) -> u64 {
        *self.published.lock()
    }
}

/// orsa's grid as ROS's: the same cells in the same order (row by row from the origin, -1
/// unknown, 0-100), the origin as a pose in `map`.
pub fn ros_grid(grid: &OccupancyGrid) -> m::OccupancyGrid {
    let stamp = m::Time::from_nanos(grid.stamp.0);
    let origin = Pose {
        position: m::Point { x: grid.origin_x_m, y: grid.origin_y_m, z: 0.0 },
        orientation: m::Quaternion::from_yaw(0.0),
    };
    m::OccupancyGrid {
        header: Header { stamp, frame_id: MAP_FRAME.into() },
        info: MapMetaData {
            map_load_time: stamp,
            resolution: grid.resolution_m as f32,
            width: grid.width,
            height: grid.height,
            origin,
        },
        data: grid.cells.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_keeps_its_cells_order_and_placement() {
        let mut g = OccupancyGrid::filled(0.05, 3, 2, (-1.0, 2.5), imap::FREE);
        g.cells[1] = imap::OCCUPIED;
        g.cells[5] = imap::UNKNOWN;
        g.stamp = orsa_actors::Timestamp(1_700_000_000_250_000_000);
        let r = ros_grid(&g);
        assert_eq!(r.data, vec![0, 100, 0, 0, 0, -1]);
        assert_eq!((r.info.width, r.info.height, r.info.resolution), (3, 2, 0.05));
        assert_eq!((r.info.origin.position.x, r.info.origin.position.y), (-1.0, 2.5));
        assert_eq!(r.info.origin.orientation.w, 1.0);
        assert_eq!(r.header.frame_id, "map");
        assert_eq!((r.header.stamp.sec, r.header.stamp.nanosec), (1_700_000_000, 250_000_000));
    }
}
