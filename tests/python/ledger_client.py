#!/usr/bin/env python3
"""Checks orsa's delivery ledger across processes from outside, written from
docs/wire-format.md (section 2, "The attachment"; section 8, the stats) with eclipse-zenoh and
cbor2 only, none of orsa's code:

1. the robot's stream updates carry `<zid>/<outlet>/<n>` attachments, with the robot's zid, one
   outlet per stream and consecutive numbers;
2. Send messages this client numbers itself, with some numbers skipped and one sent twice,
   are counted by the robot as missing and duplicated in its stats.

    ledger_client.py --connect tcp/127.0.0.1:7447 --prefix orsa

Exits 0 and prints `ledger: ok ...` when every check holds; otherwise exits non-zero saying
which did not.
"""

import argparse
import json
import sys
import threading
import time

import cbor2
import zenoh


def fail(why):
    sys.exit(f"ledger_client: {why}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", required=True)
    parser.add_argument("--prefix", default="orsa")
    args = parser.parse_args()
    root = f"{args.prefix}/v1"

    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([args.connect]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(conf)
    me = str(session.info.zid())
    token = session.liveliness().declare_token(f"{root}/alive/proc/{me}/tool")

    # The robot's zid, from its process token.
    robot = None
    deadline = time.monotonic() + 30
    while robot is None and time.monotonic() < deadline:
        for reply in session.liveliness().get(f"{root}/alive/proc/*/robot", timeout=2):
            if reply.ok is not None:
                robot = str(reply.ok.key_expr).split("/")[-2]
    if robot is None:
        fail("no robot process token within 30 s")

    # 1. Subscribe to the base state, every update, and read the attachments.
    seen = []
    got = threading.Condition()

    def on_update(sample):
        with got:
            seen.append(sample.attachment.to_bytes().decode() if sample.attachment else None)
            got.notify_all()

    sub = session.declare_subscriber(f"{root}/svc/nomad200/basestate/push/1", on_update)
    request = {"op": "subscribe", "every": 1, "client": me, "id": 1}
    for reply in session.get(f"{root}/svc/nomad200/basestate/subscribe", payload=cbor2.dumps(request), timeout=5):
        answer = cbor2.loads(reply.ok.payload.to_bytes()) if reply.ok is not None else None
        if answer != {"ok": None}:
            fail(f"subscribe answered {answer!r}")
    with got:
        if not got.wait_for(lambda: len(seen) >= 10, timeout=10):
            fail(f"{len(seen)} base states in 10 s")
        first = list(seen[:10])
    parts = [a.split("/") if a else None for a in first]
    if any(p is None or len(p) != 3 for p in parts):
        fail(f"attachments are not <zid>/<outlet>/<n>: {first}")
    if {p[0] for p in parts} != {robot}:
        fail(f"attachments name {sorted({p[0] for p in parts})}, the robot is {robot}")
    if len({p[1] for p in parts}) != 1:
        fail(f"one stream, several outlets: {first}")
    numbers = [int(p[2]) for p in parts]
    if numbers != list(range(numbers[0], numbers[0] + 10)):
        fail(f"numbers not consecutive: {numbers}")

    # 2. Numbered Send messages with gaps and a duplicate: zero velocity on the teleop input.
    teleop = f"{root}/svc/nomad200/teleop/send"
    sent = [1, 2, 3, 5, 6, 6, 9, 10]  # 4, 7 and 8 never sent; 6 twice
    outlet = 7
    for seq, n in enumerate(sent, start=1):
        now = time.time_ns()
        value = {"stamp": now, "v_m_s": 0.0, "omega_rad_s": 0.0}
        message = cbor2.dumps({"seq": seq, "stamp_ns": now, "value": value})
        session.put(teleop, message, attachment=f"{me}/{outlet}/{n}")
    stats = None
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        for reply in session.get(f"{root}/stats/{robot}", timeout=2):
            if reply.ok is not None:
                stats = cbor2.loads(reply.ok.payload.to_bytes()).get("ok")
        if stats and stats.get("missing") == 3 and stats.get("duplicated") == 1:
            break
        time.sleep(0.05)
    if not stats or stats.get("missing") != 3 or stats.get("duplicated") != 1:
        fail(f"the robot's stats after 4, 7, 8 skipped and 6 sent twice: {stats}")

    sub.undeclare()
    token.undeclare()
    session.close()
    print(f"ledger: ok: base state outlet {parts[0][1]} numbers {numbers[0]}..{numbers[-1]}; "
          f"robot counted missing {stats['missing']} duplicated {stats['duplicated']}")


if __name__ == "__main__":
    main()
