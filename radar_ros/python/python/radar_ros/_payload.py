"""Payloads: Python values <-> the CDR body of a ROS message of a named type.

A payload may be:

- an instance of a rosidl message class (``std_msgs.msg.String``, any generated type of the environment),
  written by the package itself when the type's definition found here has exactly the class's fields
  (:func:`native_codec`), else serialized with rclpy's own CDR (``rclpy.serialization``; rclpy need not be
  initialised);
- a ``dict`` of fields (left out: their defaults), for the types radar_ros knows (:func:`dict_types`: std_msgs
  basics, geometry poses, radar_msgs, ...) and for any type whose definition is found (``AMENT_PREFIX_PATH``, or
  a directory given to :func:`add_interfaces_dir`), where no Python message package is installed;
- ``bytes``: the CDR body itself (little-endian, without the 4-byte encapsulation header);
- ``None``: the type's default message (``std_msgs/msg/Empty`` for a signal that carries nothing).

Received payloads are given as the type's rosidl class when it can be imported, else as a ``dict`` for a
type with a dict form (known, or its definition found), else as :class:`RawPayload`.
"""

from __future__ import annotations

import functools
import importlib
import json
from typing import Any, Dict, FrozenSet, List, NamedTuple, Optional, Tuple, Union

from . import _native
from ._errors import InvalidArgument, PayloadTypeError

EMPTY = "std_msgs/msg/Empty"
#: What rclpy's serialize_message puts before the body: CDR little-endian, no options.
_HEADER = b"\x00\x01\x00\x00"

#: A message type: a rosidl class (``std_msgs.msg.String``) or its name (``"std_msgs/msg/String"``).
MsgType = Union[type, str]


class RawPayload(NamedTuple):
    """A payload of a type this process can neither import nor convert to a dict: its type and CDR body."""

    ros_type: str
    data: bytes


def type_name(t: MsgType) -> str:
    """The ROS name (``pkg/msg/Name``) of a rosidl class, or a name given as a string."""
    if isinstance(t, str):
        return t
    parts = getattr(t, "__module__", "").split(".")
    if len(parts) >= 2 and parts[1] in ("msg", "action", "srv") and isinstance(t, type):
        return f"{parts[0]}/{parts[1]}/{t.__name__}"
    raise InvalidArgument(
        f"{t!r} is not a ROS message class: give a rosidl class (such as std_msgs.msg.String) or a type "
        "name such as 'std_msgs/msg/String'"
    )


@functools.lru_cache(maxsize=None)
def message_class(ros_type: str) -> Optional[type]:
    """The rosidl class of ``ros_type`` if this environment has it (and rclpy to serialize it), else None."""
    parts = ros_type.split("/")
    if len(parts) != 3:
        return None
    try:
        importlib.import_module("rclpy.serialization")
        module = importlib.import_module(f"{parts[0]}.{parts[1]}")
        cls = getattr(module, parts[2])
    except (ImportError, AttributeError):
        return None
    return cls if isinstance(cls, type) else None


def dict_types() -> List[str]:
    """The ROS types whose payloads convert to and from dicts without a Python message package."""
    return list(_native.dict_types())


def has_dict_form(ros_type: str) -> bool:
    """Whether ``ros_type`` payloads convert to and from dicts here: a known type (:func:`dict_types`), or one
    whose definition is found (``AMENT_PREFIX_PATH``, or a directory given to :func:`add_interfaces_dir`)."""
    return bool(_native.has_dict_form(ros_type))


def add_interfaces_dir(path: str) -> None:
    """Looks for message definitions in ``path`` too (``<pkg>/msg/<Name>.msg``, ``srv/``, ``action/``), before
    ``AMENT_PREFIX_PATH``: a package of the program's own that is not installed."""
    _native.add_interfaces_dir(str(path))


def _serialize(msg: Any) -> bytes:
    from rclpy.serialization import serialize_message

    data: bytes = serialize_message(msg)
    return data[4:]


#: Per rosidl class: its type's name and the package's own codec of its objects, or None (:func:`native_codec`).
_NATIVE: Dict[type, Tuple[str, Optional[_native.RosidlCodec]]] = {}


def native_codec(cls: type, ros_type: str) -> Optional[_native.RosidlCodec]:
    """The package's own codec of objects of the rosidl class ``cls`` (of ``ros_type``), which reads and sets
    their fields (a few microseconds) where rclpy's ``serialize_message`` and ``deserialize_message`` convert
    them to and from C (tens between signals); None, and rclpy does it, unless the definition found here
    (:func:`has_dict_form`) has exactly the class's fields and types, nested types too. Decided once per
    class."""
    known = _NATIVE.get(cls)
    if known is None:
        known = _NATIVE[cls] = (ros_type, _native.rosidl_codec(ros_type, cls))
    return known[1] if known[0] == ros_type else None


def encode(payload: Any, ros_type: str) -> bytes:
    """``payload`` as the CDR body of a ``ros_type`` message; PayloadTypeError if it is not one."""
    known = _NATIVE.get(type(payload))
    if known is not None and known[0] == ros_type and known[1] is not None:
        return known[1].encode(payload)  # a rosidl object of a class seen before, the shortest way
    if isinstance(payload, (bytes, bytearray, memoryview)):
        return bytes(payload)
    if isinstance(payload, RawPayload):
        if payload.ros_type != ros_type:
            raise PayloadTypeError(f"a {payload.ros_type} payload where {ros_type} is expected")
        return payload.data
    if payload is None or isinstance(payload, dict):
        fields = payload or {}
        cls = message_class(ros_type)
        if ros_type in _known():
            return bytes(_native.encode_json(ros_type, json.dumps(fields)))
        if cls is not None:
            try:
                return _serialize(cls(**fields))
            except (TypeError, AssertionError, AttributeError) as e:
                raise PayloadTypeError(f"{fields!r} does not make a {ros_type}: {e}") from e
        if has_dict_form(ros_type):
            return bytes(_native.encode_json(ros_type, json.dumps(fields)))
        raise PayloadTypeError(
            f"cannot make a {ros_type} from {payload!r}: its Python message package is not importable "
            f"here and no definition of it is found (AMENT_PREFIX_PATH, add_interfaces_dir; types known "
            f"without one: {', '.join(sorted(_known()))}); pass an instance of its rosidl class, or its CDR bytes"
        )
    given = type(payload)
    try:
        name = type_name(given)
    except InvalidArgument:
        raise PayloadTypeError(
            f"a {given.__name__} is no ROS message: give a {ros_type} (its rosidl class), a dict of its "
            "fields, its CDR bytes, or None for its default"
        ) from None
    if name != ros_type:
        raise PayloadTypeError(f"a {name} payload where {ros_type} is expected")
    codec = native_codec(given, ros_type)
    if codec is not None:
        return codec.encode(payload)
    return _serialize(payload)


def decode(body: bytes, ros_type: str, want: Optional[type] = None) -> Any:
    """The body of a ``ros_type`` message as ``want`` (``bytes``, ``dict``, a rosidl class), or as the best
    form this environment has (see the module's text)."""
    if want is bytes:
        return body
    if want is not None and want is not dict:
        if type_name(want) != ros_type:
            raise PayloadTypeError(f"a {ros_type} payload asked for as {type_name(want)}")
        cls: Optional[type] = want
    elif want is dict:
        cls = None
    else:
        cls = message_class(ros_type)
    if cls is not None:
        codec = native_codec(cls, ros_type)
        if codec is not None:
            return codec.decode(body)
        from rclpy.serialization import deserialize_message

        return deserialize_message(_HEADER + body, cls)
    j = _native.decode_json(ros_type, body)
    if j is not None:
        return json.loads(j)
    if want is dict:
        raise PayloadTypeError(f"{ros_type} has no dict form here; ask for bytes or its rosidl class")
    return RawPayload(ros_type, body)


@functools.lru_cache(maxsize=1)
def _known() -> FrozenSet[str]:
    return frozenset(_native.dict_types())
