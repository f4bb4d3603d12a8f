#!/usr/bin/env python3
"""The rclpy side of tests/user_crate.rs's generated-types test (the Rust program is
tests/fixtures/generated_crate): the oracle is rclpy with ROS 2's own fixtures, never radar_ros's code.

    generated_types.py roundtrip   every fixture of every test_msgs message type (test_msgs.message_fixtures)
                                   published to /echo_<type>/start and to /fx/<type>; prints one JSON line per
                                   fixture and path ({type, index, via: "response"|"event", equal, got}): whether
                                   what came back on /echo_<type>/exited or /seen_<type>/triggered equals it
    generated_types.py dock        sends one radar_demo_msgs/action/Dock goal to /dock with an rclpy
                                   ActionClient (speed left at its default) and prints the result as JSON
"""
import json
import re
import sys
import time
from typing import Any, Dict, List, Optional

import rclpy
from rclpy.action import ActionClient
from rclpy.node import Node
from test_msgs.message_fixtures import get_test_msg
import test_msgs.msg

TYPES = [
    "Arrays", "BasicTypes", "BoundedPlainSequences", "BoundedSequences", "Builtins", "Constants",
    "Defaults", "Empty", "MultiNested", "Nested", "Strings", "UnboundedSequences", "WStrings",
]


def snake(name: str) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def spin_until(node: Node, done: Any, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if done():
            return True
        rclpy.spin_once(node, timeout_sec=0.05)
    return bool(done())


def roundtrip() -> None:
    rclpy.init()
    node = rclpy.create_node("generated_types_roundtrip")
    for name in TYPES:
        cls = getattr(test_msgs.msg, name)
        fixtures = get_test_msg(name)
        s = snake(name)
        got: Dict[str, List[Any]] = {"response": [], "event": []}
        start = node.create_publisher(cls, f"/echo_{s}/start", 10)
        source = node.create_publisher(cls, f"/fx/{s}", 10)
        subs = [
            node.create_subscription(cls, f"/echo_{s}/exited", lambda m: got["response"].append(m), 10),
            node.create_subscription(cls, f"/seen_{s}/triggered", lambda m: got["event"].append(m), 10),
        ]
        matched = spin_until(
            node,
            lambda: start.get_subscription_count() > 0 and source.get_subscription_count() > 0
            and node.count_publishers(f"/echo_{s}/exited") > 0
            and node.count_publishers(f"/seen_{s}/triggered") > 0,
            20.0,
        )
        if not matched:
            print(json.dumps({"type": f"test_msgs/msg/{name}", "error": "the Rust program's endpoints never matched"}),
                  flush=True)
            continue
        for i, fixture in enumerate(fixtures):
            for via, pub in (("response", start), ("event", source)):
                answer: Optional[Any] = None

                def arrived() -> bool:
                    nonlocal answer
                    while got[via]:
                        m = got[via].pop(0)
                        if m == fixture:
                            answer = m
                            return True
                        # a late copy of an earlier fixture (sent again while the event activated) is no answer
                        if not any(m == f for f in fixtures[:i]):
                            answer = m
                            return True
                    return False

                # the event checks only while something listens: send again until it answers
                for _ in range(40):
                    pub.publish(fixture)
                    if spin_until(node, arrived, 0.5):
                        break
                print(json.dumps({
                    "type": f"test_msgs/msg/{name}", "index": i, "via": via,
                    "equal": answer is not None and answer == fixture,
                    "got": repr(answer),
                }), flush=True)
        for sub in subs:
            node.destroy_subscription(sub)
        node.destroy_publisher(start)
        node.destroy_publisher(source)
    node.destroy_node()
    rclpy.shutdown()


def dock() -> None:
    from geometry_msgs.msg import PoseStamped
    from radar_demo_msgs.action import Dock

    rclpy.init()
    node = rclpy.create_node("generated_types_dock")
    client = ActionClient(node, Dock, "/dock")
    if not client.wait_for_server(timeout_sec=30.0):
        print(json.dumps({"error": "no /dock action server"}), flush=True)
        sys.exit(1)
    goal = Dock.Goal()
    goal.target = PoseStamped()
    goal.target.header.frame_id = "map"
    goal.target.pose.position.x = 1.0
    goal.target.pose.position.y = 2.0
    goal.tags = ["north", "wall"]
    accepted = client.send_goal_async(goal)
    rclpy.spin_until_future_complete(node, accepted, timeout_sec=30.0)
    handle = accepted.result()
    if handle is None or not handle.accepted:
        print(json.dumps({"error": "goal not accepted"}), flush=True)
        sys.exit(1)
    result = handle.get_result_async()
    rclpy.spin_until_future_complete(node, result, timeout_sec=30.0)
    r = result.result()
    if r is None:
        print(json.dumps({"error": "no result"}), flush=True)
        sys.exit(1)
    res = r.result
    print(json.dumps({
        "status": r.status,
        "result_status": res.status,
        "docked_constant": Dock.Result.STATUS_DOCKED,
        "travelled": res.travelled,
        "dock_position": [res.dock.position.x, res.dock.position.y, res.dock.position.z],
        "dock_name": res.dock.name,
        "dock_covariance": list(res.dock.covariance),
    }), flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    {"roundtrip": roundtrip, "dock": dock}[sys.argv[1]]()
