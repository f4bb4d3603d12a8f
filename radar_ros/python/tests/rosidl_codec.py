"""Run by test_payload.py in a process of its own (definitions are read once per process): rosidl objects
written as CDR and read from it by the package (`radar_ros._payload.encode` and `decode`, its native codec when
the class matches the definition found), judged by rclpy alone: `deserialize_message` must read each body the
package wrote as the object written, and each body rclpy wrote must be read by the package as rclpy reads it,
field types (numpy arrays, `array.array` type codes, lists, bytes) included.

    rosidl_codec.py fixtures     every fixture of every test_msgs type (ROS 2's own `message_fixtures`), values
                                 rclpy's setters would not make (wrong array types, out of range), and
                                 malformed bodies
    rosidl_codec.py mismatched   with another definition of test_msgs/msg/BasicTypes found first: that class
                                 and those nesting it are left to rclpy, the others are not

Prints one JSON line of counts; any disagreement is an AssertionError (exit status 1).
"""

from __future__ import annotations

import array
import json
import math
import os
import struct
import sys
import tempfile
from typing import Any, Dict, List

os.environ.pop("AMENT_PREFIX_PATH", None)  # the definitions come from the directories given below only
# rosidl's setters check what they are given (off by default): an object the package reads must check alike
# (mode `unchecked`: off, as by default)
CHECKED = sys.argv[1:2] != ["unchecked"]
os.environ["ROS_PYTHON_CHECK_FIELDS"] = "1" if CHECKED else "0"

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


def shape(v: Any) -> Any:
    """What a value is made of, beyond equality: its type, a numpy array's dtype, an array's type code, and the
    same of every field and element."""
    if hasattr(v, "get_fields_and_field_types"):
        return (type(v), [(f, shape(getattr(v, f))) for f in v.get_fields_and_field_types()])
    if isinstance(v, numpy.ndarray):
        return ("ndarray", str(v.dtype), v.shape, v.flags.writeable)
    if isinstance(v, array.array):
        return ("array", v.typecode)
    if isinstance(v, list):
        return ("list", [shape(x) for x in v])
    return type(v)


def check_all_fixtures(expect_native: Dict[str, bool]) -> int:
    checked = 0
    for name in TYPES:
        cls = getattr(test_msgs.msg, name)
        ros_type = f"test_msgs/msg/{name}"
        native = _payload.native_codec(cls, ros_type) is not None
        assert native == expect_native.get(name, True), f"{ros_type}: native codec {native}"
        for i, msg in enumerate(get_test_msg(name)):
            body = _payload.encode(msg, ros_type)
            assert read_back(cls, body) == msg, f"{ros_type} fixture {i}: rclpy reads {body.hex()} otherwise"
            theirs = serialize_message(msg)[4:]
            ours, rclpys = _payload.decode(theirs, ros_type), read_back(cls, theirs)
            assert ours == rclpys == msg, f"{ros_type} fixture {i}: read as {ours}"
            assert shape(ours) == shape(rclpys), f"{ros_type} fixture {i}: {shape(ours)} != {shape(rclpys)}"
            checked += 1
    return checked


def malformed() -> List[str]:
    """Bodies that are not their type's: an error naming the type and where, never a crash or a huge allocation."""
    done = []
    body = _payload.encode(get_test_msg("Strings")[1], "test_msgs/msg/Strings")
    for cut in (0, 3, len(body) // 2, len(body) - 1):
        try:
            _payload.decode(body[:cut], "test_msgs/msg/Strings")
        except PayloadTypeError as e:
            assert str(e).startswith("test_msgs/msg/Strings."), e
        else:
            raise AssertionError(f"a Strings body cut at {cut} was read")
    done.append("cut short")
    huge = b"\xff\xff\xff\x7f" + bytes(64)  # a sequence of 2**31 - 1 elements in 68 bytes
    for name in ("UnboundedSequences", "WStrings"):
        try:
            _payload.decode(huge, f"test_msgs/msg/{name}")
        except PayloadTypeError as e:
            assert f"test_msgs/msg/{name}." in str(e), e
        else:
            raise AssertionError(f"{name}: a length beyond the body was read")
    done.append("lengths beyond the body")
    strings = test_msgs.msg.Strings(string_value="ok")
    bad = bytearray(_payload.encode(strings, "test_msgs/msg/Strings"))
    bad[4] = 0xFF  # not UTF-8
    try:
        _payload.decode(bytes(bad), "test_msgs/msg/Strings")
    except PayloadTypeError as e:
        assert "test_msgs/msg/Strings.string_value" in str(e) and "UTF-8" in str(e), e
    else:
        raise AssertionError("a string that is not UTF-8 was read")
    done.append("not UTF-8")
    return done


def beyond_bounds() -> List[str]:
    """A bounded string or sequence longer than its bound (a faulty writer's; rclpy never writes one) is read as
    rclpy reads it: a sequence whole; a string whole when the classes do not check their fields, refused by field
    when they do (rclpy's reading fails in the string's setter then). The package never writes either back."""
    done = []
    strings = test_msgs.msg.Strings(bounded_string_value="x" * 22)
    sequences = test_msgs.msg.BoundedPlainSequences(int32_values=[11, 22, 33])
    for msg, old, new, what, unit in (
        (strings, struct.pack("<I", 23) + b"x" * 22 + b"\0", struct.pack("<I", 31) + b"x" * 30 + b"\0",
         "bounded_string_value", "30 characters, at most 22"),
        (sequences, struct.pack("<4i", 3, 11, 22, 33), struct.pack("<6i", 5, 11, 22, 33, 44, 55), "int32_values",
         None),
    ):
        theirs = serialize_message(msg)[4:]
        assert theirs.count(old) == 1, theirs.hex()
        body = theirs.replace(old, new)  # 8 bytes longer: every later field keeps its alignment
        ros_type = f"test_msgs/msg/{type(msg).__name__}"
        if CHECKED and unit is not None:
            try:
                read_back(type(msg), body)
            except Exception:
                pass
            else:
                raise AssertionError(f"{what}: rclpy read it with its fields checked")
            try:
                _payload.decode(body, ros_type)
            except PayloadTypeError as e:
                assert f"{ros_type}.{what}: {unit}" in str(e), e
            else:
                raise AssertionError(f"{what}: read with its fields checked")
        else:
            ours, rclpys = _payload.decode(body, ros_type), read_back(type(msg), body)
            assert ours == rclpys and getattr(ours, what) != getattr(msg, what), f"{what}: read as {ours}"
            assert shape(ours) == shape(rclpys), f"{what}: {shape(ours)} != {shape(rclpys)}"
            refused(ours, ros_type, f"{ros_type}.{what}: at most")
        done.append(what)
    return done


def read_objects_behave_as_rclpys() -> None:
    """An object the package read is one a program can change and send again, with the class's checks."""
    theirs = serialize_message(get_test_msg("Nested")[1])[4:]
    msg = _payload.decode(theirs, "test_msgs/msg/Nested")
    msg.basic_types_value.int32_value = 7
    try:
        msg.basic_types_value.int32_value = "seven"
    except AssertionError:
        pass
    else:
        raise AssertionError("a read object's setter let a str into an int32")
    assert read_back(test_msgs.msg.Nested, _payload.encode(msg, "test_msgs/msg/Nested")) == msg
    arrays = _payload.decode(serialize_message(get_test_msg("Arrays")[0])[4:], "test_msgs/msg/Arrays")
    arrays.float64_values[0] = 2.5  # writable, as rclpy's are
    assert read_back(test_msgs.msg.Arrays, _payload.encode(arrays, "test_msgs/msg/Arrays")).float64_values[0] == 2.5


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
    assert _payload.native_codec(Header, "std_msgs/msg/Header") is not None
    header = Header(frame_id="base_link")
    header.stamp.sec, header.stamp.nanosec = -5, 999_999_999
    assert read_back(Header, _payload.encode(header, "std_msgs/msg/Header")) == header
    assert _payload.decode(serialize_message(header)[4:], "std_msgs/msg/Header") == header
    if mode == "unchecked":
        counts = {"beyond_bounds": beyond_bounds()}
    elif mode == "fixtures":
        read_objects_behave_as_rclpys()
        counts: Dict[str, Any] = {
            "fixtures": check_all_fixtures({}),
            "beyond_setters": beyond_setters(),
            "malformed": malformed(),
            "beyond_bounds": beyond_bounds(),
        }
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
