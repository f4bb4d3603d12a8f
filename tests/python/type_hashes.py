#!/usr/bin/env python3
"""What rclpy (rmw_fastrtps) reads from discovery about the endpoints of some topics: their type and the type
hash they announce (ROS 2 Jazzy's `typehash=RIHS01_...;` in USER_DATA, REP 2011), as `ros2 topic info -v` shows.

    type_hashes.py TOPIC...   waits (up to 20 s) until every TOPIC has a publisher or a subscription other
                              than this node's, then prints one JSON line per endpoint:
                              {topic, kind: "publisher"|"subscription", node, type, hash: "RIHS01_<hex>" or ""}
"""
import json
import sys
import time
from typing import Any, List

import rclpy


def hash_string(h: Any) -> str:
    """RIHS01_<hex>, or "" for an endpoint that announced none (version 0)."""
    if h is None or getattr(h, "version", 0) == 0:
        return ""
    return "RIHS%02d_%s" % (h.version, bytes(h.value).hex())


def main(topics: List[str]) -> None:
    rclpy.init()
    node = rclpy.create_node("type_hash_reader")
    end = time.monotonic() + 20.0
    while time.monotonic() < end:
        if all(node.get_publishers_info_by_topic(t) or node.get_subscriptions_info_by_topic(t) for t in topics):
            break
        rclpy.spin_once(node, timeout_sec=0.1)
    for t in topics:
        for kind, infos in (("publisher", node.get_publishers_info_by_topic(t)),
                            ("subscription", node.get_subscriptions_info_by_topic(t))):
            for i in infos:
                print(json.dumps({"topic": t, "kind": kind, "node": i.node_name, "type": i.topic_type,
                                  "hash": hash_string(i.topic_type_hash)}), flush=True)
    print(json.dumps({"done": True}), flush=True)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main(sys.argv[1:])
