"""Shared helpers for the package's tests: every test runs over real DDS (RustDDS in the engine, Fast DDS in
rclpy), inside tests/isolated.sh's private network namespace, each test file on a domain of its own.

The tests are run by `cargo test` (tests/python_package.rs), which builds and installs the package into the
interop venv first and says where the Rust helper binaries are (RADAR_TEST_PEER, RADAR_COUNT_UP_EXE).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterator, List, Optional

import pytest

ROOT = Path(__file__).resolve().parents[3]
#: How long a wait on discovery or a signal may take before a test fails.
WAIT = 15.0


def require_isolation() -> None:
    assert os.environ.get("RADAR_ISOLATED") == "1" or os.environ.get("RADAR_ALLOW_NETWORK") == "1", (
        "these tests send DDS multicast: run them inside tests/isolated.sh (cargo test does)"
    )


def helper(var: str) -> str:
    """The path of a Rust helper binary the test runner names; fails (not skips) without it."""
    path = os.environ.get(var)
    assert path and Path(path).exists(), (
        f"{var} is not set to a built binary: run these tests through `cargo test -p radar_ros_tests --test "
        f"python_package` (it builds the helpers and sets {var})"
    )
    return path


def eventually(cond: Callable[[], bool], what: str, timeout: float = WAIT) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.01)


@pytest.fixture(autouse=True)
def _isolated() -> None:
    require_isolation()


class Peer:
    """`radar_test_peer host`: a Rust radar_ros program in another process, driven line by line."""

    def __init__(self, domain: int):
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
        self.proc = subprocess.Popen(
            [helper("RADAR_TEST_PEER"), "host"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )

    def ask(self, line: str) -> List[str]:
        """Sends one command; the lines it answered, up to its `ok` (fails on `err`)."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        out = []
        while True:
            reply = self.proc.stdout.readline().strip()
            assert reply, f"the peer ended while answering {line!r}: {self.stderr()}"
            assert not reply.startswith("err"), f"{line!r}: {reply}"
            if reply == "ok":
                return out
            out.append(reply)

    def stderr(self) -> str:
        if self.proc.poll() is None:
            return ""
        assert self.proc.stderr is not None
        return self.proc.stderr.read()

    def quit(self) -> str:
        """Leaves the graph cleanly; what it logged."""
        if self.proc.poll() is None:
            assert self.proc.stdin is not None
            self.proc.stdin.write("quit\n")
            self.proc.stdin.flush()
        _, err = self.proc.communicate(timeout=WAIT)
        return err


@pytest.fixture
def peer_factory() -> Iterator[Callable[[int], Peer]]:
    peers: List[Peer] = []

    def make(domain: int) -> Peer:
        p = Peer(domain)
        peers.append(p)
        return p

    yield make
    for p in peers:
        if p.proc.poll() is None:
            p.proc.kill()
            p.proc.wait()


def run_python(script: str, domain: int, *args: str, timeout: Optional[float] = 60) -> subprocess.CompletedProcess:
    """Runs a Python program with this interpreter (the venv with the package) in `domain`."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    return subprocess.run(
        [sys.executable, script, *args], capture_output=True, text=True, env=env, timeout=timeout
    )


def error_lines(stderr: str) -> List[str]:
    return [line for line in stderr.splitlines() if "ERROR" in line or "Traceback" in line]
