"""Mixed systems (domain 216): a Python response driven by a Rust event through a connection manager in
another process (a Rust radar_ros program), and an rclpy node in the same process as the package."""

from __future__ import annotations

import threading
import time
from typing import Any, List

from conftest import WAIT, eventually

import radar_ros
from std_msgs.msg import Int64, String

DOMAIN = 216


def test_a_rust_event_drives_a_python_response_through_a_manager_in_another_process(peer_factory: Any) -> None:
    seen: List[int] = []

    class Arm(radar_ros.Response):
        start_type = Int64
        output_type = Int64

        def start(self, stamp: Int64) -> Int64:
            seen.append(stamp.data)
            return Int64(data=stamp.data + 1)

    with radar_ros.Radar(domain_id=DOMAIN, args=[]) as r:
        arm = r.spawn_response("py_arm", Arm(), start_policy="queue_one")
        exited = r.waiter(arm.exited, timeout=WAIT)
        peer = peer_factory(DOMAIN)
        peer.ask("manager mgr")
        # the Rust event emits its send time (ns) every 100 ms while listened to
        peer.ask("event tick 100")
        answer = peer.ask("connect-via /mgr /tick/triggered /py_arm/start")
        assert answer and answer[0].startswith("id "), answer
        out = exited.recv(timeout=WAIT)
        assert seen and out.data == seen[0] + 1
        # the stamp is the Rust process's clock: it was sent a moment ago
        assert abs(time.time_ns() - seen[0]) < 5e9
        eventually(lambda: len(seen) >= 3, "three triggers through the remote manager")
        assert seen == sorted(seen)
        assert arm.state()["panics"] == 0 and arm.state()["failures"] == 0
        err = peer.quit()
        assert "ERROR" not in err, err


def test_an_rclpy_node_in_the_same_process_talks_to_python_components() -> None:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=DOMAIN)
    node = rclpy.create_node("talker", context=ctx)
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    pub = node.create_publisher(String, "/py_talk/start", qos)
    heard: List[str] = []
    node.create_subscription(String, "/py_talk/exited", lambda m: heard.append(m.data), qos)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    spinning = threading.Thread(target=executor.spin, daemon=True)
    spinning.start()
    try:
        with radar_ros.Radar(domain_id=DOMAIN, args=[]) as r:
            talk = r.spawn_response("py_talk", lambda m: String(data=m.data.upper()), start_type=String,
                                    output_type=String)
            # rclpy sees the response's node and topics as it sees any ROS 2 node's
            eventually(lambda: ("py_talk", "/") in node.get_node_names_and_namespaces(), "rclpy to see the node")
            eventually(lambda: pub.get_subscription_count() == 1, "the start slot to match rclpy's publisher")
            eventually(lambda: node.count_publishers("/py_talk/exited") == 1, "exited to match")
            pub.publish(String(data="dock"))
            eventually(lambda: heard == ["DOCK"], "rclpy to hear exited")
            assert talk.state()["starts"] == 1
            # and the package hears rclpy's publisher through a connection, as any signal
            got: List[str] = []
            sig = radar_ros.Signal("/py_talk/start", "std_msgs/msg/String")
            with r.whenever(sig).call(lambda m: got.append(m.data)):
                pub.publish(String(data="again"))
                eventually(lambda: "again" in got, "the anonymous slot to get rclpy's message")
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def test_the_action_example_drives_an_rclpy_action_client_and_an_interrupt_cancels_its_goal() -> None:
    from conftest import ROOT, error_lines, run_python

    script = str(ROOT / "examples/python/fibonacci_action.py")
    done = run_python(script, DOMAIN, "--order", "8")
    assert done.returncode == 0, done.stderr
    assert "fib: exit slot (completed)" in done.stdout and "fib exited with 21" in done.stdout, done.stdout
    canceled = run_python(script, DOMAIN, "--order", "30", "--cancel-after", "0.5")
    assert canceled.returncode == 0, canceled.stderr
    out = canceled.stdout
    assert "server: goal canceled after" in out and "fib: exit slot (interrupted)" in out, out
    # the interrupt slot ends when the server has stopped the goal; then the exit slot runs
    assert (
        out.index("server: goal canceled after")
        < out.index("fib: interrupted: goal ended with status 5 (5: canceled)")
        < out.index("fib: exit slot (interrupted)")
    ), out
    assert not error_lines(done.stderr + canceled.stderr), done.stderr + canceled.stderr
