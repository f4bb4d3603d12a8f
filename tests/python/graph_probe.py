"""What rclpy sees of the ROS graph, for checking where a program put its nodes, topics and parameters.

    python graph_probe.py NODE:PARAM[,PARAM...] ...

Waits until every NODE is on the graph (15 s at most), then prints one JSON object: the graph's node names
(fully qualified), its topic names, and for each NODE the values of its PARAMs from its parameter services.
"""

import json
import sys
import time
from typing import Any, Dict, List

import rclpy
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient


def fq(name: str, ns: str) -> str:
    return (ns.rstrip("/") + "/" + name) if ns != "/" else "/" + name


def main() -> None:
    wanted: Dict[str, List[str]] = {}
    for arg in sys.argv[1:]:
        node, params = arg.split(":", 1)
        wanted[node] = params.split(",")
    rclpy.init()
    probe = Node("graph_probe")
    deadline = time.monotonic() + 15.0
    nodes: List[str] = []
    while time.monotonic() < deadline:
        rclpy.spin_once(probe, timeout_sec=0.1)
        nodes = sorted(fq(n, ns) for n, ns in probe.get_node_names_and_namespaces())
        if all(w in nodes for w in wanted):
            break
    params: Dict[str, Dict[str, Any]] = {}
    for node, names in wanted.items():
        client = AsyncParameterClient(probe, node)
        if not client.wait_for_services(timeout_sec=15.0):
            raise SystemExit(f"{node}'s parameter services did not appear within 15 s")
        f = client.get_parameters(names)
        rclpy.spin_until_future_complete(probe, f, timeout_sec=15.0)
        if not f.done():
            raise SystemExit(f"no answer from {node}'s get_parameters within 15 s")
        params[node] = {n: parameter_value_to_python(v) for n, v in zip(names, f.result().values)}
    topics = sorted(t for t, _ in probe.get_topic_names_and_types())
    print(json.dumps({"nodes": nodes, "topics": topics, "params": params}), flush=True)
    probe.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
