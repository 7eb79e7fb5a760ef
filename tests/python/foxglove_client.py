"""A client of orsa's live view (`--foxglove`), written from the public Foxglove WebSocket
protocol specification (github.com/foxglove/ws-protocol, docs/spec.md, subprotocol
`foxglove.websocket.v1`, which the SDK's server calls `foxglove.sdk.v1`) with the `websockets` package, not with the Foxglove SDK.

    python3 foxglove_client.py ws://127.0.0.1:PORT [--seconds S]
    python3 foxglove_client.py ws://127.0.0.1:PORT --params NAME VALUE
    python3 foxglove_client.py ws://127.0.0.1:PORT --watch-param NAME [--seconds S]
    python3 foxglove_client.py ws://127.0.0.1:PORT --teleop

The first form checks, against a live `orsa run --realtime --foxglove`:
- the server's info, and the channels it advertises (topics, encodings, schema names);
- bad input from a second client: a text frame that is not JSON, JSON with an unknown op,
  JSON with no op, a subscription to a channel that does not exist, an unsubscription of a
  subscription that does not exist, a binary frame of an unknown opcode, parameters asked
  of a server without them; each answered with a status or ignored, the server staying up;
- a third client that subscribes to everything and then never reads (stalls);
- meanwhile the first client, subscribed to everything, decodes every message (protobuf,
  from the FileDescriptorSet each channel advertises) and measures the scans' and the
  odometry's periods, by their log times and by the wall clock.
It prints what it saw as JSON on stdout and exits 1 with the reason on stderr if a check fails.

The second form (`--params`) asks for every parameter, sets NAME to VALUE (JSON) while a
second client is subscribed to it (spec: "Subscribe Parameter Update"), and prints the values the
server answers with, those pushed to the second client, and any status it sends.

The third form (`--watch-param`) subscribes to NAME's updates, prints `subscribed` once the
server has the subscription, and then, as JSON, the first update pushed within S seconds
(whoever changed the value).

The fourth form (`--teleop`) drives the robot by client publish, as Foxglove's Teleop panel
does, and prints how fast the robot went before, while held by zero commands, and while sent
stale stamped ones, with the statuses the server sent (see `teleop`).
"""

import argparse
import asyncio
import base64
import json
import math
import statistics
import struct
import sys
import time

import websockets
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

# The spec's name for protocol v1, and the name the Foxglove SDK's server (0.30) gives the same
# messages; it refuses a client that offers only the first. (Not `foxglove.sdk.v1.1`, whose
# advertisements differ.)
SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]
# Binary opcodes, server to client (spec: "Message Data").
OP_MESSAGE_DATA = 0x01

# What a run serves, by topic: (schema name, the period of its source in ms, or None).
EXPECTED = {
    "/infrared": ("foxglove.LaserScan", 40.0),
    "/sonar": ("foxglove.LaserScan", 64.0),
    "/tf": ("foxglove.FrameTransforms", 100.0),
    "/truth/tf": ("foxglove.FrameTransforms", 100.0),
    "/robot": ("foxglove.SceneUpdate", None),
    "/world": ("foxglove.SceneUpdate", None),
    "/map": ("foxglove.Grid", None),
    "/people": ("foxglove.SceneUpdate", None),
    "/trajectory": ("foxglove.PosesInFrame", None),
    "/driving": ("foxglove.Log", None),
    "/events": ("foxglove.Log", None),
}
# Measured periods may differ from the source's by this fraction: by log time (the robot's
# stamps: the views keep them) and by the wall clock (what a viewer sees at real time, with
# the network and the views' thread in between).
LOG_TOLERANCE = 0.05
WALL_TOLERANCE = 0.25


def fail(why):
    print(f"foxglove_client: {why}", file=sys.stderr)
    sys.exit(1)


def decoder(channel):
    """A function from a payload to a protobuf message, built from the channel's schema."""
    if channel.get("encoding") != "protobuf":
        fail(f"{channel['topic']}: encoding {channel.get('encoding')!r}, not protobuf")
    if channel.get("schemaEncoding", "protobuf") != "protobuf":
        fail(f"{channel['topic']}: schema encoding {channel.get('schemaEncoding')!r}")
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))
    return cls.FromString


async def recv_json(ws, timeout):
    """The next text message, as JSON (binary ones are skipped)."""
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        msg = await asyncio.wait_for(ws.recv(), left)
        if isinstance(msg, str):
            return json.loads(msg)


async def handshake(url, want_topics, timeout=10.0):
    """Connects; the server's info and the channels advertised, once every wanted topic is."""
    ws = await websockets.connect(url, subprotocols=SUBPROTOCOLS, max_size=None)
    if ws.subprotocol not in SUBPROTOCOLS:
        fail(f"the server chose subprotocol {ws.subprotocol!r}")
    info = await recv_json(ws, timeout)
    if info.get("op") != "serverInfo":
        fail(f"the first message is not serverInfo: {info}")
    channels = {}
    deadline = time.monotonic() + timeout
    while not want_topics <= {c["topic"] for c in channels.values()}:
        try:
            msg = await recv_json(ws, deadline - time.monotonic())
        except TimeoutError:
            got = sorted(c["topic"] for c in channels.values())
            fail(f"within {timeout} s, advertised only {got}")
        if msg.get("op") == "advertise":
            for c in msg["channels"]:
                channels[c["id"]] = c
    return ws, info, channels


def subscribe_all(channels):
    subs = [{"id": i + 1, "channelId": cid} for i, cid in enumerate(sorted(channels))]
    return subs, json.dumps({"op": "subscribe", "subscriptions": subs})


async def bad_inputs(url, known_ids):
    """Sends each bad input on a connection of its own; what the server answered to each."""
    answers = {}
    unknown_id = max(known_ids) + 1000
    inputs = {
        "not_json": "this is not JSON {",
        "unknown_op": json.dumps({"op": "fly", "to": "the moon"}),
        "no_op": json.dumps({"subscriptions": []}),
        "json_not_object": json.dumps([1, 2, 3]),
        "subscribe_unknown_channel": json.dumps(
            {"op": "subscribe", "subscriptions": [{"id": 7, "channelId": unknown_id}]}
        ),
        "subscribe_malformed": json.dumps({"op": "subscribe", "subscriptions": [{"id": "x"}]}),
        "unsubscribe_unknown": json.dumps({"op": "unsubscribe", "subscriptionIds": [424242]}),
        "get_parameters_unknown": json.dumps(
            {"op": "getParameters", "parameterNames": ["wallfollow.no_such_gain"], "id": "q"}
        ),
        "binary_unknown_opcode": b"\x7f\x00\x01\x02",
        "binary_empty": b"",
    }
    for name, payload in inputs.items():
        ws = await websockets.connect(url, subprotocols=SUBPROTOCOLS, max_size=None)
        await recv_json(ws, 5.0)  # serverInfo
        await ws.send(payload)
        statuses = []
        closed = None
        # A status, if the server sends one, comes at once; a closed connection is an answer.
        deadline = time.monotonic() + 0.5
        try:
            while time.monotonic() < deadline:
                msg = await recv_json(ws, deadline - time.monotonic())
                if msg.get("op") == "status":
                    statuses.append({"level": msg.get("level"), "message": msg.get("message")})
        except TimeoutError:
            pass
        except websockets.ConnectionClosed as e:
            closed = e.rcvd.code if e.rcvd else None
        answers[name] = {"statuses": statuses, "closed": closed}
        await ws.close()
    return answers


async def watch(url, seconds):
    ws, info, channels = await handshake(url, set(EXPECTED))
    by_topic = {c["topic"]: c for c in channels.values()}
    for topic, (schema, _) in EXPECTED.items():
        if by_topic[topic]["schemaName"] != schema:
            fail(f"{topic}: schema {by_topic[topic]['schemaName']}, not {schema}")
    decoders = {cid: decoder(c) for cid, c in channels.items()}

    # The stalled client: subscribes to everything, then never reads (its receive queue fills
    # and the library stops reading the socket).
    stalled = await websockets.connect(url, subprotocols=SUBPROTOCOLS, max_size=None, max_queue=1)
    _, stalled_subs = subscribe_all(channels)
    await stalled.send(stalled_subs)

    answers = await bad_inputs(url, list(channels))

    subs, request = subscribe_all(channels)
    sub_topic = {s["id"]: channels[s["channelId"]]["topic"] for s in subs}
    await ws.send(request)
    log_times = {t: [] for t in EXPECTED}
    wall_times = {t: [] for t in EXPECTED}
    decoded = {}
    statuses = []
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        msg = await asyncio.wait_for(ws.recv(), 5.0)
        now = time.monotonic()
        if isinstance(msg, str):
            m = json.loads(msg)
            if m.get("op") == "status":
                statuses.append(m)
            continue
        if len(msg) < 13 or msg[0] != OP_MESSAGE_DATA:
            continue
        sub_id, log_time = struct.unpack_from("<IQ", msg, 1)
        topic = sub_topic.get(sub_id)
        if topic is None:
            fail(f"message data on subscription {sub_id}, which this client did not make")
        cid = next(s["channelId"] for s in subs if s["id"] == sub_id)
        m = decoders[cid](msg[13:])
        decoded[topic] = m
        log_times[topic].append(log_time)
        wall_times[topic].append(now)
    await stalled.close()
    await ws.close()

    periods = {}
    for topic, (_, period_ms) in EXPECTED.items():
        if period_ms is None:
            continue
        lt, wt = log_times[topic], wall_times[topic]
        if len(lt) < 10:
            fail(f"{topic}: only {len(lt)} messages in {seconds} s")
        by_log = statistics.median((b - a) / 1e6 for a, b in zip(lt, lt[1:]))
        by_wall = (wt[-1] - wt[0]) * 1e3 / (len(wt) - 1)
        periods[topic] = {"log_ms": by_log, "wall_ms": by_wall, "messages": len(lt)}
        if abs(by_log - period_ms) > LOG_TOLERANCE * period_ms:
            fail(f"{topic}: a period of {by_log:.1f} ms by log time, not {period_ms} ms")
        if abs(by_wall - period_ms) > WALL_TOLERANCE * period_ms:
            fail(f"{topic}: a period of {by_wall:.1f} ms by the wall clock, not {period_ms} ms")

    # What the messages say.
    for topic in ("/infrared", "/sonar"):
        scan = decoded[topic]
        if scan.frame_id != "base_link" or len(scan.ranges) != 16:
            fail(f"{topic}: a scan in {scan.frame_id!r} with {len(scan.ranges)} ranges")
        # Foxglove's 3D panel draws an infinite range at infinity: none is sent.
        if not all(math.isfinite(r) for r in scan.ranges):
            fail(f"{topic}: a range that is not finite in {list(scan.ranges)}")
    chain = [(t.parent_frame_id, t.child_frame_id) for t in decoded["/tf"].transforms]
    if chain != [("world", "odom"), ("odom", "base_link")]:
        fail(f"/tf: the chain {chain}")
    if not decoded["/world"].entities:
        fail("/world: no entities (the world is re-sent to a client that subscribes late)")
    grid = decoded.get("/map")
    if grid is None or grid.column_count == 0 or len(grid.data) % (grid.column_count * grid.cell_stride) != 0:
        fail("/map: no grid, or one whose data does not fill whole rows (it is re-sent to a late client)")
    return {
        "server": {"name": info.get("name"), "capabilities": info.get("capabilities", [])},
        "topics": sorted(by_topic),
        "periods": periods,
        "messages": {t: len(v) for t, v in log_times.items()},
        "bad_inputs": answers,
        "statuses": [s.get("message") for s in statuses],
    }



async def time_base(url, seconds, within_s=60.0):
    """Subscribes to every topic of a server (a robot process serves fewer than a run) and
    checks that every message, the latched views sent on subscribing included, is stamped on
    one time base: within `within_s` of the wall clock (UNIX time), as the scans are. Its log
    times' spread per topic."""
    ws, _, channels = await handshake(url, {"/world", "/robot", "/tf"})
    decoders = {cid: decoder(c) for cid, c in channels.items()}
    subs, request = subscribe_all(channels)
    sub_channel = {s["id"]: s["channelId"] for s in subs}
    await ws.send(request)
    seen = {}
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        msg = await asyncio.wait_for(ws.recv(), 5.0)
        if isinstance(msg, str) or len(msg) < 13 or msg[0] != OP_MESSAGE_DATA:
            continue
        sub_id, log_time = struct.unpack_from("<IQ", msg, 1)
        cid = sub_channel.get(sub_id)
        if cid is None:
            fail(f"message data on subscription {sub_id}, which this client did not make")
        topic = channels[cid]["topic"]
        now = time.time()
        stamps = [log_time / 1e9]
        m = decoders[cid](msg[13:])
        # The stamps inside: a scene's entities, a message's own, each transform's.
        inner = [m] + list(getattr(m, "entities", [])) + list(getattr(m, "transforms", []))
        for part in inner:
            if "timestamp" in part.DESCRIPTOR.fields_by_name and part.HasField("timestamp"):
                stamps.append(part.timestamp.seconds + part.timestamp.nanos / 1e9)
        for t in stamps:
            if abs(t - now) > within_s:
                fail(f"{topic}: a message stamped {t:.3f} s (UNIX time), {t - now:+.1f} s from now")
        lo, hi = seen.get(topic, (log_time, log_time))
        seen[topic] = (min(lo, log_time), max(hi, log_time))
    await ws.close()
    for topic in ("/world", "/robot", "/tf"):
        if topic not in seen:
            fail(f"{topic}: nothing in {seconds} s")
    return {"topics": {t: {"first_ns": lo, "last_ns": hi} for t, (lo, hi) in seen.items()}}


class Session:
    """One connection whose binary messages on /tf are turned into the robot's positions
    (odom -> base_link, by log time) while the test waits for text replies."""

    def __init__(self, ws, channels):
        self.ws = ws
        self.tf = next(cid for cid, c in channels.items() if c["topic"] == "/tf")
        self.decode = decoder(channels[self.tf])
        self.positions = []  # (log time s, x, y)

    async def subscribe_tf(self):
        await self.ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": self.tf}]}))

    def _binary(self, msg):
        if len(msg) < 13 or msg[0] != OP_MESSAGE_DATA:
            return
        sub_id, log_time = struct.unpack_from("<IQ", msg, 1)
        if sub_id != 1:
            return
        for t in self.decode(msg[13:]).transforms:
            if (t.parent_frame_id, t.child_frame_id) == ("odom", "base_link"):
                self.positions.append((log_time / 1e9, t.translation.x, t.translation.y))

    async def until(self, done, timeout):
        """Reads until `done(text message)` is true; the text messages read meanwhile."""
        seen = []
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no reply within {timeout} s; read {seen}")
            msg = await asyncio.wait_for(self.ws.recv(), left)
            if isinstance(msg, str):
                m = json.loads(msg)
                seen.append(m)
                if done(m):
                    return seen
            else:
                self._binary(msg)

    async def read_for(self, seconds):
        """Reads everything for `seconds` (by the wall clock); the text messages read."""
        seen = []
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                msg = await asyncio.wait_for(self.ws.recv(), max(end - time.monotonic(), 0.001))
            except asyncio.TimeoutError:
                break
            if isinstance(msg, str):
                seen.append(json.loads(msg))
            else:
                self._binary(msg)
        return seen

    def top_speed(self, since_s, window_s=0.5):
        """The fastest the robot went over any `window_s` after `since_s` (robot time), m/s."""
        ps = [p for p in self.positions if p[0] >= since_s]
        best, j = 0.0, 0
        for i, (t, x, y) in enumerate(ps):
            while j < len(ps) and ps[j][0] < t + window_s:
                j += 1
            if j < len(ps):
                t2, x2, y2 = ps[j]
                best = max(best, math.hypot(x2 - x, y2 - y) / (t2 - t))
        return best

    def still_share(self, since_s, until_s, limit=0.02):
        """The share of the intervals between consecutive positions from `since_s` to
        `until_s` (robot time) in which the robot went slower than `limit` m/s."""
        ps = [p for p in self.positions if since_s <= p[0] <= until_s]
        steps = [(b[0] - a[0], math.hypot(b[1] - a[1], b[2] - a[2])) for a, b in zip(ps, ps[1:])]
        steps = [(dt, d) for dt, d in steps if dt > 0]
        return sum(1 for dt, d in steps if d / dt < limit) / len(steps) if steps else 0.0

    async def set(self, request_id, params):
        await self.ws.send(json.dumps({"op": "setParameters", "parameters": params, "id": request_id}))
        seen = await self.until(lambda m: m.get("op") == "parameterValues" and m.get("id") == request_id, 5.0)
        statuses = [m["message"] for m in seen if m.get("op") == "status"]
        if not statuses:
            # An error status may follow the (empty) answer.
            statuses = [m["message"] for m in await self.read_for(0.3) if m.get("op") == "status"]
        return seen[-1]["parameters"], statuses


async def subscribe_parameters(url, names):
    """A second client, subscribed to updates of `names` (spec: "Subscribe Parameter Update")."""
    ws, info, _ = await handshake(url, set())
    if "parametersSubscribe" not in info.get("capabilities", []):
        fail(f"the server does not offer parameter subscriptions: {info.get('capabilities')}")
    await ws.send(json.dumps({"op": "subscribeParameterUpdates", "parameterNames": names}))
    return ws


async def parameter_updates(ws, names, value, timeout):
    """The `parameterValues` pushed to a subscribed client (they carry no request id) until
    every one of `names` was pushed with `value`; fails after `timeout` s."""
    pushed = []
    deadline = time.monotonic() + timeout
    while not all(any(p["name"] == n and p.get("value") == value for p in pushed) for n in names):
        try:
            m = await recv_json(ws, deadline - time.monotonic())
        except (TimeoutError, asyncio.TimeoutError):
            fail(f"within {timeout} s the subscribed client was pushed only {pushed}")
        if m.get("op") == "parameterValues":
            if "id" in m:
                fail(f"a pushed update carries a request id: {m}")
            pushed.extend(m["parameters"])
    return pushed


async def watch_param(url, name, seconds):
    """Subscribes to updates of `name`, says so on stdout (a line `subscribed`), and prints
    every value pushed within `seconds`."""
    ws = await subscribe_parameters(url, [name])
    # The server takes the subscription before anything this client sends after it: a
    # round trip (getParameters) says it has been read.
    await ws.send(json.dumps({"op": "getParameters", "parameterNames": [name], "id": "now"}))
    while True:
        m = await recv_json(ws, 10.0)
        if m.get("op") == "parameterValues" and m.get("id") == "now":
            break
    print("subscribed", flush=True)
    pushed = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            m = await recv_json(ws, end - time.monotonic())
        except (TimeoutError, asyncio.TimeoutError):
            break
        if m.get("op") == "parameterValues" and "id" not in m:
            pushed.extend(m["parameters"])
            break
    await ws.close()
    return {"pushed": pushed}


async def params(url, name, value):
    """Reads the parameters, watches the robot, sets `name` (and the other behaviour's same
    parameter) to `value` while a second client is subscribed to both, sends values that must
    be refused, and watches the robot again."""
    ws, info, channels = await handshake(url, {"/tf"})
    if "parameters" not in info.get("capabilities", []):
        fail(f"the server does not offer parameters: {info.get('capabilities')}")
    s = Session(ws, channels)
    await ws.send(json.dumps({"op": "getParameters", "parameterNames": [], "id": "all"}))
    every = (await s.until(lambda m: m.get("op") == "parameterValues" and m.get("id") == "all", 5.0))[-1]
    names = {p["name"]: p.get("value") for p in every["parameters"]}
    await s.subscribe_tf()
    await s.read_for(4.0)
    if len(s.positions) < 20:
        fail(f"/tf: only {len(s.positions)} positions in 4 s")
    before = s.top_speed(s.positions[0][0])
    field = name.split(".", 1)[1]
    targets = [f"{b}.{field}" for b in ("wallfollow", "centerfollow")]
    other = await subscribe_parameters(url, targets)
    # The subscription is read before the other client's getParameters, answered after it.
    await other.send(json.dumps({"op": "getParameters", "parameterNames": targets, "id": "sub"}))
    while (await recv_json(other, 5.0)).get("id") != "sub":
        pass
    applied, statuses = await s.set("set", [{"name": t, "value": value} for t in targets])
    set_at = s.positions[-1][0] if s.positions else 0.0
    pushed = await parameter_updates(other, targets, value, 5.0)
    refusals = {}
    for label, v in [("negative", -1.0), ("text", "fast"), ("too_fast", 5.0), ("unknown", None)]:
        p = {"name": name, "value": v} if label != "unknown" else {"name": name + "_nope", "value": 1.0}
        got, why = await s.set(label, [p])
        refusals[label] = {"applied": got, "statuses": why}
    await ws.send(json.dumps({"op": "getParameters", "parameterNames": [name], "id": "one"}))
    now = (await s.until(lambda m: m.get("op") == "parameterValues" and m.get("id") == "one", 5.0))[-1]
    # The robot slows at its braking rate, then holds the new top speed.
    await s.read_for(5.0)
    after = s.top_speed(set_at + 1.5)
    # Nothing refused was pushed to the subscribed client.
    late = []
    try:
        while True:
            m = await recv_json(other, 0.2)
            if m.get("op") == "parameterValues":
                late.extend(m["parameters"])
    except (TimeoutError, asyncio.TimeoutError):
        pass
    await other.close()
    await ws.close()
    return {
        "pushed": pushed,
        "pushed_after_refusals": late,
        "parameters": names,
        "applied": applied,
        "set_statuses": statuses,
        "refusals": refusals,
        "now": now["parameters"],
        "speed_before": before,
        "speed_after": after,
        "positions_after": len([p for p in s.positions if p[0] >= set_at + 1.5]),
    }


async def teleop(url):
    """Drives the robot from Foxglove as its Teleop panel does (the spec's client publish): a
    `/cmd_vel` channel of JSON `geometry_msgs/msg/Twist`, zeros ten times a second, which must
    stop the robot the behaviours drive; then TwistStamped zeros stamped 10 s ago, which the
    robot must refuse as stale (it drives on); then bad input: a channel on another topic, a
    message that is not JSON, a lateral speed, each answered with a status."""
    ws, info, channels = await handshake(url, {"/tf"})
    if "clientPublish" not in info.get("capabilities", []):
        fail(f"the server does not take client messages: {info.get('capabilities')}")
    if "json" not in info.get("supportedEncodings", []):
        fail(f"the server does not take JSON: {info.get('supportedEncodings')}")
    s = Session(ws, channels)
    await s.subscribe_tf()
    await s.read_for(3.0)
    if len(s.positions) < 10:
        fail(f"/tf: only {len(s.positions)} positions in 3 s")
    before = s.top_speed(s.positions[0][0])
    await ws.send(json.dumps({"op": "advertise", "channels": [
        {"id": 1, "topic": "/cmd_vel", "encoding": "json", "schemaName": "geometry_msgs/msg/Twist"},
        {"id": 2, "topic": "/cmd_vel", "encoding": "json", "schemaName": "geometry_msgs/msg/TwistStamped"},
        {"id": 3, "topic": "/elsewhere", "encoding": "json", "schemaName": "geometry_msgs/msg/Twist"},
    ]}))

    def data(channel, obj):
        raw = obj if isinstance(obj, bytes) else json.dumps(obj).encode()
        return struct.pack("<BI", 0x01, channel) + raw  # spec: client "Message Data"

    zero = {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    statuses = []

    async def publish(channel, make, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            await ws.send(data(channel, make()))
            statuses.extend(m for m in await s.read_for(0.1) if m.get("op") == "status")

    start = s.positions[-1][0]
    await publish(1, lambda: zero, 3.0)
    # From 1 s on (it brakes meanwhile): a loaded machine that holds this client back for
    # more than the velocity timeout lets the behaviours drive for a moment, as it should.
    end = s.positions[-1][0]
    held = s.still_share(start + 1.0, end)
    held_positions = len([p for p in s.positions if start + 1.0 <= p[0] <= end])

    def stale():
        t = time.time() - 10.0
        return {"header": {"stamp": {"sec": int(t), "nanosec": int((t % 1) * 1e9)}, "frame_id": "base_link"},
                "twist": zero}

    start = s.positions[-1][0]
    await publish(2, stale, 3.0)
    stale_speed = s.top_speed(start + 1.0)
    await ws.send(data(3, zero))
    await ws.send(data(1, b"not json"))
    await ws.send(data(1, {"linear": {"x": 0.1, "y": 0.3, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}))
    statuses.extend(m for m in await s.read_for(1.0) if m.get("op") == "status")
    await ws.close()
    return {
        "speed_before": before,
        "still_share_held": held,
        "positions_held": held_positions,
        "speed_stale": stale_speed,
        "statuses": [{"level": m.get("level"), "message": m.get("message")} for m in statuses],
    }


async def goal(url, x, y, yaw):
    """Sends a navigation goal as the 3D panel's pose tool does, set to publish on /goal_pose: a
    JSON geometry_msgs/msg/PoseStamped in the map frame (the spec's client publish). Then the same
    goal in the odom frame, which must be refused with a status."""
    ws, info, channels = await handshake(url, {"/tf"})
    if "clientPublish" not in info.get("capabilities", []):
        fail(f"the server does not take client messages: {info.get('capabilities')}")
    await ws.send(json.dumps({"op": "advertise", "channels": [
        {"id": 1, "topic": "/goal_pose", "encoding": "json", "schemaName": "geometry_msgs/msg/PoseStamped"},
    ]}))
    now = time.time()

    def pose(frame):
        return {"header": {"stamp": {"sec": int(now), "nanosec": int((now % 1) * 1e9)}, "frame_id": frame},
                "pose": {"position": {"x": x, "y": y, "z": 0.0},
                         "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}}

    statuses = []
    for frame in ["map", "odom"]:
        await ws.send(struct.pack("<BI", 0x01, 1) + json.dumps(pose(frame)).encode())  # client "Message Data"
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            try:
                m = await recv_json(ws, max(0.01, end - time.monotonic()))
            except Exception:
                break
            if m is not None and m.get("op") == "status":
                statuses.append({"level": m.get("level"), "message": m.get("message")})
    await ws.close()
    return {"sent": 2, "statuses": statuses}


def main():
    p = argparse.ArgumentParser()
    p.add_argument("url")
    p.add_argument("--seconds", type=float, default=5.0)
    p.add_argument("--params", nargs=2, metavar=("NAME", "VALUE"))
    p.add_argument("--time-base", action="store_true", help="check every message's stamps only")
    p.add_argument("--watch-param", metavar="NAME", help="print the first update of NAME pushed")
    p.add_argument("--teleop", action="store_true", help="drive the robot by client publish")
    p.add_argument("--goal", metavar="X,Y,YAW", help="send a navigation goal on /goal_pose (yaw in rad)")
    a = p.parse_args()
    if a.goal:
        x, y, yaw = (float(v) for v in a.goal.split(","))
        out = asyncio.run(goal(a.url, x, y, yaw))
    elif a.teleop:
        out = asyncio.run(teleop(a.url))
    elif a.watch_param:
        out = asyncio.run(watch_param(a.url, a.watch_param, a.seconds))
    elif a.time_base:
        out = asyncio.run(time_base(a.url, a.seconds))
    elif a.params:
        out = asyncio.run(params(a.url, a.params[0], json.loads(a.params[1])))
    else:
        out = asyncio.run(watch(a.url, a.seconds))
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
