#!/usr/bin/env python3
"""A RADAR response written with plain rclpy, following radar_ros's topic conventions.

    python3 radar_response.py NAME [--duration SECONDS]

Slots (subscribed): NAME/start, NAME/interrupt, NAME/exit (std_msgs/msg/Empty).
Signals (published): NAME/started, NAME/interrupted, NAME/exited (std_msgs/msg/Empty).

The behaviour runs for DURATION seconds after `start` and then exits. `interrupt` stops a run early and emits
`interrupted` then `exited` (exit always runs); `exit` ends a run and emits `exited`. A `start` while running
is ignored (radar_ros's default start policy). Prints each signal it emits.
"""
import argparse
import sys

import rclpy
from rclpy.node import Node
from std_msgs.msg import Empty

from radar_event import SIGNAL_QOS, run


class RadarResponse(Node):
    def __init__(self, name: str, duration: float):
        namespace, _, node_name = name.rstrip("/").rpartition("/")
        super().__init__(node_name, namespace=namespace or "/")
        fq = self.get_fully_qualified_name()
        self.duration = duration
        self.running = None  # the timer of the run in progress
        self.signals = {s: self.create_publisher(Empty, f"{fq}/{s}", SIGNAL_QOS)
                        for s in ("started", "interrupted", "exited")}
        self.create_subscription(Empty, f"{fq}/start", self.on_start, SIGNAL_QOS)
        self.create_subscription(Empty, f"{fq}/interrupt", self.on_interrupt, SIGNAL_QOS)
        self.create_subscription(Empty, f"{fq}/exit", self.on_exit, SIGNAL_QOS)

    def emit(self, signal: str):
        self.signals[signal].publish(Empty())
        print(signal, flush=True)

    def on_start(self, _msg):
        if self.running is not None:
            print("ignored start", flush=True)
            return
        self.running = self.create_timer(self.duration, self.finish)
        self.emit("started")

    def finish(self):
        self.stop_run()
        self.emit("exited")

    def on_interrupt(self, _msg):
        if self.running is None:
            return
        self.stop_run()
        self.emit("interrupted")
        self.emit("exited")

    def on_exit(self, _msg):
        if self.running is None:
            return
        self.stop_run()
        self.emit("exited")

    def stop_run(self):
        self.destroy_timer(self.running)
        self.running = None


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", help="the response's name, e.g. /robot/dock")
    p.add_argument("--duration", type=float, default=0.2)
    a = p.parse_args()
    rclpy.init()
    return run(RadarResponse(a.name, a.duration))


if __name__ == "__main__":
    sys.exit(main())
