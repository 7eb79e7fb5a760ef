#!/usr/bin/env python3
"""A ROS 2 node as rmw_zenoh (ROS 2 Jazzy) makes one, written from rmw_zenoh's design document
(docs/design.md, branch jazzy) with eclipse-zenoh and rosbags only, none of orsa's code: the
message definitions, CDR codec and RIHS01 type hashes are rosbags' (its ROS 2 Jazzy typestore).

    ros2_node.py --connect tcp/127.0.0.1:7447 observe     # see and drive a ROS 2 robot
    ros2_node.py --connect tcp/127.0.0.1:7447 bad-input   # feed its /cmd_vel what it must refuse
    ros2_node.py --connect tcp/127.0.0.1:7447 robot       # be a ROS 2 robot in a corridor
    ros2_node.py --connect tcp/127.0.0.1:7447 at-wall     # drive a robot at a wall at top speed
    ros2_node.py --connect tcp/127.0.0.1:7447 params      # ros2 param list/get/set on its node
    ros2_node.py --connect tcp/127.0.0.1:7447 goal --x 12 --y 3 --yaw 1.57  # RViz's 2D Goal Pose

Each mode prints one line of JSON (its findings) and exits 0, or exits non-zero saying what did
not hold.

The layout it follows:
- data: `<domain>/<topic without the leading '/'>/<pkg>::msg::dds_::<Type>_/RIHS01_<hex>`;
- liveliness tokens: `@ros2_lv/<domain>/<zid>/<nid>/<eid>/<NN|MP|MS>/<enclave>/<namespace>/<node>`
  and, for topics, `/<topic>/<DDS type>/<hash>/<qos>`, a name's '/' written '%';
- a publication's attachment: int64 sequence number, int64 source timestamp (ns), then the
  16-byte gid after its length, little-endian; the gid is the XXH3 128-bit hash of the
  publisher's liveliness token, low 64 bits then high 64 bits (rmw_zenoh_cpp's
  `liveliness_utils.cpp`, `Entity`'s constructor);
- payloads: CDR with its 4-byte encapsulation header;
- services (rmw_service_data.cpp, rmw_client_data.cpp): a queryable on
  `<domain>/<service>/<pkg>::srv::dds_::<Type>_/<service RIHS01 hash>`, announced by a token of
  kind SS (clients: SC); a request is a query with the request in CDR and the client's attachment,
  the reply carries the response and the client's sequence number and gid.
"""

import argparse
import json
import math
import os
import struct
import sys
import threading
import time

import xxhash
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS2_JAZZY)
QOS_DEFAULT = "::,10:,:,:,,"
QOS_SENSOR = "2::,5:,:,:,,"


def fail(why):
    sys.exit(f"ros2_node: {why}")


def dds_name(ros_type):
    pkg, kind, name = ros_type.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def data_key(domain, topic, ros_type):
    return f"{domain}/{topic.lstrip('/')}/{dds_name(ros_type)}/{TS.hash_rihs01(ros_type)}"


def mangle(name):
    return name.replace("/", "%") if name else "%"


class Node:
    """A node: a zenoh session, its token, publishers with rmw_zenoh's attachment."""

    def __init__(self, connect, domain, name):
        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("connect/endpoints", json.dumps([connect]))
        conf.insert_json5("scouting/multicast/enabled", "false")
        # As rmw_zenoh's sessions: samples stamped (what a transient local publisher's cache needs).
        conf.insert_json5("timestamping/enabled", "{ router: true, peer: true, client: true }")
        self.session = zenoh.open(conf)
        self.zid = str(self.session.info.zid())
        self.domain = domain
        self.name = name
        self.entities = 0
        self.tokens = [self.token("NN")[1]]

    def token(self, kind, topic=None, ros_type=None, qos=QOS_DEFAULT):
        """Declares the next entity's token; its key and the token."""
        key = f"@ros2_lv/{self.domain}/{self.zid}/0/{self.entities}/{kind}/%/%/{self.name}"
        if topic is not None:
            key += f"/{mangle(topic)}/{dds_name(ros_type)}/{TS.hash_rihs01(ros_type)}/{qos}"
        self.entities += 1
        return key, self.session.liveliness().declare_token(key)

    def publisher(self, topic, ros_type, qos=QOS_DEFAULT):
        key, token = self.token("MP", topic, ros_type, qos)
        self.tokens.append(token)
        pub = self.session.declare_publisher(data_key(self.domain, topic, ros_type))
        gid = gid_of(key)
        seq = [0]

        def publish(msg=None, raw=None):
            seq[0] += 1
            attachment = struct.pack("<qqB", seq[0], time.time_ns(), 16) + gid
            payload = raw if raw is not None else bytes(TS.serialize_cdr(msg, ros_type))
            pub.put(payload, attachment=attachment)

        return publish

    def subscribe(self, topic, ros_type, on, qos=QOS_DEFAULT):
        self.tokens.append(self.token("MS", topic, ros_type, qos)[1])

        def cb(sample):
            a = sample.attachment.to_bytes() if sample.attachment is not None else None
            on(TS.deserialize_cdr(sample.payload.to_bytes(), ros_type), a)

        return self.session.declare_subscriber(data_key(self.domain, topic, ros_type), cb)

    def close(self):
        for t in self.tokens:
            t.undeclare()
        self.session.close()


def gid_of(token):
    """The gid rmw_zenoh derives from an entity's liveliness token."""
    h = xxhash.xxh3_128_intdigest(token.encode())
    return (h & (2**64 - 1)).to_bytes(8, "little") + (h >> 64).to_bytes(8, "little")


def twist(v, w):
    V3 = TS.types["geometry_msgs/msg/Vector3"]
    return TS.types["geometry_msgs/msg/Twist"](linear=V3(x=v, y=0.0, z=0.0), angular=V3(x=0.0, y=0.0, z=w))


def discover(node, want, within=30):
    """The publishers of `want` (topic -> type) that some node announces; fails after `within`."""
    found = {}
    lock = threading.Lock()

    def on_token(sample):
        parts = str(sample.key_expr).split("/")
        if len(parts) != 13 or parts[5] != "MP":
            return
        topic = "/" + parts[9].replace("%", "/").lstrip("/")
        with lock:
            found[topic] = {"zid": parts[2], "node": parts[8], "type": parts[10], "hash": parts[11], "qos": parts[12],
                            "token": str(sample.key_expr)}

    sub = node.session.liveliness().declare_subscriber(f"@ros2_lv/{node.domain}/**", on_token, history=True)
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        with lock:
            if all(t in found for t in want):
                break
        time.sleep(0.05)
    sub.undeclare()
    missing = [t for t in want if t not in found]
    if missing:
        fail(f"no publisher token for {missing} within {within} s (found {sorted(found)})")
    for topic, ros_type in want.items():
        f = found[topic]
        if f["type"] != dds_name(ros_type) or f["hash"] != TS.hash_rihs01(ros_type):
            fail(f"{topic} is announced as {f['type']} {f['hash']}, not {ros_type} {TS.hash_rihs01(ros_type)}")
    return found


def subscribed_types(node, topic, count, within=10):
    """The (DDS type, hash) of every subscription some node announces on `topic`, once there
    are `count` of them; fails after `within`."""
    found = set()
    lock = threading.Lock()

    def on_token(sample):
        parts = str(sample.key_expr).split("/")
        if len(parts) == 13 and parts[5] == "MS" and "/" + parts[9].replace("%", "/").lstrip("/") == topic:
            with lock:
                found.add((parts[10], parts[11]))

    sub = node.session.liveliness().declare_subscriber(f"@ros2_lv/{node.domain}/**", on_token, history=True)
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        with lock:
            if len(found) >= count:
                break
        time.sleep(0.05)
    sub.undeclare()
    return found


def observe(node, args):
    want = {
        "/scan": "sensor_msgs/msg/LaserScan",
        "/ir_scan": "sensor_msgs/msg/LaserScan",
        "/odom": "nav_msgs/msg/Odometry",
        "/tf": "tf2_msgs/msg/TFMessage",
        "/bumper": "std_msgs/msg/Bool",
    }
    found = discover(node, want)
    seen = {t: [] for t in want}
    lock = threading.Lock()

    def keep(topic):
        def on(msg, attachment):
            with lock:
                seen[topic].append((time.monotonic(), msg, attachment))
        return on

    subs = [node.subscribe(t, ty, keep(t)) for t, ty in want.items()]
    window = 3.0
    time.sleep(window)  # count what arrives in a window of known length
    with lock:
        counts = {t: len(v) for t, v in seen.items()}
        scans = [m for _, m, _ in seen["/scan"]]
        odoms = [m for _, m, _ in seen["/odom"]]
        tfs = [m for _, m, _ in seen["/tf"]]
        seqs = [struct.unpack("<q", a[:8])[0] for _, _, a in seen["/odom"] if a is not None and len(a) == 33]
    rates = {t: c / window for t, c in counts.items()}
    for topic, lo in [("/scan", 10.0), ("/ir_scan", 15.0), ("/odom", 7.0), ("/tf", 7.0), ("/bumper", 20.0)]:
        if rates[topic] < lo:
            fail(f"{topic} at {rates[topic]:.1f} Hz, expected at least {lo}")
    s = scans[-1]
    if len(s.ranges) != 16 or abs(s.angle_increment - math.pi / 8) > 1e-4 or s.header.frame_id != "base_link":
        fail(f"a /scan is not the 16-sensor ring: {len(s.ranges)} rays, step {s.angle_increment}, frame {s.header.frame_id}")
    if not any(math.isfinite(r) for r in s.ranges):
        fail("a /scan sees nothing at all in a corridor")
    o = odoms[-1]
    if o.header.frame_id != "odom" or o.child_frame_id != "base_link":
        fail(f"odometry frames {o.header.frame_id} -> {o.child_frame_id}")
    t = tfs[-1].transforms[0]
    if (t.header.frame_id, t.child_frame_id) != ("odom", "base_link"):
        fail(f"tf frames {t.header.frame_id} -> {t.child_frame_id}")
    if len(seqs) < 5 or any(b != a + 1 for a, b in zip(seqs, seqs[1:])):
        fail(f"odometry attachments' sequence numbers are not consecutive: {seqs[:20]}")
    # Every message's gid is its publisher's, derived from its token as rmw_zenoh does.
    with lock:
        for topic, got in seen.items():
            want_gid = gid_of(found[topic]["token"])
            bad = [a[17:].hex() for _, _, a in got if a is None or len(a) != 33 or a[16] != 16 or a[17:] != want_gid]
            if bad:
                fail(f"{topic}: {len(bad)} of {len(got)} attachments carry gid {bad[0]}, not {want_gid.hex()} "
                     f"(the XXH3-128 of {found[topic]['token']})")

    # Drive it through /cmd_vel: forward at 0.2 m/s for 2 s, then nothing.
    cmd = node.publisher("/cmd_vel", "geometry_msgs/msg/Twist")
    x0 = o.pose.pose.position.x
    y0 = o.pose.pose.position.y
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        cmd(twist(0.2, 0.0))
        time.sleep(0.05)
    stopped_publishing = time.monotonic()
    with lock:
        moving = [m.twist.twist.linear.x for _, m, _ in seen["/odom"][-10:]]
        last = seen["/odom"][-1][1]
    moved = math.hypot(last.pose.pose.position.x - x0, last.pose.pose.position.y - y0)
    if max(moving) < 0.1 or moved < 0.1:
        fail(f"/cmd_vel did not drive the robot: speeds {moving}, moved {moved:.3f} m")
    # Covariances: never zero where measured (x, y, yaw: zero would say certain), large where
    # not (z, roll, pitch), and the position's growing as the robot drives (drift).
    for name, odom in [("before driving", o), ("after driving", last)]:
        c = list(odom.pose.covariance)
        if min(c[0], c[7], c[35]) <= 0.0 or min(c[14], c[21], c[28]) < 1e3:
            fail(f"/odom pose covariance {name}: diagonal {[c[i * 7] for i in range(6)]}")
        if min(odom.twist.covariance[0], odom.twist.covariance[35]) <= 0.0:
            fail(f"/odom twist covariance {name}: {list(odom.twist.covariance)}")
    if last.pose.covariance[0] + last.pose.covariance[7] <= o.pose.covariance[0] + o.pose.covariance[7]:
        fail(f"/odom position variance did not grow over {moved:.2f} m: "
             f"{o.pose.covariance[0] + o.pose.covariance[7]} then {last.pose.covariance[0] + last.pose.covariance[7]}")
    # The commands ceased: the velocity timeout stops the robot.
    at_rest = None
    deadline = stopped_publishing + 5.0
    while time.monotonic() < deadline and at_rest is None:
        with lock:
            for t_arr, m, _ in seen["/odom"]:
                if t_arr > stopped_publishing and m.twist.twist.linear.x == 0.0 and m.twist.twist.angular.z == 0.0:
                    at_rest = t_arr - stopped_publishing
                    break
        time.sleep(0.02)
    if at_rest is None:
        fail("the robot did not come to rest within 5 s of the last /cmd_vel")

    # /cmd_vel is announced as a subscription of each type it takes, with ROS 2's hashes.
    want_cmd = {(dds_name(t), TS.hash_rihs01(t)) for t in ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped")}
    got_cmd = subscribed_types(node, "/cmd_vel", 2)
    if got_cmd != want_cmd:
        fail(f"/cmd_vel subscriptions announced {sorted(got_cmd)}, not {sorted(want_cmd)}")

    # TwistStamped on /cmd_vel (what diff_drive_controller takes since Jazzy), judged by its
    # header's stamp: 5 s old, refused (the robot stays at rest); stamped now, or zero as
    # `ros2 topic pub` sends it, it drives.
    stamped = node.publisher("/cmd_vel", "geometry_msgs/msg/TwistStamped")
    H = TS.types["std_msgs/msg/Header"]
    T = TS.types["builtin_interfaces/msg/Time"]

    def twist_stamped(v, stamp_s):
        sec = int(stamp_s)
        return TS.types["geometry_msgs/msg/TwistStamped"](
            header=H(stamp=T(sec=sec, nanosec=int((stamp_s - sec) * 1e9)), frame_id="base_link"),
            twist=twist(v, 0.0))

    def drive_stamped(stamp_of, seconds):
        """Sends for `seconds`; how many it sent and the speeds odometry reported meanwhile."""
        began, sent = time.monotonic(), 0
        while time.monotonic() < began + seconds:
            stamped(twist_stamped(0.2, stamp_of()))
            sent += 1
            time.sleep(0.05)
        time.sleep(0.3)
        with lock:
            return sent, [m.twist.twist.linear.x for t_arr, m, _ in seen["/odom"] if t_arr > began]

    stale_sent, stale = drive_stamped(lambda: time.time() - 5.0, 1.0)
    if not stale or max(abs(v) for v in stale) > 0.0:
        fail(f"TwistStamped 5 s old moved the robot: {stale}")
    n = [0]

    def now_or_zero():
        n[0] += 1
        return time.time() if n[0] % 2 else 0.0

    _, fresh = drive_stamped(now_or_zero, 1.5)
    if max(fresh) < 0.1:
        fail(f"TwistStamped stamped now (or zero) did not drive the robot: speeds {fresh}")
    for sub in subs:
        sub.undeclare()
    return {
        "found": sorted(found),
        "stamped_stale_sent": stale_sent,
        "stamped_top_speed": round(max(fresh), 3),
        "robot_node": found["/odom"]["node"],
        "rates_hz": {t: round(r, 1) for t, r in rates.items()},
        "moved_m": round(moved, 3),
        "at_rest_after_s": round(at_rest, 3),
    }


def bad_input(node, args):
    discover(node, {"/odom": "nav_msgs/msg/Odometry"})
    odoms = []
    sub = node.subscribe("/odom", "nav_msgs/msg/Odometry", lambda m, a: odoms.append(m))
    cmd = node.publisher("/cmd_vel", "geometry_msgs/msg/Twist")
    # Not a type /cmd_vel takes (it takes Twist and TwistStamped).
    wrong = node.publisher("/cmd_vel", "geometry_msgs/msg/Vector3")
    deadline = time.monotonic() + 10
    while not odoms and time.monotonic() < deadline:
        time.sleep(0.01)
    if not odoms:
        fail("no odometry within 10 s")
    sent = {"undecodable": 0, "wrong_type": 0, "not_finite": 0, "burst": 0}
    for raw in [b"", b"\x00", b"\x00\x01\x00\x00\x01", b"\x07\x07\x00\x00" + b"\x00" * 48, os.urandom(20)]:
        cmd(raw=raw)
        sent["undecodable"] += 1
    for _ in range(3):
        wrong(TS.types["geometry_msgs/msg/Vector3"](x=0.3, y=0.0, z=0.0))
        sent["wrong_type"] += 1
    time.sleep(0.5)  # the rate gate fills up again
    for v, w in [(float("nan"), 0.0), (0.0, float("inf")), (float("-inf"), float("nan"))]:
        cmd(twist(v, w))
        sent["not_finite"] += 1
        time.sleep(0.05)
    for _ in range(5000):
        cmd(twist(0.0, 0.0))
        sent["burst"] += 1
    # Still alive, at rest: odometry keeps coming.
    n = len(odoms)
    time.sleep(1.0)
    if len(odoms) < n + 5:
        fail(f"odometry stopped after the bad input: {len(odoms) - n} in 1 s")
    if any(not math.isfinite(m.twist.twist.linear.x) for m in odoms) or odoms[-1].twist.twist.linear.x != 0.0:
        fail(f"the robot moves after the bad input: {odoms[-1].twist.twist.linear.x}")
    sub.undeclare()
    return {"sent": sent}


def robot(node, args):
    """A unicycle in a straight corridor along +x, a wall at y = wall_y on its left, none on its
    right within the laser's range; /scan (360 rays) and /odom at 20 Hz, /cmd_vel in, and its own
    command timeout of 0.5 s."""
    wall_y, radius, range_max = args.wall_y, args.radius, 3.5
    lx, lyaw = args.laser_x, args.laser_yaw
    scan_pub = node.publisher("/scan", "sensor_msgs/msg/LaserScan", QOS_SENSOR)
    odom_pub = node.publisher("/odom", "nav_msgs/msg/Odometry")
    # Where the laser is, as robot_state_publisher says it: on /tf_static, transient local
    # (zenoh-ext's advanced publisher with a cache, as rmw_zenoh makes one), published once,
    # before anyone listens: base_footprint -> base_link -> base_scan, as on a TurtleBot 3.
    TfS = TS.types["geometry_msgs/msg/TransformStamped"]
    Tr = TS.types["geometry_msgs/msg/Transform"]
    V3_ = TS.types["geometry_msgs/msg/Vector3"]
    Q_ = TS.types["geometry_msgs/msg/Quaternion"]
    H_ = TS.types["std_msgs/msg/Header"]
    T_ = TS.types["builtin_interfaces/msg/Time"]

    def tf(parent, child, x, yaw):
        return TfS(header=H_(stamp=T_(sec=0, nanosec=0), frame_id=parent), child_frame_id=child,
                   transform=Tr(translation=V3_(x=x, y=0.0, z=0.1),
                                rotation=Q_(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))))

    static_type = "tf2_msgs/msg/TFMessage"
    static_key, static_token = node.token("MP", "/tf_static", static_type, ":1:,1:,:,:,,")
    node.tokens.append(static_token)
    static_pub = zenoh.ext.declare_advanced_publisher(
        node.session, data_key(node.domain, "/tf_static", static_type),
        cache=zenoh.ext.CacheConfig(max_samples=1), publisher_detection=True)
    static_msg = TS.types[static_type](transforms=[tf("base_footprint", "base_link", 0.0, 0.0),
                                                   tf("base_link", "base_scan", lx, lyaw)])
    static_pub.put(bytes(TS.serialize_cdr(static_msg, static_type)),
                   attachment=struct.pack("<qqB", 1, time.time_ns(), 16) + gid_of(static_key))
    print("tf_static published", flush=True)
    state = {"x": 0.0, "y": 0.0, "yaw": 0.0, "v": 0.0, "w": 0.0, "cmd_at": None, "cmds": 0}
    lock = threading.Lock()

    stamped = args.cmd_type == "geometry_msgs/msg/TwistStamped"
    state["stamp_lag_s"] = []

    def on_cmd(msg, attachment):
        if stamped:
            # Stamped when sent (UNIX time), in the base's frame.
            lag = time.time() - (msg.header.stamp.sec + msg.header.stamp.nanosec / 1e9)
            if msg.header.frame_id != "base_link":
                fail(f"a TwistStamped in {msg.header.frame_id!r}, not base_link")
            msg = msg.twist
        with lock:
            if stamped:
                state["stamp_lag_s"].append(lag)
            state["v"] = max(-0.5, min(0.5, msg.linear.x)) if math.isfinite(msg.linear.x) else 0.0
            state["w"] = max(-1.0, min(1.0, msg.angular.z)) if math.isfinite(msg.angular.z) else 0.0
            state["cmd_at"] = time.monotonic()
            state["cmds"] += 1

    sub = node.subscribe("/cmd_vel", args.cmd_type, on_cmd)
    H = TS.types["std_msgs/msg/Header"]
    T = TS.types["builtin_interfaces/msg/Time"]
    P = TS.types["geometry_msgs/msg/Point"]
    Q = TS.types["geometry_msgs/msg/Quaternion"]
    V3 = TS.types["geometry_msgs/msg/Vector3"]
    import numpy as np

    def stamp():
        ns = time.time_ns()
        return T(sec=ns // 10**9, nanosec=ns % 10**9)

    dt = 0.05
    # The run's clock starts at the first command (orsa may start after this fixture), within
    # 60 s; the robot publishes its scan and odometry from now on.
    waiting_since = time.monotonic()
    start = None
    trace = []
    min_clear = float("inf")
    next_t = waiting_since
    while start is None or time.monotonic() - start < args.seconds:
        with lock:
            if start is None and state["cmds"] > 0:
                start = time.monotonic()
        if start is None and time.monotonic() - waiting_since > 60:
            fail("no command on /cmd_vel within 60 s")
        next_t += dt
        with lock:
            if state["cmd_at"] is None or time.monotonic() - state["cmd_at"] > 0.5:
                state["v"] = state["w"] = 0.0
            state["yaw"] += state["w"] * dt
            state["x"] += state["v"] * math.cos(state["yaw"]) * dt
            state["y"] += state["v"] * math.sin(state["yaw"]) * dt
            x, y, yaw, v, w = state["x"], state["y"], state["yaw"], state["v"], state["w"]
        clear = wall_y - y - radius
        min_clear = min(min_clear, clear)
        if start is not None:
            trace.append((time.monotonic() - start, x, wall_y - y))
        # The rays leave the laser (lx ahead of the centre, facing lyaw), in its own frame.
        angles = np.arange(360) * (2 * math.pi / 360) - math.pi
        s = np.sin(angles + lyaw + yaw)
        laser_y = y + lx * math.sin(yaw)
        with np.errstate(divide="ignore"):
            ranges = np.where(s > 1e-6, (wall_y - laser_y) / np.where(s > 1e-6, s, 1.0), np.inf)
        ranges = np.where(ranges <= range_max, ranges, np.inf).astype(np.float32)
        LaserScan = TS.types["sensor_msgs/msg/LaserScan"]
        scan_pub(LaserScan(header=H(stamp=stamp(), frame_id="base_scan"), angle_min=-math.pi,
                           angle_max=math.pi - 2 * math.pi / 360, angle_increment=2 * math.pi / 360,
                           time_increment=0.0, scan_time=dt, range_min=0.12, range_max=range_max,
                           ranges=ranges, intensities=np.zeros(0, dtype=np.float32)))
        Odometry = TS.types["nav_msgs/msg/Odometry"]
        PWC = TS.types["geometry_msgs/msg/PoseWithCovariance"]
        TWC = TS.types["geometry_msgs/msg/TwistWithCovariance"]
        odom_pub(Odometry(header=H(stamp=stamp(), frame_id="odom"), child_frame_id="base_footprint",
                          pose=PWC(pose=TS.types["geometry_msgs/msg/Pose"](position=P(x=x, y=y, z=0.0),
                                   orientation=Q(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))),
                                   covariance=np.zeros(36)),
                          twist=TWC(twist=TS.types["geometry_msgs/msg/Twist"](linear=V3(x=v, y=0.0, z=0.0),
                                    angular=V3(x=0.0, y=0.0, z=w)), covariance=np.zeros(36))))
        time.sleep(max(0.0, next_t - time.monotonic()))
    sub.undeclare()
    second_half = [d for t, _, d in trace if t > args.seconds / 2]
    lags = state["stamp_lag_s"]
    return {
        "commands": state["cmds"],
        "cmd_type": args.cmd_type,
        "stamp_lag_s": {"min": round(min(lags), 4), "max": round(max(lags), 4)} if lags else None,
        "travelled_m": round(state["x"], 3),
        "wall_distance_m": {"min": round(min(second_half), 3), "max": round(max(second_half), 3)},
        "min_clearance_m": round(min_clear, 3),
    }


def at_wall(node, args):
    """Turns the robot to face the wall on its left (from its /odom yaw), then drives it straight
    at that wall at `--speed` through /cmd_vel for `--seconds`, 20 commands a second, as a
    teleop node that does not look would. What the robot's /bumper, /odom and forward /ir_scan
    said meanwhile."""
    want = {"/odom": "nav_msgs/msg/Odometry", "/bumper": "std_msgs/msg/Bool",
            "/ir_scan": "sensor_msgs/msg/LaserScan"}
    discover(node, want)
    lock = threading.Lock()
    st = {"yaw": None, "v": None, "x": None, "y": None, "bumper": 0, "bumped": False, "front": []}

    def on_odom(msg, attachment):
        q = msg.pose.pose.orientation
        with lock:
            st["yaw"] = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            st["v"] = msg.twist.twist.linear.x
            st["x"], st["y"] = msg.pose.pose.position.x, msg.pose.pose.position.y

    def on_bumper(msg, attachment):
        with lock:
            st["bumper"] += 1
            st["bumped"] = st["bumped"] or bool(msg.data)

    def on_ir(msg, attachment):
        # The ray nearest straight ahead (angle 0).
        k = round((0.0 - msg.angle_min) / msg.angle_increment) % len(msg.ranges)
        with lock:
            st["front"].append(float(msg.ranges[k]))

    subs = [node.subscribe("/odom", want["/odom"], on_odom), node.subscribe("/bumper", want["/bumper"], on_bumper),
            node.subscribe("/ir_scan", want["/ir_scan"], on_ir, QOS_SENSOR)]
    cmd = node.publisher("/cmd_vel", "geometry_msgs/msg/Twist")
    deadline = time.monotonic() + 30.0
    while True:
        with lock:
            yaw = st["yaw"]
        if yaw is not None:
            start = yaw
            break
        if time.monotonic() > deadline:
            fail("no /odom within 30 s")
        time.sleep(0.05)
    # Face the left wall, turning in place (a quarter turn at 0.5 rad/s takes about 3 s).
    deadline = time.monotonic() + 30.0
    while True:
        with lock:
            turned = (st["yaw"] - start) % (2 * math.pi)
        if math.pi / 2 <= turned < math.pi:
            break
        if time.monotonic() > deadline:
            fail(f"the robot did not turn to face the wall: turned {math.degrees(turned):.0f} deg")
        cmd(twist(0.0, 0.5))
        time.sleep(0.05)
    with lock:
        x0, y0, bumped_before = st["x"], st["y"], st["bumped"]
        st["front"].clear()
    # At the wall at top speed.
    end = time.monotonic() + args.seconds
    top = 0.0
    while time.monotonic() < end:
        cmd(twist(args.speed, 0.0))
        time.sleep(0.05)
        with lock:
            top = max(top, st["v"] or 0.0)
    with lock:
        v_end, front, bumped = st["v"], [r for r in st["front"] if math.isfinite(r)], st["bumped"]
        moved = math.hypot(st["x"] - x0, st["y"] - y0)
        bumper_msgs = st["bumper"]
    for s in subs:
        s.undeclare()
    if bumper_msgs == 0:
        fail("no /bumper messages: cannot tell whether it bumped")
    return {
        "bumped": bumped,
        "bumped_while_turning": bumped_before,
        "top_speed_m_s": round(top, 3),
        "speed_at_end_m_s": v_end,
        "moved_m": round(moved, 3),
        "front_ir_at_end_m": front[-1] if front else None,
        "bumper_messages": bumper_msgs,
    }


# The parameter services of a ROS 2 node (rcl_interfaces/srv, ROS 2 Jazzy), as their .srv files
# define them. rosbags' typestore has their messages but not the services: they are registered
# here, with the service type REP-2011 describes (request_message, response_message and
# event_message, the event holding service_msgs/msg/ServiceEventInfo), so that rosbags computes
# their RIHS01 hashes and encodes their requests.
SERVICES = {
    "ListParameters": ("uint64 DEPTH_RECURSIVE=0\nstring[] prefixes\nuint64 depth",
                       "rcl_interfaces/msg/ListParametersResult result"),
    "GetParameters": ("string[] names", "rcl_interfaces/msg/ParameterValue[] values"),
    "SetParameters": ("rcl_interfaces/msg/Parameter[] parameters",
                      "rcl_interfaces/msg/SetParametersResult[] results"),
    "SetParametersAtomically": ("rcl_interfaces/msg/Parameter[] parameters",
                                "rcl_interfaces/msg/SetParametersResult result"),
    "DescribeParameters": ("string[] names", "rcl_interfaces/msg/ParameterDescriptor[] descriptors"),
    "GetParameterTypes": ("string[] names", "uint8[] types"),
}


def _register_services():
    from rosbags.typesys import get_types_from_msg

    def rename(o):
        if isinstance(o, str):
            return o.replace("fixturesrv/msg/", "rcl_interfaces/srv/")
        if isinstance(o, (list, tuple)):
            return type(o)(rename(x) for x in o)
        if isinstance(o, dict):
            return {rename(k): rename(v) for k, v in o.items()}
        return o

    for name, (request, response) in SERVICES.items():
        # rosbags names a parsed type pkg/msg/Name: parse under a placeholder, then rename.
        b = f"fixturesrv/msg/{name}"
        types = {}
        types.update(get_types_from_msg(request, b + "_Request"))
        types.update(get_types_from_msg(response, b + "_Response"))
        types.update(get_types_from_msg(
            f"service_msgs/msg/ServiceEventInfo info\n{b}_Request[<=1] request\n{b}_Response[<=1] response",
            b + "_Event"))
        types.update(get_types_from_msg(
            f"{b}_Request request_message\n{b}_Response response_message\n{b}_Event event_message", b))
        TS.register(rename(types))


_register_services()
PARAM_TYPE = {"NOT_SET": 0, "BOOL": 1, "INTEGER": 2, "DOUBLE": 3, "STRING": 4, "STRING_ARRAY": 9}


def service_dds_name(srv):
    return f"rcl_interfaces::srv::dds_::{srv}_"


def service_key(domain, name, srv):
    return f"{domain}/{name.lstrip('/')}/{service_dds_name(srv)}/{TS.hash_rihs01('rcl_interfaces/srv/' + srv)}"


class ServiceClient:
    """A service client as rmw_zenoh's (rmw_client_data.cpp): a liveliness token of kind SC; a
    request is a query on the service's key, targeting every complete queryable, with the request
    in CDR and the attachment (sequence number, source timestamp, the client's gid)."""

    def __init__(self, node, name, srv):
        self.node, self.name, self.srv = node, name, srv
        # A service token carries the service's DDS name and hash (not its request's).
        self.token_key, token = node.token("SC", name, f"rcl_interfaces/srv/{srv}")
        node.tokens.append(token)
        self.gid = gid_of(self.token_key)
        self.seq = 0

    def call_raw(self, payload, attachment=True, key=None, within=10.0):
        """Sends one request: (ok, payload bytes or error text, reply attachment)."""
        self.seq += 1
        a = struct.pack("<qqB", self.seq, time.time_ns(), 16) + self.gid if attachment else None
        replies = self.node.session.get(
            key or service_key(self.node.domain, self.name, self.srv),
            target=zenoh.QueryTarget.ALL_COMPLETE,
            consolidation=zenoh.ConsolidationMode.NONE,
            payload=payload,
            attachment=a,
            timeout=within,
        )
        got = list(replies)
        if len(got) != 1:
            fail(f"{self.name}: {len(got)} replies to one request")
        r = got[0]
        if r.ok is None:
            return False, r.err.payload.to_bytes().decode("utf-8", "replace"), None
        att = r.ok.attachment.to_bytes() if r.ok.attachment is not None else None
        return True, r.ok.payload.to_bytes(), att

    def call(self, **fields):
        req_type = f"rcl_interfaces/srv/{self.srv}_Request"
        req = TS.types[req_type](**fields)
        ok, body, att = self.call_raw(bytes(TS.serialize_cdr(req, req_type)))
        if not ok:
            fail(f"{self.name}: an error reply to a valid request: {body}")
        if att is None or len(att) != 33 or att[16] != 16:
            fail(f"{self.name}: the reply's attachment is not rmw_zenoh's: {att!r}")
        seq, stamp = struct.unpack("<qq", att[:16])
        if seq != self.seq or att[17:] != self.gid:
            fail(f"{self.name}: the reply carries sequence {seq} and gid {att[17:].hex()}, "
                 f"not the request's {self.seq} and {self.gid.hex()}")
        if abs(stamp - time.time_ns()) > 5e9:
            fail(f"{self.name}: the reply's source timestamp {stamp} is not now")
        return TS.deserialize_cdr(body, f"rcl_interfaces/srv/{self.srv}_Response")


def value(kind, v=None):
    V = TS.types["rcl_interfaces/msg/ParameterValue"]
    import numpy as np
    empty = dict(bool_value=False, integer_value=0, double_value=0.0, string_value="",
                 byte_array_value=np.array([], dtype=np.uint8), bool_array_value=np.array([], dtype=np.bool_),
                 integer_array_value=np.array([], dtype=np.int64), double_array_value=np.array([], dtype=np.float64),
                 string_array_value=[])
    field = {1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value"}.get(kind)
    if field:
        empty[field] = v
    return V(type=kind, **empty)


def param(name, kind, v=None):
    return TS.types["rcl_interfaces/msg/Parameter"](name=name, value=value(kind, v))


def params(node, args):
    """`ros2 param list/get/set/describe` on the robot's node, as rclcpp's parameter client makes
    those calls, and the bad requests a peer can send; /rosout is watched meanwhile."""
    target = "/" + args.target_node
    names = ["list_parameters", "get_parameters", "set_parameters", "set_parameters_atomically",
             "describe_parameters", "get_parameter_types"]
    srv_of = dict(zip(names, ["ListParameters", "GetParameters", "SetParameters", "SetParametersAtomically",
                              "DescribeParameters", "GetParameterTypes"]))
    # The services, found by their tokens (kind SS), typed and hashed as REP-2011 computes it.
    found = {}
    lock = threading.Lock()

    def on_token(sample):
        parts = str(sample.key_expr).split("/")
        if len(parts) == 13 and parts[5] == "SS" and parts[8] == args.target_node:
            with lock:
                found["/" + parts[9].replace("%", "/").lstrip("/")] = (parts[10], parts[11], parts[12])

    sub = node.session.liveliness().declare_subscriber(f"@ros2_lv/{node.domain}/**", on_token, history=True)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        with lock:
            if all(f"{target}/{n}" in found for n in names):
                break
        time.sleep(0.05)
    sub.undeclare()
    for n in names:
        srv = srv_of[n]
        want = (service_dds_name(srv), TS.hash_rihs01(f"rcl_interfaces/srv/{srv}"), QOS_DEFAULT)
        if found.get(f"{target}/{n}") != want:
            fail(f"{target}/{n} is announced as {found.get(f'{target}/{n}')}, not {want}")

    # /rosout, as rqt_console reads it: transient local, so a late joiner (this client) gets
    # the lines said before it came (zenoh-ext's advanced subscriber, as rmw_zenoh makes one).
    logs = []
    rosout_type = "rcl_interfaces/msg/Log"
    node.tokens.append(node.token("MS", "/rosout", rosout_type, ":1:,1000:,:,:,,")[1])
    rosout_sub = zenoh.ext.declare_advanced_subscriber(
        node.session, data_key(node.domain, "/rosout", rosout_type),
        lambda sample: logs.append(TS.deserialize_cdr(sample.payload.to_bytes(), rosout_type)),
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1000))
    rosout_qos = subscribed_or_published(node, "/rosout", "MP")

    c = {n: ServiceClient(node, f"{target}/{n}", srv_of[n]) for n in names}
    listed = c["list_parameters"].call(prefixes=[], depth=0).result
    speed = "centerfollow.v_max_m_s"
    if speed not in listed.names or "centerfollow" not in listed.prefixes:
        fail(f"list_parameters: {speed} not listed: {list(listed.names)[:20]} prefixes {list(listed.prefixes)}")
    shallow = c["list_parameters"].call(prefixes=["centerfollow"], depth=1).result
    if not shallow.names or any(not n.startswith("centerfollow.") or n.count(".") != 1 for n in shallow.names):
        fail(f"list_parameters under centerfollow, depth 1: {list(shallow.names)}")

    got = c["get_parameters"].call(names=[speed, "nosuch.param"]).values
    if got[0].type != PARAM_TYPE["DOUBLE"] or got[1].type != PARAM_TYPE["NOT_SET"]:
        fail(f"get_parameters: types {[v.type for v in got]}")
    before = got[0].double_value
    types = c["get_parameter_types"].call(names=[speed, "nosuch.param"]).types
    described = c["describe_parameters"].call(names=[speed]).descriptors[0]
    if list(types) != [PARAM_TYPE["DOUBLE"], PARAM_TYPE["NOT_SET"]] or described.type != PARAM_TYPE["DOUBLE"] \
            or described.read_only or described.name != speed:
        fail(f"types {list(types)}, descriptor {described}")
    every = c["describe_parameters"].call(names=list(listed.names)).descriptors
    read_only = sorted(d.name for d in every if d.read_only)

    new = round(before * 0.8, 4)
    results = c["set_parameters"].call(parameters=[
        param(speed, PARAM_TYPE["DOUBLE"], new),
        param(speed, PARAM_TYPE["DOUBLE"], 5.0),
        param("nosuch.param", PARAM_TYPE["DOUBLE"], 1.0),
        param(speed, PARAM_TYPE["STRING"], "fast"),
        param(speed, PARAM_TYPE["NOT_SET"]),
    ]).results
    outcome = [(r.successful, r.reason) for r in results]
    after = c["get_parameters"].call(names=[speed]).values[0].double_value
    atomic = c["set_parameters_atomically"].call(parameters=[
        param(speed, PARAM_TYPE["DOUBLE"], before), param("centerfollow.v_min_m_s", PARAM_TYPE["DOUBLE"], 0.01)]).result
    unchanged = c["get_parameters"].call(names=[speed]).values[0].double_value

    # Bad requests: each gets an error reply saying why; the service keeps answering.
    gp = c["get_parameters"]
    bad = {
        "no_attachment": gp.call_raw(bytes(TS.serialize_cdr(
            TS.types["rcl_interfaces/srv/GetParameters_Request"](names=[speed]),
            "rcl_interfaces/srv/GetParameters_Request")), attachment=False),
        "undecodable": gp.call_raw(b"\x00\x01\x00\x00\xff\xff\xff\x7f"),
        "wrong_type": gp.call_raw(b"\x00\x01\x00\x00\x00\x00\x00\x00",
                                  key=service_key(node.domain, f"{target}/get_parameters", "SetParameters")),
        # 20000 names (about 640 KB of CDR): refused by its size before it is decoded or asked.
        "huge": gp.call_raw(bytes(TS.serialize_cdr(
            TS.types["rcl_interfaces/srv/GetParameters_Request"](names=[f"centerfollow.p{i:012d}" for i in range(20000)]),
            "rcl_interfaces/srv/GetParameters_Request"))),
    }
    for what, (ok, text, _) in bad.items():
        if ok:
            fail(f"a request with {what} was answered")
    still = c["get_parameters"].call(names=[speed]).values[0].double_value
    # Put the speed back as it was.
    restored = c["set_parameters"].call(parameters=[param(speed, PARAM_TYPE["DOUBLE"], before)]).results[0]
    time.sleep(0.5)
    rosout_sub.undeclare()
    return {
        "listed": len(listed.names),
        "prefixes": len(listed.prefixes),
        "shallow": len(shallow.names),
        "read_only": read_only,
        "before": before,
        "set": outcome,
        "after": after,
        "atomic": [atomic.successful, atomic.reason],
        "unchanged": unchanged,
        "bad": {k: v[1] for k, v in bad.items()},
        "still": still,
        "restored": restored.successful,
        "rosout_qos": rosout_qos,
        "rosout": [{"level": m.level, "name": m.name, "msg": m.msg} for m in logs],
    }


def goal(node, args):
    """Sends a goal as RViz's "2D Goal Pose" tool does: one geometry_msgs/msg/PoseStamped in the
    map frame on /goal_pose, once the robot's node announces its subscription there (with
    Jazzy's type hash). Also sends one in the odom frame first, which must be refused."""
    ros_type = "geometry_msgs/msg/PoseStamped"
    want = (dds_name(ros_type), TS.hash_rihs01(ros_type))
    types = subscribed_types(node, "/goal_pose", 1, within=30)
    if want not in types:
        fail(f"/goal_pose subscriptions announced {sorted(types)}, not {want}")
    pub = node.publisher("/goal_pose", ros_type)
    # Let the robot's subscriber see the publisher's token before the first message.
    time.sleep(0.5)
    T = TS.types
    now = time.time_ns()

    def pose(frame):
        stamp = T["builtin_interfaces/msg/Time"](sec=now // 10**9, nanosec=now % 10**9)
        header = T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)
        position = T["geometry_msgs/msg/Point"](x=args.x, y=args.y, z=0.0)
        q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(args.yaw / 2), w=math.cos(args.yaw / 2))
        return T[ros_type](header=header, pose=T["geometry_msgs/msg/Pose"](position=position, orientation=q))

    pub(pose("odom"))
    time.sleep(0.2)
    pub(pose("map"))
    time.sleep(0.5)
    return {"sent": 2, "subscribed": list(want)}


def map_(node, args):
    """Joins late, as RViz or a planner does, and takes /map as map_server's subscribers do: a
    transient local subscription (zenoh-ext's advanced subscriber asking for history, as rmw_zenoh
    makes one) on nav_msgs/msg/OccupancyGrid with Jazzy's type hash. Says what came: the
    publisher's QoS, the grid's header and info, and its cells run-length encoded."""
    ros_type = "nav_msgs/msg/OccupancyGrid"
    got = []
    node.tokens.append(node.token("MS", "/map", ros_type, ":1:,1:,:,:,,")[1])
    sub = zenoh.ext.declare_advanced_subscriber(
        node.session, data_key(node.domain, "/map", ros_type),
        lambda sample: got.append(TS.deserialize_cdr(sample.payload.to_bytes(), ros_type)),
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1))
    qos = subscribed_or_published(node, "/map", "MP", within=args.seconds)
    deadline = time.monotonic() + args.seconds
    while not got and time.monotonic() < deadline:
        time.sleep(0.05)
    sub.undeclare()
    if not got:
        fail(f"no /map within {args.seconds} s (publisher QoS {qos})")
    m = got[-1]
    runs = []
    for v in m.data:
        v = int(v)
        if runs and runs[-1][0] == v:
            runs[-1][1] += 1
        else:
            runs.append([v, 1])
    o = m.info.origin
    return {
        "qos": qos,
        "received": len(got),
        "frame_id": m.header.frame_id,
        "width": int(m.info.width),
        "height": int(m.info.height),
        "resolution": float(m.info.resolution),
        "origin": [o.position.x, o.position.y, o.position.z],
        "orientation": [o.orientation.x, o.orientation.y, o.orientation.z, o.orientation.w],
        "runs": runs,
    }


def subscribed_or_published(node, topic, kind, within=10):
    """The QoS of the first `kind` (MP, MS) token on `topic`, once one is seen."""
    found = []

    def on_token(sample):
        parts = str(sample.key_expr).split("/")
        if len(parts) == 13 and parts[5] == kind and "/" + parts[9].replace("%", "/").lstrip("/") == topic:
            found.append(parts[12])

    sub = node.session.liveliness().declare_subscriber(f"@ros2_lv/{node.domain}/**", on_token, history=True)
    deadline = time.monotonic() + within
    while not found and time.monotonic() < deadline:
        time.sleep(0.05)
    sub.undeclare()
    return found[0] if found else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", required=True)
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--wall-y", type=float, default=0.5)
    parser.add_argument("--radius", type=float, default=0.25)
    parser.add_argument("--speed", type=float, default=0.5, help="at-wall: the speed commanded, m/s")
    parser.add_argument("--laser-x", type=float, default=0.0, help="robot: the laser, m ahead of the centre")
    parser.add_argument("--laser-yaw", type=float, default=0.0, help="robot: the way the laser faces, rad")
    parser.add_argument("--cmd-type", default="geometry_msgs/msg/TwistStamped",
                        help="robot: the type it takes on /cmd_vel")
    parser.add_argument("--target-node", default="orsa", help="params: the node whose parameters to use")
    parser.add_argument("--x", type=float, default=0.0, help="goal: x in the map, m")
    parser.add_argument("--y", type=float, default=0.0, help="goal: y in the map, m")
    parser.add_argument("--yaw", type=float, default=0.0, help="goal: the heading, rad")
    parser.add_argument("mode", choices=["observe", "bad-input", "robot", "at-wall", "params", "goal", "map"])
    args = parser.parse_args()
    node = Node(args.connect, args.domain, {"observe": "fixture_observer", "bad-input": "fixture_bad",
                                             "robot": "fixture_robot", "at-wall": "fixture_teleop",
                                             "params": "fixture_param_client", "goal": "fixture_rviz",
                                             "map": "fixture_map_client"}[args.mode])
    try:
        modes = {"observe": observe, "bad-input": bad_input, "robot": robot, "at-wall": at_wall, "params": params,
                 "goal": goal, "map": map_}
        result = modes[args.mode](node, args)
    finally:
        node.close()
    print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
