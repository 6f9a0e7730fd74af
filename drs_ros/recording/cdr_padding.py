"""The alignment padding of recorded CDR bytes, found by walking them by their type.

Why: CDR leaves the content of alignment padding unspecified (Fast DDS sends uninitialised
memory there, rclpy decodes such a message as any other), so recorded bytes may differ from
the exact CDR that :func:`drs_ros.recording.cdr.serializer` writes (padding zero) at padding
bytes only, and that is no corruption. :func:`zero_padding` walks the bytes field by field with
:class:`drs_ros.recording.cdr_received.Reader` (the serialisers' alignment rule, from the message
class's rosidl introspection, ``SLOT_TYPES``), and gives them back with every padding byte
zeroed: equal to the exact CDR of what they decode to if and only if they differ from it in
padding alone (or the transport's trailing zero bytes).
"""

from __future__ import annotations

import functools
import importlib
import struct

from .cdr import BASIC_TYPES, CdrError
from .cdr_received import Reader


def _message_class(typ) -> type:
    return getattr(importlib.import_module(".".join(typ.namespaces)), typ.name)


def _skip_basic(r: Reader, typename: str, n: int, what: str) -> None:
    """``n`` primitives of ``typename`` back to back (aligned once, as the serialisers write
    them); none: no alignment either."""
    size = BASIC_TYPES[typename][1]
    if n:
        r.align(size)
        r.need(size * n, what)
        r.pos += size * n


def _walk_value(r: Reader, typ, what: str) -> None:
    from rosidl_parser.definition import AbstractString, BasicType, NamespacedType

    if isinstance(typ, BasicType):
        _skip_basic(r, typ.typename, 1, what)
    elif isinstance(typ, AbstractString):
        if type(typ).__name__.endswith("WString"):
            raise CdrError("wide strings (wstring) are not supported")
        r.string(what)
    elif isinstance(typ, NamespacedType):
        _walk_struct(r, _message_class(typ), what)
    else:
        raise CdrError(f"unsupported rosidl type {typ!r}")


def _walk_field(r: Reader, typ, what: str) -> None:
    from rosidl_parser.definition import AbstractSequence, Array, BasicType

    if not isinstance(typ, (Array, AbstractSequence)):
        _walk_value(r, typ, what)
        return
    n = r.count(what) if isinstance(typ, AbstractSequence) else typ.size
    if isinstance(typ.value_type, BasicType):
        _skip_basic(r, typ.value_type.typename, n, what)
        return
    if isinstance(typ, AbstractSequence) and n > len(r.buf):  # each element takes a byte at least
        raise CdrError(f"{what}: a count of {n} elements in {len(r.buf)} bytes")
    for k in range(n):
        _walk_value(r, typ.value_type, f"{what}[{k}]")


def _walk_struct(r: Reader, msg_class: type, what: str) -> None:
    fields = _fields(msg_class)
    if not fields:  # an empty structure carries one dummy byte
        r.need(1, what)
        r.pos += 1
        return
    for name, typ in fields:
        _walk_field(r, typ, f"{what}.{name}" if what else name)


@functools.cache
def _fields(msg_class: type) -> tuple:
    try:
        names = list(msg_class.get_fields_and_field_types())
        return tuple(zip(names, msg_class.SLOT_TYPES, strict=True))
    except AttributeError as exc:
        raise CdrError(f"{msg_class!r} is not a ROS message class") from exc


def zero_padding(data: bytes, msg_class: type) -> bytes:
    """``data`` (CDR of a ``msg_class``, as recorded) with every alignment padding byte zeroed
    and the transport's trailing zero bytes (at most 3) left off.

    Raises
    ------
    CdrError
        ``data`` is not CDR of a ``msg_class``: too short, a string not UTF-8 or not ended by
        its NUL, more after the data than the transport's padding.
    """
    r = Reader(data)
    try:
        _walk_struct(r, msg_class, "")
    except struct.error as exc:
        raise CdrError(f"cannot read a {msg_class.__name__}: {exc}") from exc
    return r.finish(msg_class.__name__)


__all__ = ["zero_padding"]
