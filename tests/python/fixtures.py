#!/usr/bin/env python3
"""ROS 2's own message fixtures (`test_msgs.message_fixtures`, from the ros-jazzy-test-msgs wheel) for radar_ros's
run-time types: the oracle is rclpy's own serialization, never radar_ros's code.

    fixtures.py dump     one JSON line per fixture of every test_msgs message type: its type, index, the
                         fixture as plain JSON (float32 fields rounded to float32, bytes and chars as integers)
                         and the CDR body rclpy serializes it to (hex, without the 4-byte encapsulation header)
    fixtures.py check    reads JSON lines {type, index, cdr} (a CDR body written by someone else) and prints
                         {type, index, equal, got}: whether rclpy reads it as that fixture
    fixtures.py mcap F   every message of the MCAP file F read as rosbag2 reads one: its CDR deserialized by
                         rclpy into the class its schema names; prints {topic, schema, msg} (msg as in dump)
    fixtures.py listen   subscribes /fx/<Name> for every type (ROS_DOMAIN_ID from the environment), prints
                         {"ready": true}, then {type, matches} for each message: the indices of the fixtures
                         it equals
"""
import json
import struct
import sys
from typing import Any, List

import rclpy
from rclpy.serialization import deserialize_message, serialize_message
from test_msgs.message_fixtures import get_test_msg
import test_msgs.msg

TYPES = [
    "Arrays", "BasicTypes", "BoundedPlainSequences", "BoundedSequences", "Builtins", "Constants",
    "Defaults", "Empty", "MultiNested", "Nested", "Strings", "UnboundedSequences", "WStrings",
]

HEADER = b"\x00\x01\x00\x00"  # CDR, little-endian


def element_type(ty: str) -> str:
    """The element type of an array or sequence type string as rclpy gives it."""
    if ty.startswith("sequence<"):
        return ty[len("sequence<"):-1].split(",")[0].strip()
    if ty.endswith("]"):
        return ty[:ty.index("[")]
    return ty


def plain_value(v: Any, ty: str) -> Any:
    if hasattr(v, "get_fields_and_field_types"):
        return plain(v)
    is_array = ty.startswith("sequence<") or ty.endswith("]")
    if is_array:
        elem = element_type(ty)
        if isinstance(v, (bytes, bytearray)):
            return list(v)
        return [plain_value(x, elem) for x in v]
    if isinstance(v, (bytes, bytearray)):
        return v[0]
    if ty == "char" and isinstance(v, str):
        return ord(v)
    if ty == "float":
        return struct.unpack("<f", struct.pack("<f", float(v)))[0]
    if ty == "double":
        return float(v)
    if ty == "boolean":
        return bool(v)
    if isinstance(v, str):
        return v
    return int(v)


def plain(msg: Any) -> dict:
    """A message as plain JSON values, field by field."""
    return {name: plain_value(getattr(msg, name), ty)
            for name, ty in msg.get_fields_and_field_types().items()}


def dump() -> None:
    for name in TYPES:
        for i, m in enumerate(get_test_msg(name)):
            print(json.dumps({
                "type": f"test_msgs/msg/{name}",
                "index": i,
                "value": plain(m),
                "cdr": serialize_message(m)[4:].hex(),
            }), flush=True)


def check() -> None:
    for line in sys.stdin:
        if not line.strip():
            continue
        q = json.loads(line)
        name = q["type"].rsplit("/", 1)[1]
        cls = getattr(test_msgs.msg, name)
        try:
            got = deserialize_message(HEADER + bytes.fromhex(q["cdr"]), cls)
            equal = got == get_test_msg(name)[q["index"]]
            shown = repr(got)
        except Exception as e:  # a body rclpy cannot read is a finding, reported as such
            equal, shown = False, f"unreadable: {e!r}"
        print(json.dumps({"type": q["type"], "index": q["index"], "equal": equal, "got": shown}), flush=True)


def mcap(path: str) -> None:
    import importlib

    from mcap.reader import make_reader

    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if channel.message_encoding != "cdr":
                continue  # radar record's own /radar/trace (JSON), not a ROS message
            pkg, kind, name = schema.name.split("/")
            cls = getattr(importlib.import_module(f"{pkg}.{kind}"), name)
            m = deserialize_message(message.data, cls)
            print(json.dumps({"topic": channel.topic, "schema": schema.name, "msg": plain(m)}), flush=True)


def listen() -> None:
    rclpy.init()
    node = rclpy.create_node("fixtures_listener")
    subs: List[Any] = []

    def on(name: str) -> Any:
        fixtures = get_test_msg(name)

        def cb(m: Any) -> None:
            print(json.dumps({
                "type": f"test_msgs/msg/{name}",
                "matches": [i for i, f in enumerate(fixtures) if f == m],
                "got": repr(m),
            }), flush=True)
        return cb

    for name in TYPES:
        subs.append(node.create_subscription(getattr(test_msgs.msg, name), f"/fx/{name}", on(name), 10))
    print(json.dumps({"ready": True}), flush=True)
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    if sys.argv[1] == "mcap":
        mcap(sys.argv[2])
    else:
        {"dump": dump, "check": check, "listen": listen}[sys.argv[1]]()
