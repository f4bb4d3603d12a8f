"""A Zenoh router as rmw_zenoh's default layout has one: router mode, gossip scouting on, multicast scouting
off, listening on the endpoint given (rmw_zenoh's own listens on tcp/[::]:7447), and, as rmw_zenoh's router
configuration says, no failover brokering: it forwards nothing between two peers that cannot reach each other
(programs on other hosts connect as clients, or through a router of their own).

    python zenoh_router.py tcp/127.0.0.1:PORT [CONNECT_ENDPOINT ...]

CONNECT_ENDPOINTs are other routers to connect to (a router per site, joined to the others). Prints "up" once listening and runs until its stdin closes (the test that started it ended).
"""

import json
import sys

import zenoh


def main() -> None:
    endpoint = sys.argv[1]
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"')
    conf.insert_json5("listen/endpoints", json.dumps([endpoint]))
    conf.insert_json5("connect/endpoints", json.dumps(sys.argv[2:]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "true")
    conf.insert_json5("routing/router/peers_failover_brokering", "false")
    with zenoh.open(conf):
        print("up", flush=True)
        sys.stdin.read()


if __name__ == "__main__":
    main()
