"""Publishes simulated time on /clock as Gazebo or `ros2 bag play --clock` does (rosgraph_msgs/msg/Clock).

    python clock_pub.py START_S STEP_MS TICK_MS TICKS JUMP_TICK JUMP_TO_S

Waits for a /clock subscriber, prints "ready", waits for a line on stdin, then publishes TICKS times, one every TICK_MS of wall time, the time
advancing STEP_MS each tick from START_S; from tick JUMP_TICK on it counts from JUMP_TO_S instead (a backward
jump, as a simulation reset). Prints "done".
"""

import sys
import time

import rclpy
from builtin_interfaces.msg import Time
from rclpy.node import Node
from rosgraph_msgs.msg import Clock


def main() -> None:
    start_s, step_ms, tick_ms, ticks, jump_tick, jump_to_s = (float(a) for a in sys.argv[1:7])
    rclpy.init()
    node = Node("clock_pub")
    pub = node.create_publisher(Clock, "/clock", 10)
    # the listener must hear the first tick: wait until it is matched
    deadline = time.monotonic() + 15.0
    while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    if pub.get_subscription_count() < 1:
        raise SystemExit("no /clock subscriber matched within 15 s")
    print("ready", flush=True)
    sys.stdin.readline()
    for i in range(int(ticks)):
        if i < jump_tick:
            ns = int(start_s * 1e9) + int(i * step_ms * 1e6)
        else:
            ns = int(jump_to_s * 1e9) + int((i - jump_tick) * step_ms * 1e6)
        pub.publish(Clock(clock=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)))
        time.sleep(tick_ms / 1000.0)
    print("done", flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
