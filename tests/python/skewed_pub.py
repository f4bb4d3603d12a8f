"""Publishes one std_msgs/msg/Empty on a topic from a process whose clock may be off (run it under libfaketime).

    python skewed_pub.py TOPIC

Waits until a subscriber of TOPIC is matched, publishes once (Fast DDS stamps it with this process's clock),
prints "published" with this process's idea of the time, then waits for a line on stdin before it leaves, so the
sample is not lost to an early exit.
"""

import sys
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Empty


def main() -> None:
    topic = sys.argv[1]
    rclpy.init()
    node = Node("skewed_pub")
    pub = node.create_publisher(Empty, topic, QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
    deadline = time.monotonic() + 15.0
    while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    if pub.get_subscription_count() < 1:
        raise SystemExit(f"no subscriber of {topic} matched within 15 s")
    pub.publish(Empty())
    print(f"published {time.time():.3f}", flush=True)
    sys.stdin.readline()
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
