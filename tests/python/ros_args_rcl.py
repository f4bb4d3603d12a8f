"""What rcl (through rclpy, ROS 2 Jazzy) makes of command lines: the reference tests/ros_args.rs compares
radar_ros::ros_args against.

    python ros_args_rcl.py CASES.json

CASES.json is a list of {"argv": [...], "names": [...]} objects. For each case one JSON line: either
{"error": "<exception type>"} or the node "prog" made with that command line: its name, namespace, how it
resolves each of `names` (expanded and remapped), its parameter overrides as [type, value], and the effective
log levels of the loggers "prog" and "other".
"""

import json
import sys
from typing import Any, Dict, List

import rclpy
import rclpy.context
import rclpy.logging
from rclpy.node import Node


def value(p: Any) -> List[Any]:
    v = p.value
    if not isinstance(v, (bool, int, float, str)):
        v = list(v)
    return [p.type_.name, v]


def one(case: Dict[str, Any]) -> Dict[str, Any]:
    # logging levels are process-wide in rcutils: start every case from the defaults
    rclpy.logging.set_logger_level("", rclpy.logging.LoggingSeverity.INFO)
    for name in ("prog", "other"):
        rclpy.logging.set_logger_level(name, rclpy.logging.LoggingSeverity.UNSET)
    ctx = rclpy.context.Context()
    try:
        rclpy.init(args=case["argv"], context=ctx)
    except Exception as e:  # rclpy's UnknownROSArgsError, RCLError, ...
        return {"error": type(e).__name__}
    try:
        node = Node("prog", context=ctx)
    except Exception as e:
        rclpy.shutdown(context=ctx)
        return {"error": type(e).__name__}
    try:
        return {
            "name": node.get_name(),
            "namespace": node.get_namespace(),
            "names": {n: node.resolve_topic_name(n) for n in case["names"]},
            "params": {k: value(p) for k, p in sorted(node._parameter_overrides.items())},
            "levels": {
                n: int(rclpy.logging.get_logger(n).get_effective_level()) for n in ("prog", "other")
            },
        }
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def main() -> None:
    with open(sys.argv[1]) as f:
        cases = json.load(f)
    for case in cases:
        print(json.dumps(one(case)), flush=True)


if __name__ == "__main__":
    main()
