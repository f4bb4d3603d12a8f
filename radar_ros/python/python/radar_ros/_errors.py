"""The exceptions radar_ros raises. Each message says what went wrong and what to do next."""

from __future__ import annotations

from typing import Optional, Sequence


class RadarError(Exception):
    """Base class of every radar_ros error."""


class RadarTimeout(RadarError, TimeoutError):
    """A wait ran out (discovery, a signal, a shutdown): the message names what was waited for.

    Raised by radar_ros with ``what`` (what was awaited) and ``waited`` (seconds) set.
    """

    what: Optional[str] = None
    waited: Optional[float] = None


class NotFound(RadarError, LookupError):
    """No component of that name (and kind) appeared on the ROS graph in time; the message suggests names.

    Raised by radar_ros with ``name`` (fully qualified) and ``kind`` (``event`` or ``response``: what was asked
    for, or what the name turned out to be) set; when nothing of that name appeared, ``waited`` (seconds) and
    ``candidates`` (the RADAR components seen, closest names first) too.
    """

    name: Optional[str] = None
    kind: Optional[str] = None
    waited: Optional[float] = None
    candidates: Sequence[str] = ()


class PayloadTypeError(RadarError, TypeError):
    """A payload's type is not the topic's (or a dict does not fit the type)."""


class InvalidArgument(RadarError, ValueError):
    """An invalid ROS name, type name, statement or setting."""


class ComponentLost(RadarError):
    """A component this call depended on left the graph."""


class SlotError(Exception):
    """Raise in a slot to end the run as failed (Rust's ``Err(SlotError)``), rather than as a crash.

    Any other exception in a slot is reported as a Rust slot's panic is: the run ends as ``panicked`` with the
    exception and its traceback, and the exit slot still runs.
    """


class Cancelled(BaseException):
    """Raised inside a plain (``def``) slot running in its thread when the run is interrupted or ended.

    A ``BaseException`` (like ``asyncio.CancelledError``) so that ``except Exception`` in user code does not
    swallow it. ``async def`` slots see ``asyncio.CancelledError`` instead.
    """
