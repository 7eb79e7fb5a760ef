#!/usr/bin/env python3
"""A client of a running `orsa robot` in Python, with nothing of orsa: only zenoh and CBOR.

It follows docs/wire-format.md step by step:

1. joins the zenoh network and announces itself with a process token
   (`orsa/v1/alive/proc/<zid>/teleop`), so the robot drops what it holds for this client the
   moment the client is gone;
2. waits for the robot's service tokens and checks the communication object identifiers
   (`orsa.nomad200.DistanceScan/1`, `orsa.nomad200.NavigationVelocity/1`, ...);
3. asks `nomad200/robotparams` (Query) for the infrared ring's geometry;
4. subscribes to every 10th infrared scan (Push timed handshake: a subscriber on
   `.../distanceir/push/10`, then a `subscribe` request) and prints the ring (`--ring
   distanceson` for the sonar ring); if the robot restarts, subscribes again;
5. after a few scans, drives the robot by hand: `nomad200/teleop` (Send), 10 commands a
   second for 2 s, then a zero command;
6. asks `nomad200/safety` what the robot did with the commands, unsubscribes, and leaves.

Every message that fails to decode is counted and logged, never raised.

    python3 -m venv /tmp/zvenv && /tmp/zvenv/bin/pip install "eclipse-zenoh>=1.10,<1.11" cbor2
    /tmp/zvenv/bin/python docs/examples/python_client.py --connect tcp/127.0.0.1:7447
"""

import argparse
import json
import logging
import math
import sys
import threading
import time

import cbor2
import zenoh

log = logging.getLogger("orsa-python-client")

# The communication objects this client speaks, with the versions it understands.
DISTANCE_SCAN = "orsa.nomad200.DistanceScan/1"
NAVIGATION_VELOCITY = "orsa.nomad200.NavigationVelocity/1"
EMPTY = "orsa.Empty/1"
ROBOT_PARAMS = "orsa.nomad200.RobotParams/1"
SAFETY_COUNTERS = "orsa.nomad200.SafetyCounters/1"


class Orsa:
    """One zenoh session into an orsa system, with the key layout of wire format v1."""

    def __init__(self, args):
        conf = zenoh.Config.from_file(args.zenoh_config) if args.zenoh_config else zenoh.Config()
        if not args.zenoh_config:
            # What orsa itself sets when no configuration file is given: peer mode and a 1 s
            # lease, so that the robot notices within 1 s that this client went silent.
            conf.insert_json5("mode", '"peer"')
            conf.insert_json5("transport/link/tx/lease", "1000")
            conf.insert_json5("transport/link/tx/keep_alive", "4")
        if args.connect:
            conf.insert_json5("connect/endpoints", json.dumps(args.connect))
            conf.insert_json5("scouting/multicast/enabled", "false")
        self.session = zenoh.open(conf)
        self.zid = str(self.session.info.zid())
        self.root = f"{args.prefix}/v1"
        self.decode_errors = 0
        self.services = {}  # "component/service" -> (host zid, pattern, [identifiers])
        self.changed = threading.Condition()
        self.on_service_back = []  # callbacks(addr) when a service (re)appears
        # 1. Announce this process. Keep the token: dropping it tells every peer we are gone.
        self.token = self.session.liveliness().declare_token(f"{self.root}/alive/proc/{self.zid}/{args.role}")
        # 2. Discovery: every service token, those already there included (history).
        self.svc_sub = self.session.liveliness().declare_subscriber(
            f"{self.root}/alive/svc/**", self._on_service_token, history=True
        )

    # -- decoding that never raises --------------------------------------------------------
    def decode(self, payload: bytes, what: str):
        """CBOR-decodes a payload; on failure counts it, logs it and answers None."""
        try:
            return cbor2.loads(payload)
        except Exception as e:  # noqa: BLE001 - any malformed input is the sender's fault
            self.decode_errors += 1
            log.warning("dropped an undecodable %s (%d bytes): %s", what, len(payload), e)
            return None

    # -- discovery -------------------------------------------------------------------------
    def _on_service_token(self, sample):
        key = str(sample.key_expr)
        rest = key[len(f"{self.root}/alive/svc/"):].split("/")
        if len(rest) != 5:
            log.warning("ignoring a malformed service token %s", key)
            return
        host, component, service, pattern, types = rest
        addr = f"{component}/{service}"
        ids = [t.replace("@", "/") for t in types.split(",")]
        with self.changed:
            if sample.kind == zenoh.SampleKind.PUT:
                self.services[addr] = (host, pattern, ids)
            elif self.services.get(addr, (None,))[0] == host:
                del self.services[addr]
            self.changed.notify_all()
        if sample.kind == zenoh.SampleKind.PUT:
            for f in list(self.on_service_back):
                f(addr)

    def wait_for(self, addr: str, pattern: str, ids: list, timeout: float):
        """Waits until `addr` is announced, and checks its pattern and identifiers."""
        deadline = time.monotonic() + timeout
        with self.changed:
            while addr not in self.services:
                left = deadline - time.monotonic()
                if left <= 0:
                    sys.exit(f"no peer offers {addr} after {timeout} s (is the robot running?)")
                self.changed.wait(left)
            host, found_pattern, found_ids = self.services[addr]
        if (found_pattern, found_ids) != (pattern, ids):
            sys.exit(f"{addr} is {found_pattern} of {found_ids}; this client speaks {pattern} of {ids}")
        return host

    # -- keys ------------------------------------------------------------------------------
    def svc(self, addr: str, what: str) -> str:
        return f"{self.root}/svc/{addr}/{what}"

    # -- Query, and the control requests (subscribe, activate): a zenoh get -----------------
    def request(self, key: str, message, timeout: float = 5.0):
        """Sends one request; answers the decoded `ok` value or raises with the `err`."""
        replies = self.session.get(key, payload=cbor2.dumps(message), timeout=timeout)
        for reply in replies:
            if reply.ok is None:
                raise RuntimeError(f"{key}: zenoh error {reply.err.payload.to_bytes()!r}")
            answer = self.decode(reply.ok.payload.to_bytes(), f"reply from {key}")
            if isinstance(answer, dict) and "ok" in answer:
                return answer["ok"]
            if isinstance(answer, dict) and "err" in answer:
                err = answer["err"]
                raise RuntimeError(f"{key}: {err['code']}: {err['message']}")
            raise RuntimeError(f"{key}: a reply that is neither ok nor err: {answer!r}")
        raise TimeoutError(f"{key}: no reply within {timeout} s")

    def query(self, addr: str, value, seq: int):
        """Query pattern: the request is a stamped envelope; the answer comes back in one."""
        now = time.time_ns()
        answer = self.request(self.svc(addr, "request"), {"seq": seq, "stamp_ns": now, "value": value})
        return answer["value"]


def ring_header(name, angles, max_range_m):
    """The column heads: each sensor's direction, degrees counter-clockwise from the front."""
    heads = " ".join(f"{round(math.degrees(a)):>4}" for a in angles)
    return f"{name} ring, m ('-': nothing within {max_range_m} m); sensor direction, deg:\n" \
           f"{'seq':>10} {'age ms':>6}  {heads}"


def ring_row(name, msg, age_ms):
    """One line per scan: each sensor's distance, '-' when its reading is not valid."""
    cells = " ".join(f"{r['distance_m']:4.2f}" if r["valid"] else "   -" for r in msg["value"]["readings"])
    return f"{name[:5]:<5} {msg['seq']:>4} {age_ms:6.1f}  {cells}"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                   help="zenoh endpoint of the robot, e.g. tcp/127.0.0.1:7447 (repeatable)")
    p.add_argument("--zenoh-config", metavar="PATH", help="zenoh configuration file (JSON5), e.g. for TLS")
    p.add_argument("--prefix", default="orsa", help="key prefix (orsa's --prefix)")
    p.add_argument("--robot", default="nomad200", help="the robot component")
    p.add_argument("--role", default="teleop", help="role in the process token")
    p.add_argument("--ring", choices=["distanceir", "distanceson"], default="distanceir",
                   help="the ring to print: infrared (default) or sonar")
    p.add_argument("--every", type=int, default=10, help="every n-th scan")
    p.add_argument("--scans", type=int, default=5, help="scans to print before driving")
    p.add_argument("--v", type=float, default=0.2, help="teleop translation velocity, m/s")
    p.add_argument("--omega", type=float, default=0.0, help="teleop turn rate, rad/s")
    p.add_argument("--for", dest="for_s", type=float, default=2.0, help="seconds to drive")
    p.add_argument("--rate", type=float, default=10.0, help="commands per second")
    p.add_argument("--wait", type=float, default=30.0, help="seconds to wait for the robot")
    args = p.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")

    orsa = Orsa(args)
    robot = args.robot
    print(f"client: zenoh id {orsa.zid}, waiting for {robot}")
    ring = f"{robot}/{args.ring}"
    orsa.wait_for(ring, "push_timed", [DISTANCE_SCAN], args.wait)
    orsa.wait_for(f"{robot}/teleop", "send", [NAVIGATION_VELOCITY], args.wait)
    orsa.wait_for(f"{robot}/robotparams", "query", [EMPTY, ROBOT_PARAMS], args.wait)
    orsa.wait_for(f"{robot}/safety", "query", [EMPTY, SAFETY_COUNTERS], args.wait)

    # 3. The robot's geometry, so nothing about the ring is hard-coded here.
    params = orsa.query(f"{robot}/robotparams", {}, seq=1)
    name = "infrared" if args.ring == "distanceir" else "sonar"
    angles, max_range = params[name]["angles_rad"], params[name]["max_range_m"]
    print(f"robotparams: body radius {params['body_radius_m']} m, max v {params['max_v_m_s']} m/s, "
          f"{len(angles)} {name} sensors to {max_range} m")

    # 4. Every n-th scan. The subscriber first, so the first update is not missed.
    scans = threading.Semaphore(0)

    def on_scan(sample):
        msg = orsa.decode(sample.payload.to_bytes(), DISTANCE_SCAN)
        try:
            age_ms = (time.time_ns() - msg["stamp_ns"]) / 1e6  # both UNIX time: same host or NTP
            print(ring_row(name, msg, age_ms), flush=True)
        except (TypeError, KeyError, IndexError, ValueError) as e:
            if msg is not None:  # decodable CBOR, but not a DistanceScan/1
                orsa.decode_errors += 1
                log.warning("dropped a message that is not a %s: %s", DISTANCE_SCAN, e)
            return
        scans.release()

    stream = orsa.session.declare_subscriber(orsa.svc(ring, f"push/{args.every}"), on_scan)
    print(ring_header(name, angles, max_range))
    subscribe = {"op": "subscribe", "every": args.every, "client": orsa.zid, "id": 1}
    orsa.request(orsa.svc(ring, "subscribe"), subscribe)
    # Renewal: if the robot restarts, its service token reappears and the new process knows
    # nothing of us: subscribe again (the same request again is harmless).
    def renew(addr):
        if addr != ring:
            return

        def again():
            try:
                orsa.request(orsa.svc(ring, "subscribe"), subscribe)
                log.info("%s is back: subscribed again", ring)
            except Exception as e:  # noqa: BLE001 - logged; the next reappearance retries
                log.warning("cannot subscribe again to %s: %s", ring, e)

        threading.Thread(target=again, daemon=True).start()  # not in zenoh's callback thread

    orsa.on_service_back.append(renew)
    for _ in range(args.scans):
        if not scans.acquire(timeout=10):
            sys.exit(f"no {name} scan within 10 s")

    # 5. Teleoperation: a stamped NavigationVelocity on nomad200/teleop, `rate` times a second.
    teleop = orsa.session.declare_publisher(
        orsa.svc(f"{robot}/teleop", "send"), express=True, congestion_control=zenoh.CongestionControl.DROP
    )
    seq = 0

    def send(v, omega):
        nonlocal seq
        seq += 1
        now = time.time_ns()  # UNIX time in ns: the robot judges the command by `stamp`
        value = {"stamp": now, "v_m_s": float(v), "omega_rad_s": float(omega)}
        teleop.put(cbor2.dumps({"seq": seq, "stamp_ns": now, "value": value}))

    print(f"driving: v {args.v} m/s, omega {args.omega} rad/s for {args.for_s} s", flush=True)
    end = time.monotonic() + args.for_s
    while time.monotonic() < end:
        send(args.v, args.omega)
        time.sleep(1.0 / args.rate)
    send(0.0, 0.0)
    print(f"stopped: {seq} commands sent", flush=True)
    time.sleep(0.2)

    # 6. What the robot did with them.
    safety = orsa.query(f"{robot}/safety", {}, seq=2)
    print(f"safety: {safety}")
    orsa.request(orsa.svc(ring, "subscribe"), {"op": "unsubscribe", "client": orsa.zid, "id": 1})
    stream.undeclare()
    teleop.undeclare()
    print(f"undecodable messages: {orsa.decode_errors}")
    orsa.session.close()


if __name__ == "__main__":
    main()
