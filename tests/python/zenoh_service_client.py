"""A ROS 2 service client over Zenoh written from rmw_zenoh's design document (docs/design.md of ros2/rmw_zenoh),
with the eclipse-zenoh wheel and rclpy's CDR, as `zenoh_peer.py` is for topics: nothing here comes from
radar_ros or ros2-client.

    python zenoh_service_client.py ROUTER_ENDPOINT DOMAIN SERVICE TYPE REQUEST_JSON

- A session as rmw_zenoh's default one (peer, connected to the router, gossip on, multicast off), a node
  `zenoh_service_client` (its `NN` token) and a client of SERVICE (its `SC` token).
- TYPE (`pkg/srv/Name`) is named as the design says: `pkg::srv::dds_::Name_` with the RIHS01 hash of the
  service as a whole that rosidl wrote into this venv's `share/pkg/srv/Name.json`.
- Waits (10 s at most) for a server's `SS` liveliness token naming SERVICE with that type and hash, and prints
  {"server": token}; then sends the request (REQUEST_JSON: its fields) as rmw_zenoh's client does, a query on
  `<domain>/<service>/<type>/<hash>` with the request's CDR as payload and the attachment (sequence number 1,
  the time, the client's GID), and prints each reply as {"reply": <the response as rclpy reads it>, "seq": <the
  reply attachment's sequence number>} (or {"bad_attachment": hex}, {"error": text}), then {"replies": n}.
"""

import importlib
import json
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any

import zenoh
from rclpy.serialization import deserialize_message, serialize_message

from zenoh_peer import mangle, out, session_config, set_fields, to_dict

NODE = "zenoh_service_client"
# the design document's default service QoS: reliable, volatile, keep last 10
QOS = "::,10:,:,:,,"


def main() -> None:
    router, domain, service, srv_type, request_json = sys.argv[1:6]
    pkg, kind, name = srv_type.split("/")
    module = importlib.import_module(f"{pkg}.{kind}")
    request = getattr(module, f"{name}_Request")()
    set_fields(request, json.loads(request_json))
    response_class = getattr(module, f"{name}_Response")
    dds_type = f"{pkg}::{kind}::dds_::{name}_"
    doc = json.loads((Path(sys.prefix) / "share" / pkg / kind / f"{name}.json").read_text())
    type_hash = str(doc["type_hashes"][0]["hash_string"])
    assert doc["type_hashes"][0]["type_name"] == srv_type, doc["type_hashes"][0]

    with zenoh.open(session_config(router)) as session:
        zid = str(session.info.zid())
        server = threading.Event()
        wanted = "/SS/"  # a server in any enclave
        tail = f"/{mangle(service)}/{dds_type}/{type_hash}/"

        def on_token(sample: zenoh.Sample) -> None:
            key = str(sample.key_expr)
            if sample.kind == zenoh.SampleKind.PUT and wanted in key and tail in key and not server.is_set():
                out({"server": key})
                server.set()

        tokens = session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", on_token, history=True)
        live = [
            session.liveliness().declare_token(f"@ros2_lv/{domain}/{zid}/0/0/NN/%/%/{NODE}"),
            session.liveliness().declare_token(
                f"@ros2_lv/{domain}/{zid}/0/10/SC/%/%/{NODE}{tail}{QOS}"
            ),
        ]
        if not server.wait(10.0):
            out({"error": f"no server of {service} with {dds_type} and {type_hash} in 10 s"})
            sys.exit(1)
        gid = os.urandom(16)
        attachment = (
            (1).to_bytes(8, "little", signed=True)
            + time.time_ns().to_bytes(8, "little", signed=True)
            + bytes([len(gid)])
            + gid
        )
        replies = session.get(
            f"{domain}/{service.strip('/')}/{dds_type}/{type_hash}",
            payload=serialize_message(request),
            attachment=attachment,
            target=zenoh.QueryTarget.ALL_COMPLETE,
            consolidation=zenoh.ConsolidationMode.NONE,
            timeout=10.0,
        )
        n = 0
        for reply in replies:
            if reply.ok is None:
                out({"error": str(reply.err.payload.to_string() if reply.err else "no reply")})
                continue
            sample = reply.ok
            att = sample.attachment.to_bytes() if sample.attachment is not None else b""
            if len(att) < 17 or len(att) != 17 + att[16]:
                out({"bad_attachment": att.hex()})
                continue
            response: Any = deserialize_message(sample.payload.to_bytes(), response_class)
            out({"reply": to_dict(response), "seq": int.from_bytes(att[0:8], "little", signed=True)})
            n += 1
        out({"replies": n})
        del tokens, live


if __name__ == "__main__":
    main()
