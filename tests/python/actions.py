#!/usr/bin/env python3
"""rclpy side of the action tests (tests/actions.rs): a real rclpy ActionServer and ActionClient of
test_msgs/action/Fibonacci, on Fast DDS, from the venv that tests/python_env.sh builds. Prints JSON lines on
stdout, one per observation; exits non-zero (with a reason on stderr) when something it waits for does not come.

    actions.py server ACTION [--period S] [--reject-above N]
        the ROS 2 tutorial's Fibonacci server: one number every S seconds with feedback; a canceled goal ends
        CANCELED with the sequence so far; goals with order > N are rejected. Serves until killed.
    actions.py client ACTION ORDER [--cancel-after S]
        sends one goal as `ros2 action send_goal --feedback` does (a fresh process), prints the answer, each
        feedback and the result; cancels after S seconds if asked.
"""
import argparse
import json
import sys
import threading
import time

import rclpy
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from test_msgs.action import Fibonacci

TIMEOUT = 15.0
STATUS = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED", 5: "CANCELED",
          6: "ABORTED"}


def out(**kv):
    kv.setdefault("t", time.time())
    print(json.dumps(kv), flush=True)


def fail(why):
    print(f"actions.py: {why}", file=sys.stderr, flush=True)
    sys.exit(2)


def server(node, a):
    group = ReentrantCallbackGroup()

    def on_goal(goal):
        if a.reject_above is not None and goal.order > a.reject_above:
            out(event="rejected", order=goal.order)
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_cancel(_):
        out(event="cancel_requested")
        return CancelResponse.ACCEPT

    def execute(goal_handle):
        order = goal_handle.request.order
        out(event="execute", order=order)
        seq = [0, 1]
        fb = Fibonacci.Feedback()
        for i in range(1, order):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                out(event="done", status="CANCELED", sequence=seq)
                return Fibonacci.Result(sequence=seq)
            seq.append(seq[i] + seq[i - 1])
            fb.sequence = seq
            goal_handle.publish_feedback(fb)
            time.sleep(a.period)
        goal_handle.succeed()
        out(event="done", status="SUCCEEDED", sequence=seq)
        return Fibonacci.Result(sequence=seq)

    ActionServer(node, Fibonacci, a.action, execute_callback=execute, goal_callback=on_goal,
                 cancel_callback=on_cancel, callback_group=group)
    out(event="ready")
    ex = MultiThreadedExecutor(num_threads=4)
    ex.add_node(node)
    ex.spin()


def client(node, a):
    c = ActionClient(node, Fibonacci, a.action)
    if not c.wait_for_server(timeout_sec=TIMEOUT):
        fail(f"no action server {a.action} within {TIMEOUT}s")
    out(event="server")

    def feedback(msg):
        out(event="feedback", sequence=list(msg.feedback.sequence))

    fut = c.send_goal_async(Fibonacci.Goal(order=a.order), feedback_callback=feedback)
    rclpy.spin_until_future_complete(node, fut, timeout_sec=TIMEOUT)
    if not fut.done():
        fail("no answer to the goal")
    handle = fut.result()
    out(event="answer", accepted=handle.accepted)
    if not handle.accepted:
        return
    res = handle.get_result_async()
    if a.cancel_after is not None:
        deadline = time.monotonic() + a.cancel_after
        while time.monotonic() < deadline and not res.done():
            rclpy.spin_once(node, timeout_sec=0.01)
        cf = handle.cancel_goal_async()
        rclpy.spin_until_future_complete(node, cf, timeout_sec=TIMEOUT)
        if not cf.done():
            fail("no answer to the cancel request")
        out(event="cancel_answer", canceling=len(cf.result().goals_canceling))
    rclpy.spin_until_future_complete(node, res, timeout_sec=TIMEOUT)
    if not res.done():
        fail("no result")
    r = res.result()
    out(event="result", status=STATUS.get(r.status, str(r.status)), sequence=list(r.result.sequence))


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("server")
    s.add_argument("action")
    s.add_argument("--period", type=float, default=0.05)
    s.add_argument("--reject-above", type=int, default=None)
    c = sub.add_parser("client")
    c.add_argument("action")
    c.add_argument("order", type=int)
    c.add_argument("--cancel-after", type=float, default=None)
    a = p.parse_args()
    rclpy.init()
    node = Node(f"actions_py_{a.cmd}")
    try:
        {"server": server, "client": client}[a.cmd](node, a)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
