//! An occupancy grid as Foxglove's `foxglove.Grid`, drawn as a map is: occupied cells dark,
//! free cells light, unknown ones not at all.

use super::shapes;
use foxglove::schemas::packed_element_field::NumericType;
use foxglove::schemas::{Grid, PackedElementField, Vector2};
use orsa_actors::Timestamp;
use orsa_interfaces::map::{OccupancyGrid, UNKNOWN};

/// Bytes per cell: the occupancy (`INT8`, as the grid holds it: -1 unknown, 0-100), then the
/// colour (`red`, `green`, `blue`, `alpha`, `UINT8`), which Foxglove's 3D panel uses as it is.
pub const CELL_STRIDE: u32 = 5;

/// The colour of a cell: unknown is transparent, free a pale grey, occupied near black (the
/// occupancy in between shades between them).
fn colour(occupancy: i8) -> [u8; 4] {
    if occupancy == UNKNOWN {
        return [0, 0, 0, 0];
    }
    let p = f64::from(occupancy.clamp(0, 100)) / 100.0;
    let shade = (235.0 - p * 205.0).round() as u8;
    [shade, shade, shade, (110.0 + p * 145.0).round() as u8]
}

/// `grid` as a `foxglove.Grid` in `frame` at `at`: one row per row of the grid, from its origin.
pub fn grid_view(grid: &OccupancyGrid, frame: &str, at: Timestamp) -> Grid {
    let field = |name: &str, offset: u32, ty: NumericType| PackedElementField {
        name: name.to_owned(),
        offset,
        r#type: ty as i32,
    };
    let mut data = Vec::with_capacity(grid.cells.len() * CELL_STRIDE as usize);
    for &c in &grid.cells {
        data.push(c as u8);
        data.extend(colour(c));
    }
    Grid {
        timestamp: Some(shapes::stamp(at)),
        frame_id: frame.to_owned(),
        // Just under the floor, so that the world's shapes and the robot draw over it.
        pose: Some(shapes::pose(grid.origin_x_m, grid.origin_y_m, -0.01, 0.0)),
        column_count: grid.width,
        cell_size: Some(Vector2 { x: grid.resolution_m, y: grid.resolution_m }),
        row_stride: grid.width * CELL_STRIDE,
        cell_stride: CELL_STRIDE,
        fields: vec![
            field("occupancy", 0, NumericType::Int8),
            field("red", 1, NumericType::Uint8),
            field("green", 2, NumericType::Uint8),
            field("blue", 3, NumericType::Uint8),
            field("alpha", 4, NumericType::Uint8),
        ],
        data: data.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::map::{FREE, OCCUPIED};

    #[test]
    fn cells_keep_their_place_value_and_a_colour_a_map_has() {
        let mut g = OccupancyGrid::filled(0.05, 3, 2, (1.0, -2.0), FREE);
        let i = g.index(2, 1);
        g.cells[i] = OCCUPIED;
        g.cells[0] = UNKNOWN;
        let v = grid_view(&g, "world", Timestamp(2_000_000_000));
        assert_eq!((v.column_count, v.row_stride, v.cell_stride), (3, 15, 5));
        assert_eq!(v.data.len(), 30);
        let cell = |ix: usize, iy: usize| &v.data[iy * 15 + ix * 5..iy * 15 + ix * 5 + 5];
        assert_eq!(cell(0, 0), [0xff, 0, 0, 0, 0], "unknown: -1, transparent");
        assert_eq!(cell(2, 1)[0], 100);
        assert_eq!(cell(1, 0)[0], 0);
        assert!(cell(2, 1)[1] < 40 && cell(1, 0)[1] > 200, "occupied dark, free light");
        assert!(cell(2, 1)[4] == 255 && cell(1, 0)[4] > 0);
        let p = v.pose.expect("pose").position.expect("position");
        assert_eq!((p.x, p.y), (1.0, -2.0));
        assert_eq!(v.cell_size.map(|c| (c.x, c.y)), Some((0.05, 0.05)));
        let names: Vec<&str> = v.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["occupancy", "red", "green", "blue", "alpha"]);
    }
}
