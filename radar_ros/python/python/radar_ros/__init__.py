"""RADAR on ROS 2 for Python programs: the radar_ros Rust engine, with the paper's statements.

Events (condition checks that trigger) and responses (behaviour with ``start``, ``interrupt`` and ``exit``
slots) are ROS 2 nodes; ``once`` and ``whenever`` connect them for the length of a ``with`` block::

    import radar_ros

    class CountUp(radar_ros.Response):
        def start(self, payload):
            for i in range(10):
                print(i)
                radar_ros.sleep(0.5)

    with radar_ros.Radar() as radar:
        counter = radar.spawn_response("counter", CountUp())
        go = radar.spawn_event("go", radar_ros.TimerEvent(2.0))
        with radar.whenever(go).start(counter):
            radar.waitfor(counter.exited)

The response state machine, the connections and the wire are the Rust crate's (same rules, same topics, same
errors); Python code runs only inside slots. See README.md, "Python", for what differs from the Rust API.
"""

from __future__ import annotations

import asyncio
import atexit
import ctypes
import inspect
import signal as _signal_module
import sys
import threading
import time
import types
import weakref
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Dict, Generator, List, Literal, Optional, Tuple, Union

from . import _native
from ._errors import (
    Cancelled,
    ComponentLost,
    InvalidArgument,
    NotFound,
    PayloadTypeError,
    RadarError,
    RadarTimeout,
    SlotError,
)
from ._payload import (
    EMPTY,
    MsgType,
    RawPayload,
    add_interfaces_dir,
    decode,
    dict_types,
    encode,
    has_dict_form,
    message_class,
    native_codec,
    type_name,
)

Signal = _native.Signal
Slot = _native.Slot
EventRef = _native.EventRef
ResponseRef = _native.ResponseRef

__all__ = [
    "Radar",
    "Response",
    "Event",
    "TimerEvent",
    "Restart",
    "ExitReason",
    "Component",
    "Connection",
    "Statement",
    "Connect",
    "Waiter",
    "Subscription",
    "Signal",
    "Slot",
    "EventRef",
    "ResponseRef",
    "RawPayload",
    "sleep",
    "dict_types",
    "has_dict_form",
    "add_interfaces_dir",
    "type_name",
    "RadarError",
    "RadarTimeout",
    "NotFound",
    "PayloadTypeError",
    "InvalidArgument",
    "ComponentLost",
    "SlotError",
    "Cancelled",
    "EMPTY",
]


class Restart:
    """Return ``Restart`` (the class or an instance) from ``exit`` to start again with the same payload: the
    paper's ``on exit: restart``."""


class ExitReason(str):
    """Why a run ended, as the response's state says it: ``completed``, ``interrupted``, ``exit_signal``,
    ``failed: <message>`` or ``panicked: <exception and traceback>``."""

    @property
    def kind(self) -> str:
        """The reason without its detail: ``completed``, ``interrupted``, ``exit_signal``, ``failed`` or
        ``panicked``."""
        return self.split(":", 1)[0]

    @property
    def detail(self) -> str:
        """The failure's message or the exception's text ('' for the other kinds)."""
        parts = self.split(": ", 1)
        return parts[1] if len(parts) > 1 else ""


def sleep(seconds: float) -> None:
    """``time.sleep`` for plain ``def`` slots: sleeps in short steps so that an interrupt ends it at once (a
    plain ``time.sleep`` ends only when it has slept)."""
    end = time.monotonic() + seconds
    while True:
        left = end - time.monotonic()
        if left <= 0:
            return
        time.sleep(min(left, 0.02))


class Response:
    """Behaviour with ``start``, ``interrupt`` and ``exit`` slots. Subclass it and override ``start``.

    Slots may be plain functions (they run in a thread of their own; an interrupt raises :class:`Cancelled`
    in that thread at its next Python instruction: use :func:`sleep`, not ``time.sleep``) or ``async def``
    (they run on the package's event loop; an interrupt cancels them at their current ``await``).

    Class attributes (or the same-named arguments of :meth:`Radar.spawn_response`):

    - ``start_type``: what ``start`` takes and ``started`` carries (a rosidl class or ``"pkg/msg/Name"``;
      default ``std_msgs/msg/Empty``);
    - ``output_type``: what ``start`` returns and ``exited`` carries (default ``std_msgs/msg/Empty``);
    - ``start_policy``: what a ``start`` during a run does: ``"ignore"`` (default), ``"restart"``,
      ``"queue_one"``;
    - ``inline``: ``True`` calls the slots as rclpy calls a subscription's callback: plain functions, called
      on the engine's thread that received the signal, with no hand-off to a thread or to the event loop (the
      shortest path from a signal to the behaviour; ``started`` is still on the wire before ``start`` is
      called). They must return quickly, as a callback must: a running inline ``start`` cannot be interrupted
      (an ``interrupt`` or ``exit`` that arrives meanwhile is taken once it has returned, and finds the run
      ended), and while it runs it holds one of the engine's two threads. ``async def`` slots are refused
      (leave ``interrupt`` and ``exit`` as they are, or make them plain functions).
    """

    start_type: MsgType = EMPTY
    output_type: MsgType = EMPTY
    start_policy: str = "ignore"
    inline: bool = False

    def start(self, payload: Any) -> Any:
        """The main behaviour; its return value is the output (None: the output type's default). Raise
        :class:`SlotError` to end the run as failed."""
        return None

    async def interrupt(self) -> None:
        """Runs after an ``interrupt`` signal cancelled ``start``, before ``exit``."""

    async def exit(self, reason: ExitReason) -> Any:
        """Always runs last, whatever ended the run. Return :class:`Restart` to start again."""
        return None


class _FnResponse(Response):
    def __init__(self, fn: Callable[..., Any]):
        self._fn = fn
        self.start = fn  # type: ignore[method-assign]


class Event:
    """A condition check. Subclass it and override ``check``: it returns (the payload) when the condition
    holds, and is called again after each trigger while something listens to the event.

    ``check`` may be a plain function (a thread of its own, :class:`Cancelled` when the event becomes
    inactive) or ``async def``. ``payload_type`` is what ``triggered`` carries (default
    ``std_msgs/msg/Empty``).
    """

    payload_type: MsgType = EMPTY

    def check(self) -> Any:
        """Returns when the condition holds, with the payload (None: the payload type's default)."""
        raise NotImplementedError("an Event's check says when it triggers")

    def on_activate(self) -> None:
        """Called when the event becomes active (something listens), before the first check."""

    def on_deactivate(self) -> None:
        """Called when the event becomes inactive, after the running check was cancelled."""


class TimerEvent(Event):
    """Triggers every ``period`` seconds while active, first ``period`` after it becomes active."""

    def __init__(self, period: float):
        self.period = period

    async def check(self) -> None:
        await asyncio.sleep(self.period)


class _FnEvent(Event):
    def __init__(self, fn: Callable[[], Any]):
        self.check = fn  # type: ignore[method-assign]


def _is_async(fn: Any) -> bool:
    return inspect.iscoroutinefunction(fn) or inspect.iscoroutinefunction(getattr(fn, "__call__", None))


class _SlotCall:
    """A coroutine the engine runs on the slot loop, from the engine's thread: the coroutine runs in a task of
    the loop, ``done(outcome)`` is called in the loop's thread as it ends (``outcome.result()`` returns its value
    or raises what it raised), and :meth:`cancel` (any thread) cancels it. What ``asyncio.run_coroutine_threadsafe``
    does without its thread-safe future and the callbacks that chain the two, which the loop's thread ran before
    the coroutine's first step; ``done`` is called inside the task's last step, not by a done callback a loop
    iteration later, unless the task was cancelled before its first step.

    The task is made here, in the engine's thread, and the loop woken after: its first step runs in the loop
    iteration the wake-up starts, not in the one after it (where a task made by a callback of the loop's would
    take it), 15-50 us sooner on a 2-core machine. A task made outside its loop's thread is safe here: only
    the first step is queued (``call_soon``, one append to the loop's ready queue under the GIL), the loop is
    woken by ``call_soon_threadsafe`` after, and nothing else touches the task from this thread. asyncio's debug
    mode refuses it (``PYTHONASYNCIODEBUG``, ``-X dev``): then the loop's thread makes the task, as before."""

    __slots__ = ("_loop", "_coro", "_done", "_task", "_ended", "_cancelling")

    def __init__(self, coro: Any, loop: asyncio.AbstractEventLoop, done: Callable[[Any], None]):
        self._loop = loop
        self._coro: Any = coro
        self._done = done
        self._task: Optional["asyncio.Task[None]"] = None
        self._ended = False
        self._cancelling = False
        try:
            if loop.get_debug():
                loop.call_soon_threadsafe(self._begin)
            else:
                self._begin()
                loop.call_soon_threadsafe(_nothing)  # the wake-up: the first step is queued already
        except BaseException:
            # the loop is closed: the coroutine never runs; closed here, not left to warn "never awaited"
            self._coro = None
            coro.close()
            if self._task is not None:  # closed between the task and the wake-up: the task never steps
                self._task._log_destroy_pending = False
                self._task.get_coro().close()
            raise

    def _begin(self) -> None:
        run = self._run()
        try:
            self._task = self._loop.create_task(run)
        except BaseException:
            run.close()  # a closed loop: the wrapper never runs, and is not left to warn "never awaited"
            raise
        self._task.add_done_callback(self._after)

    async def _run(self) -> None:
        coro, self._coro = self._coro, None  # awaited from here on
        if self._cancelling:
            # cancel() came before this first step: the body never runs (the task itself is cancelled next)
            coro.close()
            self._end(_Outcome(None, asyncio.CancelledError()))
            return
        try:
            value = await coro
        except GeneratorExit:
            raise  # the task is being destroyed with its loop: no outcome (the engine sees the loop stopped)
        except BaseException as e:  # noqa: BLE001 - the outcome is the engine's to read, cancellation too
            self._end(_Outcome(None, e))
        else:
            self._end(_Outcome(value, None))

    def _end(self, outcome: "_Outcome") -> None:
        self._ended = True
        self._done(outcome)

    def _after(self, task: "asyncio.Task[None]") -> None:
        if self._ended:
            return
        # cancelled before its first step: the coroutine never ran
        coro, self._coro = self._coro, None
        if coro is not None:
            coro.close()
        self._end(_Outcome(None, asyncio.CancelledError()))

    def cancel(self) -> None:
        """Cancels the coroutine at its current ``await`` (before its first step if it has not taken it: its
        body does not run); from any thread."""
        self._cancelling = True  # read by the first step, if it has not begun
        try:
            self._loop.call_soon_threadsafe(self._cancel)
        except RuntimeError:  # the loop is closed: nothing runs on it any more
            pass

    def _cancel(self) -> None:
        # on the loop, after _begin: call_soon_threadsafe keeps the order of its calls
        if self._task is not None:
            self._task.cancel()


def _nothing() -> None:
    """What wakes the slot loop for a task queued from another thread (see :class:`_SlotCall`)."""


class _Outcome:
    """How a slot's coroutine ended, as the engine reads it: :meth:`result` returns its value or raises what it
    raised."""

    __slots__ = ("_value", "_error")

    def __init__(self, value: Any, error: Optional[BaseException]):
        self._value = value
        self._error = error

    def result(self) -> Any:
        if self._error is not None:
            raise self._error
        return self._value


@types.coroutine
def _begun_after_first_step(coro: Any, begun: Callable[[], None]) -> Generator[Any, Any, Any]:
    """Runs the coroutine ``coro`` in the awaiting task, as ``await coro`` does, calling ``begun()`` once it has
    run up to its first suspension (or ended before one). A task of its own would tell the same, one loop
    iteration later on the start path; cancelling the awaiting task cancels ``coro`` at its ``await`` alike."""
    it = coro.__await__()
    try:
        suspended = it.send(None)
    except StopIteration as done:
        begun()
        return done.value
    except BaseException:
        begun()
        raise
    begun()
    while True:
        try:
            sent = yield suspended
        except GeneratorExit:
            it.close()
            raise
        except BaseException as e:  # noqa: BLE001 - passed on into the coroutine, as `await` does
            try:
                suspended = it.throw(e)
            except StopIteration as done:
                return done.value
        else:
            try:
                suspended = it.send(sent)
            except StopIteration as done:
                return done.value


def _main_thread_signals_only() -> None:
    """Blocks SIGINT and SIGTERM in the calling thread (one of this package's), so that the kernel hands them
    to the main thread: Python acts on a signal only there, and a main thread asleep in ``time.sleep`` is woken
    only by a signal it takes itself (taken by another thread, Ctrl-C would wait for the sleep to end)."""
    if hasattr(_signal_module, "pthread_sigmask"):
        _signal_module.pthread_sigmask(_signal_module.SIG_BLOCK, {_signal_module.SIGINT, _signal_module.SIGTERM})


async def _in_thread(
    fn: Callable[..., Any], args: Tuple[Any, ...], name: str, begun: Optional[Callable[[], None]] = None
) -> Any:
    """Runs the plain function ``fn`` in a thread of its own; if this is cancelled, raises
    :class:`Cancelled` in that thread and waits until it has stopped before passing the cancel on."""
    loop = asyncio.get_running_loop()
    fut: "asyncio.Future[Any]" = loop.create_future()

    def settle(value: Any, error: Optional[BaseException]) -> None:
        if not fut.done():
            if error is not None:
                fut.set_exception(error)
            else:
                fut.set_result(value)

    def work() -> None:
        _main_thread_signals_only()
        try:
            try:
                if begun is not None:
                    begun()
                value, error = fn(*args), None
            except BaseException as e:  # noqa: BLE001 - handed to the slot's caller
                value, error = None, e
            loop.call_soon_threadsafe(settle, value, error)
        except BaseException as late:  # a Cancelled that landed after fn returned
            try:
                loop.call_soon_threadsafe(settle, None, late)
            except RuntimeError:
                pass

    t = threading.Thread(target=work, name=f"radar-slot {name}", daemon=True)
    t.start()
    try:
        return await asyncio.shield(fut)
    except asyncio.CancelledError:
        if t.is_alive() and t.ident is not None:
            ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(t.ident), ctypes.py_object(Cancelled))
        await asyncio.wait([fut])
        if not fut.cancelled():
            fut.exception()  # retrieved: the run was cancelled, its end is not news
        raise


class _Runner:
    def __init__(self, name: str):
        self._name = name
        self._lock_: Optional[asyncio.Lock] = None

    def _lock(self) -> asyncio.Lock:
        # made on the slot loop (Python 3.9's Lock binds to the loop current when made)
        if self._lock_ is None:
            self._lock_ = asyncio.Lock()
        return self._lock_

    async def _call(self, fn: Callable[..., Any], *args: Any, begun: Optional[Callable[[], None]] = None) -> Any:
        """Runs the slot ``fn``; ``begun()`` is called once it has begun: an ``async def`` run up to its first
        ``await``, a plain function's thread started."""
        if _is_async(fn):
            # in this task: a task of its own would cost a loop iteration each way (a check's trigger and a
            # start's behaviour wait for them); cancelling this task cancels it alike
            if begun is None:
                return await fn(*args)
            return await _begun_after_first_step(fn(*args), begun)
        return await _in_thread(fn, args, self._name, begun)


class _ResponseRunner(_Runner):
    """The Python side of a response: the engine calls these coroutines, one slot after the other."""

    def __init__(self, name: str, r: Response, start_type: str, output_type: str):
        super().__init__(name)
        self._r = r
        self._start_type = start_type
        self._output_type = output_type

    async def start(self, body: bytes, begun: Callable[[], None]) -> bytes:
        async with self._lock():
            payload = decode(body, self._start_type)
            out = await self._call(self._r.start, payload, begun=begun)
            try:
                return encode(out, self._output_type)
            except PayloadTypeError as e:
                raise SlotError(f"start returned {out!r}, not its output ({self._output_type}): {e}") from None

    async def interrupt(self) -> None:
        async with self._lock():
            await self._call(self._r.interrupt)

    async def exit(self, reason: str) -> bool:
        async with self._lock():
            res = await self._call(self._r.exit, ExitReason(reason))
            return _restarts(res)

    # an inline response's slots (``Response.inline``): called by the engine on its own thread, holding the GIL

    def start_inline(self, body: bytes) -> bytes:
        out = self._r.start(decode(body, self._start_type))
        try:
            return encode(out, self._output_type)
        except PayloadTypeError as e:
            raise SlotError(f"start returned {out!r}, not its output ({self._output_type}): {e}") from None

    def interrupt_inline(self) -> None:
        if _overrides(self._r, "interrupt"):
            interrupt: Callable[[], Any] = self._r.interrupt  # a plain def (checked at spawn)
            interrupt()

    def exit_inline(self, reason: str) -> bool:
        if not _overrides(self._r, "exit"):
            return False
        return _restarts(self._r.exit(ExitReason(reason)))


def _restarts(exit_result: Any) -> bool:
    return exit_result is Restart or isinstance(exit_result, Restart)


def _overrides(r: Response, slot: str) -> bool:
    """Whether the response ``r`` has a ``slot`` of its own (not :class:`Response`'s, which does nothing)."""
    return slot in getattr(r, "__dict__", {}) or getattr(type(r), slot) is not getattr(Response, slot)


def _inline_slots_checked(name: str, r: Response) -> None:
    """Refuses an inline response whose slots cannot be called inline (``async def``), saying what to do."""
    for slot in ("start", "interrupt", "exit"):
        fn = getattr(r, slot)
        if (slot == "start" or _overrides(r, slot)) and _is_async(fn):
            raise InvalidArgument(
                f"{name}: an inline response's slots are plain functions, called on the engine's thread as "
                f"rclpy calls a callback; its {slot} is an async def: make it a plain def, or leave inline "
                "False to run async slots on the package's event loop"
            )


class _EventRunner(_Runner):
    def __init__(self, name: str, e: Event, payload_type: str):
        super().__init__(name)
        self._e = e
        self._payload_type = payload_type

    async def check(self) -> bytes:
        out = await self._call(self._e.check)
        try:
            return encode(out, self._payload_type)
        except PayloadTypeError as e:
            raise SlotError(f"check returned {out!r}, not its payload ({self._payload_type}): {e}") from None

    def activate(self) -> None:
        self._e.on_activate()

    def deactivate(self) -> None:
        self._e.on_deactivate()


class Component:
    """A component this process spawned. Stands for its reference (``.started``, ``.exited``, ``.triggered``,
    ``.start_slot``, ...) wherever a signal, slot or response is expected; lives until :meth:`shutdown` or
    the end of its :class:`Radar`."""

    def __init__(self, native: Any, ref: Any):
        self._native = native
        self.ref: Any = ref
        """Its :class:`ResponseRef` or :class:`EventRef`."""

    @property
    def name(self) -> str:
        """Its fully qualified name."""
        return str(self.ref.name)

    def state(self) -> Dict[str, Any]:
        """The state it publishes (its phase, counters, last exit reason; for an event whether it is active)."""
        return dict(self._native.state())

    def shutdown(self, timeout: Optional[float] = None) -> None:
        """Stops it: a run in progress ends as by an exit signal (the exit slot runs), then its node leaves."""
        self._native.shutdown(timeout)

    def __getattr__(self, attr: str) -> Any:
        if attr.startswith("_"):
            raise AttributeError(attr)
        return getattr(self.ref, attr)

    def __repr__(self) -> str:
        return f"Component({self.ref!r})"


Source = Union[Signal, EventRef, Component]
Target = Union[ResponseRef, Component]


def _signal(s: Any) -> Any:
    if isinstance(s, Signal):
        return s
    if isinstance(s, EventRef):
        return s.triggered
    if isinstance(s, Component) and isinstance(s.ref, EventRef):
        return s.ref.triggered
    raise InvalidArgument(
        f"{s!r} is not a signal: give an event (its reference or the component), or a response's signal "
        "(r.started, r.interrupted, r.exited)"
    )


def _response(r: Any) -> Any:
    if isinstance(r, ResponseRef):
        return r
    if isinstance(r, Component) and isinstance(r.ref, ResponseRef):
        return r.ref
    raise InvalidArgument(f"{r!r} is not a response: give radar.response(name) or a spawned response")


def _warm(*ros_types: str) -> None:
    """Imports the message classes (and rclpy's serializer) of these types and loads their type support now,
    in the caller's thread: each takes tens of milliseconds the first time, which a first signal should not
    wait for."""
    for t in ros_types:
        cls = message_class(t)
        if cls is not None:
            native_codec(cls, t)  # the package's own codec of the class, made once
        load = getattr(type(cls), "__import_type_support__", None) if cls is not None else None
        if load is not None:
            try:
                load()  # the C type support, loaded on first (de)serialization otherwise: ~30 ms
            except Exception:  # noqa: BLE001 - a type that cannot load fails where it is used, saying why
                pass


class Connection:
    """A live connection; ends with :meth:`close` or its ``with`` block (a fired ``once`` ends by itself)."""

    def __init__(self, native: Any, executor: Optional[ThreadPoolExecutor] = None):
        self._native = native
        self._executor = executor

    @property
    def id(self) -> int:
        """Its id in the manager's list (``radar connections``)."""
        return int(self._native.id)

    @property
    def live(self) -> bool:
        """Whether it still delivers."""
        return bool(self._native.live)

    @property
    def delivered(self) -> int:
        """Signals delivered so far."""
        return int(self._native.delivered)

    def wait_closed(self, timeout: Optional[float] = None) -> None:
        """Waits until it no longer delivers (a ``once`` that fired)."""
        self._native.wait_closed(timeout)

    def close(self) -> None:
        """Ends it. Idempotent."""
        self._native.close()
        if self._executor is not None:
            self._executor.shutdown(wait=False)

    def __enter__(self) -> "Connection":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


#: What a :class:`Connect` delivers to: one of the native :class:`_native.Statement`'s methods.
_Kind = Literal["start", "interrupt", "exit", "slot", "call"]


class Connect:
    """A connection being described: add ``until``, ``rearm``, ``depth``, ``timeout``; it is made when a
    ``with`` block is entered (and ends with the block, exceptions included) or by :meth:`connect`."""

    def __init__(self, radar: "Radar", once: bool, source: Any, kind: _Kind, target: Any):
        self._radar = radar
        self._once = once
        self._source = source
        self._kind = kind
        self._target = target
        self._until: Any = None
        self._rearm = False
        self._depth: Optional[int] = None
        self._timeout: Optional[float] = None
        self._executor: Optional[ThreadPoolExecutor] = None
        self._made: Optional[Connection] = None

    def until(self, signal: Source) -> "Connect":
        """Ends the connection's run when ``signal`` comes: the response it started is interrupted."""
        self._until = _signal(signal)
        return self

    def rearm(self) -> "Connect":
        """A ``once ... until`` that arms again after ``until`` fired."""
        self._rearm = True
        return self

    def depth(self, depth: int) -> "Connect":
        """The relay's history depth (default 10)."""
        self._depth = depth
        return self

    def timeout(self, seconds: float) -> "Connect":
        """How long making the connection may wait for its components (default 10 s)."""
        self._timeout = seconds
        return self

    def connect(self) -> Connection:
        """Makes it now; the caller closes it (or uses it in a ``with`` block)."""
        statement = (_native.Statement.once if self._once else _native.Statement.whenever)(self._source)
        if self._until is not None and self._kind != "start":
            raise InvalidArgument(
                f"`until` goes with a `start` target (once E start R until U), not {self._kind}"
            )
        if self._kind == "start":
            request = statement.start(self._target, self._until)
        elif self._kind == "interrupt":
            request = statement.interrupt(self._target)
        elif self._kind == "exit":
            request = statement.exit(self._target)
        elif self._kind == "slot":
            request = statement.slot(self._target)
        else:
            request = statement.call(self._deliverer(self._target))
        native = self._radar._engine_().connect(request, self._timeout, self._rearm, self._depth)
        return Connection(native, self._executor)

    def _deliverer(self, fn: Callable[..., Any]) -> Callable[[bytes], None]:
        ros_type = self._source.ros_type
        _warm(ros_type)
        want_none = len(inspect.signature(fn).parameters) == 0 if _arity_known(fn) else False
        radar = self._radar
        if _is_async(fn):
            slot_loop = radar._loop
            lock_box: List[asyncio.Lock] = []

            async def run(body: bytes) -> None:
                if not lock_box:
                    lock_box.append(asyncio.Lock())
                async with lock_box[0]:
                    try:
                        await (fn() if want_none else fn(decode(body, ros_type)))
                    except Exception:
                        _report("anonymous slot", fn)

            def deliver_async(body: bytes) -> None:
                asyncio.run_coroutine_threadsafe(run(body), slot_loop)

            return deliver_async
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="radar-call")
        executor = self._executor

        def call(body: bytes) -> None:
            try:
                fn() if want_none else fn(decode(body, ros_type))
            except Exception:
                _report("anonymous slot", fn)

        def deliver(body: bytes) -> None:
            try:
                executor.submit(call, body)
            except RuntimeError:
                pass  # closed: a payload that raced the close is not delivered

        return deliver

    def __enter__(self) -> Connection:
        self._made = self.connect()
        return self._made

    def __exit__(self, *exc: Any) -> None:
        if self._made is not None:
            self._made.close()
            self._made = None

    async def __aenter__(self) -> Connection:
        """``async with``: makes the connection without blocking the caller's event loop."""
        self._made = await asyncio.get_running_loop().run_in_executor(None, self.connect)
        return self._made

    async def __aexit__(self, *exc: Any) -> None:
        self.__exit__(*exc)


def _arity_known(fn: Any) -> bool:
    try:
        inspect.signature(fn)
        return True
    except (TypeError, ValueError):
        return False


def _report(what: str, fn: Any) -> None:
    import traceback

    sys.stderr.write(f"radar_ros: {what} {getattr(fn, '__qualname__', fn)!s} raised:\n{traceback.format_exc()}")


class Statement:
    """``once source`` / ``whenever source``: say what it connects to."""

    def __init__(self, radar: "Radar", once: bool, source: Source):
        self._radar = radar
        self._once = once
        self._source = _signal(source)

    def start(self, response: Target) -> Connect:
        """... ``start`` the response (its start slot gets the payload)."""
        return Connect(self._radar, self._once, self._source, "start", _response(response))

    def interrupt(self, response: Target) -> Connect:
        """... ``interrupt`` the response."""
        return Connect(self._radar, self._once, self._source, "interrupt", _response(response))

    def exit(self, response: Target) -> Connect:
        """... ``exit`` the response."""
        return Connect(self._radar, self._once, self._source, "exit", _response(response))

    def slot(self, slot: Slot) -> Connect:
        """... any slot topic (a node that is not a RADAR response)."""
        return Connect(self._radar, self._once, self._source, "slot", slot)

    def call(self, fn: Callable[..., Any]) -> Connect:
        """... an anonymous slot: ``fn(payload)`` (or ``fn()``) for each signal, one call after the other, in
        a thread of its own (``async def``: on the package's event loop). An exception in ``fn`` is printed
        and the connection goes on."""
        return Connect(self._radar, self._once, self._source, "call", fn)


class Waiter:
    """Armed on a signal (nothing after arming is missed); :meth:`recv` gives its first payload."""

    def __init__(self, native: Any, ros_type: str, want: Optional[type]):
        self._native = native
        self._ros_type = ros_type
        self._want = want

    def recv(self, timeout: Optional[float] = None) -> Any:
        """The payload (waits for it; ``timeout`` in seconds raises :class:`RadarTimeout`)."""
        return decode(bytes(self._native.recv(timeout)), self._ros_type, self._want)

    async def recv_async(self, timeout: Optional[float] = None) -> Any:
        """:meth:`recv` for ``asyncio`` programs (a ``timeout`` bounds it; cancelling the awaiting task leaves
        the waiter armed)."""
        return await asyncio.get_running_loop().run_in_executor(None, self.recv, timeout)

    def close(self) -> None:
        """Disarms it."""
        self._native.close()

    def __enter__(self) -> "Waiter":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class Subscription:
    """A plain subscription (:meth:`Radar.subscribe`); delivers until :meth:`close` or its ``with`` block."""

    def __init__(self, native: Any, executor: ThreadPoolExecutor):
        self._native = native
        self._executor = executor

    @property
    def topic(self) -> str:
        """The topic, resolved."""
        return str(self._native.topic)

    def close(self) -> None:
        """Stops delivering. Idempotent."""
        self._native.close()
        self._executor.shutdown(wait=False)

    def __enter__(self) -> "Subscription":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


_live: "weakref.WeakSet[Radar]" = weakref.WeakSet()


def _shutdown_all() -> None:
    for radar in list(_live):
        try:
            radar.shutdown()
        except Exception as e:  # noqa: BLE001 - the program is ending: say it and go on
            sys.stderr.write(f"radar_ros: shutting down at exit: {e}\n")


atexit.register(_shutdown_all)


def _on_sigterm(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


class Radar:
    """One process's RADAR participant: spawns events and responses as ROS 2 nodes, finds others by name,
    connects them with :meth:`once` and :meth:`whenever`.

    Honours ``ROS_DOMAIN_ID`` and the command line's ``--ros-args`` (``-r __ns:=``, ``-r __node:=``, ``-p``,
    ``--log-level``) as a ROS 2 node does. Leaving its ``with`` block, :meth:`shutdown`, Ctrl-C
    (``KeyboardInterrupt`` reaching the top) and SIGTERM all stop every component it spawned, running their
    exit slots, before the program ends.

    ``handle_sigterm`` (default True) makes SIGTERM raise ``SystemExit`` in the main thread, so that the
    same path runs (Python's default for SIGTERM ends the process at once, exit slots not run); it is left
    alone if the program has its own handler.
    """

    def __init__(
        self,
        *,
        domain_id: Optional[int] = None,
        namespace: Optional[str] = None,
        program: Optional[str] = None,
        args: Optional[List[str]] = None,
        shutdown_timeout: Optional[float] = None,
        handle_sigterm: bool = True,
    ):
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._run_loop, name="radar-slots", daemon=True)
        self._thread.start()
        argv = list(sys.argv if args is None else args)
        try:
            self._engine: Any = _native.Engine(
                self._loop,
                _SlotCall,
                argv,
                domain_id,
                namespace,
                program,
                shutdown_timeout,
            )
        except BaseException:
            self._stop_loop()
            raise
        self._closed = False
        # spawned components live until their shutdown() or this Radar's, whether or not the caller keeps them
        self._components: List[Any] = []
        _live.add(self)
        _warm(EMPTY)  # rclpy's serializer, if there is one: ~75 ms to import, better now than on a first signal
        if (
            handle_sigterm
            and threading.current_thread() is threading.main_thread()
            and _signal_module.getsignal(_signal_module.SIGTERM) in (_signal_module.SIG_DFL, None)
        ):
            _signal_module.signal(_signal_module.SIGTERM, _on_sigterm)

    def _run_loop(self) -> None:
        _main_thread_signals_only()
        asyncio.set_event_loop(self._loop)
        self._loop.run_forever()

    def _stop_loop(self) -> None:
        if self._loop.is_running():
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=5)

    def _engine_(self) -> Any:
        if self._closed:
            raise RadarError("this Radar was shut down: make a new one to go on")
        return self._engine

    @property
    def domain_id(self) -> int:
        """The ROS domain id in use."""
        return int(self._engine_().domain_id)

    @property
    def namespace(self) -> str:
        """The namespace names are resolved in."""
        return str(self._engine_().namespace)

    def event(self, name: str, timeout: Optional[float] = None) -> EventRef:
        """Finds the event ``name`` on the ROS graph (waits for discovery, default 10 s); :class:`NotFound`
        names similar components if it does not appear."""
        found: EventRef = self._engine_().event(name, timeout)
        return found

    def response(self, name: str, timeout: Optional[float] = None) -> ResponseRef:
        """Finds the response ``name`` on the ROS graph (as :meth:`event`)."""
        found: ResponseRef = self._engine_().response(name, timeout)
        return found

    def spawn_response(
        self,
        name: str,
        response: Union[Response, Callable[..., Any]],
        *,
        start_type: Optional[MsgType] = None,
        output_type: Optional[MsgType] = None,
        start_policy: Optional[str] = None,
        inline: Optional[bool] = None,
    ) -> Component:
        """Starts ``response`` (a :class:`Response`, or a function that is its start behaviour) as the ROS 2
        node ``name`` (relative to the namespace, or absolute). The keyword arguments override the
        response's class attributes of the same names (see :class:`Response`)."""
        r = response if isinstance(response, Response) else _FnResponse(response)
        st = type_name(start_type if start_type is not None else r.start_type)
        ot = type_name(output_type if output_type is not None else r.output_type)
        policy = start_policy if start_policy is not None else r.start_policy
        run_inline = bool(inline if inline is not None else r.inline)
        if run_inline:
            _inline_slots_checked(name, r)
        runner = _ResponseRunner(name, r, st, ot)
        _warm(st, ot)
        try:
            output_default = encode(None, ot)
        except PayloadTypeError as e:
            raise PayloadTypeError(
                f"{name}: output type {ot}: its default message (sent on exited after a run that did not "
                f"complete) cannot be made here: {e}"
            ) from None
        native = self._engine_().spawn_response(name, runner, st, ot, output_default, policy, run_inline)
        self._components.append(native)
        return Component(native, native.response_ref())

    def spawn_event(
        self,
        name: str,
        event: Union[Event, Callable[[], Any]],
        *,
        payload_type: Optional[MsgType] = None,
    ) -> Component:
        """Starts ``event`` (an :class:`Event`, or a function that is its check) as the ROS 2 node ``name``;
        it checks only while something listens to ``triggered``."""
        e = event if isinstance(event, Event) else _FnEvent(event)
        pt = type_name(payload_type if payload_type is not None else e.payload_type)
        runner = _EventRunner(name, e, pt)
        _warm(pt)
        native = self._engine_().spawn_event(name, runner, pt)
        self._components.append(native)
        return Component(native, native.event_ref())

    def once(self, source: Source) -> Statement:
        """``once source``: the first signal is delivered, then the connection ends."""
        return Statement(self, True, source)

    def whenever(self, source: Source) -> Statement:
        """``whenever source``: every signal is delivered while the connection lives."""
        return Statement(self, False, source)

    def waiter(self, source: Source, msg_type: Optional[type] = None, timeout: Optional[float] = None) -> Waiter:
        """Arms a waiter on ``source`` and returns once it is armed: arm, then do what makes the signal come,
        then ``recv``. ``msg_type``: ``bytes``, ``dict`` or a rosidl class to receive the payload as."""
        s = _signal(source)
        _warm(s.ros_type)
        return Waiter(self._engine_().waiter(s, timeout), s.ros_type, msg_type)

    def waitfor(self, source: Source, msg_type: Optional[type] = None, timeout: Optional[float] = None) -> Any:
        """``waitfor source``: the payload of the next signal. A signal that comes while the waiter arms is not
        seen: when what you do next makes it come, arm first with :meth:`waiter`."""
        s = _signal(source)
        w = self._engine_().waiter(s, timeout)
        try:
            return decode(bytes(w.recv(timeout)), s.ros_type, msg_type)
        finally:
            w.close()

    def inject(self, slot: Slot, payload: Any = None, timeout: Optional[float] = None) -> None:
        """Sends ``payload`` (a message, a dict, bytes, None for the default) into ``slot`` once its subscriber
        is there: the paper's ``rtinject``, ``ros2 topic pub --once``."""
        self._engine_().inject(slot, encode(payload, slot.ros_type), timeout)

    def subscribe(
        self,
        topic: str,
        msg_type: MsgType,
        fn: Callable[[Any], Any],
        *,
        state: bool = False,
    ) -> Subscription:
        """Calls ``fn(message)`` for each message on ``topic`` (a plain ROS subscription, signal QoS; not a
        RADAR connection: it does not make an event active). ``state=True`` subscribes to a component's
        transient-local state topic (``radar_msgs/msg/EventState`` or ``ResponseState``, delivered as dicts),
        getting the current state at once. Calls run one after the other in a thread of their own."""
        ros_type = type_name(msg_type)
        if not state:
            _warm(ros_type)
        want: Optional[type] = dict if state else None if isinstance(msg_type, str) else msg_type
        executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="radar-sub")

        def call(body: bytes) -> None:
            try:
                fn(decode(body, ros_type, want))
            except Exception:
                _report("subscription callback", fn)

        def deliver(body: bytes) -> None:
            try:
                executor.submit(call, body)
            except RuntimeError:
                pass  # closed

        native = self._engine_().subscribe(topic, ros_type, deliver, state)
        return Subscription(native, executor)

    def shutdown(self, timeout: Optional[float] = None) -> None:
        """Stops every component (exit slots run, ``exited`` is sent) and leaves the graph. Idempotent."""
        if self._closed:
            return
        self._closed = True
        _live.discard(self)
        try:
            self._engine.shutdown(timeout)
        finally:
            self._components.clear()
            self._stop_loop()

    def __enter__(self) -> "Radar":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.shutdown()

    async def waitfor_async(
        self, source: Source, msg_type: Optional[type] = None, timeout: Optional[float] = None
    ) -> Any:
        """:meth:`waitfor` for ``asyncio`` programs: awaits without blocking the caller's event loop."""
        return await asyncio.get_running_loop().run_in_executor(None, self.waitfor, source, msg_type, timeout)

    async def response_async(self, name: str, timeout: Optional[float] = None) -> ResponseRef:
        """:meth:`response` for ``asyncio`` programs."""
        return await asyncio.get_running_loop().run_in_executor(None, self.response, name, timeout)

    async def event_async(self, name: str, timeout: Optional[float] = None) -> EventRef:
        """:meth:`event` for ``asyncio`` programs."""
        return await asyncio.get_running_loop().run_in_executor(None, self.event, name, timeout)

    async def inject_async(self, slot: Slot, payload: Any = None, timeout: Optional[float] = None) -> None:
        """:meth:`inject` for ``asyncio`` programs."""
        await asyncio.get_running_loop().run_in_executor(None, self.inject, slot, payload, timeout)
