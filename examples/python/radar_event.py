#!/usr/bin/env python3
"""A RADAR event written with plain rclpy, following radar_ros's topic conventions.

    python3 radar_event.py NAME [--period SECONDS]

Publishes std_msgs/msg/Empty on NAME/triggered every PERIOD seconds, but only while at least one subscriber
is matched (RADAR events check only while someone listens). Connect it from a radar_ros program with
`radar.event("NAME").await?` and `whenever`, or from the command line through a connection manager.
Prints `active` / `inactive` when listeners come and go, and `triggered N` for each trigger.
"""
import argparse
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from std_msgs.msg import Empty

# the signal QoS of the conventions: reliable, volatile, keep-last 10 (rclpy's default)
SIGNAL_QOS = QoSProfile(
    depth=10,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)


class RadarEvent(Node):
    def __init__(self, name: str, period: float):
        namespace, _, node_name = name.rstrip("/").rpartition("/")
        super().__init__(node_name, namespace=namespace or "/")
        self.triggered = self.create_publisher(Empty, f"{self.get_fully_qualified_name()}/triggered", SIGNAL_QOS)
        self.active = False
        self.count = 0
        # the activation check is cheap; the condition check (here: a timer) runs only while active
        self.create_timer(0.02, self.update_activation)
        self.create_timer(period, self.check)

    def update_activation(self):
        active = self.triggered.get_subscription_count() > 0
        if active != self.active:
            self.active = active
            print("active" if active else "inactive", flush=True)

    def check(self):
        if self.active:
            self.count += 1
            self.triggered.publish(Empty())
            print(f"triggered {self.count}", flush=True)


def run(node):
    """Spins `node` until Ctrl-C or shutdown, then cleans up (shared by the examples)."""
    print("up", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", help="the event's name, e.g. /robot/bumper")
    p.add_argument("--period", type=float, default=0.1)
    a = p.parse_args()
    rclpy.init()
    return run(RadarEvent(a.name, a.period))


if __name__ == "__main__":
    sys.exit(main())
