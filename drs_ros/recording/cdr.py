"""Exact CDR serialisation of rclpy messages: the bytes a ROS 2 subscriber receives.

Why not ``rclpy.serialization.serialize_message``: with the Jazzy wheels (Fast DDS) its buffer can
be longer than the CDR data (a 2-point JointTrajectory: 140 bytes where the wire carries 112) and
its alignment padding is uninitialised memory. A recorder using it leaks process memory into the
log, and readers that check sizes (rosbags) reject such messages.

The encoding is what ``rmw_fastrtps`` puts on the wire for ROS 2 messages: the 4-byte
encapsulation header ``00 01 00 00`` (plain CDR, little endian), then the fields in order, each
primitive aligned to its own size (at most 8) counted from the end of the header
(:func:`padding`), padding bytes zero, no padding after the last field. Strings are a ``uint32``
length (including the NUL), the UTF-8 bytes and a NUL; sequences a ``uint32`` count then the
elements; fixed arrays the elements only; an empty structure one zero byte.

Each message class is compiled once (:func:`serializer`) into a chain of closures over
``struct.Struct`` objects, from the class's own rosidl introspection (``SLOT_TYPES``). The same
code serves the node's publishers, the recorder and the bag checker (which re-serialises what it
decoded and compares bytes). A :class:`Layout` is that serialiser's output for one prototype
message with the offsets of its numeric fields: the template the node's real-time publishers pack
their numbers into, so that nothing else writes CDR by hand. What arrives (a raw subscription's
bytes, read in place or decoded exactly) is :mod:`.cdr_received`'s.
"""

from __future__ import annotations

import array
import functools
import importlib
import operator
import struct
import sys
import threading
from collections.abc import Callable, Sequence

from ..errors import DRSRosError

#: Encapsulation header of little-endian plain CDR (what Fast DDS sends for ROS 2 messages).
CDR_LE_HEADER = b"\x00\x01\x00\x00"

# rosidl basic type -> (struct code, size [bytes]); size is also the alignment
BASIC_TYPES = {
    "boolean": ("?", 1),
    "octet": ("B", 1),
    "char": ("B", 1),
    "uint8": ("B", 1),
    "int8": ("b", 1),
    "int16": ("h", 2),
    "uint16": ("H", 2),
    "int32": ("i", 4),
    "uint32": ("I", 4),
    "int64": ("q", 8),
    "uint64": ("Q", 8),
    "float": ("f", 4),
    "double": ("d", 8),
}
_U32 = struct.Struct("<I")
_ZEROS = bytes(8)
_LITTLE = sys.byteorder == "little"

Writer = Callable[[bytearray, object], None]

#: The layout pass of :class:`Layout` (this thread only): the path of the field being written,
#: and the numeric fields written so far, ``(path, offset, struct code, count)``.
_TRACE = threading.local()


def _traced(buf: bytearray, code: str, count: int) -> None:
    """In a layout pass: the numeric field(s) about to be written at the end of ``buf``."""
    fields = getattr(_TRACE, "fields", None)
    if fields is not None:
        fields.append((".".join(_TRACE.path), len(buf), code, count))


class CdrError(DRSRosError, TypeError):
    """A message type or value that cannot be serialised as ROS 2 CDR."""


def padding(offset: int, size: int) -> int:
    """Bytes of alignment padding before a primitive of ``size`` bytes (its alignment, at most 8)
    that would start at ``offset``, counted from the start of the bytes: CDR aligns each
    primitive to its size counted from the end of the encapsulation header. The one statement of
    the rule: the serialisers and :class:`Reader` both ask it."""
    return -(offset - len(CDR_LE_HEADER)) % size


def _align(buf: bytearray, n: int) -> None:
    pad = padding(len(buf), n)
    if pad:
        buf += _ZEROS[:pad]


def _as_int(value) -> int:
    """octet and char fields hold ``bytes`` / ``str`` of length 1 in rclpy."""
    if isinstance(value, (bytes, bytearray)):
        return value[0]
    if isinstance(value, str):
        return ord(value)
    return value


def _basic_writer(typename: str) -> tuple[Writer, int]:
    code, size = BASIC_TYPES[typename]
    packer = struct.Struct("<" + code)
    convert = _as_int if typename in ("octet", "char") else None

    def write(buf: bytearray, value, pack=packer.pack, size=size, code=code) -> None:
        _align(buf, size)
        if _TRACE.__dict__:
            _traced(buf, code, 1)
        buf += pack(convert(value) if convert else value)

    return write, size


#: A string's length (uint32) after the padding that aligns it, by the padding's size [bytes]:
#: one pack for both (a record of the effect log holds ~16 strings).
_PADDED_LENGTH = tuple(struct.Struct(f"<{pad}xI").pack for pad in range(4))


def write_string(buf: bytearray, value: str) -> None:
    data = value.encode("utf-8")
    buf += _PADDED_LENGTH[padding(len(buf), 4)](len(data) + 1)
    buf += data
    buf += b"\x00"


def _basic_block_writer(typename: str) -> Writer:
    """Elements of a basic type, back to back (the body of an array or a sequence)."""
    code, size = BASIC_TYPES[typename]
    convert = typename in ("octet", "char", "boolean")

    def write(buf: bytearray, values) -> None:
        n = len(values)
        if n == 0:
            return
        _align(buf, size)
        if _TRACE.__dict__:
            _traced(buf, code, n)
        if (
            _LITTLE
            and isinstance(values, array.array)
            and values.itemsize == size
            and values.typecode.lower() == code.lower()
        ):
            buf += values.tobytes()  # the generated classes hold numeric sequences as arrays
        elif isinstance(values, (bytes, bytearray)) and size == 1:
            buf += values
        elif hasattr(values, "dtype"):  # fixed-size array fields are numpy arrays
            buf += values.astype("<" + code, copy=False).tobytes()
        else:
            items = [_as_int(v) for v in values] if convert else values
            buf += struct.pack(f"<{n}{code}", *items)

    return write


def _element_writer(typ) -> Writer:
    """Writer of one value of a rosidl type (basic, string, nested message)."""
    from rosidl_parser.definition import AbstractString, BasicType, NamespacedType

    if isinstance(typ, BasicType):
        return _basic_writer(typ.typename)[0]
    if isinstance(typ, AbstractString):
        if type(typ).__name__.endswith("WString"):
            raise CdrError("wide strings (wstring) are not supported")
        return write_string
    if isinstance(typ, NamespacedType):
        flat = _flat_struct(typ)
        if flat is not None:  # e.g. a Vector3 or a Quaternion: one pack
            code, size, get = flat

            def write_flat(buf: bytearray, value, code=code, size=size, get=get) -> None:
                _align(buf, size)
                values = get(value)
                if _TRACE.__dict__:
                    _traced(buf, code, len(values))
                buf += struct.pack(f"<{len(values)}{code}", *values)

            return write_flat
        module = importlib.import_module(".".join(typ.namespaces))
        return _struct_writer(getattr(module, typ.name))
    raise CdrError(f"unsupported rosidl type {typ!r}")


def _flat_struct(typ):
    """:func:`_flat_class` of a rosidl type; None if it is not a message type."""
    from rosidl_parser.definition import NamespacedType

    if not isinstance(typ, NamespacedType):
        return None
    return _flat_class(getattr(importlib.import_module(".".join(typ.namespaces)), typ.name))


def _flat_class(cls: type):
    """``(struct code, size, getter)`` for a message class whose fields are all one fixed-size
    floating-point type (geometry_msgs/Point: 3 doubles, std_msgs/ColorRGBA: 4 floats), whose
    elements then lie back to back with no padding; None for any other class."""
    from rosidl_parser.definition import BasicType

    kinds = {t.typename if isinstance(t, BasicType) else None for t in cls.SLOT_TYPES}
    if len(kinds) != 1 or kinds & {None} or next(iter(kinds)) not in ("double", "float"):
        return None
    code, size = BASIC_TYPES[next(iter(kinds))]
    getter = operator.attrgetter(*cls.get_fields_and_field_types())
    if len(cls.SLOT_TYPES) == 1:
        return code, size, lambda item, g=getter: (g(item),)
    return code, size, getter


def _field_writer(typ) -> Writer:
    from rosidl_parser.definition import AbstractSequence, Array, BasicType

    if isinstance(typ, (Array, AbstractSequence)):
        is_sequence = isinstance(typ, AbstractSequence)
        flat = _flat_struct(typ.value_type)
        if isinstance(typ.value_type, BasicType):
            body = _basic_block_writer(typ.value_type.typename)
        elif flat is not None:  # e.g. geometry_msgs/Point: one pack for the whole sequence
            code, size, get = flat

            def body(buf: bytearray, values, code=code, size=size, get=get) -> None:
                if values:
                    _align(buf, size)
                    flat_values = [v for item in values for v in get(item)]
                    if _TRACE.__dict__:
                        _traced(buf, code, len(flat_values))
                    buf += struct.pack(f"<{len(flat_values)}{code}", *flat_values)

        else:
            element = _element_writer(typ.value_type)

            def body(buf: bytearray, values, element=element) -> None:
                if _TRACE.__dict__:  # a layout pass: each element's index is in the path
                    for k, v in enumerate(values):
                        _TRACE.path.append(str(k))
                        element(buf, v)
                        _TRACE.path.pop()
                    return
                for v in values:
                    element(buf, v)

        if not is_sequence:
            return body

        def write(buf: bytearray, values, body=body) -> None:
            _align(buf, 4)
            buf += _U32.pack(len(values))
            body(buf, values)

        return write
    return _element_writer(typ)


@functools.cache
def _struct_writer(msg_class: type) -> Writer:
    try:
        names = list(msg_class.get_fields_and_field_types())
        types = msg_class.SLOT_TYPES
    except AttributeError as exc:
        raise CdrError(f"{msg_class!r} is not a ROS message class") from exc
    if not names:  # an empty structure carries one dummy uint8 on the wire

        def write_empty(buf: bytearray, msg) -> None:
            buf += b"\x00"

        return write_empty
    fields = [(name, _field_writer(typ)) for name, typ in zip(names, types, strict=True)]

    def write(buf: bytearray, msg, fields=fields) -> None:
        if _TRACE.__dict__:  # a layout pass: each field's name is in the path
            for name, writer in fields:
                _TRACE.path.append(name)
                writer(buf, getattr(msg, name))
                _TRACE.path.pop()
            return
        for name, writer in fields:
            writer(buf, getattr(msg, name))

    return write


@functools.cache
def serializer(msg_class: type) -> Callable[[object], bytes]:
    """A function ``msg -> bytes``: the exact CDR serialisation of messages of ``msg_class``.

    Parameters
    ----------
    msg_class : type
        A generated rclpy message class (e.g. ``sensor_msgs.msg.JointState``, or a service's
        ``SetBool.Event``).

    Raises
    ------
    CdrError
        The class is not a message class, or holds a type this module does not encode.
    """
    write = _struct_writer(msg_class)

    def serialize(msg) -> bytes:
        buf = bytearray(CDR_LE_HEADER)
        try:
            write(buf, msg)
        except (struct.error, TypeError, AttributeError, UnicodeError) as exc:
            raise CdrError(f"cannot serialise a {msg_class.__name__}: {exc}") from exc
        return bytes(buf)

    return serialize


def flat_packer(msg_class: type) -> Callable[..., bytes]:
    """``pack(*values) -> bytes``: the exact CDR of a message whose fields are all one
    floating-point type (std_msgs/Float64, geometry_msgs/Point...), from the values in field
    order, without building the message: its :class:`Layout`'s packer of every field."""
    if _flat_class(msg_class) is None:
        raise CdrError(f"{msg_class.__name__} is not made of one floating-point type only")
    return Layout(msg_class()).packer(list(msg_class.get_fields_and_field_types()))


class Layout:
    """The exact CDR of messages of one type and one shape, packed from their numbers: the one
    way drs packs a message it sends at rate (the joint states, /tf, the markers, the pressures,
    the Float64 topics).

    A message's shape is everything but its numbers: its strings and the lengths of its
    sequences. ``Layout(prototype)`` serialises the prototype once with :func:`serializer`,
    noting where each numeric field lies (its path, e.g. ``header.stamp.sec``, ``position``,
    ``transforms.1.transform.rotation``); :meth:`packer` compiles the fields it is given into
    one ``struct`` whose gaps are the template's own bytes (the strings, the padding, the
    fields not given), so a message is one ``struct.pack``. A message of the prototype's shape
    packed this way has exactly the bytes :func:`serializer` gives it (~1-2 us against ~10-30 us
    to fill the message and serialise it field by field).

    ``fields``: path -> ``(offset, struct code, count)``, offsets counted from the start of the
    bytes (the encapsulation header included)."""

    def __init__(self, prototype) -> None:
        _TRACE.path, _TRACE.fields = [], []
        try:
            self.template = serializer(type(prototype))(prototype)
            traced = _TRACE.fields
        finally:
            _TRACE.__dict__.clear()
        self.fields = {path: (offset, code, count) for path, offset, code, count in traced}

    def packer(self, paths: Sequence[str]) -> Callable[..., bytes]:
        """``pack(*values) -> bytes``: the template with the numeric fields ``paths`` set, in
        that order (the order they lie in: repeated blocks, e.g. a TFMessage's transforms, one
        after the other), from ``values`` (a field of ``count`` numbers takes that many
        values); the fields not named keep the prototype's values."""
        missing = [p for p in paths if p not in self.fields]
        if missing:
            raise CdrError(f"no numeric field {missing} in the layout; known: {list(self.fields)}")
        fmt, blocks, end = "<", [], None  # blocks: (the template's bytes before, count)
        for path in paths:
            offset, code, count = self.fields[path]
            if end is not None and offset < end:
                raise CdrError(f"{path} at byte {offset} is not after the field before it")
            gap = self.template[end:offset] if end is not None else b""
            fmt += (f"{len(gap)}s" if gap else "") + f"{count}{code}"
            blocks.append((gap, count))
            end = offset + struct.calcsize(f"<{count}{code}")
        start = self.fields[paths[0]][0] if paths else len(self.template)
        head, tail = self.template[:start], self.template[end or start :]
        whole = struct.Struct(fmt).pack
        n_values = sum(count for _gap, count in blocks)
        # the struct's arguments picked from (values..., gaps...) in one C call
        fixed = tuple(gap for gap, _count in blocks if gap)
        order, i, k = [], 0, n_values
        for gap, count in blocks:
            if gap:
                order.append(k)
                k += 1
            order += range(i, i + count)
            i += count
        if len(order) > 1:
            pick = operator.itemgetter(*order)
        else:  # itemgetter of one index returns the item, not a tuple
            pick = lambda v, o=tuple(order): tuple(v[j] for j in o)  # noqa: E731

        def pack(*values) -> bytes:
            if len(values) != n_values:
                raise CdrError(f"{len(values)} values for {n_values} numbers of {list(paths)}")
            try:
                return head + whole(*pick(values + fixed)) + tail
            except struct.error as exc:
                raise CdrError(f"cannot pack {list(paths)}: {exc}") from exc

        return pack


__all__ = [
    "CDR_LE_HEADER",
    "CdrError",
    "Layout",
    "flat_packer",
    "padding",
    "serializer",
    "write_string",
]
