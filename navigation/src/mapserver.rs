//! The map component: serves the known map and the places it names, to whoever needs them,
//! in this process or another.
//!
//! It holds the map the world gives (walls, boxes and discs as an occupancy grid) and pushes it
//! on `map` when it starts, so that a subscriber (the live view, a recording) has it; a planner
//! that joins later, in this process or on another host, asks for it on `known`. A planner in
//! the executive's process so needs no world file of its own: the robot's process is the one
//! that knows the world.

use orsa_actors::push_newest::PushNewestServer;
use orsa_actors::query::QueryRequest;
use orsa_actors::{Component, ComponentError, Ctx, Empty};
use orsa_interfaces::map::{KNOWN, KnownMap, MAP, OccupancyGrid};
use std::sync::Arc;

/// The map component.
#[derive(Debug, Clone)]
pub struct MapServer {
    /// The known map and its places.
    pub map: Arc<KnownMap>,
}

/// Messages of [`MapServer`].
#[derive(Debug)]
pub enum MapMsg {
    /// Someone asks for the map as it stands.
    Known(QueryRequest<Empty, KnownMap>),
}

/// The running state of [`MapServer`].
pub struct MapState {
    /// Kept so that the service stays registered.
    _push: PushNewestServer<OccupancyGrid>,
    /// The map as served, stamped when the component started.
    map: KnownMap,
}

impl Component for MapServer {
    type Msg = MapMsg;
    type State = MapState;

    async fn setup(&self, ctx: &Ctx<MapMsg>) -> Result<MapState, ComponentError> {
        self.map.validate().map_err(|e| format!("{}: the map: {e}", ctx.name()))?;
        let mut map = (*self.map).clone();
        map.grid.stamp = ctx.now();
        map.grid.version = map.grid.version.max(1);
        let push = ctx.push_newest_server(MAP)?;
        push.put(map.grid.clone());
        ctx.query_server(KNOWN, MapMsg::Known)?;
        Ok(MapState { _push: push, map })
    }

    async fn handle(&self, _ctx: &Ctx<MapMsg>, st: &mut MapState, msg: MapMsg) -> Result<(), ComponentError> {
        match msg {
            MapMsg::Known(q) => {
                // A client that gave up waiting is no failure of the map's.
                let _ = q.answer(st.map.clone());
            }
        }
        Ok(())
    }
}
