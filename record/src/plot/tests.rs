//! Figures of a synthetic patrol along the reference corridor.

use super::*;
use resvg::usvg;

/// A patrol along World::palazzina(): east and west at 0.3 m/s, centre following for a minute,
/// wall following (the right-hand wall) for half a minute, a second unwired between them, and a
/// bump every twenty minutes.
fn synthetic_run(world: &World, duration_s: f64, hz: f64) -> PlotData<'_> {
    let n = (duration_s * hz) as usize;
    let dt = 1.0 / hz;
    let (mut x, mut y, mut heading) = (2.0f64, 1.2f64, 1.0f64);
    let mut data = PlotData {
        title: "Palazzina 1 corridor · seed 7 · synthetic".into(),
        world,
        trajectory: Vec::with_capacity(n),
        offset: Vec::new(),
        clearance: Vec::new(),
        bumps: Vec::new(),
        targets: Targets::default(),
        kinds: Default::default(),
        navigation: None,
    };
    for i in 0..n {
        let t = i as f64 * dt;
        let phase = t % 91.0;
        let behaviour = match phase {
            p if p < 60.0 => Some("centerfollow"),
            p if p < 61.0 => None,
            _ => Some("wallfollow"),
        };
        let wiggle = 0.04 * (t / 6.0).sin() + 0.015 * (t * 1.7).sin();
        let target_y = match behaviour {
            Some("centerfollow") => 1.2 + wiggle,
            Some(_) if heading > 0.0 => 0.45 + wiggle * 0.5,
            Some(_) => 2.4 - 0.45 + wiggle * 0.5,
            None => y,
        };
        y += (target_y - y) * 0.04;
        x += heading * 0.3 * dt;
        if !(2.0..=38.0).contains(&x) {
            heading = -heading;
        }
        data.trajectory.push(TrajectorySample {
            t_s: t,
            x_m: x,
            y_m: y,
            behaviour: behaviour.map(str::to_owned),
        });
        match behaviour {
            Some("centerfollow") => data.offset.push((t, y - 1.2)),
            Some(_) => data.clearance.push((t, if heading > 0.0 { y - 0.25 } else { 2.4 - 0.25 - y })),
            None => {}
        }
        if i % (1200.0 * hz) as usize == (300.0 * hz) as usize {
            data.bumps.push(Bump { t_s: t, x_m: x, y_m: y });
        }
    }
    data
}

fn temp_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("orsa-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

fn palazzina() -> World {
    World::palazzina().expect("the reference world loads")
}

#[test]
fn the_svg_parses_and_shows_trajectory_legend_and_targets() {
    let world = palazzina();
    let data = synthetic_run(&world, 600.0, 10.0);
    let svg = render_svg(&data);
    let tree = usvg::Tree::from_str(&svg, &usvg::Options::default()).expect("well-formed SVG");
    assert_eq!(tree.size().width(), WIDTH_PX as f32);
    assert!(svg.contains(r#"class="trajectory""#));
    assert!(svg.contains(r#"class="bumps""#));
    assert_eq!(svg.matches(r#"class="target""#).count(), 2);
    for label in ["centerfollow", "wallfollow", ">none<", ">bump<", "x (m)", "time (min)", "target 0.20 m"] {
        assert!(svg.contains(label), "no {label:?} in the figure");
    }
    assert!(svg.contains("Palazzina 1 corridor · seed 7"), "the title");
    assert!(svg.contains("centerfollow 69%, wallfollow 30%, none 1%"), "the headline's time shares");
}

#[test]
fn the_map_has_equal_scale_and_spans_the_width() {
    let world = palazzina();
    let data = synthetic_run(&world, 60.0, 10.0);
    let tree = usvg::Tree::from_str(&render_svg(&data), &usvg::Options::default()).expect("SVG");
    let map = tree.node_by_id("map").expect("the map group");
    let t = map.abs_transform();
    assert!(t.sx > 0.0, "{t:?}");
    assert_eq!(t.sy, -t.sx, "equal scale, y up: {t:?}");
    assert_eq!((t.kx, t.ky), (0.0, 0.0));
    // The 40 m corridor (with 0.3 m margins) fills the plot width.
    let corridor_px = 40.6 * t.sx;
    assert!((corridor_px - (WIDTH_PX as f32 - 180.0)).abs() < 1.0, "{corridor_px}");
}

#[test]
fn an_hour_at_10_hz_stays_small() {
    let world = palazzina();
    let data = synthetic_run(&world, 3600.0, 10.0);
    assert_eq!(data.trajectory.len(), 36_000);
    let svg = render_svg(&data);
    assert!(svg.len() < 2_000_000, "{} bytes", svg.len());
    // Per-pixel reduction: at most 4 points per column in each time series.
    let series_points: usize = svg
        .lines()
        .filter(|l| l.contains(r#"class="series""#))
        .map(|l| l.matches('L').count() + l.matches('M').count())
        .sum();
    assert!(series_points <= 2 * 4 * 1820, "{series_points}");
    usvg::Tree::from_str(&svg, &usvg::Options::default()).expect("well-formed SVG");
}

#[test]
fn a_png_has_the_figure_size() {
    let world = palazzina();
    let data = synthetic_run(&world, 300.0, 10.0);
    let path = temp_path("run.png");
    write_plot(&path, &data).expect("PNG written");
    let png = std::fs::read(&path).expect("read back");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    let width = u32::from_be_bytes([png[16], png[17], png[18], png[19]]);
    let height = u32::from_be_bytes([png[20], png[21], png[22], png[23]]);
    let svg_size = usvg::Tree::from_str(&render_svg(&data), &usvg::Options::default()).expect("SVG").size();
    assert_eq!(width, WIDTH_PX);
    assert_eq!(height, svg_size.height().ceil() as u32);
}

#[test]
fn an_svg_file_is_the_rendered_svg() {
    let world = palazzina();
    let data = synthetic_run(&world, 30.0, 10.0);
    let path = temp_path("run.SVG");
    write_plot(&path, &data).expect("SVG written");
    assert_eq!(std::fs::read_to_string(&path).expect("read back"), render_svg(&data));
}

#[test]
fn other_extensions_are_errors_naming_them() {
    let world = palazzina();
    let data = synthetic_run(&world, 10.0, 10.0);
    let path = temp_path("run.pdf");
    let error = write_plot(&path, &data).expect_err("pdf is not supported");
    let text = error.to_string();
    assert!(text.contains(&path.display().to_string()) && text.contains("\"pdf\""), "{text}");
    assert!(!path.exists());
    let error = write_plot(&temp_path("run"), &data).expect_err("no extension");
    assert!(error.to_string().contains("unknown extension \"\""), "{error}");
}

#[test]
fn an_unwritable_path_is_an_error_naming_it() {
    let world = palazzina();
    let data = synthetic_run(&world, 10.0, 10.0);
    let path = temp_path("missing").join("dir").join("run.svg");
    let error = write_plot(&path, &data).expect_err("no such directory");
    assert!(error.to_string().contains(&path.display().to_string()), "{error}");
}

#[test]
fn an_empty_run_still_draws_the_world() {
    let world = palazzina();
    let data = PlotData {
        title: String::new(),
        world: &world,
        trajectory: Vec::new(),
        offset: Vec::new(),
        clearance: Vec::new(),
        bumps: Vec::new(),
        targets: Targets::default(),
        kinds: Default::default(),
        navigation: None,
    };
    let svg = render_svg(&data);
    usvg::Tree::from_str(&svg, &usvg::Options::default()).expect("SVG");
    assert!(svg.contains("centre following never drove"));
    assert!(svg.contains(">Palazzina 1 corridor</text>"), "an empty title falls back to the world's name");
    render_png(&data, Path::new("empty.png")).expect("PNG");
}

/// Writes /tmp/plot_check.png and .svg from an hour's synthetic patrol, to look at.
#[test]
#[ignore = "writes to /tmp for a person to look at"]
fn write_plot_check() {
    let world = palazzina();
    let data = synthetic_run(&world, 3600.0, 10.0);
    write_plot(Path::new("/tmp/plot_check.png"), &data).expect("PNG");
    write_plot(Path::new("/tmp/plot_check.svg"), &data).expect("SVG");
}

/// Colours follow the behaviour's kind: a `wallfollow` named `hug` is drawn in wall
/// following's orange; without its kind it would be a behaviour of another kind, in the
/// palette's first colour.
#[test]
fn a_behaviour_named_otherwise_keeps_the_colour_of_its_kind() {
    let world = palazzina();
    let mut data = synthetic_run(&world, 600.0, 10.0);
    for s in &mut data.trajectory {
        if s.behaviour.as_deref() == Some("wallfollow") {
            s.behaviour = Some("hug".into());
        }
    }
    let palette_first = "#2ca02c";
    let unknown = render_svg(&data);
    assert!(unknown.contains(palette_first), "hug, of no known kind, takes the palette's first colour");
    data.kinds = [("hug".to_string(), "wallfollow".to_string())].into();
    let known = render_svg(&data);
    assert!(known.contains(">hug<"), "the legend names it");
    assert!(!known.contains(palette_first), "hug, a wallfollow, is not a behaviour of another kind");
    assert!(
        known.matches("#ff7f0e").count() > unknown.matches("#ff7f0e").count(),
        "its path is drawn in wall following's colour"
    );
}

/// The office world shipped with the project, which has places.
fn office() -> World {
    World::from_path(Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/office.toml"))
        .expect("office loads")
}

/// A navigation run in the office: the robot drives from the dock to room-3's place in a
/// straight line, the estimate 5 cm beside it, a replan halfway, one goal reached and one missed.
fn navigation_run(world: &World) -> PlotData<'_> {
    let dock = world.place("dock").expect("dock");
    let room = world.place("room-3").expect("room-3");
    let mut data = PlotData {
        title: "office · seed 1 · tour".into(),
        world,
        trajectory: Vec::new(),
        offset: Vec::new(),
        clearance: Vec::new(),
        bumps: Vec::new(),
        targets: Targets::default(),
        kinds: Default::default(),
        navigation: Some(NavigationTrace { error_target_m: 0.10, ..Default::default() }),
    };
    let nav = data.navigation.as_mut().expect("set above");
    for i in 0..=200 {
        let f = i as f64 / 200.0;
        let (x, y, t) = (dock.x + f * (room.x - dock.x), dock.y + f * (room.y - dock.y), i as f64 * 0.1);
        data.trajectory.push(TrajectorySample {
            t_s: t,
            x_m: x,
            y_m: y,
            behaviour: Some("pathfollow".into()),
        });
        nav.estimate.push((t, x + 0.05, y));
        nav.error.push((t, 0.05));
    }
    let mid = ((dock.x + room.x) / 2.0, (dock.y + room.y) / 2.0);
    nav.paths.push(vec![[dock.x, dock.y], [room.x, room.y]]);
    nav.paths.push(vec![[mid.0, mid.1], [room.x, room.y]]);
    nav.goals.push(GoalMark { label: "room-3".into(), x_m: room.x, y_m: room.y, reached: true });
    nav.goals.push(GoalMark { label: "1,1".into(), x_m: 1.0, y_m: 1.0, reached: false });
    data
}

#[test]
fn a_navigation_run_draws_places_paths_estimate_goals_and_the_error_panel() {
    let world = office();
    let data = navigation_run(&world);
    let svg = render_svg(&data);
    usvg::Tree::from_str(&svg, &usvg::Options::default()).expect("well-formed SVG");
    for p in &world.places {
        assert!(svg.contains(&format!(">{}</text>", p.name)), "place {} not named", p.name);
    }
    assert_eq!(svg.matches(r#"class="place""#).count(), world.places.len());
    // Two planned paths, one path element with two pieces.
    let planned = svg.lines().find(|l| l.contains(r#"class="planned""#)).expect("planned paths drawn");
    assert_eq!(planned.matches('M').count(), 2, "{planned}");
    assert!(svg.contains(r#"class="estimate""#));
    assert_eq!(svg.matches(r#"class="goal""#).count(), 2);
    assert!(svg.contains(navigation::REACHED_COLOUR) && svg.contains(figure::BUMP_COLOUR));
    // Neither behaviour of the corridor drove: their panels give way to the localization
    // error's, with its target.
    assert_eq!(svg.matches(r#"class="target""#).count(), 1);
    assert!(!svg.contains("never drove"), "no empty behaviour panels");
    assert!(svg.contains("target 0.10 m") || svg.contains("target 0.1 m"), "the error target");
    assert!(svg.contains("distance from the true pose"), "the error panel's caption");
    assert!(svg.contains("1 of 2 goals reached"), "the headline counts goals");
    assert!(svg.contains("localization RMS 0.050 m"), "the headline's RMS");
    for label in ["path planned", "estimated pose", "goal reached", "goal missed"] {
        assert!(svg.contains(&format!(">{label}<")), "no legend entry {label:?}");
    }
    // Where centre following drove too, its panel is there as well.
    let mut with_offset = data.clone();
    with_offset.offset.push((1.0, 0.02));
    assert_eq!(render_svg(&with_offset).matches(r#"class="target""#).count(), 2);
    // A figure without navigation has none of it, and both behaviour panels, if empty.
    let plain = PlotData { navigation: None, ..data.clone() };
    let plain_svg = render_svg(&plain);
    assert!(!plain_svg.contains(r#"class="planned""#) && !plain_svg.contains(r#"class="goal""#));
    assert_eq!(plain_svg.matches(r#"class="target""#).count(), 2);
    assert!(plain_svg.contains("centre following never drove"));
}

/// Writes /tmp/plot_nav.png from the synthetic navigation run, to look at.
#[test]
#[ignore = "writes to /tmp for a person to look at"]
fn write_navigation_plot_check() {
    let world = office();
    write_plot(Path::new("/tmp/plot_nav.png"), &navigation_run(&world)).expect("PNG");
}
