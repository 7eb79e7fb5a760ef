//! Loading worlds: the shipped one, and one file per kind of mistake.

use super::*;

#[test]
fn palazzina_loads() {
    let w = World::palazzina().expect("the shipped world loads");
    assert_eq!(w.name, "Palazzina 1 corridor");
    assert_eq!(w.walls.len(), 1);
    assert!(w.walls[0].closed);
    assert_eq!(w.walls[0].segments().count(), w.walls[0].points.len(), "closed adds one");
    assert_eq!(w.boxes.len(), 1);
    assert_eq!(w.discs.len(), 2);
    assert_eq!(w.movers.len(), 3);
    assert_eq!(w.movers[0].yield_distance, 0.6, "default applied");
    assert_eq!(w.movers[2].yield_distance, 0.8);
    assert_eq!(w.movers[1].start_delay, 20.0);
    assert_eq!(w.movers[0].start_delay, 0.0, "default applied");
    let from_file =
        World::from_path(concat!(env!("CARGO_MANIFEST_DIR"), "/worlds/palazzina.toml")).expect("file loads");
    assert_eq!(from_file, w);
}

const HEAD: &str = "name = \"t\"\n[robot]\nx = 2.0\ny = 1.2\nheading_deg = 0.0\n";
const MOVER: &str = "[[movers]]\nradius = 0.25\nspeed = 0.7\npath = [[3.0, 0.6], [37.0, 0.6]]\n";

/// Loads `body` after the common head and returns the error message.
fn error_of(body: &str) -> String {
    let text = format!("{HEAD}{body}");
    match World::from_str(&text, "bad.toml") {
        Ok(w) => panic!("accepted a bad world: {w:?}"),
        Err(e) => e.to_string(),
    }
}

/// Asserts that `msg` starts with the file and place, and names `key` and `what`.
fn assert_names(msg: &str, place: &str, key: &str, what: &str) {
    assert!(msg.starts_with(&format!("bad.toml{place}: {key}: ")), "place/key in: {msg}");
    assert!(msg.contains(what), "'{what}' in: {msg}");
}

#[test]
fn unknown_keys_are_rejected() {
    let msg = error_of("[[movers]]\nradius = 0.25\nspede = 0.7\npath = [[3.0, 0.6], [37.0, 0.6]]\n");
    assert_names(&msg, ":8:1", "movers[0].spede", "unknown field `spede`");
    let msg = error_of("wals = []\n");
    assert_names(&msg, ":6:1", "robot.wals", "unknown field `wals`");
}

#[test]
fn missing_keys_are_rejected() {
    let msg = error_of(&format!("{MOVER}[[movers]]\nradius = 0.25\npath = [[3.0, 0.6], [5.0, 0.6]]\n"));
    assert_names(&msg, ":10:1", "movers[1].speed", "missing");
    let msg = World::from_str("name = \"t\"\n", "bad.toml").expect_err("no robot").to_string();
    assert_eq!(msg, "bad.toml: robot: missing (this key is required)");
}

#[test]
fn wrong_types_are_rejected() {
    let msg = error_of("[[discs]]\ncenter = [8.0, 1.0]\nradius = \"big\"\n");
    assert_names(&msg, ":8:10", "discs[0].radius", "invalid type: string \"big\"");
}

#[test]
fn pairs_must_have_exactly_two_numbers() {
    let msg = error_of("[[walls]]\npoints = [[0.0, 0.0], [1.0, 2.0, 3.0]]\n");
    assert_names(&msg, ":7:23", "walls[0].points[1]", "invalid length 3");
    let msg = error_of("[[boxes]]\nmin = [1.0]\nmax = [2.0, 2.0]\n");
    assert_names(&msg, ":7:7", "boxes[0].min", "invalid length 1");
}

#[test]
fn polylines_need_two_points() {
    let msg = error_of("[[walls]]\npoints = [[0.0, 0.0]]\n");
    assert_names(&msg, ":7:10", "walls[0].points", "at least 2 points, got 1");
    let msg = error_of("[[movers]]\nradius = 0.2\nspeed = 1.0\npath = [[5.0, 0.5]]\n");
    assert_names(&msg, ":9:8", "movers[0].path", "at least 2 points, got 1");
}

#[test]
fn boxes_need_min_below_max_on_both_axes() {
    let msg = error_of("[[boxes]]\nmin = [5.0, 1.0]\nmax = [4.5, 2.0]\n");
    assert_names(&msg, ":8:7", "boxes[0].max", "min < max on both axes");
    let msg = error_of("[[boxes]]\nmin = [5.0, 1.0]\nmax = [6.0, 1.0]\n");
    assert_names(&msg, ":8:7", "boxes[0].max", "min < max on both axes");
}

#[test]
fn sizes_and_speeds_must_be_in_range() {
    let msg = error_of("[[discs]]\ncenter = [8.0, 1.0]\nradius = 0.0\n");
    assert_names(&msg, ":8:10", "discs[0].radius", "must be > 0, got 0");
    let msg = error_of(&format!("{MOVER}{MOVER}").replacen("speed = 0.7", "speed = 0.5", 1).replacen(
        "speed = 0.7",
        "speed = -0.5",
        1,
    ));
    assert_names(&msg, ":12:9", "movers[1].speed", "must be >= 0, got -0.5");
    let msg = error_of(&format!("{MOVER}yield_distance = -1.0\n"));
    assert_names(&msg, ":10:18", "movers[0].yield_distance", "must be > 0, got -1");
    let msg = error_of(&format!("{MOVER}start_delay = -2\n"));
    assert_names(&msg, ":10:15", "movers[0].start_delay", "must be >= 0, got -2");
    let msg = error_of(&format!("{MOVER}patience = 0\n"));
    assert_names(&msg, ":10:12", "movers[0].patience", "must be > 0, got 0");
    let w = World::from_str(&format!("{HEAD}{MOVER}patience = 8.5\n"), "ok.toml").expect("a patience loads");
    assert_eq!(w.movers[0].patience, Some(8.5));
    let msg = error_of(&MOVER.replace("radius = 0.25", "radius = -0.25"));
    assert_names(&msg, ":7:10", "movers[0].radius", "must be > 0");
    // A mover that stands still is fine.
    let text = format!("{HEAD}{}", MOVER.replace("speed = 0.7", "speed = 0"));
    assert_eq!(World::from_str(&text, "ok.toml").expect("speed 0").movers[0].speed, 0.0);
}

#[test]
fn numbers_must_be_finite() {
    let msg = error_of("[[discs]]\ncenter = [8.0, 1.0]\nradius = nan\n");
    assert_names(&msg, ":8:10", "discs[0].radius", "finite number, got NaN");
    let msg = error_of("[[walls]]\npoints = [[0.0, 0.0], [inf, 0.0]]\n");
    assert_names(&msg, ":7:23", "walls[0].points[1]", "finite numbers, got [inf, 0]");
    let text = HEAD.replace("heading_deg = 0.0", "heading_deg = -inf");
    let msg = World::from_str(&text, "bad.toml").expect_err("inf heading").to_string();
    assert_names(&msg, ":5:15", "robot.heading_deg", "finite number, got -inf");
}

#[test]
fn the_robot_must_start_clear_of_everything() {
    let cases = [
        ("[[walls]]\npoints = [[0.0, 1.0], [4.0, 1.0]]\n", "walls[0] (segment 0"),
        ("[[boxes]]\nmin = [2.2, 0.0]\nmax = [3.0, 3.0]\n", "boxes[0]"),
        ("[[discs]]\ncenter = [2.0, 1.6]\nradius = 0.2\n", "discs[0]"),
        ("[[movers]]\nradius = 0.25\nspeed = 1\npath = [[2.4, 1.2], [9.0, 1.2]]\n", "movers[0]"),
    ];
    for (body, culprit) in cases {
        let msg = error_of(body);
        assert_names(&msg, ":2:1", "robot", "overlaps");
        assert!(msg.contains(culprit), "{culprit} in {msg}");
    }
    // Just clear (0.26 m from a wall) is fine.
    let ok = format!("{HEAD}[[walls]]\npoints = [[0.0, 0.94], [4.0, 0.94]]\n");
    assert!(World::from_str(&ok, "ok.toml").is_ok());
}

#[test]
fn syntax_errors_have_a_place() {
    let msg = error_of("[[walls]\n");
    assert!(msg.starts_with("bad.toml:6:9: not valid TOML: "), "{msg}");
}

#[test]
fn unreadable_files_name_the_path() {
    let msg = World::from_path("/no/such/dir/w.toml").expect_err("missing").to_string();
    assert!(msg.starts_with("cannot read world file /no/such/dir/w.toml: "), "{msg}");
}

#[test]
fn worlds_built_in_code_are_checked_too() {
    let mut w = World::palazzina().expect("loads");
    w.movers[2].path.truncate(1);
    let msg = w.check("test").expect_err("one-point path").to_string();
    assert_eq!(msg, "test: movers[2].path: a mover's path needs at least 2 points, got 1");
}

#[test]
fn places_load_with_their_optional_heading_and_are_found_by_name() {
    let text = format!(
        "{HEAD}[[places]]\nname = \"lab\"\nx = 6.0\ny = 1.2\nheading_deg = 180.0\n\
         [[places]]\nname = \"door_2-b\"\nx = 9.0\ny = 1.0\n"
    );
    let w = World::from_str(&text, "ok.toml").expect("places load");
    assert_eq!(w.places.len(), 2);
    let lab = w.place("lab").expect("lab");
    assert_eq!((lab.x, lab.y, lab.heading_deg), (6.0, 1.2, Some(180.0)));
    assert!((lab.heading_rad().expect("heading") - std::f64::consts::PI).abs() < 1e-12);
    assert_eq!(w.place("door_2-b").expect("door").heading_deg, None, "no heading: any");
    assert!(w.place("kitchen").is_none());
}

#[test]
fn places_need_a_good_unique_name_finite_numbers_and_room_for_the_body() {
    const PLACE: &str = "[[places]]\nname = \"lab\"\nx = 6.0\ny = 1.2\n";
    let msg = error_of(&PLACE.replace("name = \"lab\"", "name = \"\""));
    assert_names(&msg, ":7:8", "places[0].name", "must not be empty");
    let msg = error_of(&PLACE.replace("lab", "room 3"));
    assert_names(&msg, ":7:8", "places[0].name", "letters, digits, '-' and '_' only, got \"room 3\"");
    let msg = error_of(&format!("{PLACE}{}", PLACE.replace("x = 6.0", "x = 8.0")));
    assert_names(&msg, ":11:8", "places[1].name", "\"lab\" is taken by places[0]");
    let msg = error_of(&PLACE.replace("y = 1.2", "y = nan"));
    assert_names(&msg, ":9:5", "places[0].y", "finite number, got NaN");
    let msg = error_of(&format!("{PLACE}heading_deg = inf\n"));
    assert_names(&msg, ":10:15", "places[0].heading_deg", "finite number, got inf");
    let msg = error_of(&format!("{PLACE}floor = 2\n"));
    assert_names(&msg, ":10:1", "places[0].floor", "unknown field `floor`");
    let msg = error_of(&PLACE.replace("name = \"lab\"\n", ""));
    assert!(msg.contains("places[0].name") && msg.contains("missing"), "{msg}");
    // The body must fit: a disc 0.2 m from the place's centre is in the way, a mover is not.
    let msg = error_of(&format!("{PLACE}[[discs]]\ncenter = [6.3, 1.2]\nradius = 0.1\n"));
    assert_names(
        &msg,
        ":6:1",
        "places[0]",
        "does not fit at place \"lab\" (6, 1.2): it would overlap discs[0]",
    );
    let ok = format!("{HEAD}{PLACE}[[movers]]\nradius = 0.25\nspeed = 1\npath = [[6.0, 1.2], [9.0, 1.2]]\n");
    assert!(World::from_str(&ok, "ok.toml").is_ok(), "a mover may walk through a place");
}

#[test]
fn the_office_floor_loads_with_its_places() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../worlds/office.toml");
    let w = World::from_path(path).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = w.places.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["dock", "room-1", "room-2", "room-3", "room-4", "room-5"]);
    assert_eq!(w.place("dock").and_then(|p| p.heading_deg), Some(0.0));
}
