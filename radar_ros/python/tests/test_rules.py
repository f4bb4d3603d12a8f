"""Every response rule and statement kind, from Python, over real DDS (domain 215).

The rules are the Rust engine's: these tests check that a Python response and event run under them (start,
started, interrupt, exit always last, restart, the three start policies, failures and exceptions) and that
every statement (once, whenever, until, anonymous slots, waitfor, inject) works with Python components.
"""

from __future__ import annotations

import asyncio
import threading
import time
from typing import Any, List

import pytest
from conftest import WAIT, eventually

import radar_ros
from std_msgs.msg import Empty, Int32, String

DOMAIN = 215


def radar() -> radar_ros.Radar:
    return radar_ros.Radar(domain_id=DOMAIN, args=[])


class Recorder(radar_ros.Response):
    """Records what its slots do, in order; `start` runs `work` seconds (interruptible) and echoes."""

    start_type = String
    output_type = String

    def __init__(self, work: float = 0.0, restarts: int = 0):
        self.log: List[str] = []
        self.work = work
        self.restarts = restarts
        self.lock = threading.Lock()

    def add(self, what: str) -> None:
        with self.lock:
            self.log.append(what)

    def start(self, payload: Any) -> String:
        data = getattr(payload, "data", "")
        self.add(f"start:{data}")
        try:
            radar_ros.sleep(self.work)
        except radar_ros.Cancelled:
            self.add("cancelled")
            raise
        self.add("done")
        return String(data=f"out:{data}")

    def interrupt(self) -> None:
        self.add("interrupt")

    def exit(self, reason: radar_ros.ExitReason) -> Any:
        self.add(f"exit:{reason.kind}")
        if self.restarts > 0:
            self.restarts -= 1
            return radar_ros.Restart
        return None


def test_a_run_starts_completes_and_exits_with_its_output() -> None:
    with radar() as r:
        rec = Recorder()
        c = r.spawn_response("rules_echo", rec)
        found = r.response("/rules_echo", timeout=WAIT)
        assert found.start_slot.ros_type == "std_msgs/msg/String"
        assert found.exited.ros_type == "std_msgs/msg/String"
        started = r.waiter(c.started, timeout=WAIT)
        exited = r.waiter(c.exited, timeout=WAIT)
        r.inject(c.start_slot, String(data="a"), timeout=WAIT)
        assert started.recv(timeout=WAIT).data == "a"
        assert exited.recv(timeout=WAIT).data == "out:a"
        eventually(lambda: c.state()["exits"] == 1, "the state to count the run")
        st = c.state()
        assert (st["starts"], st["completed"], st["last_exit_reason"]) == (1, 1, "completed")
        assert rec.log == ["start:a", "done", "exit:completed"]


def test_until_interrupts_the_run_and_the_exit_slot_runs_last() -> None:
    with radar() as r:
        rec = Recorder(work=30.0)
        c = r.spawn_response("rules_until", rec, start_type=Empty)
        go = r.spawn_event("rules_go", radar_ros.TimerEvent(0.2))
        stop = r.spawn_event("rules_stop", radar_ros.TimerEvent(0.6))
        interrupted = r.waiter(c.interrupted, timeout=WAIT)
        exited = r.waiter(c.exited, timeout=WAIT)
        with r.once(go).start(c).until(stop):
            interrupted.recv(timeout=WAIT)
            out = exited.recv(timeout=WAIT)
        # an incomplete run's exited carries the output type's default
        assert out.data == ""
        eventually(lambda: "exit:interrupted" in rec.log, "the exit slot")
        assert rec.log == ["start:", "cancelled", "interrupt", "exit:interrupted"], rec.log
        st = c.state()
        assert (st["interrupts"], st["last_exit_reason"]) == (1, "interrupted")


def test_an_exit_signal_ends_the_run_and_restart_starts_it_again() -> None:
    with radar() as r:
        rec = Recorder(work=30.0, restarts=1)
        c = r.spawn_response("rules_exit", rec)
        started = r.waiter(c.started, timeout=WAIT)
        r.inject(c.start_slot, String(data="x"), timeout=WAIT)
        started.recv(timeout=WAIT)
        restarted = r.waiter(c.started, timeout=WAIT)
        r.inject(c.exit_slot, None, timeout=WAIT)
        # on exit: restart, with the same payload
        assert restarted.recv(timeout=WAIT).data == "x"
        eventually(lambda: c.state()["restarts"] == 1 and len(rec.log) >= 4, "the restart")
        assert rec.log[:4] == ["start:x", "cancelled", "exit:exit_signal", "start:x"], rec.log
        assert c.state()["exit_signals"] == 1


@pytest.mark.parametrize(
    "policy, expect_starts, expect_ignored",
    [("ignore", ["start:1"], 1), ("restart", ["start:1", "start:2"], 0), ("queue_one", ["start:1", "start:2"], 0)],
)
def test_start_policies(policy: str, expect_starts: List[str], expect_ignored: int) -> None:
    with radar() as r:
        rec = Recorder(work=0.6)
        c = r.spawn_response(f"rules_policy_{policy}", rec, start_policy=policy)
        assert c.state()["start_policy"] == policy
        started = r.waiter(c.started, timeout=WAIT)
        r.inject(c.start_slot, String(data="1"), timeout=WAIT)
        started.recv(timeout=WAIT)
        r.inject(c.start_slot, String(data="2"), timeout=WAIT)
        eventually(lambda: c.state()["state"] == "idle" and c.state()["starts"] >= 1, "the runs to end", 10)
        time.sleep(0.8)  # a queued or restarted run would begin within this
        eventually(lambda: c.state()["state"] == "idle", "the last run to end", 10)
        starts = [e for e in rec.log if e.startswith("start:")]
        assert starts == expect_starts, rec.log
        assert c.state()["ignored_starts"] == expect_ignored
        if policy == "restart":
            assert "exit:exit_signal" in rec.log or "cancelled" in rec.log, rec.log
        if policy == "queue_one":
            assert rec.log.index("exit:completed") < rec.log.index("start:2"), rec.log


@pytest.mark.parametrize("inline", [False, True])
def test_a_slot_error_fails_the_run_and_an_exception_is_reported_as_a_panic(inline: bool) -> None:
    """Plain slots in a thread of their own, and inline (called on the engine's thread): the same ends."""

    class Failing(radar_ros.Response):
        def __init__(self) -> None:
            self.exits: List[str] = []

        def start(self, payload: Any) -> None:
            if isinstance(payload, Empty) and not self.exits:
                raise radar_ros.SlotError("no path to the dock")
            raise ValueError("dock sensor unreadable")

        def exit(self, reason: radar_ros.ExitReason) -> None:
            self.exits.append(str(reason))

    with radar() as r:
        f = Failing()
        c = r.spawn_response(f"rules_fail_{'inline' if inline else 'thread'}", f, inline=inline)
        r.inject(c.start_slot, None, timeout=WAIT)
        eventually(lambda: c.state()["exits"] == 1, "the failed run to end")
        assert c.state()["failures"] == 1
        assert c.state()["last_exit_reason"] == "failed: no path to the dock"
        r.inject(c.start_slot, None, timeout=WAIT)
        eventually(lambda: c.state()["exits"] == 2, "the crashed run to end")
        st = c.state()
        assert st["panics"] == 1
        reason = st["last_exit_reason"]
        # as a Rust panic is reported: the run ends as panicked, with what raised and where
        assert reason.startswith("panicked: "), reason
        assert "ValueError('dock sensor unreadable')" in reason and "test_rules.py" in reason, reason
        # the exit slot ran after each, and the response carries on
        assert [e.split(":")[0] for e in f.exits] == ["failed", "panicked"]


def test_async_slots_are_cancelled_at_their_await() -> None:
    class Waits(radar_ros.Response):
        def __init__(self) -> None:
            self.log: List[str] = []

        async def start(self, payload: Any) -> None:
            self.log.append("start")
            try:
                await asyncio.sleep(3600)
            except asyncio.CancelledError:
                self.log.append("cancelled")
                raise

        async def interrupt(self) -> None:
            self.log.append("interrupt")

        async def exit(self, reason: radar_ros.ExitReason) -> None:
            self.log.append(f"exit:{reason}")

    with radar() as r:
        w = Waits()
        c = r.spawn_response("rules_async", w)
        started = r.waiter(c.started, timeout=WAIT)
        r.inject(c.start_slot, None, timeout=WAIT)
        started.recv(timeout=WAIT)
        exited = r.waiter(c.exited, timeout=WAIT)
        t0 = time.monotonic()
        r.inject(c.interrupt_slot, None, timeout=WAIT)
        exited.recv(timeout=WAIT)
        assert time.monotonic() - t0 < 2.0
        assert w.log == ["start", "cancelled", "interrupt", "exit:interrupted"]


def test_an_event_checks_only_while_listened_to_and_drives_whenever() -> None:
    class Counter(radar_ros.Event):
        payload_type = Int32

        def __init__(self) -> None:
            self.n = 0
            self.active: List[bool] = []

        async def check(self) -> Int32:
            await asyncio.sleep(0.05)
            self.n += 1
            return Int32(data=self.n)

        def on_activate(self) -> None:
            self.active.append(True)

        def on_deactivate(self) -> None:
            self.active.append(False)

    with radar() as r:
        ev = Counter()
        e = r.spawn_event("rules_counter", ev)
        time.sleep(0.3)
        assert ev.n == 0 and not e.state()["active"], "no listener: no checks"
        got: List[int] = []
        seen_async: List[int] = []

        async def on_async(m: Int32) -> None:
            seen_async.append(m.data)

        with r.whenever(e).call(lambda m: got.append(m.data)), r.whenever(e).call(on_async):
            eventually(lambda: len(got) >= 5 and len(seen_async) >= 5, "five triggers in each slot")
        assert got == sorted(got) and len(set(got)) == len(got), got
        assert seen_async == sorted(seen_async), seen_async
        eventually(lambda: ev.active == [True, False], "the event to go inactive with its last listener")
        n = ev.n
        time.sleep(0.3)
        assert ev.n == n, "inactive: no more checks"


def test_once_delivers_one_signal_and_whenever_every_one() -> None:
    with radar() as r:
        e = r.spawn_event("rules_tick", radar_ros.TimerEvent(0.05))
        once: List[Any] = []
        every: List[Any] = []
        with r.once(e).call(lambda: once.append(1)) as c1, r.whenever(e).call(lambda: every.append(1)):
            c1.wait_closed(timeout=WAIT)
            assert not c1.live
            eventually(lambda: len(every) >= 4, "four triggers")
        assert once == [1]


def test_waitfor_gets_the_next_payload() -> None:
    with radar() as r:
        doubled = r.spawn_response(
            "rules_double",
            lambda m: Int32(data=m.data * 2),
            start_type="std_msgs/msg/Int32",
            output_type=Int32,
        )
        w = r.waiter(doubled.exited, msg_type=dict, timeout=WAIT)
        r.inject(doubled.start_slot, {"data": 21}, timeout=WAIT)
        assert w.recv(timeout=WAIT) == {"data": 42}

        def later() -> None:
            time.sleep(0.3)
            r.inject(doubled.start_slot, Int32(data=5), timeout=WAIT)

        threading.Thread(target=later).start()
        got = r.waitfor(doubled.exited, timeout=WAIT)
        assert isinstance(got, Int32) and got.data == 10
        raw = r.waiter(doubled.exited, msg_type=bytes, timeout=WAIT)
        r.inject(doubled.start_slot, (3).to_bytes(4, "little"), timeout=WAIT)
        assert raw.recv(timeout=WAIT) == (6).to_bytes(4, "little")


NO_RCLPY = """
import os, sys, tempfile
sys.modules["rclpy"] = None  # as on a machine without ROS 2's Python packages
os.environ.pop("AMENT_PREFIX_PATH", None)  # and no installation sourced
import radar_ros
# a package of the program's own, not installed: its definition in a directory given
own = tempfile.mkdtemp()
os.makedirs(os.path.join(own, "my_robot_msgs", "msg"))
with open(os.path.join(own, "my_robot_msgs", "msg", "Dock.msg"), "w") as f:
    f.write("string station\\nfloat64 speed 0.5\\nint32[] bays\\n")
assert not radar_ros.has_dict_form("my_robot_msgs/msg/Dock")
radar_ros.add_interfaces_dir(own)
assert radar_ros.has_dict_form("my_robot_msgs/msg/Dock")
with radar_ros.Radar(args=[]) as r:
    dock = r.spawn_response("nr_dock", lambda m: dict(m, bays=[len(m["station"])]),
                            start_type="my_robot_msgs/msg/Dock", output_type="my_robot_msgs/msg/Dock")
    wd = r.waiter(dock.exited, timeout=15)
    r.inject(dock.start_slot, {"station": "left"}, timeout=15)
    print("docked", sorted(wd.recv(timeout=15).items()))
    assert radar_ros._payload.message_class("std_msgs/msg/Int32") is None
    c = r.spawn_response("nr_double", lambda m: {"data": m["data"] * 2},
                         start_type="std_msgs/msg/Int32", output_type="std_msgs/msg/Int32")
    w = r.waiter(c.exited, timeout=15)
    r.inject(c.start_slot, {"data": 21}, timeout=15)
    print("got", w.recv(timeout=15))
    try:
        r.inject(c.start_slot, {"date": 1}, timeout=15)
    except radar_ros.PayloadTypeError as e:
        print("refused", e)
    unknown = r.spawn_response("nr_unknown", lambda m: None, start_type="no_such_msgs/msg/Thing")
    try:
        r.inject(unknown.start_slot, {"x": 1}, timeout=15)
    except radar_ros.PayloadTypeError as e:
        print("unknown", e)
"""


def test_dicts_work_without_python_message_packages() -> None:
    from conftest import run_python

    import os
    import tempfile

    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
        f.write(NO_RCLPY)
    try:
        out = run_python(f.name, DOMAIN)
    finally:
        os.unlink(f.name)
    assert out.returncode == 0, out.stderr
    assert "got {'data': 42}" in out.stdout, out.stdout
    # a type of the program's own, from its definition: fields left out take their defaults
    assert "docked [('bays', [4]), ('speed', 0.5), ('station', 'left')]" in out.stdout, out.stdout
    refused = [line for line in out.stdout.splitlines() if line.startswith("refused")]
    assert refused and "date" in refused[0], out.stdout
    unknown = [line for line in out.stdout.splitlines() if line.startswith("unknown")]
    assert unknown and "pass an instance of its rosidl class, or its CDR bytes" in unknown[0], out.stdout


def test_bad_input_gets_errors_that_say_what_to_do() -> None:
    with radar() as r:
        r.spawn_response("no_such_responder", lambda m: None)
        with pytest.raises(radar_ros.NotFound) as nf:
            r.response("/no_such_response", timeout=0.5)
        assert "no_such_response" in str(nf.value)
        # the details as attributes, not only in the text
        assert nf.value.name == "/no_such_response" and nf.value.kind == "response", vars(nf.value)
        assert nf.value.waited == pytest.approx(0.5), vars(nf.value)
        assert nf.value.candidates and nf.value.candidates[0].startswith("/no_such_responder"), vars(nf.value)
        with pytest.raises(radar_ros.RadarTimeout) as to:
            r.waitfor(radar_ros.Signal("/rules_silence/triggered", "std_msgs/msg/String"), timeout=0.2)
        assert to.value.waited == pytest.approx(0.2) and "/rules_silence" in (to.value.what or ""), vars(to.value)
        c = r.spawn_response("rules_typed", lambda m: None, start_type=String)
        with pytest.raises(radar_ros.PayloadTypeError) as pt:
            r.inject(c.start_slot, Int32(data=1), timeout=WAIT)
        assert "std_msgs/msg/Int32" in str(pt.value) and "std_msgs/msg/String" in str(pt.value)
        with pytest.raises(radar_ros.InvalidArgument) as ia:
            r.spawn_response("bad name!", lambda m: None)
        assert "bad name!" in str(ia.value)
        with pytest.raises(radar_ros.InvalidArgument):
            r.spawn_response("rules_dup", lambda m: None)
            r.spawn_response("rules_dup", lambda m: None)
        e = r.spawn_event("rules_payload", radar_ros.TimerEvent(1.0))
        with pytest.raises(radar_ros.PayloadTypeError):
            r.whenever(e).start(c).connect()
        with pytest.raises(radar_ros.InvalidArgument):
            r.once("not a signal")  # type: ignore[arg-type]
        # `until` goes with a start only (the native request has no other place for it), and says so
        u = radar_ros.Signal("/rules_u/triggered", "std_msgs/msg/Empty")
        with pytest.raises(radar_ros.InvalidArgument) as ia:
            r.once(e).interrupt(c).until(u).connect()
        assert "`until` goes with a `start` target" in str(ia.value) and "interrupt" in str(ia.value)
        # a depth of 0 is refused by the native request, saying what the default is
        with pytest.raises(radar_ros.InvalidArgument) as ia:
            r.once(e).exit(c).depth(0).connect()
        assert "at least 1" in str(ia.value)


def test_a_with_block_ends_its_connection_on_an_exception() -> None:
    with radar() as r:
        e = r.spawn_event("rules_exc", radar_ros.TimerEvent(0.05))
        got: List[int] = []
        conn: List[radar_ros.Connection] = []
        with pytest.raises(RuntimeError):
            with r.whenever(e).call(lambda: got.append(1)) as c:
                conn.append(c)
                eventually(lambda: len(got) >= 1, "a trigger")
                raise RuntimeError("the deliberative code failed")
        assert not conn[0].live
        eventually(lambda: not e.state()["active"], "the event to go inactive")


def test_asyncio_programs_await_lookups_connections_and_signals() -> None:
    async def main(r: radar_ros.Radar) -> List[Any]:
        c = r.spawn_response("rules_aio", lambda m: Int32(data=m.data + 1), start_type=Int32, output_type=Int32)
        e = r.spawn_event("rules_aio_tick", radar_ros.TimerEvent(0.05))
        found = await r.response_async("/rules_aio", timeout=WAIT)
        ticks: List[int] = []
        ticker = asyncio.get_running_loop()
        beat = asyncio.Event()

        async def on_tick() -> None:
            ticks.append(1)
            ticker.call_soon_threadsafe(beat.set)

        async with r.whenever(e).call(on_tick) as conn:
            # the caller's loop keeps running while the engine works
            await asyncio.wait_for(beat.wait(), WAIT)
            assert conn.live
        w = r.waiter(found.exited, timeout=WAIT)
        await r.inject_async(found.start_slot, Int32(data=41), timeout=WAIT)
        out = await w.recv_async(timeout=WAIT)
        return [out.data, len(ticks) >= 1, conn.live]

    with radar() as r:
        assert asyncio.run(main(r)) == [42, True, False]


def test_ros_args_place_components_as_rcl_does_and_bad_ones_are_refused() -> None:
    with radar_ros.Radar(domain_id=DOMAIN, args=["prog", "--ros-args", "-r", "__ns:=/robot7"]) as r:
        assert r.namespace == "/robot7"
        r.spawn_response("dock", lambda m: None)
        assert r.response("/robot7/dock", timeout=WAIT).name == "/robot7/dock"
        assert r.response("dock", timeout=WAIT).name == "/robot7/dock"
    with pytest.raises(radar_ros.InvalidArgument) as e:
        radar_ros.Radar(domain_id=DOMAIN, args=["prog", "--ros-args", "-r", "__ns:=no slash"])
    assert "no slash" in str(e.value)


@pytest.mark.parametrize("kind", ["async", "plain"])
def test_an_interrupt_right_after_a_start_finds_the_behaviour_begun(kind: str) -> None:
    """`started` never announces a behaviour that did not run: the engine's start slot ends its first step
    only once the Python behaviour has begun, even while the package's loop is busy elsewhere."""

    class Begins(radar_ros.Response):
        def __init__(self) -> None:
            self.log: List[str] = []

        async def interrupt(self) -> None:
            self.log.append("interrupt")

        async def exit(self, reason: radar_ros.ExitReason) -> None:
            self.log.append(f"exit:{reason}")

    class AsyncBegins(Begins):
        async def start(self, payload: Any) -> None:
            self.log.append("began")
            await asyncio.sleep(3600)

    class PlainBegins(Begins):
        def start(self, payload: Any) -> None:
            self.log.append("began")
            radar_ros.sleep(3600)

    b = AsyncBegins() if kind == "async" else PlainBegins()
    with radar() as r:
        c = r.spawn_response(f"rules_begins_{kind}", b)
        for i in range(10):
            started = r.waiter(c.started, timeout=WAIT)
            exited = r.waiter(c.exited, timeout=WAIT)
            # the slot loop busy for a moment (a slow slot elsewhere), then start and interrupt back to back
            r._loop.call_soon_threadsafe(time.sleep, 0.1)
            r.inject(c.start_slot, None, timeout=WAIT)
            r.inject(c.interrupt_slot, None, timeout=WAIT)
            started.recv(timeout=WAIT)
            exited.recv(timeout=WAIT)
            eventually(lambda: len(b.log) == 3 * (i + 1), "the run's slots")
            assert b.log[-3:] == ["began", "interrupt", "exit:interrupted"], (i, b.log)


def test_a_start_behaviour_run_in_the_runners_task_says_it_began_after_its_first_step_and_cancels_alike() -> None:
    """The package runs an `async def start` inside the task the engine scheduled (no task of its own, a loop
    iteration less on the start path): `begun` is said once it reached its first `await` (or ended before
    one), its value and exceptions come out as `await` gives them, values its awaits resolve to reach it,
    and cancelling the task cancels it at its `await` (its `finally` runs)."""
    from radar_ros import _begun_after_first_step

    async def scenario() -> None:
        log: List[str] = []

        def begun() -> None:
            log.append("begun")

        loop = asyncio.get_running_loop()
        fut: "asyncio.Future[int]" = loop.create_future()

        async def behaviour(x: int) -> int:
            log.append("first step")
            got = await fut
            log.append(f"got {got}")
            await asyncio.sleep(0)
            return x + got

        task = asyncio.ensure_future(_begun_after_first_step(behaviour(1), begun))
        await asyncio.sleep(0)
        assert log == ["first step", "begun"]
        fut.set_result(41)
        assert await task == 42
        assert log == ["first step", "begun", "got 41"]

        async def fails_at_once() -> None:
            raise ValueError("no")

        log.clear()
        with pytest.raises(ValueError, match="no"):
            await _begun_after_first_step(fails_at_once(), begun)
        assert log == ["begun"]

        async def returns_at_once() -> str:
            return "done"

        log.clear()
        assert await _begun_after_first_step(returns_at_once(), begun) == "done"
        assert log == ["begun"]

        async def runs_long() -> None:
            try:
                await asyncio.sleep(3600)
            except asyncio.CancelledError:
                log.append("cancelled at its await")
                raise
            finally:
                log.append("finally")

        log.clear()
        task = asyncio.ensure_future(_begun_after_first_step(runs_long(), begun))
        await asyncio.sleep(0)
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        assert log == ["begun", "cancelled at its await", "finally"]

        async def catches_and_goes_on() -> str:
            try:
                await asyncio.sleep(3600)
            except asyncio.CancelledError:
                await asyncio.sleep(0)
                return "handled"
            return "slept"

        task = asyncio.ensure_future(_begun_after_first_step(catches_and_goes_on(), begun))
        await asyncio.sleep(0)
        task.cancel()
        assert await task == "handled"

    asyncio.run(scenario())


def test_a_slot_call_to_a_closed_loop_raises_and_closes_its_coroutine() -> None:
    """A slot handed over after the slot loop closed (a program shutting down): `_SlotCall` raises, so the engine
    sees the slot fail, and the coroutine is closed, not left for Python to warn that it was never awaited."""
    import gc
    import warnings

    from radar_ros import _SlotCall

    ran: List[str] = []

    async def body() -> None:
        ran.append("ran")

    loop = asyncio.new_event_loop()
    loop.close()
    coro = body()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(RuntimeError):
            _SlotCall(coro, loop, lambda task: None)
        assert coro.cr_frame is None, "closed"
        del coro
        gc.collect()
    assert ran == []
    assert not [w for w in caught if "never awaited" in str(w.message)]


@pytest.mark.parametrize("debug", [False, True], ids=["task made by the engine's thread", "asyncio debug mode"])
def test_a_slot_call_runs_its_coroutine_on_the_loop_tells_its_end_and_cancels_from_another_thread(debug: bool) -> None:
    """How the engine hands a slot's coroutine to the slot loop (`_SlotCall`): it runs in a task of the loop,
    `done(outcome)` is called in the loop's thread with how it ended, inside the task's last step (not by a done
    callback a loop iteration later), and `cancel()` from another thread cancels it at its `await`, or, called
    before the loop took it, keeps it from running at all (closed, no warning). The same in asyncio's debug mode,
    where the loop's thread makes the task."""
    import gc
    import warnings

    from radar_ros import _SlotCall

    loop = asyncio.new_event_loop()
    loop.set_debug(debug)
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        ended: "List[Any]" = []
        got = threading.Event()

        def done(outcome: Any) -> None:
            try:
                value = outcome.result()
            except asyncio.CancelledError:
                value = "cancelled"
            in_task = asyncio.current_task(loop) is not None
            ended.append((threading.current_thread() is thread, in_task, value))
            got.set()

        async def answer() -> int:
            await asyncio.sleep(0)
            return 42

        _SlotCall(answer(), loop, done)
        assert got.wait(WAIT)
        assert ended == [(True, True, 42)]

        log: List[str] = []
        running = threading.Event()

        async def long() -> None:
            running.set()
            try:
                await asyncio.sleep(3600)
            except asyncio.CancelledError:
                log.append("cancelled at its await")
                raise

        got.clear()
        call = _SlotCall(long(), loop, done)
        assert running.wait(WAIT)
        call.cancel()
        assert got.wait(WAIT)
        assert ended[-1] == (True, True, "cancelled") and log == ["cancelled at its await"]

        # cancelled before its first step (the loop held busy, so cancel() comes before the loop takes it): its
        # body never runs, it is not left unawaited, and done() says it was cancelled
        gate = threading.Event()
        loop.call_soon_threadsafe(gate.wait, WAIT)
        ran: List[str] = []

        async def never() -> None:
            ran.append("ran")

        got.clear()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            call = _SlotCall(never(), loop, done)
            call.cancel()
            gate.set()
            assert got.wait(WAIT)
            gc.collect()
        # told by the task's first step (the task made by the engine's thread), or by its done callback (made by
        # the loop's, cancelled before that step)
        assert ran == [] and ended[-1] == (True, not debug, "cancelled")
        assert not [w for w in caught if "never awaited" in str(w.message)]
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(WAIT)
        loop.close()


def test_a_slot_call_pending_when_its_loop_is_closed_is_destroyed_untold() -> None:
    """A slot's coroutine still pending when its loop stops and closes (the program's end): its task is destroyed
    with the loop, and `done` is not told an outcome (the engine sees the loop stopped), not a `GeneratorExit`."""
    import gc

    from radar_ros import _SlotCall

    told: List[Any] = []
    started = threading.Event()

    async def forever() -> None:
        started.set()
        await asyncio.sleep(3600)

    def run_and_close() -> None:
        loop = asyncio.new_event_loop()
        thread = threading.Thread(target=loop.run_forever, daemon=True)
        thread.start()
        _SlotCall(forever(), loop, told.append)
        assert started.wait(WAIT)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(WAIT)
        loop.close()

    run_and_close()
    gc.collect()
    assert told == []


def os_thread_name() -> str:
    """The calling thread's name as the OS knows it (a thread the engine made is no Python thread: Python calls
    it "Dummy-N")."""
    with open(f"/proc/self/task/{threading.get_native_id()}/comm") as f:
        return f.read().strip()


class InlineRecorder(Recorder):
    """A Recorder whose slots are called inline (``Response.inline``): on the engine's thread, as rclpy calls
    a callback. Records the thread each slot ran on."""

    inline = True

    def __init__(self, work: float = 0.0, restarts: int = 0):
        super().__init__(work, restarts)
        self.threads: List[str] = []

    def start(self, payload: Any) -> String:
        self.threads.append(os_thread_name())
        data = getattr(payload, "data", "")
        self.add(f"start:{data}")
        time.sleep(self.work)  # a callback that overstays: nothing can cut it short
        self.add("done")
        return String(data=f"out:{data}")

    def exit(self, reason: radar_ros.ExitReason) -> Any:
        self.threads.append(os_thread_name())
        return super().exit(reason)


def test_an_inline_response_runs_its_slots_on_the_engines_thread_in_order() -> None:
    with radar() as r:
        rec = InlineRecorder(restarts=1)
        c = r.spawn_response("rules_inline", rec)
        started = r.waiter(c.started, timeout=WAIT)
        exited = r.waiter(c.exited, timeout=WAIT)
        r.inject(c.start_slot, String(data="a"), timeout=WAIT)
        assert started.recv(timeout=WAIT).data == "a"
        assert exited.recv(timeout=WAIT).data == "out:a"
        # exit returned Restart once: the run started again with the same payload, then ended
        eventually(lambda: c.state()["exits"] == 2, "the state to count both runs")
        assert rec.log == ["start:a", "done", "exit:completed"] * 2, rec.log
        # called where the signal was taken: neither a thread of their own nor the package's event loop
        assert len(rec.threads) == 4 and all(t.startswith("radar-engine") for t in rec.threads), rec.threads
        st = c.state()
        assert (st["starts"], st["completed"], st["restarts"]) == (2, 2, 1)


def test_an_interrupt_that_reaches_a_running_inline_start_finds_the_run_ended() -> None:
    """An inline start runs to its end as a callback does: an interrupt sent while it runs is taken after it
    returned (the run completed; its exit slot ran once, as completed), and the response takes the next start."""
    with radar() as r:
        rec = InlineRecorder(work=0.4)
        c = r.spawn_response("rules_inline_busy", rec)
        for i in range(3):
            began = len(rec.log)
            r.inject(c.start_slot, String(data=str(i)), timeout=WAIT)
            eventually(lambda: len(rec.log) > began, "the inline start to begin")
            r.inject(c.interrupt_slot, None, timeout=WAIT)
            eventually(lambda: c.state()["exits"] == i + 1, "the run to end")
            assert rec.log[began:] == [f"start:{i}", "done", "exit:completed"], rec.log
        st = c.state()
        assert (st["completed"], st["interrupts"]) == (3, 0), st


def test_an_inline_start_with_a_wrong_output_or_a_blocking_call_fails_saying_why() -> None:
    with radar() as r:
        # a start that returns what is not its output fails the run, saying so
        c2 = r.spawn_response("rules_inline_bad_output", lambda p: 42, inline=True, output_type=String)
        r.inject(c2.start_slot, None, timeout=WAIT)
        eventually(lambda: c2.state()["exits"] == 1, "the run to end")
        reason = c2.state()["last_exit_reason"]
        assert reason.startswith("failed: start returned 42, not its output (std_msgs/msg/String)"), reason
        # a blocking call on the engine's own thread is refused (it would wait for that thread), saying why
        c3 = r.spawn_response("rules_inline_blocks", lambda p: r.inject(c2.start_slot, None), inline=True)
        r.inject(c3.start_slot, None, timeout=WAIT)
        eventually(lambda: c3.state()["exits"] == 1, "the run to end")
        reason = c3.state()["last_exit_reason"]
        assert "InvalidArgument" in reason and "would stall the engine" in reason, reason
        assert c2.state()["starts"] == 1


def test_an_inline_response_with_async_slots_is_refused_saying_what_to_do() -> None:
    class AsyncStart(radar_ros.Response):
        async def start(self, payload: Any) -> None:
            pass

    class AsyncExit(radar_ros.Response):
        def start(self, payload: Any) -> None:
            pass

        async def exit(self, reason: radar_ros.ExitReason) -> None:
            pass

    with radar() as r:
        for name, resp, slot in [("rules_inline_a", AsyncStart(), "start"), ("rules_inline_b", AsyncExit(), "exit")]:
            with pytest.raises(radar_ros.InvalidArgument) as e:
                r.spawn_response(name, resp, inline=True)
            assert f"its {slot} is an async def: make it a plain def" in str(e.value), e.value
        # the same classes are fine on the event loop; the base's interrupt and exit (do nothing) fine inline
        r.spawn_response("rules_inline_c", AsyncExit())
        r.spawn_response("rules_inline_d", lambda p: None, inline=True)
