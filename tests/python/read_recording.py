"""Reads an orsa recording with the `mcap` Python package alone, as a user's tool would.

Prints, as JSON: the `run` metadata's keys, the world and config it holds (parsed with the
standard library's TOML reader; a process that simulates no world records none), the message
count per topic, the count per topic of messages that came from another process (channels
whose metadata says `orsa.from`), the count per topic of the views (protobuf channels for
Foxglove, which `read_views.py` decodes), and the log time span. Exits non-zero, naming what
is wrong, if the file is not a finished MCAP file, a message of a JSON channel is not JSON, a
channel is neither JSON nor protobuf, or the metadata is missing what a replay needs.
"""

import json
import sys
import tomllib

from mcap.reader import make_reader

REQUIRED = ["orsa", "wire", "process", "world", "world_toml", "seed", "duration_s",
            "config_toml", "hosted", "robot", "clock", "clock_origin_ns"]



def robot_name(config):
    """The robot server's name: the first component of kind robot or nomad200 in [system]."""
    for c in config.get("system", {}).get("components", []):
        if c.get("kind", c["name"]) in ("robot", "nomad200"):
            return c["name"]
    return "nomad200"

def main(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        if summary is None:
            sys.exit(f"{path}: no summary section: the file was not finished")
        runs = [m for m in reader.iter_metadata() if m.name == "run"]
        if len(runs) != 1:
            sys.exit(f"{path}: {len(runs)} 'run' metadata records, expected 1")
        meta = runs[0].metadata
        missing = [k for k in REQUIRED if k not in meta]
        if missing:
            sys.exit(f"{path}: the 'run' metadata lacks {missing}")
        # The run's end, written as the file closes (absent in older recordings).
        ended = [m.metadata for m in reader.iter_metadata() if m.name == "run_ended"]
        if len(ended) > 1:
            sys.exit(f"{path}: {len(ended)} 'run_ended' metadata records, expected at most 1")
        config = tomllib.loads(meta["config_toml"])
        world = tomllib.loads(meta["world_toml"])
        counts = {}
        remote = {}
        views = {}
        first, last = None, None
        for schema, channel, message in reader.iter_messages():
            encodings = (channel.message_encoding, schema.encoding)
            if encodings == ("protobuf", "protobuf"):
                views[channel.topic] = views.get(channel.topic, 0) + 1
            elif encodings != ("json", "jsonschema"):
                sys.exit(f"{path}: channel {channel.topic} is {channel.message_encoding}/{schema.encoding}")
            else:
                try:
                    json.loads(message.data)
                except ValueError as e:
                    sys.exit(f"{path}: channel {channel.topic}, log time {message.log_time}: not JSON: {e}")
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.metadata.get("orsa.from") == "another process":
                remote[channel.topic] = remote.get(channel.topic, 0) + 1
            first = message.log_time if first is None else min(first, message.log_time)
            last = message.log_time if last is None else max(last, message.log_time)
    print(json.dumps({
        "metadata_keys": sorted(meta),
        "seed": int(meta["seed"]),
        "process": meta["process"],
        "clock": meta["clock"],
        "clock_origin_ns": int(meta["clock_origin_ns"]),
        "ended": {"at_ns": int(ended[0]["at_ns"]), "how": ended[0].get("how")} if ended else None,
        "robot_name": robot_name(config),
        "config_sections": sorted(config),
        "world_name": world.get("name"),
        "hosted": meta["hosted"].split(","),
        "counts": counts,
        "from_other_processes": remote,
        "views": views,
        "first_log_time": first,
        "last_log_time": last,
    }))


if __name__ == "__main__":
    main(sys.argv[1])
