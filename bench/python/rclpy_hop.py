#!/usr/bin/env python3
"""The rclpy baseline of radar_bench: what a user would write without radar_ros.

    rclpy_hop.py sink --topic T      records each std_msgs/msg/Header's age when its callback runs
    rclpy_hop.py source --topic T    publishes stamped Headers
    rclpy_hop.py oneshot --topic T --seq N
                                     `ros2 topic pub --once`, as the ros2 CLI does it: a fresh process that
                                     polls every 0.1 s until its publisher counts one subscription,
                                     publishes one stamped Header, stays 0.1 s and exits (prints `published`)

Speaks radar_bench's child protocol: prints `ready`, then answers one line per command on stdin
(`wait`, `run N PERIOD_US`, `report WARMUP`, `quit`). Stamps use CLOCK_MONOTONIC, as the Rust side does, and
the QoS is the RADAR signal QoS (reliable, volatile, keep-last 10, which is rclpy's default).
"""
import argparse
import json
import sys
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from std_msgs.msg import Header

QOS = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.VOLATILE)


def now_ns():
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


def stamped(seq):
    t = now_ns()
    h = Header()
    h.stamp.sec = t // 1_000_000_000
    h.stamp.nanosec = t % 1_000_000_000
    h.frame_id = str(seq)
    return h


def oneshot(node, topic, seq):
    """What `ros2 topic pub --once` does after rclpy.init (ros2cli Jazzy, ros2topic/verb/pub.py)."""
    pub = node.create_publisher(Header, topic, QOS)
    deadline = time.monotonic() + 20
    while pub.get_subscription_count() < 1:
        if time.monotonic() > deadline:
            print(f"oneshot: no subscriber on {topic} within 20 s", file=sys.stderr)
            sys.exit(2)
        time.sleep(0.1)
    pub.publish(stamped(seq))
    time.sleep(0.1)
    print("published", flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=["sink", "source", "oneshot"])
    ap.add_argument("--topic", required=True)
    ap.add_argument("--seq", type=int, default=0)
    a = ap.parse_args()
    rclpy.init()
    node = Node(f"rclpy_{a.role}", namespace="/bench")
    if a.role == "oneshot":
        oneshot(node, a.topic, a.seq)
        return
    lock = threading.Lock()
    record = []
    if a.role == "sink":
        def on_msg(h):
            age = now_ns() - (h.stamp.sec * 1_000_000_000 + h.stamp.nanosec)
            with lock:
                record.append((int(h.frame_id), age))
        node.create_subscription(Header, a.topic, on_msg, QOS)
    else:
        pub = node.create_publisher(Header, a.topic, QOS)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin)
    spinner.start()
    print("ready", flush=True)
    for line in sys.stdin:
        w = line.split()
        if not w:
            continue
        if w[0] == "quit":
            break
        try:
            if w[0] == "wait" and a.role == "source":
                deadline = time.monotonic() + 20
                while pub.get_subscription_count() < 1:
                    if time.monotonic() > deadline:
                        raise RuntimeError("no subscriber within 20 s")
                    time.sleep(0.01)
                answer = "ok"
            elif w[0] == "run" and a.role == "source":
                n, period = int(w[1]), int(w[2]) / 1e6
                start = time.monotonic()
                for i in range(n):
                    delay = start + i * period - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)
                    pub.publish(stamped(i))
                answer = f"sent {n}"
            elif w[0] == "report" and a.role == "sink":
                warmup = int(w[1])
                with lock:
                    got = list(record)
                    record.clear()
                answer = json.dumps({"lat_ns": [l for s, l in got if s >= warmup], "received": len(got),
                                     "extra": {}})
            else:
                raise ValueError(f"unknown command {w[0]} for {a.role}")
        except Exception as e:  # answer, and go on serving
            answer = f"error {e}"
        print(answer, flush=True)
    executor.shutdown()
    spinner.join(timeout=5)
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
