#!/usr/bin/env python3
"""A Python event's own share of its trigger, without DDS: from its check resuming (the moment the payload is
stamped, as `rclpy_hop.py radar-source` stamps it) to the engine's done callback holding the payload's CDR bytes.

Drives the package's own `_EventRunner` and `_SlotCall` as the engine does (the coroutine scheduled on a slot
loop thread, `done` called in that thread as it ends), with a `std_msgs/msg/Header` payload, a check woken through
an `asyncio.Queue` 1 ms after it began to wait (between signals, as the bench's 1 kHz feed). Prints the p50 and
p90 of 2,000 triggers after 500 of warm-up.

    python_event_probe.py LABEL                  the package as installed
    python_event_probe.py LABEL --rclpy-codec    the same with the payload serialized by rclpy's
                                                 `serialize_message` (the package's own codec turned off)
"""

import argparse
import asyncio
import threading
import time

import radar_ros
from radar_ros import _EventRunner, _SlotCall, _native, _payload
from std_msgs.msg import Header


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("label")
    p.add_argument("--rclpy-codec", action="store_true")
    a = p.parse_args()

    loop = asyncio.new_event_loop()
    threading.Thread(target=loop.run_forever, daemon=True).start()
    fed = {}

    async def make_queue() -> None:
        fed["queue"] = asyncio.Queue()

    asyncio.run_coroutine_threadsafe(make_queue(), loop).result()
    stamp = {}

    class Fed(radar_ros.Event):
        payload_type = Header

        async def check(self):
            seq = await fed["queue"].get()
            t = time.perf_counter_ns()
            stamp["t"] = t
            h = Header(frame_id=str(seq))
            h.stamp.sec, h.stamp.nanosec = divmod(t, 1_000_000_000)
            return h

    radar_ros._warm("std_msgs/msg/Header")
    if a.rclpy_codec:
        _payload._NATIVE[Header] = ("std_msgs/msg/Header", None)
    runner = _EventRunner("probe", Fed(), "std_msgs/msg/Header")
    lat = []
    for i in range(2500):
        ended = threading.Event()
        got = {}

        def done(outcome) -> None:
            got["t"] = time.perf_counter_ns()
            got["body"] = outcome.result()
            ended.set()

        _SlotCall(runner.check(), loop, done)
        time.sleep(0.001)
        loop.call_soon_threadsafe(fed["queue"].put_nowait, i)
        if not ended.wait(5):
            raise SystemExit("the check never ended")
        if not isinstance(got["body"], bytes):
            raise SystemExit(f"the check gave {got['body']!r}, not the payload's bytes")
        if i >= 500:
            lat.append((got["t"] - stamp["t"]) / 1000)
    lat.sort()
    print(f"{a.label}: check resumed -> done with the payload's bytes: p50 {lat[len(lat) // 2]:.1f} us, "
          f"p90 {lat[int(len(lat) * 0.9)]:.1f} us ({_native.BUILD} build)")


if __name__ == "__main__":
    main()
