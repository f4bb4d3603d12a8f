"""Run by test_payload.py in a process of its own (definitions are read once per process): rosidl objects
written as CDR by the package (`radar_ros._payload.encode`, its native encoder when the class matches the
definition found), judged by rclpy alone: `deserialize_message` must read each body back as the object written.

    rosidl_encoding.py fixtures     every fixture of every test_msgs type (ROS 2's own `message_fixtures`), and
                                    values rclpy's setters would not make (wrong array types, out of range)
    rosidl_encoding.py mismatched   with another definition of test_msgs/msg/BasicTypes found first: that
                                    class and those nesting it are left to rclpy, the others are not

Prints one JSON line of counts; any disagreement is an AssertionError (exit status 1).
"""

from __future__ import annotations

import array
import json
import math
import os
import sys
import tempfile
from typing import Any, Dict, List

os.environ.pop("AMENT_PREFIX_PATH", None)  # the definitions come from the directories given below only

import numpy
import test_msgs.msg
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Header
from test_msgs.message_fixtures import get_test_msg

import radar_ros
from radar_ros import PayloadTypeError, _payload

TYPES = [
    "Arrays", "BasicTypes", "BoundedPlainSequences", "BoundedSequences", "Builtins", "Constants",
    "Defaults", "Empty", "MultiNested", "Nested", "Strings", "UnboundedSequences", "WStrings",
]
HEADER = b"\x00\x01\x00\x00"  # CDR, little-endian: what rclpy puts before a body


def read_back(cls: type, body: bytes) -> Any:
    return deserialize_message(HEADER + body, cls)


def check_all_fixtures(expect_native: Dict[str, bool]) -> int:
    checked = 0
    for name in TYPES:
        cls = getattr(test_msgs.msg, name)
        ros_type = f"test_msgs/msg/{name}"
        native = _payload.native_encoder(cls, ros_type) is not None
        assert native == expect_native.get(name, True), f"{ros_type}: native encoder {native}"
        for i, msg in enumerate(get_test_msg(name)):
            body = _payload.encode(msg, ros_type)
            assert read_back(cls, body) == msg, f"{ros_type} fixture {i}: rclpy reads {body.hex()} otherwise"
            checked += 1
    return checked


def refused(msg: Any, ros_type: str, says: str) -> None:
    try:
        _payload.encode(msg, ros_type)
    except PayloadTypeError as e:
        assert says in str(e), f"{says!r} not in {e}"
        return
    raise AssertionError(f"{ros_type}: encoded where {says!r} was expected")


def beyond_setters() -> List[str]:
    """Values rclpy's property setters would convert or refuse, put in the slots directly."""
    done = []
    seq = test_msgs.msg.UnboundedSequences()
    # arrays that are not what rosidl stores: written element by element, read back the same
    seq._float32_values = array.array("d", [1.5, -2.25])
    seq._int16_values = numpy.array([1, -2, 300], dtype=numpy.int64)
    seq._uint8_values = b"\x00\x07\xff"
    seq._float64_values = [0.5, 1e300]
    got = read_back(test_msgs.msg.UnboundedSequences, _payload.encode(seq, "test_msgs/msg/UnboundedSequences"))
    assert list(got.float32_values) == [1.5, -2.25] and list(got.int16_values) == [1, -2, 300]
    assert list(got.uint8_values) == [0, 7, 255] and list(got.float64_values) == [0.5, 1e300]
    done.append("converted arrays")
    # a large array copied whole, and floats that are not numbers
    seq = test_msgs.msg.UnboundedSequences()
    seq.float64_values = array.array("d", (i / 7 for i in range(100_000)))
    seq.float32_values = array.array("f", [math.nan, math.inf, -0.0])
    seq.int64_values = array.array("q", [-(2**63), 2**63 - 1])
    got = read_back(test_msgs.msg.UnboundedSequences, _payload.encode(seq, "test_msgs/msg/UnboundedSequences"))
    assert list(got.float64_values) == list(seq.float64_values)
    assert math.isnan(got.float32_values[0]) and got.float32_values[1] == math.inf
    assert math.copysign(1, got.float32_values[2]) == -1 and list(got.int64_values) == [-(2**63), 2**63 - 1]
    arrays = test_msgs.msg.Arrays()
    arrays.float64_values = numpy.array([math.nan, 1.0, -math.inf])
    got = read_back(test_msgs.msg.Arrays, _payload.encode(arrays, "test_msgs/msg/Arrays"))
    assert numpy.array_equal(got.float64_values, arrays.float64_values, equal_nan=True)
    done.append("large and non-finite arrays")
    # what cannot be written says which field and why
    basic = test_msgs.msg.BasicTypes()
    basic._int32_value = 2**31
    refused(basic, "test_msgs/msg/BasicTypes", "test_msgs/msg/BasicTypes.int32_value: 2147483648 is out of")
    basic = test_msgs.msg.BasicTypes()
    basic._float64_value = "fast"
    refused(basic, "test_msgs/msg/BasicTypes", "test_msgs/msg/BasicTypes.float64_value: 'fast' is no float64")
    nested = test_msgs.msg.Nested()
    nested.basic_types_value._bool_value = 2
    refused(nested, "test_msgs/msg/Nested", "test_msgs/msg/Nested.basic_types_value.bool_value: 2 is no bool")
    strings = test_msgs.msg.Strings()
    strings._bounded_string_value = "x" * 23
    refused(strings, "test_msgs/msg/Strings", "bounded_string_value: at most 22 characters, not 23")
    arrays = test_msgs.msg.Arrays()
    arrays._int32_values = numpy.array([1, 2], dtype=numpy.int32)
    refused(arrays, "test_msgs/msg/Arrays", "test_msgs/msg/Arrays.int32_values: exactly 3 elements, not 2")
    bounded = test_msgs.msg.BoundedSequences()
    bounded._string_values = ["a", "b", "c", "d"]
    refused(bounded, "test_msgs/msg/BoundedSequences", "string_values: at most 3 elements, not 4")
    done.append("refusals")
    return done


def main() -> None:
    mode = sys.argv[1]
    radar_ros.add_interfaces_dir(os.path.join(sys.prefix, "share"))  # the venv's share/<pkg>/msg
    # without any definition directory: the interfaces radar_ros ships (std_msgs) are written natively
    assert _payload.native_encoder(Header, "std_msgs/msg/Header") is not None
    header = Header(frame_id="base_link")
    header.stamp.sec, header.stamp.nanosec = -5, 999_999_999
    assert read_back(Header, _payload.encode(header, "std_msgs/msg/Header")) == header
    if mode == "fixtures":
        counts: Dict[str, Any] = {"fixtures": check_all_fixtures({}), "beyond_setters": beyond_setters()}
    elif mode == "mismatched":
        own = tempfile.mkdtemp()
        os.makedirs(os.path.join(own, "test_msgs", "msg"))
        with open(os.path.join(sys.prefix, "share", "test_msgs", "msg", "BasicTypes.msg")) as f:
            text = f.read()
        assert "\nint32 int32_value" in text, text
        with open(os.path.join(own, "test_msgs", "msg", "BasicTypes.msg"), "w") as f:
            f.write(text.replace("\nint32 int32_value", "\nuint32 int32_value"))  # another version's
        radar_ros.add_interfaces_dir(own)  # looked in before the venv's
        off = {name: False for name in ("BasicTypes", "Nested", "Arrays", "BoundedSequences",
                                        "UnboundedSequences", "MultiNested", "BoundedPlainSequences")}
        counts = {"fixtures": check_all_fixtures(off)}
        # what rclpy wrote, byte for byte, for a class left to it
        msg = get_test_msg("BasicTypes")[1]
        assert _payload.encode(msg, "test_msgs/msg/BasicTypes") == serialize_message(msg)[4:]
    else:
        raise SystemExit(f"unknown mode {mode}")
    print(json.dumps(counts))


if __name__ == "__main__":
    main()
