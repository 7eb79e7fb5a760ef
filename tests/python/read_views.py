"""Reads the views of an orsa recording (the channels in Foxglove's well-known schemas) with
the `mcap` package and its protobuf support alone, as Foxglove would, and checks them against
the recording's own JSON channels and its `run` metadata.

Checks, each failing with a message that names what is wrong:
- every protobuf channel decodes with the schema it carries;
- `/world`'s walls are the world file's walls (same points, a loop where the wall is closed),
  its boxes and discs the world file's;
- `/infrared` and `/sonar` hold one scan per JSON scan, at the same log time, in `base_link`,
  with 16 ranges at the ring's angles (sensor i at i x 22.5 degrees), each the JSON reading
  plus the mount radius with intensity 1 (range 0, intensity 0 where the reading is not
  valid: never an infinite range, which Foxglove draws at infinity), at the push periods
  (40 ms and 64 ms);
- `/tf` chains `world` -> `odom` -> `base_link`: `odom` at the world's start pose, `base_link`
  at the JSON `basestate`'s odometry; `/truth/tf` places `base_link_truth`; the odometry's
  error against the truth starts near zero and grows (drift);
- `/trajectory` grows and ends where the truth is;
- `/driving` says, in order, the behaviour each JSON `driving` message names, and `/robot`'s
  metadata follows it;
- `/people` has one entity per person of the world file.

Prints, as JSON, what it found (counts, periods, drift, the behaviours seen driving).
"""

import bisect
import json
import math
import statistics
import sys
import tomllib

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

RING = 16
STEP = math.radians(22.5)


def fail(path, what):
    sys.exit(f"{path}: {what}")


def yaw_of(q):
    return 2.0 * math.atan2(q.z, q.w)


def compose(a, b):
    """The pose (x, y, yaw) b given in the frame of pose a."""
    (ax, ay, at), (bx, by, bt) = a, b
    return (ax + bx * math.cos(at) - by * math.sin(at), ay + bx * math.sin(at) + by * math.cos(at), at + bt)


def planar(t):
    return (t.translation.x, t.translation.y, yaw_of(t.rotation))


def periods_ms(times):
    return [(b - a) / 1e6 for a, b in zip(times, times[1:])]



def check_map(path, world, maps):
    """`/map` is written once, as a grid of int8 occupancy plus RGBA per cell laid out as its
    fields say; every point on a wall, inside a box or a disc of the world file is in an
    occupied cell, the robot's start in a free one, and unknown cells are not drawn."""
    if len(maps) != 1:
        fail(path, f"/map has {len(maps)} messages, expected 1")
    g = maps[0][1]
    fields = {f.name: (f.offset, f.type) for f in g.fields}
    # NumericType: UINT8 = 1, INT8 = 2.
    want = {"occupancy": (0, 2), "red": (1, 1), "green": (2, 1), "blue": (3, 1), "alpha": (4, 1)}
    if fields != want:
        fail(path, f"/map fields {fields}, expected {want}")
    cols, stride, row = g.column_count, g.cell_stride, g.row_stride
    if stride != 5 or row != cols * stride or len(g.data) % row != 0:
        fail(path, f"/map: {cols} columns, cell stride {stride}, row stride {row}, {len(g.data)} bytes")
    rows = len(g.data) // row
    res = g.cell_size.x
    if not (g.cell_size.y == res and 0 < res <= 0.05):
        fail(path, f"/map cells {g.cell_size.x} x {g.cell_size.y} m: a map's cells are square, 5 cm or finer")
    ox, oy = g.pose.position.x, g.pose.position.y
    if g.pose.orientation.z != 0 or g.frame_id != "world":
        fail(path, f"/map is rotated or not in the world frame: {g.pose}, {g.frame_id!r}")

    def cell(x, y):
        ix, iy = math.floor((x - ox) / res), math.floor((y - oy) / res)
        if not (0 <= ix < cols and 0 <= iy < rows):
            fail(path, f"/map does not cover ({x}, {y})")
        i = iy * row + ix * stride
        return int.from_bytes(g.data[i:i + 1], "little", signed=True), g.data[i + 4]

    def occupied(x, y, what):
        value, alpha = cell(x, y)
        if value != 100 or alpha == 0:
            fail(path, f"/map: {what} at ({x:.3f}, {y:.3f}) is in a cell holding {value} (alpha {alpha}), not occupied")

    for i, wall in enumerate(world.get("walls", [])):
        pts = wall["points"] + (wall["points"][:1] if wall.get("closed", False) else [])
        for (ax, ay), (bx, by) in zip(pts, pts[1:]):
            n = max(1, math.ceil(math.hypot(bx - ax, by - ay) / 0.02))
            for k in range(n + 1):
                occupied(ax + (bx - ax) * k / n, ay + (by - ay) * k / n, f"walls[{i}]")
    for i, b in enumerate(world.get("boxes", [])):
        occupied((b["min"][0] + b["max"][0]) / 2, (b["min"][1] + b["max"][1]) / 2, f"the centre of boxes[{i}]")
    for i, d in enumerate(world.get("discs", [])):
        occupied(d["center"][0], d["center"][1], f"the centre of discs[{i}]")
    r = world["robot"]
    value, alpha = cell(r["x"], r["y"])
    if value != 0 or alpha == 0:
        fail(path, f"/map: the robot's start is in a cell holding {value} (alpha {alpha}), not free")
    counts = {"unknown": 0, "free": 0, "occupied": 0}
    for i in range(0, len(g.data), stride):
        value, alpha = int.from_bytes(g.data[i:i + 1], "little", signed=True), g.data[i + 4]
        kind = "unknown" if value == -1 else "occupied" if value == 100 else "free" if value == 0 else None
        if kind is None or (alpha == 0) != (kind == "unknown"):
            fail(path, f"/map byte {i}: occupancy {value} with alpha {alpha}")
        counts[kind] += 1
    return counts


def robot_name(config):
    """The robot server's name: the first component of kind robot or nomad200 in [system]."""
    for c in config.get("system", {}).get("components", []):
        if c.get("kind", c["name"]) in ("robot", "nomad200"):
            return c["name"]
    return "nomad200"

def main(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        meta = next(m for m in reader.iter_metadata() if m.name == "run").metadata
        world = tomllib.loads(meta["world_toml"])
        config = tomllib.loads(meta["config_toml"])
        robot = robot_name(config)
        protobuf = DecoderFactory()
        views, json_msgs = {}, {}
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            if channel.message_encoding == "protobuf":
                decode = protobuf.decoder_for(channel.message_encoding, schema)
                if decode is None:
                    fail(path, f"channel {channel.topic} is protobuf without a protobuf schema")
                decoded = decode(message.data)
                views.setdefault(channel.topic, []).append((message.log_time, schema.name, decoded))
            else:
                json_msgs.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))

    def only(topic, schema_name):
        got = views.get(topic)
        if not got:
            fail(path, f"no messages on {topic}")
        names = {s for _, s, _ in got}
        if names != {schema_name}:
            fail(path, f"{topic} has schemas {names}, expected {schema_name}")
        return [(t, m) for t, _, m in got]

    # The world.
    scene = only("/world", "foxglove.SceneUpdate")
    if len(scene) != 1:
        fail(path, f"/world has {len(scene)} messages, expected 1")
    entities = {e.id: e for e in scene[0][1].entities}
    walls = world.get("walls", [])
    lines = entities["walls"].lines
    if len(lines) != len(walls):
        fail(path, f"/world draws {len(lines)} walls, the world file has {len(walls)}")
    for i, (line, wall) in enumerate(zip(lines, walls)):
        points = [[p.x, p.y] for p in line.points]
        if points != wall["points"]:
            fail(path, f"/world wall {i} runs through {points}, the world file's through {wall['points']}")
        loop = line.type == 1  # LINE_LOOP
        if loop != wall.get("closed", False):
            fail(path, f"/world wall {i}: loop {loop}, closed {wall.get('closed', False)} in the world file")
    boxes = [[[c.pose.position.x, c.pose.position.y], [c.size.x, c.size.y]] for c in entities["boxes"].cubes]
    want = [[[(b["min"][0] + b["max"][0]) / 2, (b["min"][1] + b["max"][1]) / 2],
             [b["max"][0] - b["min"][0], b["max"][1] - b["min"][1]]] for b in world.get("boxes", [])]
    if not all(math.isclose(a, b, abs_tol=1e-9) for g, w in zip(boxes, want) for p, q in zip(g, w) for a, b in zip(p, q)) \
            or len(boxes) != len(want):
        fail(path, f"/world boxes {boxes}, the world file's {want}")
    discs = [[c.pose.position.x, c.pose.position.y, c.size.x / 2] for c in entities["discs"].cylinders]
    want = [[d["center"][0], d["center"][1], d["radius"]] for d in world.get("discs", [])]
    if discs != want:
        fail(path, f"/world discs {discs}, the world file's {want}")

    # The map: the world file's walls, boxes and discs as an occupancy grid.
    map_cells = check_map(path, world, only("/map", "foxglove.Grid"))

    # The scans, against the JSON scans.
    mount = config["sim"]["body"]["radius_m"]
    periods = {}
    for topic, service, expected_ms in [("/infrared", "distanceir", 40.0), ("/sonar", "distanceson", 64.0)]:
        scans = only(topic, "foxglove.LaserScan")
        source = json_msgs.get(f"{robot}/{service}", [])
        if [t for t, _ in scans] != [t for t, _ in source]:
            fail(path, f"{topic}: {len(scans)} scans, {len(source)} JSON scans on {robot}/{service}, or at other times")
        for (t, scan), (_, js) in zip(scans, source):
            if scan.frame_id != "base_link" or len(scan.ranges) != RING:
                fail(path, f"{topic} at {t}: frame {scan.frame_id!r}, {len(scan.ranges)} ranges")
            step = (scan.end_angle - scan.start_angle) / (RING - 1)
            if abs(scan.start_angle) > 1e-12 or abs(step - STEP) > 1e-12:
                fail(path, f"{topic} at {t}: angles from {scan.start_angle} by {step}, not 0 by 22.5 degrees")
            if not all(math.isfinite(r) for r in scan.ranges) or len(scan.intensities) != RING:
                fail(path, f"{topic} at {t}: ranges {list(scan.ranges)}, {len(scan.intensities)} intensities")
            for r in js["value"]["readings"]:
                i = r["sensor_id"]
                got = (scan.ranges[i], scan.intensities[i])
                # No return: range 0 (the scan's origin, inside the robot) and intensity 0.
                want = (mount + r["distance_m"], 1.0) if r["valid"] else (0.0, 0.0)
                if got[1] != want[1] or not (got[0] == want[0] or math.isclose(got[0], want[0], abs_tol=1e-12)):
                    fail(path, f"{topic} at {t}: sensor {i} range and intensity {got}, JSON says {want}")
        median = statistics.median(periods_ms([t for t, _ in scans]))
        if abs(median - expected_ms) > 1e-6:
            fail(path, f"{topic}: scans every {median} ms, not {expected_ms}")
        periods[topic] = median

    # The frames: odometry from the JSON basestate, truth from /truth/tf.
    start = world["robot"]
    start_pose = (start["x"], start["y"], math.radians(start["heading_deg"]))
    base = json_msgs.get(f"{robot}/basestate", [])
    tf = only("/tf", "foxglove.FrameTransforms")
    if [t for t, _ in tf] != [t for t, _ in base]:
        fail(path, f"/tf: {len(tf)} messages, {len(base)} JSON basestates, or at other times")
    odometry = []
    for (t, m), (_, b) in zip(tf, base):
        chain = {(x.parent_frame_id, x.child_frame_id): x for x in m.transforms}
        if set(chain) != {("world", "odom"), ("odom", "base_link")}:
            fail(path, f"/tf at {t} holds {sorted(chain)}")
        odom = planar(chain[("world", "odom")])
        if any(abs(a - b) > 1e-9 for a, b in zip(odom, start_pose)):
            fail(path, f"/tf at {t}: odom at {odom}, the world's start pose is {start_pose}")
        v = b["value"]
        link = planar(chain[("odom", "base_link")])
        if any(abs(a - b) > 1e-9 for a, b in zip(link, (v["x_m"], v["y_m"], v["heading_rad"]))):
            fail(path, f"/tf at {t}: base_link at {link}, the basestate says {v}")
        odometry.append((t, compose(odom, link)))
    truth = []
    for t, m in only("/truth/tf", "foxglove.FrameTransforms"):
        [x] = m.transforms
        if (x.parent_frame_id, x.child_frame_id) != ("world", "base_link_truth"):
            fail(path, f"/truth/tf at {t} places {x.child_frame_id} in {x.parent_frame_id}")
        truth.append((t, planar(x)))
    truth_at = dict(truth)
    # The truth is sampled every 100 ms, not at the odometry's instants: it is interpolated.
    errors = []
    times = [t for t, _ in truth]
    for t, p in odometry:
        i = bisect.bisect_right(times, t)
        if 0 < i < len(times):
            (t0, a), (t1, b) = truth[i - 1], truth[i]
            k = (t - t0) / (t1 - t0)
            errors.append(math.dist(p[:2], (a[0] + k * (b[0] - a[0]), a[1] + k * (b[1] - a[1]))))
    if len(errors) < 10:
        fail(path, f"only {len(errors)} odometry poses fall within the truth's samples")
    first, last = errors[0], max(errors[-10:])
    if not (first < 0.01 and last > 2 * first and last > 0.001):
        fail(path, f"odometry error against the truth goes from {first} m to {last} m: no drift seen")

    # The trajectory.
    trajectory = only("/trajectory", "foxglove.PosesInFrame")
    sizes = [len(m.poses) for _, m in trajectory]
    if sizes[-1] <= sizes[0] or any(b < a for a, b in zip(sizes, sizes[1:])):
        fail(path, f"/trajectory does not grow: {sizes[:5]} ... {sizes[-5:]}")
    t, last_path = trajectory[-1]
    end = last_path.poses[-1].position
    if last_path.frame_id != "world" or math.dist((end.x, end.y), truth_at[t][:2]) > 1e-9:
        fail(path, f"/trajectory ends at {(end.x, end.y)} in {last_path.frame_id}, the truth is at {truth_at[t]}")

    # Which behaviour drives.
    said = [m.message.split(" drives")[0] for _, m in only("/driving", "foxglove.Log")]
    said = [None if s == "no behaviour" else s for s in said]
    driving = [d["value"]["driving"] for _, d in json_msgs.get("master/driving", [])]
    if said != driving:
        fail(path, f"/driving says {said}, master/driving says {driving}")
    robot_said = [next(kv.value for kv in e.metadata if kv.key == "driving") or None
                  for _, m in only("/robot", "foxglove.SceneUpdate") for e in m.entities if e.id == "robot"]
    if robot_said[1:] != driving:
        fail(path, f"/robot shows {robot_said}, master/driving says {driving}")

    # The people.
    people = only("/people", "foxglove.SceneUpdate")
    movers = len(world.get("movers", []))
    counts = {len(m.entities) for _, m in people}
    if counts != {movers}:
        fail(path, f"/people has {counts} entities per message, the world file {movers} people")

    # The localizer's estimate and the path followed, where the system navigates: each JSON
    # pose a frame world -> base_link_estimate at its instant, each path given a PosesInFrame
    # through its points; the estimate compared with the truth.
    estimate = {}
    poses = sorted(((t, m) for topic, msgs in json_msgs.items() if topic == "localizer/pose" for t, m in msgs),
                   key=lambda p: p[0])
    if poses:
        frames = only("/estimate/tf", "foxglove.FrameTransforms")
        if [t for t, _ in frames] != [t for t, _ in poses]:
            fail(path, f"/estimate/tf: {len(frames)} messages, {len(poses)} JSON poses, or at other times")
        sq = []
        for (t, m), (_, j) in zip(frames, poses):
            [x] = m.transforms
            v = j["value"]
            got = planar(x)
            if (x.parent_frame_id, x.child_frame_id) != ("world", "base_link_estimate") or \
                    any(abs(a - b) > 1e-9 for a, b in zip(got, (v["x_m"], v["y_m"], v["heading_rad"]))):
                fail(path, f"/estimate/tf at {t}: {x.parent_frame_id} -> {x.child_frame_id} at {got}, the pose says {v}")
            i = bisect.bisect_right(times, t)
            if 0 < i < len(times):
                (t0, a), (t1, b) = truth[i - 1], truth[i]
                k = (t - t0) / (t1 - t0)
                sq.append(math.dist(got[:2], (a[0] + k * (b[0] - a[0]), a[1] + k * (b[1] - a[1]))) ** 2)
        paths = sorted(((t, m) for topic, msgs in json_msgs.items() if topic == "pathfollow/path" for t, m in msgs),
                       key=lambda p: p[0])
        plans = only("/plan", "foxglove.PosesInFrame")
        if [t for t, _ in plans] != [t for t, _ in paths]:
            fail(path, f"/plan: {len(plans)} messages, {len(paths)} JSON paths, or at other times")
        for (t, m), (_, j) in zip(plans, paths):
            points = [(p.position.x, p.position.y) for p in m.poses]
            if m.frame_id != "world" or points != [tuple(q) for q in j["value"]["points"]]:
                fail(path, f"/plan at {t}: {len(points)} poses in {m.frame_id}, the path has {len(j['value']['points'])} points")
        if not sq or not plans:
            fail(path, f"{len(sq)} estimates within the truth's samples, {len(plans)} paths: nothing to compare")
        estimate = {"estimates": len(frames), "rms_m": math.sqrt(sum(sq) / len(sq)), "plans": len(plans),
                    "plan_poses": max(len(m.poses) for _, m in plans)}

    print(json.dumps({
        "estimate": estimate,
        "views": {topic: len(msgs) for topic, msgs in sorted(views.items())},
        "scan_period_ms": periods,
        "odometry_error_m": [first, last],
        "trajectory_poses": [sizes[0], sizes[-1]],
        "driving": said,
        "map_cells": map_cells,
    }))


if __name__ == "__main__":
    main(sys.argv[1])
