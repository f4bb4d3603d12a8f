#!/usr/bin/env python3
"""The paper's Listing 1 with the radar_ros Python package (the same engine, names, topics and printout as
the Rust example `cargo run --bin count_up`):

    response CountUp:            event StartEvent:      event EndEvent:
      i = 0                        sleep (2 s)            sleep (4 s)
      while i < 10:                trigger                trigger
        sleep(0.5 s); i += 1
      interrupt                  def main:
      on exit: restart             once start_event start count_up until end_event

    pip install ./radar_ros/python        # once (needs a Rust toolchain)
    python3 examples/python/count_up.py [--duration SECONDS]

Ctrl-C (or SIGTERM) stops it at any time: CountUp's exit slot runs (`count_up exit slot (exit_signal)`),
`exited` is sent, and the program leaves the ROS graph.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from typing import Any, Dict, List, Optional

import radar_ros


class Timeline:
    """Prints what happens, with the time since main began (and the listing's time where it gives one)."""

    def __init__(self) -> None:
        self.t0 = time.monotonic()

    def mark(self, what: str, listing: Optional[float] = None) -> None:
        now = time.monotonic() - self.t0
        if listing is None:
            line = f"[{now:7.3f} s] {what}\n"
        else:
            line = f"[{now:7.3f} s] {what:<34} (listing: {listing:.1f} s)\n"
        # one write: marks come from several threads, and print() writes the text and its newline apart
        sys.stdout.write(line)
        sys.stdout.flush()


class CountUp(radar_ros.Response):
    """Counts to 10, one count every 0.5 s; on exit: restart."""

    def __init__(self, tl: Timeline):
        self.tl = tl

    async def start(self, payload: Any) -> None:
        # the listing's sleep(0.5 s) per count, on a grid from the run's start: late wake-ups do not add up
        begun = asyncio.get_running_loop().time()
        for i in range(1, 11):
            await asyncio.sleep(begun + 0.5 * i - asyncio.get_running_loop().time())
            self.tl.mark(f"count_up counts {i}")

    async def exit(self, reason: radar_ros.ExitReason) -> Any:
        self.tl.mark(f"count_up exit slot ({reason})")
        return radar_ros.Restart


class SleepThenTrigger(radar_ros.Event):
    """Triggers `delay` seconds after its check begins (the paper's StartEvent and EndEvent)."""

    def __init__(self, delay: float):
        self.delay = delay

    async def check(self) -> None:
        await asyncio.sleep(self.delay)


def watch_event(radar: radar_ros.Radar, tl: Timeline, name: str) -> radar_ros.Subscription:
    """Prints the event's triggers and activity, from its state topic."""
    seen: Dict[str, Any] = {"active": None, "triggers": 0}

    def on_state(st: Dict[str, Any]) -> None:
        if st["triggers"] > seen["triggers"]:
            seen["triggers"] = st["triggers"]
            listing = {("start_event", 1): 2.0, ("end_event", 1): 4.0}.get((name, st["triggers"]))
            tl.mark(f"{name} triggered", listing)
        if seen["active"] != st["active"]:
            seen["active"] = st["active"]
            tl.mark(f"{name} {'active (checking)' if st['active'] else 'inactive'}")

    return radar.subscribe(f"{name}/state", "radar_msgs/msg/EventState", on_state, state=True)


def watch_count_up(radar: radar_ros.Radar, tl: Timeline) -> List[radar_ros.Subscription]:
    """Prints count_up's signals, from its topics."""
    n = {"started": 0}

    def started(_: Any) -> None:
        n["started"] += 1
        tl.mark("count_up started", {1: 2.0, 2: 4.0, 3: 9.0}.get(n["started"]))

    return [
        radar.subscribe("count_up/started", radar_ros.EMPTY, started),
        radar.subscribe("count_up/interrupted", radar_ros.EMPTY, lambda _: tl.mark("count_up interrupted", 4.0)),
        radar.subscribe("count_up/exited", radar_ros.EMPTY, lambda _: tl.mark("count_up exited")),
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=12.0, help="seconds to run (default 12)")
    args, _ = ap.parse_known_args()  # --ros-args ... is the engine's
    with radar_ros.Radar() as radar:
        print(
            f"Listing 1 (count_up) on ROS 2 domain {radar.domain_id}; every component is a node on one DDS "
            "participant",
            flush=True,
        )
        tl = Timeline()  # main begins: the listing's times count from here
        count_up = radar.spawn_response("count_up", CountUp(tl))
        start_event = radar.spawn_event("start_event", SleepThenTrigger(2.0))
        end_event = radar.spawn_event("end_event", SleepThenTrigger(4.0))
        watchers = [watch_event(radar, tl, "start_event"), watch_event(radar, tl, "end_event")]
        watchers += watch_count_up(radar, tl)
        tl.mark("once start_event start count_up until end_event", 0.0)
        with radar.once(start_event).start(count_up).until(end_event):
            time.sleep(args.duration)
            for w in watchers:
                w.close()
            tl.mark("done: shutting down (count_up's exit slot runs once more)")
            count_up.shutdown()


if __name__ == "__main__":
    main()
