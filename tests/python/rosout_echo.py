"""Listens on /rosout as rqt_console does (rcl's rosout QoS: reliable, transient-local, keep-last 1000) and
prints every line whose text contains MARKER as JSON ({"name", "level", "msg"}), until it has seen COUNT of them
or 15 s passed.

    python rosout_echo.py MARKER COUNT
"""

import json
import sys
import time

import rclpy
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


def main() -> None:
    marker, count = sys.argv[1], int(sys.argv[2])
    rclpy.init()
    node = Node("rosout_echo")
    seen = 0
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=1000,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )

    def on_line(m: Log) -> None:
        nonlocal seen
        if marker in m.msg:
            seen += 1
            print(json.dumps({"name": m.name, "level": int(m.level), "msg": m.msg}), flush=True)

    node.create_subscription(Log, "/rosout", on_line, qos)
    print(json.dumps({"ready": True}), flush=True)
    deadline = time.monotonic() + 15.0
    while seen < count and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
