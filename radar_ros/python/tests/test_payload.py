"""rosidl objects written as CDR and read from it by the package itself rather than by rclpy's
`serialize_message` and `deserialize_message` (the shorter path of a Python event's payload and of a Python
response's start), judged by rclpy: every test_msgs fixture written as rclpy reads it and read as rclpy reads
it (field types too), values rclpy's setters would not make written or refused by field, malformed bodies
refused by field, bounded fields over their bound read as rclpy reads them (with its fields checked and
not), and a class whose definition here differs from its own left to rclpy. No DDS: each case runs
`rosidl_codec.py` in a process of its own."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

HELPER = Path(__file__).with_name("rosidl_codec.py")


def run(mode: str) -> dict:
    out = subprocess.run([sys.executable, str(HELPER), mode], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    counts: dict = json.loads(out.stdout.strip().splitlines()[-1])
    return counts


def test_every_test_msgs_fixture_is_written_and_read_natively_as_rclpy_does() -> None:
    counts = run("fixtures")
    assert counts["fixtures"] == 31  # every fixture of the 13 types test_msgs has
    assert counts["beyond_setters"] == ["converted arrays", "large and non-finite arrays", "refusals"]
    assert counts["malformed"] == ["cut short", "lengths beyond the body", "not UTF-8"]
    assert counts["beyond_bounds"] == ["bounded_string_value", "int32_values"]


def test_a_bounded_field_over_its_bound_is_read_as_rclpy_reads_it_when_fields_are_not_checked() -> None:
    assert run("unchecked")["beyond_bounds"] == ["bounded_string_value", "int32_values"]


def test_a_class_unlike_the_definition_found_is_left_to_rclpy() -> None:
    assert run("mismatched")["fixtures"] == 31
