"""A ROS 2 peer over Zenoh written from rmw_zenoh's design document (docs/design.md of ros2/rmw_zenoh), with
the eclipse-zenoh wheel and rclpy's CDR: what radar_ros's Zenoh side is checked against. Nothing here comes
from radar_ros or ros2-client.

    python zenoh_peer.py ROUTER_ENDPOINT DOMAIN TYPE TOPIC_IN TOPIC_OUT [MODE [DURABILITY]]

- A session as rmw_zenoh's default one: peer mode, connected to the router, listening on loopback, gossip
  scouting on, multicast scouting off. MODE `client` makes it a client of the router instead (how a program
  on another host reaches a robot's router).
- DURABILITY `transient_local` makes both endpoints latched (keep last 1) as rmw_zenoh makes them since its
  0.2.2 (ros2/rmw_zenoh#368, "introduce the advanced publisher and subscriber"): the publisher a zenoh-ext
  advanced publisher with a cache of the depth and publisher detection, the subscription an advanced
  subscriber with subscriber detection that queries the history of publishers (late ones too) for the
  depth; both tokens' QoS say transient local. `volatile` (the default): plain Zenoh publisher and
  subscriber, as the design document describes them.
- A node `zenoh_peer` (liveliness token `@ros2_lv/<domain>/<session id>/0/0/NN/%/%/zenoh_peer`).
- TYPE (`pkg/msg/Name`) is named as the design says: `pkg::msg::dds_::Name_` and the RIHS01 hash rosidl wrote
  into this venv's `share/pkg/msg/Name.json`.
- A subscription on TOPIC_IN declared as rmw_zenoh declares one: on the exact key
  `<domain>/<topic>/<type>/<hash>` (so a publisher naming another hash is never heard), with its `MS` token.
  Each sample is printed as {"received": <the message as rclpy reads it, as a dict>, "seq", "stamp_ns",
  "gid", "extra"} from its attachment (8 bytes little-endian sequence number, 8 bytes little-endian
  nanoseconds since the epoch, 1 byte GID length, the GID), read as rmw_zenoh's attachment_helpers.cpp reads
  it: those fields in order, nothing after them looked at ("extra": what follows, in hex); a sample whose
  attachment is shorter than those fields is printed as {"bad_attachment": hex}.
- A publisher on TOPIC_OUT (its `MP` token): each line the test writes on stdin (the message's fields as JSON)
  is put on the exact key with an attachment as above (sequence numbers from 1, the peer's own random GID),
  then {"sent": <sequence number>} is printed.
- Every liveliness token seen on the domain (history included) is printed as {"token": key, "put": bool}.

Prints {"up": <session id>} once its entities are declared; ends when stdin closes.
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
import zenoh.ext
from rclpy.serialization import deserialize_message, serialize_message

# the compact QoS of the design document's examples: reliable, volatile, keep last 10; and reliable,
# transient local (durability code 1), keep last 1
QOS = {"volatile": "::,10:,:,:,,", "transient_local": ":1:,1:,:,:,,"}
NODE = "zenoh_peer"


_OUT = threading.Lock()


def out(doc: dict[str, Any]) -> None:
    """One JSON line; Zenoh's callback threads and the main thread print, one whole line at a time."""
    with _OUT:
        print(json.dumps(doc), flush=True)


def to_dict(msg: Any) -> Any:
    """A message as plain JSON values, field by field (rosidl's generated classes list their fields)."""
    if hasattr(msg, "get_fields_and_field_types"):
        return {f: to_dict(getattr(msg, f)) for f in msg.get_fields_and_field_types()}
    if isinstance(msg, (list, tuple)):
        return [to_dict(v) for v in msg]
    if hasattr(msg, "tolist"):  # a fixed-size numeric array: rclpy gives a numpy array
        return msg.tolist()
    return msg


def set_fields(msg: Any, values: dict[str, Any]) -> None:
    """Sets the fields named in `values` (nested messages from nested dicts)."""
    for field, value in values.items():
        if isinstance(value, dict):
            set_fields(getattr(msg, field), value)
        else:
            setattr(msg, field, value)


def mangle(name: str) -> str:
    """A mangled name: each `/` replaced by `%` (`%` alone for the empty namespace)."""
    return name.replace("/", "%") if name not in ("", "/") else "%"


def session_config(router: str, mode: str = "peer") -> zenoh.Config:
    """A session as rmw_zenoh's default one: `mode` (peer, or client of the router), connected to the router,
    a peer listening on loopback, gossip scouting on, multicast scouting off."""
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    conf.insert_json5("connect/endpoints", json.dumps([router]))
    if mode == "peer":
        conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "true")
    return conf


def latched_subscriber(session: zenoh.Session, key: str, on_sample: Any) -> Any:
    """A transient-local, keep-last-1 subscription as rmw_zenoh makes one: a zenoh-ext advanced subscriber
    (subscriber detection on) that asks matching publishers' caches, late ones too, for their last sample."""
    return zenoh.ext.declare_advanced_subscriber(
        session,
        key,
        on_sample,
        history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1),
        subscriber_detection=True,
    )


def rosidl_hash(ros_type: str) -> str:
    pkg, kind, name = ros_type.split("/")
    share = Path(sys.prefix) / "share" / pkg / kind / f"{name}.json"
    doc = json.loads(share.read_text())
    return str(doc["type_hashes"][0]["hash_string"])


def main() -> None:
    router, domain, ros_type, topic_in, topic_out = sys.argv[1:6]
    mode = sys.argv[6] if len(sys.argv) > 6 else "peer"
    durability = sys.argv[7] if len(sys.argv) > 7 else "volatile"
    if durability not in QOS:
        sys.exit(f"DURABILITY is one of {sorted(QOS)}, not {durability!r}")
    pkg, kind, name = ros_type.split("/")
    msg_class = getattr(importlib.import_module(f"{pkg}.{kind}"), name)
    dds_type = f"{pkg}::{kind}::dds_::{name}_"
    type_hash = rosidl_hash(ros_type)

    conf = session_config(router, mode)
    # rmw_zenoh's session stamps samples; an advanced publisher's cache needs it
    conf.insert_json5("timestamping/enabled", "true")
    with zenoh.open(conf) as session:
        serve(session, domain, msg_class, (dds_type, type_hash), (topic_in, topic_out), durability)


def serve(
    session: zenoh.Session,
    domain: str,
    msg_class: Any,
    named: tuple[str, str],
    topics: tuple[str, str],
    durability: str,
) -> None:
    """Declares the node and its two endpoints, then publishes a message per line of stdin until it closes."""
    dds_type, type_hash = named
    topic_in, topic_out = topics
    zid = str(session.info.zid())

    def on_token(sample: zenoh.Sample) -> None:
        out({"token": str(sample.key_expr), "put": sample.kind == zenoh.SampleKind.PUT})

    tokens_sub = session.liveliness().declare_subscriber(
        f"@ros2_lv/{domain}/**", on_token, history=True
    )

    def token(entity_id: int, kind_code: str, topic: str) -> str:
        return (
            f"@ros2_lv/{domain}/{zid}/0/{entity_id}/{kind_code}/%/%/{NODE}/"
            f"{mangle(topic)}/{dds_type}/{type_hash}/{QOS[durability]}"
        )

    def key(topic: str) -> str:
        return f"{domain}/{topic.strip('/')}/{dds_type}/{type_hash}"

    def on_sample(sample: zenoh.Sample) -> None:
        att = sample.attachment.to_bytes() if sample.attachment is not None else b""
        # read as rmw_zenoh reads it (attachment_helpers.cpp): the three fields in order, and nothing after
        # them looked at; what follows is printed as "extra"
        if len(att) < 17 or len(att) < 17 + att[16]:
            out({"bad_attachment": att.hex()})
            return
        gid_end = 17 + att[16]
        msg = deserialize_message(sample.payload.to_bytes(), msg_class)
        out(
            {
                "received": to_dict(msg),
                "seq": int.from_bytes(att[0:8], "little", signed=True),
                "stamp_ns": int.from_bytes(att[8:16], "little", signed=True),
                "gid": att[17:gid_end].hex(),
                "extra": att[gid_end:].hex(),
            }
        )

    live = [session.liveliness().declare_token(f"@ros2_lv/{domain}/{zid}/0/0/NN/%/%/{NODE}")]
    sub: Any
    pub: Any
    if durability == "transient_local":
        sub = latched_subscriber(session, key(topic_in), on_sample)
    else:
        sub = session.declare_subscriber(key(topic_in), on_sample)
    live.append(session.liveliness().declare_token(token(10, "MS", topic_in)))
    if durability == "transient_local":
        pub = zenoh.ext.declare_advanced_publisher(
            session,
            key(topic_out),
            cache=zenoh.ext.CacheConfig(max_samples=1),
            publisher_detection=True,
        )
    else:
        pub = session.declare_publisher(key(topic_out))
    live.append(session.liveliness().declare_token(token(11, "MP", topic_out)))
    gid = os.urandom(16)
    out({"up": zid, "hash": type_hash})

    seq = 0
    for line in sys.stdin:
        msg = msg_class()
        set_fields(msg, json.loads(line))
        seq += 1
        attachment = (
            seq.to_bytes(8, "little", signed=True)
            + time.time_ns().to_bytes(8, "little", signed=True)
            + bytes([len(gid)])
            + gid
        )
        pub.put(serialize_message(msg), attachment=attachment)
        out({"sent": seq})
    del sub, tokens_sub, live


if __name__ == "__main__":
    main()
