#!/usr/bin/env python3
"""An rclpy subscriber of `/diagnostics` (diagnostic_msgs/msg/DiagnosticArray), as rqt_runtime_monitor and the
diagnostic aggregator read it: prints {"subscribed": true}, then one JSON line per status whose name starts with
PREFIX ({"name", "level", "message", "values": {key: value}}), until its stdin gets a line (or after 90 s).

    diagnostics.py PREFIX
"""
import json
import select
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray


def main() -> None:
    prefix = sys.argv[1]
    rclpy.init()
    node = rclpy.create_node("diagnostics_listener")

    def on(msg: DiagnosticArray) -> None:
        for s in msg.status:
            if s.name.startswith(prefix):
                print(json.dumps({
                    "name": s.name,
                    "level": int.from_bytes(s.level, "little") if isinstance(s.level, bytes) else int(s.level),
                    "message": s.message,
                    "values": {kv.key: kv.value for kv in s.values},
                }), flush=True)

    sub = node.create_subscription(DiagnosticArray, "/diagnostics", on, 10)
    print(json.dumps({"subscribed": True}), flush=True)
    end = time.monotonic() + 90.0
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
        if select.select([sys.stdin], [], [], 0)[0]:
            sys.stdin.readline()
            break
    node.destroy_subscription(sub)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
