#!/usr/bin/env python3
"""The rclpy baseline of radar_bench: what a user would write without radar_ros.

    rclpy_hop.py sink --topic T      records each std_msgs/msg/Header's age when its callback runs
    rclpy_hop.py source --topic T    publishes stamped Headers
    rclpy_hop.py action-server --topic A
                                     a test_msgs/action/Fibonacci server on action A: records when each goal's
                                     execute callback begins and when a cancel request arrives; a goal of
                                     order >= 0 succeeds at once, order -(k+1) runs (feedback [k]) until canceled
    rclpy_hop.py action-client --topic A
                                     rclpy's ActionClient: `run N` sends goals 0..N one after the other (each
                                     to its result), `cancel-run N` sends long goals and cancels each once it
                                     executes; answers when each was sent / canceled
    rclpy_hop.py radar-sink --topic T
                                     the radar_ros Python package (issue 24): a Python response (async def
                                     start, queue_one) whose start slot records each Header's age, started by
                                     `whenever T start` through the package's own manager (1 hop); rclpy's
                                     node sits in the same process, unused. `--inline`: the start slot is a
                                     plain function the engine calls on its own thread (`Response.inline`,
                                     as rclpy calls a callback) instead of an async def on the slot loop
    rclpy_hop.py radar-source --topic NAME
                                     a Python event NAME through the package whose (async) check resolves
                                     when `run` feeds it a sequence number, stamped then, as the Rust
                                     `events` role's; `wait` returns once something listens to it
    rclpy_hop.py oneshot --topic T --seq N
                                     `ros2 topic pub --once`, as the ros2 CLI does it: a fresh process that
                                     polls every 0.1 s until its publisher counts one subscription,
                                     publishes one stamped Header, stays 0.1 s and exits (prints `published`)

Speaks radar_bench's child protocol: prints `ready`, then answers one line per command on stdin
(`wait`, `run N PERIOD_US`, `report WARMUP`, `quit`). Stamps use CLOCK_MONOTONIC, as the Rust side does, and
the QoS is the RADAR signal QoS (reliable, volatile, keep-last 10, which is rclpy's default).
"""
import argparse
import json
import os
import statistics
import sys
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, DurabilityPolicy, HistoryPolicy
from std_msgs.msg import Header

QOS = QoSProfile(depth=10, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.VOLATILE)


def now_ns():
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


def stamped(seq):
    t = now_ns()
    h = Header()
    h.stamp.sec = t // 1_000_000_000
    h.stamp.nanosec = t % 1_000_000_000
    h.frame_id = str(seq)
    return h


def paced(n, period, send):
    """Calls send(i) for i in 0..n, one every period seconds from now."""
    start = time.monotonic()
    for i in range(n):
        delay = start + i * period - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        send(i)


def oneshot(node, topic, seq):
    """What `ros2 topic pub --once` does after rclpy.init (ros2cli Jazzy, ros2topic/verb/pub.py)."""
    pub = node.create_publisher(Header, topic, QOS)
    deadline = time.monotonic() + 20
    while pub.get_subscription_count() < 1:
        if time.monotonic() > deadline:
            print(f"oneshot: no subscriber on {topic} within 20 s", file=sys.stderr)
            sys.exit(2)
        time.sleep(0.1)
    pub.publish(stamped(seq))
    time.sleep(0.1)
    print("published", flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


def wait_future(fut, what, timeout=20.0):
    """Waits (the executor spins in another thread) until an rclpy future is done."""
    done = threading.Event()
    fut.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        raise RuntimeError(f"no {what} within {timeout} s")
    return fut.result()


def action_server(node, action, lock, record):
    from rclpy.action import ActionServer, CancelResponse, GoalResponse
    from rclpy.callback_groups import ReentrantCallbackGroup
    from test_msgs.action import Fibonacci
    current = {"seq": None}

    def on_cancel(_):
        t = now_ns()
        with lock:
            record.setdefault("cancel", []).append((current["seq"], t))
        return CancelResponse.ACCEPT

    def execute(goal_handle):
        t = now_ns()
        order = goal_handle.request.order
        seq = order if order >= 0 else -order - 1
        with lock:
            record.setdefault("exec", []).append((seq, t))
        if order >= 0:
            goal_handle.succeed()
            return Fibonacci.Result()
        current["seq"] = seq
        goal_handle.publish_feedback(Fibonacci.Feedback(sequence=[seq]))
        while not goal_handle.is_cancel_requested:
            time.sleep(0.001)
        goal_handle.canceled()
        return Fibonacci.Result()

    return ActionServer(node, Fibonacci, action, execute_callback=execute,
                        goal_callback=lambda _: GoalResponse.ACCEPT, cancel_callback=on_cancel,
                        callback_group=ReentrantCallbackGroup())


def radar_sink(topic, lock, record, inline=False):
    """A Python response through the radar_ros package, started by `whenever topic start` (1 hop); `inline`:
    its start a plain function called on the engine's thread."""
    import radar_ros

    stages = staged_runner(radar_ros) if os.environ.get("RADAR_BENCH_STAGES") == "1" else None

    def behaviour(h):
        t = now_ns()
        age = t - (h.stamp.sec * 1_000_000_000 + h.stamp.nanosec)
        with lock:
            record.append((int(h.frame_id), age))
            if stages is not None and stages["pending"]:
                stages["runs"][int(h.frame_id)] = stages["pending"] + [t]
                stages["pending"] = None

    class Sink(radar_ros.Response):
        start_type = Header
        start_policy = "queue_one"

        async def start(self, h):
            behaviour(h)

    class InlineSink(radar_ros.Response):
        start_type = Header
        start_policy = "queue_one"
        inline = True

        def start(self, h):
            behaviour(h)

    radar = radar_ros.Radar(args=[])
    resp = radar.spawn_response("/bench/py_sink", InlineSink() if inline else Sink())
    # the connection arms once the source's publisher is there (it starts after this process)
    statement = radar.whenever(radar_ros.Signal(topic, "std_msgs/msg/Header")).start(resp).timeout(60)
    connections = []
    threading.Thread(target=lambda: connections.append(statement.connect()), daemon=True).start()
    resp.connections = connections  # kept as long as the response
    return radar, resp, stages


def staged_runner(radar_ros):
    """RADAR_BENCH_STAGES=1: where a Python response's start goes between the engine and the user's slot.
    Wraps the package's runner (its `start` is called by the engine's task, on the engine's thread, and returns
    the coroutine the slot loop runs) and its payload decoding, stamping: the engine's call, the coroutine's
    first step on the loop's thread, the payload decoded; the slot itself stamps when it begins."""
    stages = {"pending": None, "runs": {}}
    runner = radar_ros._ResponseRunner
    orig_start, orig_start_inline, orig_decode = runner.start, runner.start_inline, radar_ros.decode

    def start(self, body, begun):
        called = now_ns()

        async def staged():
            stages["pending"] = [called, now_ns()]
            return await orig_start(self, body, begun)
        return staged()

    def start_inline(self, body):
        # no hand-off: the engine's call and the first step are one moment
        stages["pending"] = [now_ns()]
        return orig_start_inline(self, body)

    def decode(*a, **k):
        out = orig_decode(*a, **k)
        if stages["pending"] is not None and len(stages["pending"]) in (1, 2):
            stages["pending"].append(now_ns())
        return out

    runner.start = start
    runner.start_inline = start_inline
    radar_ros.decode = decode
    return stages


def stage_p50s(stages, got):
    """The p50 of each stage (us) of the runs in `stages`, the first from the publisher's stamp (`got`:
    the (seq, age) pairs of the runs counted)."""
    names = ["publish -> engine calls the slot", "-> coroutine's first step on the loop",
             "-> payload decoded", "-> user's start begins"]
    if any(len(run) == 3 for run in stages["runs"].values()):
        del names[1]  # an inline start: called where the engine took the signal, no loop
    cols = [[] for _ in names]
    for seq, age in got:
        run = stages["runs"].get(seq, [])
        if len(run) != len(names):
            continue
        begin = run[-1]
        published = begin - age
        for i, (a, b) in enumerate(zip([published] + run[:-1], run)):
            cols[i].append((b - a) / 1000)
    return [[n, round(statistics.median(c), 1)] for n, c in zip(names, cols) if c]


def radar_source(name):
    """A Python event through the radar_ros package whose check resolves when `run` feeds it a sequence
    number, stamped at that moment (as the Rust `events` role's); a Rust response's process connects it."""
    import asyncio

    import radar_ros

    fed = {}
    ready = threading.Event()

    class Fed(radar_ros.Event):
        payload_type = Header

        async def check(self):
            if "queue" not in fed:
                fed["loop"], fed["queue"] = asyncio.get_running_loop(), asyncio.Queue()
                ready.set()
            return stamped(await fed["queue"].get())

    radar = radar_ros.Radar(args=[])
    ev = radar.spawn_event(name, Fed())

    def feed(seq):
        fed["loop"].call_soon_threadsafe(fed["queue"].put_nowait, seq)

    return radar, ev, ready, feed


def radar_build():
    """How the installed package was built: `release` (pip install), or `dev` (tests/python_package.sh)."""
    from radar_ros import _native
    return f"{_native.BUILD} build"


class Driver:
    """rclpy's ActionClient, driven from the command loop while the executor spins in its thread."""

    def __init__(self, node, action):
        from rclpy.action import ActionClient
        from test_msgs.action import Fibonacci
        self.goal = Fibonacci.Goal
        self.client = ActionClient(node, Fibonacci, action)
        self.feedback = threading.Event()

    def wait(self):
        if not self.client.wait_for_server(timeout_sec=20):
            raise RuntimeError("no action server within 20 s")
        return "ok"

    def send(self, order):
        self.feedback.clear()
        handle = wait_future(self.client.send_goal_async(self.goal(order=order),
                                                          feedback_callback=lambda _: self.feedback.set()),
                             "answer to the goal")
        if not handle.accepted:
            raise RuntimeError("goal rejected")
        return handle

    def run(self, n):
        sent = []
        for i in range(n):
            t0 = now_ns()
            handle = self.send(i)
            wait_future(handle.get_result_async(), "result")
            sent.append((i, t0))
        return json.dumps({"sent": sent})

    def cancel_run(self, n):
        sent = []
        for i in range(n):
            handle = self.send(-(i + 1))
            if not self.feedback.wait(20):
                raise RuntimeError("the long goal never executed")
            t0 = now_ns()
            wait_future(handle.cancel_goal_async(), "answer to the cancel")
            wait_future(handle.get_result_async(), "result of the canceled goal")
            sent.append((i, t0))
        return json.dumps({"sent": sent})


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=["sink", "source", "oneshot", "action-server", "action-client", "radar-sink",
                                         "radar-source"])
    ap.add_argument("--topic", required=True)
    ap.add_argument("--seq", type=int, default=0)
    ap.add_argument("--inline", action="store_true")
    a = ap.parse_args()
    rclpy.init()
    node = Node(f"rclpy_{a.role.replace('-', '_')}", namespace="/bench")
    if a.role == "oneshot":
        oneshot(node, a.topic, a.seq)
        return
    lock = threading.Lock()
    record = []
    actions = {}
    driver = None
    radar_stages = None
    if a.role == "action-server":
        server = action_server(node, a.topic, lock, actions)
    elif a.role == "action-client":
        driver = Driver(node, a.topic)
    elif a.role == "radar-sink":
        radar, resp, radar_stages = radar_sink(a.topic, lock, record, a.inline)
    elif a.role == "radar-source":
        radar, ev, ev_ready, feed = radar_source(a.topic)
    elif a.role == "sink":
        def on_msg(h):
            age = now_ns() - (h.stamp.sec * 1_000_000_000 + h.stamp.nanosec)
            with lock:
                record.append((int(h.frame_id), age))
        node.create_subscription(Header, a.topic, on_msg, QOS)
    else:
        pub = node.create_publisher(Header, a.topic, QOS)
    if a.role.startswith("action"):
        from rclpy.executors import MultiThreadedExecutor
        executor = MultiThreadedExecutor(num_threads=4)
    else:
        executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin)
    spinner.start()
    print("ready", flush=True)
    for line in sys.stdin:
        w = line.split()
        if not w:
            continue
        if w[0] == "quit":
            break
        try:
            if driver is not None and w[0] == "wait":
                answer = driver.wait()
            elif driver is not None and w[0] == "run":
                answer = driver.run(int(w[1]))
            elif driver is not None and w[0] == "cancel-run":
                answer = driver.cancel_run(int(w[1]))
            elif a.role == "action-server" and w[0] == "report":
                with lock:
                    answer = json.dumps({"exec": actions.get("exec", []), "cancel": actions.get("cancel", [])})
                    actions.clear()
            elif w[0] == "wait" and a.role == "source":
                deadline = time.monotonic() + 20
                while pub.get_subscription_count() < 1:
                    if time.monotonic() > deadline:
                        raise RuntimeError("no subscriber within 20 s")
                    time.sleep(0.01)
                answer = "ok"
            elif w[0] == "wait" and a.role == "radar-source":
                # something listens (the event checks only then) and its first check is waiting
                if not ev_ready.wait(20):
                    raise RuntimeError("the event got no listener within 20 s")
                answer = "ok"
            elif w[0] == "run" and a.role in ("source", "radar-source"):
                n = int(w[1])
                send = feed if a.role == "radar-source" else (lambda i: pub.publish(stamped(i)))
                paced(n, int(w[2]) / 1e6, send)
                answer = f"sent {n}"
            elif w[0] == "report" and a.role == "radar-sink":
                warmup = int(w[1])
                with lock:
                    got = list(record)
                    record.clear()
                    extra = {"not_started": resp.state()["ignored_starts"], "build": radar_build()}
                    if radar_stages is not None:
                        extra["stages_us"] = stage_p50s(radar_stages, [(s, l) for s, l in got if s >= warmup])
                        radar_stages["runs"].clear()
                answer = json.dumps({"lat_ns": [l for s, l in got if s >= warmup], "received": len(got),
                                     "extra": extra})
            elif w[0] == "report" and a.role == "sink":
                warmup = int(w[1])
                with lock:
                    got = list(record)
                    record.clear()
                answer = json.dumps({"lat_ns": [l for s, l in got if s >= warmup], "received": len(got),
                                     "extra": {}})
            else:
                raise ValueError(f"unknown command {w[0]} for {a.role}")
        except Exception as e:  # answer, and go on serving
            answer = f"error {e}"
        print(answer, flush=True)
    if a.role in ("radar-sink", "radar-source"):
        radar.shutdown()
    executor.shutdown()
    spinner.join(timeout=5)
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
