#!/usr/bin/env python3
"""A radar_ros response (the Python package) that drives an rclpy action client: its start slot sends a goal
to a `test_msgs/action/Fibonacci` server and returns the result; an interrupt (`until`, or a signal on its
`interrupt` slot) cancels the goal on the server before the exit slot runs.

    python3 examples/python/fibonacci_action.py [--order N] [--cancel-after SECONDS]

Runs its own rclpy action server (in this process, for the example to be whole), then
`once go start fib until stop`: `go` triggers at 0.5 s; with --cancel-after, `stop` triggers then and the goal
is canceled. Prints what happens.
"""

from __future__ import annotations

import argparse
import asyncio
import threading
import time
from typing import Any, List

import radar_ros
import rclpy
from rclpy.action import ActionClient, ActionServer, CancelResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from test_msgs.action import Fibonacci
from std_msgs.msg import Int32


def serve(node: Node) -> ActionServer:
    """The action server: one Fibonacci number every 0.1 s, cancelable."""

    def execute(goal: ServerGoalHandle) -> Fibonacci.Result:
        seq: List[int] = [0, 1]
        for _ in range(goal.request.order - 1):
            if goal.is_cancel_requested:
                goal.canceled()
                print(f"server: goal canceled after {len(seq)} numbers", flush=True)
                return Fibonacci.Result(sequence=seq)
            time.sleep(0.1)
            seq.append(seq[-1] + seq[-2])
        goal.succeed()
        return Fibonacci.Result(sequence=seq)

    return ActionServer(node, Fibonacci, "fibonacci", execute_callback=execute,
                        cancel_callback=lambda _: CancelResponse.ACCEPT)


class Fib(radar_ros.Response):
    """start(order) -> the last number of the sequence; interrupt cancels the goal."""

    start_type = Int32
    output_type = Int32

    def __init__(self, client: ActionClient):
        self.client = client
        self.goal: Any = None

    async def start(self, order: Int32) -> Int32:
        if not self.client.wait_for_server(timeout_sec=10):
            raise radar_ros.SlotError("no fibonacci action server within 10 s")
        self.goal = await asyncio.wrap_future(_future(self.client.send_goal_async(Fibonacci.Goal(order=order.data))))
        if not self.goal.accepted:
            raise radar_ros.SlotError("goal rejected")
        print(f"fib: goal of order {order.data} accepted", flush=True)
        result = await asyncio.wrap_future(_future(self.goal.get_result_async()))
        return Int32(data=result.result.sequence[-1])

    async def interrupt(self) -> None:
        # the run is over when the server has stopped the goal, not when it has heard the request
        if self.goal is not None:
            await asyncio.wrap_future(_future(self.goal.cancel_goal_async()))
            result = await asyncio.wrap_future(_future(self.goal.get_result_async()))
            print(f"fib: interrupted: goal ended with status {result.status} (5: canceled)", flush=True)

    async def exit(self, reason: radar_ros.ExitReason) -> None:
        print(f"fib: exit slot ({reason})", flush=True)


def _future(rclpy_future: Any) -> "asyncio.Future[Any]":
    """An rclpy future (completed by the executor's threads) as a concurrent one asyncio can await."""
    import concurrent.futures

    f: "concurrent.futures.Future[Any]" = concurrent.futures.Future()

    def done(d: Any) -> None:
        if f.set_running_or_notify_cancel():  # False: the awaiting slot was cancelled meanwhile
            f.set_result(d.result())

    rclpy_future.add_done_callback(done)
    return f  # type: ignore[return-value]


class After(radar_ros.Event):
    def __init__(self, seconds: float):
        self.seconds = seconds

    async def check(self) -> None:
        await asyncio.sleep(self.seconds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, default=10)
    ap.add_argument("--cancel-after", type=float, default=None, help="seconds after go to interrupt")
    args, _ = ap.parse_known_args()
    rclpy.init()
    node = rclpy.create_node("fibonacci_example")
    server = serve(node)
    client = ActionClient(node, Fibonacci, "fibonacci")
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    spinning = threading.Thread(target=executor.spin, daemon=True)
    spinning.start()
    try:
        with radar_ros.Radar() as radar:
            fib = radar.spawn_response("fib", Fib(client))
            def go_check() -> Int32:
                radar_ros.sleep(0.5)
                return Int32(data=args.order)

            go = radar.spawn_event("go", go_check, payload_type=Int32)
            stop_after = 0.5 + (args.cancel_after if args.cancel_after is not None else 3600.0)
            stop = radar.spawn_event("stop", After(stop_after))
            exited = radar.waiter(fib.exited)
            with radar.once(go).start(fib).until(stop):
                out = exited.recv(timeout=30)
            print(f"fib exited with {out.data}", flush=True)
    finally:
        server.destroy()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
