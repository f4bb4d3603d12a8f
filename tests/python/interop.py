#!/usr/bin/env python3
"""rclpy side of the interop tests (tests/interop.rs). Real rclpy on Fast DDS, from the venv that
tests/python_env.sh builds. Each command prints JSON lines on stdout, one per observation, for the Rust test
to assert on; it exits non-zero (with a reason on stderr) when something it waits for does not come.

    interop.py graph --nodes /a/b ... --services /m/connect ...
    interop.py inject RESPONSE              # std_msgs/Empty into start, then interrupt, like `ros2 topic pub`
    interop.py inject_string RESPONSE TEXT  # std_msgs/String into start
    interop.py state RESPONSE               # the transient-local state topic, as a late subscriber
    interop.py deliberative MANAGER SOURCE TARGET WATCH [--no-disconnect]
    interop.py bad_input RESPONSE MANAGER EVENT
    interop.py pub_once TOPIC               # std_msgs/Empty, exactly as `ros2 topic pub --once` does it
    interop.py list_once MANAGER            # one List request, as `ros2 service call` does it
    interop.py state_all RESPONSE           # every sample a late transient-local subscriber (depth 100) gets
    interop.py enclaved --enclave E --wait-for NODE [--seconds S]
                                            # a node in enclave E; the graph's nodes with their enclaves
"""
import argparse
import json
import sys
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Empty, String

TIMEOUT = 15.0


def out(**kv):
    print(json.dumps(kv), flush=True)


def fail(why):
    print(f"interop.py: {why}", file=sys.stderr, flush=True)
    sys.exit(2)


def spin_until(node, cond, what, timeout=TIMEOUT):
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            fail(f"timed out after {timeout}s waiting for {what}")
        rclpy.spin_once(node, timeout_sec=0.01)


def spin_for(node, seconds):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.01)


STATE_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)


def graph(node, a):
    """Waits until the expected nodes and services are visible, then reports the whole graph."""
    def names():
        return {(ns.rstrip("/") + "/" + n) for n, ns in node.get_node_names_and_namespaces()}

    def services():
        return {n for n, _ in node.get_service_names_and_types()}

    spin_until(node, lambda: set(a.nodes) <= names() and set(a.services) <= services(),
               f"nodes {a.nodes} and services {a.services}")
    spin_for(node, 0.5)  # let the topic list settle
    out(nodes=sorted([ns, n] for n, ns in node.get_node_names_and_namespaces()),
        topics={n: t for n, t in node.get_topic_names_and_types()},
        services={n: t for n, t in node.get_service_names_and_types()})


class Recorder:
    """Subscribes to a response's signals and records them in arrival order."""

    def __init__(self, node, response, started_type=Empty, exited_type=Empty):
        self.seen = []
        for signal, ty in (("started", started_type), ("interrupted", Empty), ("exited", exited_type)):
            node.create_subscription(ty, f"{response}/{signal}", self.recorder(signal), 10)

    def recorder(self, signal):
        def record(msg):
            data = getattr(msg, "data", None)
            self.seen.append(signal)
            out(signal=signal, data=data)
        return record


def one_shot(node, ty, topic, msg):
    """What `ros2 topic pub --once` does: a publisher with default QoS, waiting for a subscriber, one message."""
    pub = node.create_publisher(ty, topic, 10)
    spin_until(node, lambda: pub.get_subscription_count() > 0, f"a subscriber on {topic}")
    pub.publish(msg)
    out(published=topic)
    return pub


def inject(node, a):
    rec = Recorder(node, a.response)
    # our subscriptions must be matched with the response's writers before anything is emitted
    spin_for(node, 0.5)
    one_shot(node, Empty, f"{a.response}/start", Empty())
    spin_until(node, lambda: "started" in rec.seen, "started")
    one_shot(node, Empty, f"{a.response}/interrupt", Empty())
    spin_until(node, lambda: "exited" in rec.seen, "exited")
    spin_for(node, 0.3)
    out(order=rec.seen)


def inject_string(node, a):
    rec = Recorder(node, a.response, String, String)
    spin_for(node, 0.5)
    one_shot(node, String, f"{a.response}/start", String(data=a.text))
    spin_until(node, lambda: "exited" in rec.seen, "exited")
    out(order=rec.seen)


def state(node, a):
    from radar_msgs.msg import ResponseState
    got = []
    t0 = time.monotonic()
    node.create_subscription(ResponseState, f"{a.response}/state", got.append, STATE_QOS)
    spin_until(node, lambda: got, "the latched state")
    s = got[0]
    out(after_s=time.monotonic() - t0, name=s.name, state=s.state, state_label=s.state_label,
        start_type=s.start_type, starts=s.starts, exits=s.exits)


def set_fields(msg, values):
    """Sets `msg`'s fields from a dict of YAML values, nested messages included (rosidl_runtime_py's
    set_message_fields, which `ros2 topic pub` uses, for the types these tests publish)."""
    for k, v in values.items():
        if isinstance(v, dict):
            set_fields(getattr(msg, k), v)
        else:
            current = getattr(msg, k)
            setattr(msg, k, float(v) if isinstance(current, float) else v)
    return msg


def pub_once(node, a):
    """`ros2 topic pub --once TOPIC std_msgs/msg/Empty` (ros2cli Jazzy, ros2topic/verb/pub.py), run as a fresh
    process per message: a new participant, a publisher with the 'default' QoS profile (reliable, volatile,
    keep-last 10), a poll every 0.1 s until it counts one matched subscription, one publish, 0.1 s of
    keep-alive, exit."""
    ty, msg = Empty, Empty()
    if a.type:
        # `ros2 topic pub --once TOPIC TYPE VALUES`: the type's class, its fields set from the YAML values
        import importlib
        import yaml
        pkg, kind, name = a.type.split("/")
        ty = getattr(importlib.import_module(f"{pkg}.{kind}"), name)
        msg = set_fields(ty(), yaml.safe_load(a.values or "{}") or {})
    pub = node.create_publisher(ty, a.topic, 10)
    t0 = time.monotonic()
    while pub.get_subscription_count() < 1:
        if time.monotonic() - t0 > TIMEOUT:
            fail(f"no subscription on {a.topic} within {TIMEOUT}s")
        time.sleep(0.1)
    pub.publish(msg)
    out(published=a.topic, matched_after_s=time.monotonic() - t0)
    time.sleep(0.1)


def list_once(node, a):
    """`ros2 service call MANAGER/list radar_msgs/srv/List` (ros2cli Jazzy, ros2service/verb/call.py), run as
    a fresh process: a client, wait for the service, one request, wait for the answer, exit."""
    from radar_msgs.srv import List
    cli = node.create_client(List, f"{a.manager}/list")
    t0 = time.monotonic()
    if not cli.wait_for_service(timeout_sec=TIMEOUT):
        fail(f"service {a.manager}/list not available within {TIMEOUT}s")
    ready = time.monotonic() - t0
    f = cli.call_async(List.Request())
    rclpy.spin_until_future_complete(node, f, timeout_sec=10.0)
    out(answered=f.done() and f.result() is not None, service_ready_s=ready,
        answer_s=time.monotonic() - t0 - ready,
        connections=len(f.result().connections) if f.done() and f.result() is not None else None)


def state_all(node, a):
    """A late subscriber to a response's state with transient-local durability and a deep queue (100), as
    `ros2 topic echo --qos-durability transient_local --qos-depth 100` would make: reports every sample it
    gets within a second of the first."""
    from radar_msgs.msg import ResponseState
    got = []
    qos = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(ResponseState, f"{a.response}/state", got.append, qos)
    spin_until(node, lambda: got, "the latched state")
    spin_for(node, 1.0)
    out(count=len(got), states=[[s.state_label, s.starts, s.interrupts, s.exits] for s in got])


class ManagerClient:
    def __init__(self, node, manager):
        from radar_msgs.srv import Connect, Disconnect, List
        self.node = node
        self.connect = node.create_client(Connect, f"{manager}/connect")
        self.disconnect = node.create_client(Disconnect, f"{manager}/disconnect")
        self.list = node.create_client(List, f"{manager}/list")
        for c in (self.connect, self.disconnect, self.list):
            spin_until(node, c.service_is_ready, f"service {c.srv_name}")

    def call(self, client, req):
        f = client.call_async(req)
        spin_until(self.node, f.done, f"an answer from {client.srv_name}")
        return f.result()


def connect_request(kind, source, target, until="", timeout=2.0):
    from radar_msgs.srv import Connect
    req = Connect.Request()
    req.kind, req.source, req.target, req.until, req.timeout = kind, source, target, until, timeout
    return req


def deliberative(node, a):
    from radar_msgs.msg import Connection, ConnectionList
    from radar_msgs.srv import Disconnect
    lists = []
    node.create_subscription(ConnectionList, f"{a.manager}/connections", lists.append, STATE_QOS)
    starts = []
    node.create_subscription(Empty, a.watch, starts.append, 10)
    m = ManagerClient(node, a.manager)
    r = m.call(m.connect, connect_request(Connection.WHENEVER, a.source, a.target))
    out(connect_ok=r.ok, error=r.error, id=r.id)
    if not r.ok:
        sys.exit(1)

    def listed():
        return lists and any(c.id == r.id for c in lists[-1].connections)

    spin_until(node, listed, "the connection on the connections topic")
    c = next(c for c in lists[-1].connections if c.id == r.id)
    out(listed=dict(id=c.id, kind=c.kind_label, source=c.source, source_type=c.source_type,
                    target=c.target, owner=c.owner))
    spin_until(node, lambda: len(starts) >= 2, f"two signals on {a.watch} through the connection")
    out(through=len(starts))
    if a.no_disconnect:
        out(leaving=True)
        return
    d = Disconnect.Request()
    d.id = r.id
    dr = m.call(m.disconnect, d)
    out(disconnect_ok=dr.ok, error=dr.error)
    spin_until(node, lambda: lists and not any(c.id == r.id for c in lists[-1].connections),
               "the connection to leave the connections topic")
    out(unlisted=True)


def bad_input(node, a):
    from radar_msgs.msg import Connection
    rec = Recorder(node, a.response)
    spin_for(node, 0.5)
    # 1. a slot published with the wrong type: DDS does not match it, nothing arrives, nothing crashes
    wrong = node.create_publisher(String, f"{a.response}/start", 10)
    spin_for(node, 1.0)
    for i in range(5):
        wrong.publish(String(data=f"wrong {i}"))
        spin_for(node, 0.05)
    spin_for(node, 0.5)
    out(wrong_type_matched=wrong.get_subscription_count(), seen_after_wrong=list(rec.seen))
    sys.stdin.readline()  # the test checks the Rust side while the wrong publisher is the only one
    node.destroy_publisher(wrong)
    # the response still works
    one_shot(node, Empty, f"{a.response}/start", Empty())
    spin_until(node, lambda: "started" in rec.seen, "started after the wrong-type messages")
    out(still_works=True)
    # 2. connect requests the manager must refuse, with reasons
    m = ManagerClient(node, a.manager)
    for label, req in (
        ("unknown source", connect_request(Connection.ONCE, "/interop/nope/triggered", f"{a.response}/start")),
        ("unknown target", connect_request(Connection.ONCE, f"{a.event}/triggered", "/interop/nobody/start")),
        ("type mismatch", connect_request(Connection.WHENEVER, f"{a.event}/triggered", a.string_slot)),
        ("invalid name", connect_request(Connection.ONCE, "bad-name!", f"{a.response}/start")),
        ("invalid kind", connect_request(7, f"{a.event}/triggered", f"{a.response}/start")),
    ):
        r = m.call(m.connect, req)
        out(request=label, ok=r.ok, error=r.error)


def enclaved(node, a):
    """A node whose participant runs in enclave a.enclave (rcl: --ros-args --enclave), publishing
    /py_enclaved/out and subscribing /py_enclaved/in: reports every node's enclave once a.wait_for shows, then
    stays a.seconds for the other side to look at it."""
    node.create_publisher(String, "/py_enclaved/out", 10)
    node.create_subscription(String, "/py_enclaved/in", lambda _: None, 10)

    def enclaves():
        return {(ns.rstrip("/") + "/" + n): e
                for n, ns, e in node.get_node_names_and_namespaces_with_enclaves()}

    spin_until(node, lambda: a.wait_for in enclaves(), f"node {a.wait_for}")
    out(enclaves=enclaves())
    spin_for(node, a.seconds)


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("graph")
    g.add_argument("--nodes", nargs="*", default=[])
    g.add_argument("--services", nargs="*", default=[])
    i = sub.add_parser("inject")
    i.add_argument("response")
    s = sub.add_parser("inject_string")
    s.add_argument("response")
    s.add_argument("text")
    st = sub.add_parser("state")
    st.add_argument("response")
    d = sub.add_parser("deliberative")
    d.add_argument("manager")
    d.add_argument("source")
    d.add_argument("target")
    d.add_argument("watch", help="a topic that shows deliveries through the connection")
    d.add_argument("--no-disconnect", action="store_true")
    b = sub.add_parser("bad_input")
    b.add_argument("response")
    b.add_argument("manager")
    b.add_argument("event")
    b.add_argument("string_slot")
    po = sub.add_parser("pub_once")
    po.add_argument("topic")
    po.add_argument("type", nargs="?", help="pkg/msg/Name (default std_msgs/msg/Empty)")
    po.add_argument("values", nargs="?", help="the message's fields as YAML, as ros2 topic pub takes them")
    lo = sub.add_parser("list_once")
    lo.add_argument("manager")
    sa = sub.add_parser("state_all")
    sa.add_argument("response")
    en = sub.add_parser("enclaved")
    en.add_argument("--enclave", required=True)
    en.add_argument("--wait-for", required=True)
    en.add_argument("--seconds", type=float, default=20.0)
    a = p.parse_args()
    if a.cmd == "enclaved":
        rclpy.init(args=[sys.argv[0], "--ros-args", "--enclave", a.enclave])
    else:
        rclpy.init()
    node = Node(f"interop_{a.cmd}")
    try:
        globals()[a.cmd](node, a)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
