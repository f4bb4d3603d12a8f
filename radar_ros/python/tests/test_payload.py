"""rosidl objects written as CDR by the package itself rather than by rclpy's `serialize_message` (the shorter
path of a Python event's payload), judged by rclpy: every test_msgs fixture read back as written, values
rclpy's setters would not make written or refused by field, and a class whose definition here differs from
its own left to rclpy. No DDS: each case runs `rosidl_encoding.py` in a process of its own."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

HELPER = Path(__file__).with_name("rosidl_encoding.py")


def run(mode: str) -> dict:
    out = subprocess.run([sys.executable, str(HELPER), mode], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    counts: dict = json.loads(out.stdout.strip().splitlines()[-1])
    return counts


def test_every_test_msgs_fixture_is_written_natively_as_rclpy_reads_it() -> None:
    counts = run("fixtures")
    assert counts["fixtures"] == 31  # every fixture of the 13 types test_msgs has
    assert counts["beyond_setters"] == ["converted arrays", "large and non-finite arrays", "refusals"]


def test_a_class_unlike_the_definition_found_is_left_to_rclpy() -> None:
    assert run("mismatched")["fixtures"] == 31
