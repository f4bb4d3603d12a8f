#!/usr/bin/env python3
"""A plain rclpy subscriber, as `ros2 topic echo` is one: subscribes TOPIC (std_msgs/msg/Empty), prints
{"subscribed": true}, then {"received": n} after each message, and leaves when its stdin gets a line (or after
60 s), destroying its subscription first.

    subscribe.py TOPIC
"""
import json
import select
import sys
import time

import rclpy
from std_msgs.msg import Empty


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("plain_subscriber")
    count = 0

    def on(_: Empty) -> None:
        nonlocal count
        count += 1
        print(json.dumps({"received": count}), flush=True)

    sub = node.create_subscription(Empty, sys.argv[1], on, 10)
    print(json.dumps({"subscribed": True}), flush=True)
    end = time.monotonic() + 60.0
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
