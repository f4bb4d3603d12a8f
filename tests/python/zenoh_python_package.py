"""The radar_ros Python package over Zenoh (issue 37): a Python program whose `Radar` runs on Zenoh, as a ROS 2
Python program does under `RMW_IMPLEMENTATION=rmw_zenoh_cpp`, through a router in rmw_zenoh's default layout.

    python zenoh_python_package.py DOMAIN DELIBERATIVE_EXE

Needs the package built with its `zenoh` feature (`RADAR_PY_FEATURES=zenoh tests/python_package.sh`) and run
where port 7447 is free (tests/isolated.sh). It starts, each in a process of its own: the router
(`zenoh_router.py`), the design-document peer (`zenoh_peer.py`) and the `deliberative` example's
`test_response` (a Rust program on Zenoh, DELIBERATIVE_EXE built with the examples' `zenoh` feature). Then:

1. a Python response `/zp/echo` is started by the peer (its `start` published as rmw_zenoh publishes) and its
   `exited` reaches the peer, upper-cased;
2. the Rust `test_response` is found by name on the graph the liveliness tokens make, started by a Python
   event through `once ... start ... until`, and interrupted by a second Python event: its `started`,
   `interrupted` and `exited` reach this program.

Prints a JSON line per step ({"echo": ...}, {"rust_response": ...}); any failure raises (non-zero exit).

rclpy's wheels here have no rmw_zenoh_cpp, and rcl checks `RMW_IMPLEMENTATION` when its library loads (a
mismatch ends the process): this script loads rclpy's CDR first, then sets the variable for radar_ros, which
reads it when the `Radar` is made. Where rmw_zenoh is installed, setting it before starting is enough.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
from pathlib import Path
from typing import IO, Any, List

from rclpy.serialization import serialize_message  # noqa: F401 - loads rcl under the wheels' own RMW
from std_msgs.msg import Empty, String  # type: ignore[import-untyped]

HERE = Path(__file__).resolve().parent
WAIT = 20.0


class Child:
    """A helper process whose JSON lines are read in a thread of their own."""

    def __init__(self, args: List[str], python: bool = True):
        env = dict(os.environ)
        if python:
            # the Python helpers use rclpy's CDR only, under the wheels' own RMW
            env.pop("RMW_IMPLEMENTATION", None)
        env["PYTHONUNBUFFERED"] = "1"
        self.proc = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env, text=True
        )
        self.lines: "queue.Queue[str]" = queue.Queue()
        out: IO[str] = self.proc.stdout  # type: ignore[assignment]
        threading.Thread(target=self._read, args=(out,), daemon=True).start()

    def _read(self, out: IO[str]) -> None:
        for line in out:
            self.lines.put(line.rstrip("\n"))

    def line(self, timeout: float = WAIT) -> str:
        return self.lines.get(timeout=timeout)

    def until(self, pred: Any, what: str, timeout: float = WAIT) -> Any:
        """The first JSON line for which ``pred`` holds (others skipped), within ``timeout`` of the last line."""
        while True:
            try:
                raw = self.line(timeout)
            except queue.Empty:
                raise AssertionError(f"{what}: nothing more within {timeout} s") from None
            try:
                doc = json.loads(raw)
            except ValueError:
                continue
            if pred(doc):
                return doc

    def send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
        self.proc.wait(timeout=WAIT)


def main() -> None:
    domain, deliberative = sys.argv[1:3]
    router = Child([sys.executable, str(HERE / "zenoh_router.py"), "tcp/127.0.0.1:7447"])
    assert router.line() == "up"
    children = [router]
    try:
        run(domain, deliberative, children)
    finally:
        for c in reversed(children):
            c.stop()


def run(domain: str, deliberative: str, children: List[Child]) -> None:
    os.environ["ROS_DOMAIN_ID"] = domain
    os.environ["RMW_IMPLEMENTATION"] = "rmw_zenoh_cpp"
    import radar_ros

    rust = Child([deliberative, "test_response"], python=False)
    children.append(rust)
    with radar_ros.Radar(args=[], program="zp_program") as r:
        # 1. the design-document peer starts a Python response and hears its exited
        r.spawn_response("/zp/echo", lambda m: String(data=m.data.upper()), start_type=String, output_type=String)
        peer = Child(
            [sys.executable, str(HERE / "zenoh_peer.py"), "tcp/127.0.0.1:7447", domain, "std_msgs/msg/String",
             "/zp/echo/exited", "/zp/echo/start"]
        )
        children.append(peer)
        peer.until(lambda d: "up" in d, "the peer is up")
        heard = None
        for _ in range(int(WAIT / 0.2)):
            peer.send(json.dumps({"data": "dock"}))
            try:
                heard = peer.until(lambda d: "received" in d, "exited", timeout=0.2)
                break
            except AssertionError:
                continue
        assert heard is not None and heard["received"] == {"data": "DOCK"}, heard
        print(json.dumps({"echo": heard["received"]["data"]}), flush=True)

        # 2. a Rust response in another process, found by name over Zenoh and driven from Python
        far = r.response("/test_response", timeout=WAIT)
        started = r.waiter(far.started, msg_type=Empty, timeout=WAIT)
        interrupted = r.waiter(far.interrupted, msg_type=Empty, timeout=WAIT)
        exited = r.waiter(far.exited, msg_type=Empty, timeout=WAIT)
        go = r.spawn_event("/zp/go", radar_ros.TimerEvent(0.2))
        stop = r.spawn_event("/zp/stop", radar_ros.TimerEvent(1.5))
        with r.once(go).start(far).until(stop):
            started.recv(timeout=WAIT)
            interrupted.recv(timeout=WAIT)
            exited.recv(timeout=WAIT)
        print(json.dumps({"rust_response": ["started", "interrupted", "exited"]}), flush=True)


if __name__ == "__main__":
    main()
