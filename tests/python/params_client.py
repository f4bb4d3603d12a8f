"""rclpy's parameter client (what `ros2 param` uses) against a radar_ros component's parameters.

    python params_client.py NODE

Waits for NODE's parameter services, then lists, gets, describes and sets its parameters (a valid set of
`period`, and sets that must be refused: out of range, wrong type, read-only, undeclared; an atomic set with
one bad value), watching /parameter_events. Prints one JSON object with what it saw.
"""

import json
import sys
import time
from typing import Any, Dict, List

import rclpy
from rcl_interfaces.msg import ParameterEvent, ParameterValue
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.task import Future


def wait(node: Node, f: Future, what: str) -> Any:
    rclpy.spin_until_future_complete(node, f, timeout_sec=15.0)
    if not f.done():
        raise SystemExit(f"no answer to {what} within 15 s")
    return f.result()


def value(v: ParameterValue) -> Any:
    x = parameter_value_to_python(v)
    return x if isinstance(x, (bool, int, float, str)) or x is None else list(x)


def main() -> None:
    target = sys.argv[1]
    rclpy.init()
    node = Node("params_client_probe")
    events: List[Dict[str, Any]] = []

    def on_event(e: ParameterEvent) -> None:
        if e.node == target:
            events.append(
                {
                    "new": sorted(p.name for p in e.new_parameters),
                    "changed": {p.name: value(p.value) for p in e.changed_parameters},
                }
            )

    node.create_subscription(ParameterEvent, "/parameter_events", on_event, 1000)
    client = AsyncParameterClient(node, target)
    if not client.wait_for_services(timeout_sec=15.0):
        raise SystemExit(f"{target}'s parameter services did not appear within 15 s")
    out: Dict[str, Any] = {}
    listed = wait(node, client.list_parameters(), "list")
    out["list"] = sorted(listed.result.names)
    got = wait(node, client.get_parameters(["period", "limit", "name", "nope"]), "get")
    out["get"] = [value(v) for v in got.values]
    types = wait(node, client.get_parameter_types(["period", "limit", "name", "nope"]), "types")
    out["types"] = list(types.types)
    described = wait(node, client.describe_parameters(["period", "limit", "name"]), "describe")
    out["describe"] = {
        d.name: {
            "type": d.type,
            "description": d.description,
            "read_only": d.read_only,
            "float_range": [[r.from_value, r.to_value] for r in d.floating_point_range],
            "integer_range": [[r.from_value, r.to_value, r.step] for r in d.integer_range],
        }
        for d in described.descriptors
    }
    sets = [
        Parameter("period", Parameter.Type.DOUBLE, 2.0),
        Parameter("period", Parameter.Type.DOUBLE, 100.0),
        Parameter("limit", Parameter.Type.STRING, "many"),
        Parameter("name", Parameter.Type.STRING, "renamed"),
        Parameter("nope", Parameter.Type.INTEGER, 1),
    ]
    results = wait(node, client.set_parameters(sets), "set")
    out["set"] = [[r.successful, r.reason] for r in results.results]
    atomic = wait(
        node,
        client.set_parameters_atomically(
            [Parameter("limit", Parameter.Type.INTEGER, 30), Parameter("period", Parameter.Type.DOUBLE, -1.0)]
        ),
        "set atomically",
    )
    out["atomic"] = [atomic.result.successful, atomic.result.reason]
    got = wait(node, client.get_parameters(["period", "limit"]), "get after")
    out["after"] = [value(v) for v in got.values]
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and not any(e["changed"] for e in events):
        rclpy.spin_once(node, timeout_sec=0.1)
    out["events"] = events
    print(json.dumps(out), flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
