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
their numbers into, so that nothing else writes CDR by hand. A :class:`Reader` reads such bytes
in place by the same rules, where rclpy's decoder would cost too much (a long trajectory).
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


def write_string(buf: bytearray, value: str) -> None:
    data = value.encode("utf-8")
    _align(buf, 4)
    buf += _U32.pack(len(data) + 1)
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
    order, without building the message (one ``struct.pack``: ~0.3 us against ~4 us)."""
    flat = _flat_class(msg_class)
    if flat is None:
        raise CdrError(f"{msg_class.__name__} is not made of one floating-point type only")
    # the first field sits right after the header: no padding before it, none between them
    pack = struct.Struct(f"<{len(msg_class.SLOT_TYPES)}{flat[0]}").pack

    def packer(*values) -> bytes:
        return CDR_LE_HEADER + pack(*values)

    return packer


class Layout:
    """The exact CDR of messages of one type and one shape, packed into a reused buffer.

    A message's shape is everything but its numbers: its strings and the lengths of its
    sequences. ``Layout(prototype)`` serialises the prototype once with :func:`serializer`,
    noting where each numeric field lies (its path, e.g. ``header.stamp.sec``, ``position``,
    ``transforms.1.transform.rotation``); :meth:`packer` then writes chosen fields with
    ``struct.pack_into`` into a copy of those bytes, kept and reused. A message of the
    prototype's shape packed this way has exactly the bytes :func:`serializer` gives it (~1-2 us
    against ~10-30 us to fill the message and serialise it field by field).

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
        that order, from ``values`` (a field of ``count`` numbers takes that many values). The
        bytes are a copy of one buffer the packer keeps; the fields not named keep the
        prototype's values."""
        missing = [p for p in paths if p not in self.fields]
        if missing:
            raise CdrError(f"no numeric field {missing} in the layout; known: {list(self.fields)}")
        slots = [(struct.Struct(f"<{self.fields[p][2]}{self.fields[p][1]}"), self.fields[p][0],
                  self.fields[p][2]) for p in paths]  # fmt: skip
        buf = bytearray(self.template)
        n_values = sum(count for _s, _o, count in slots)

        def pack(*values) -> bytes:
            if len(values) != n_values:
                raise CdrError(f"{len(values)} values for {n_values} numbers of {list(paths)}")
            i = 0
            try:
                for packer, offset, count in slots:
                    packer.pack_into(buf, offset, *values[i : i + count])
                    i += count
            except struct.error as exc:
                raise CdrError(f"cannot pack {list(paths)}: {exc}") from exc
            return bytes(buf)

        return pack


#: Fast DDS pads a message that crosses processes to a multiple of 4 bytes with zeros.
MAX_TRANSPORT_PADDING = 3


def is_transport_padding(tail: bytes) -> bool:
    """Whether ``tail``, what follows a message's exact CDR, is the transport's padding: at most
    :data:`MAX_TRANSPORT_PADDING` zero bytes (none included)."""
    return len(tail) <= MAX_TRANSPORT_PADDING and not any(tail)


class Reader:
    """A cursor reading CDR bytes in place by the serialisers' rules (:func:`padding`), taking
    what :func:`decode_exact` takes: the little-endian header, UTF-8 strings ending in their one
    NUL, at most :data:`MAX_TRANSPORT_PADDING` zero bytes after the data, alignment padding of any
    content (Fast DDS leaves it uninitialised in what rclpy sends; :meth:`finish` zeroes it).
    ``pos`` and the offsets in :class:`CdrError` messages count from the start of the bytes."""

    def __init__(self, data: bytes) -> None:
        self.buf = memoryview(bytes(data))
        if self.buf[: len(CDR_LE_HEADER)] != CDR_LE_HEADER:
            raise CdrError(f"{len(self.buf)} bytes do not start with the little-endian CDR "
                           f"header {CDR_LE_HEADER.hex()}")  # fmt: skip
        self.pos = len(CDR_LE_HEADER)
        self._dirty: list[int] = []  # where padding holds a non-zero byte

    def align(self, size: int) -> None:
        """Skip the padding before a primitive of ``size`` bytes."""
        end = min(self.pos + padding(self.pos, size), len(self.buf))
        self._dirty += [k for k in range(self.pos, end) if self.buf[k]]
        self.pos = end

    def need(self, n: int, what: str) -> None:
        if n < 0 or self.pos + n > len(self.buf):
            raise CdrError(f"{what} at byte {self.pos} needs {n} bytes; the message ends at "
                           f"{len(self.buf)}")  # fmt: skip

    def read(self, packer: struct.Struct, size: int, what: str) -> tuple:
        """The values ``packer`` (little-endian) unpacks, its elements ``size`` bytes each."""
        self.align(size)
        self.need(packer.size, what)
        self.pos += packer.size
        return packer.unpack_from(self.buf, self.pos - packer.size)

    def count(self, what: str) -> int:
        """A string's length or a sequence's count (uint32)."""
        return self.read(_U32, _U32.size, what)[0]

    def string(self, what: str) -> str:
        size = self.count(what)
        self.need(size, what)
        if size == 0 or self.buf[self.pos + size - 1] != 0:
            raise CdrError(f"{what} at byte {self.pos} is not a NUL-terminated string")
        try:
            text = str(self.buf[self.pos : self.pos + size - 1], "utf-8")
        except UnicodeDecodeError as exc:
            raise CdrError(f"{what} at byte {self.pos} is not UTF-8: {exc}") from None
        if "\0" in text:
            raise CdrError(f"{what} at byte {self.pos} holds a NUL before its end")
        self.pos += size
        return text

    def block(self, size: int, what: str) -> tuple[int, int]:
        """``(offset, count)`` of a sequence of primitives of ``size`` bytes, skipped over."""
        n = self.count(what)
        if n:
            self.align(size)
            self.need(size * n, what)
        offset, self.pos = self.pos, self.pos + size * n
        return offset, n

    def finish(self, what: str) -> bytes:
        """The exact CDR of what was read: the bytes up to here, padding zeroed; refused if more
        than the transport's padding follows."""
        tail = self.buf[self.pos :]
        if not is_transport_padding(tail):
            raise CdrError(f"{len(tail)} bytes follow the {what}'s CDR ({self.pos} bytes): at "
                           f"most {MAX_TRANSPORT_PADDING} zero bytes of transport padding may")
        exact = bytearray(self.buf[: self.pos])
        for k in self._dirty:
            exact[k] = 0
        return bytes(exact)


def without_source_location(text: str) -> str:
    """An rmw error's text without the C++ source location rmw appends (``, at /path:line``)."""
    return text.split(", at /")[0]


def decode_exact(data: bytes, msg_class: type) -> tuple[object, bytes]:
    """``(message, its exact CDR)`` of ``data``, a ``msg_class`` as a raw subscription received
    it: it must decode, and be as long as its exact CDR plus at most 3 zero bytes of transport
    padding; its alignment padding may hold anything (Fast DDS leaves it uninitialised in what an
    rclpy publisher sends), the exact CDR has it zeroed. :class:`CdrError` for anything else."""
    from rclpy.serialization import deserialize_message

    try:
        msg = deserialize_message(data, msg_class)
        exact = serializer(msg_class)(msg)
    except Exception as exc:  # noqa: BLE001 - any decode failure is the data's
        why = without_source_location(str(exc))
        raise CdrError(f"{len(data)} bytes do not decode as {msg_class.__name__}: {why}") from exc
    tail = data[len(exact) :]
    if len(data) < len(exact) or not is_transport_padding(tail):
        raise CdrError(
            f"{len(data)} bytes are not the {len(exact)}-byte CDR of a {msg_class.__name__} plus "
            f"at most {MAX_TRANSPORT_PADDING} zero bytes of transport padding"
        )
    return msg, exact


def exact_bytes(data: bytes, msg_class: type) -> bytes:
    """``data`` (as a raw subscription received it) without the transport's padding: Fast DDS
    pads a message that crosses processes to a multiple of 4 bytes with up to 3 zero bytes (a
    650-byte DiagnosticArray arrives as 652). ``data`` must be the exact CDR of the message it
    decodes to, possibly followed by such padding; anything else raises :class:`CdrError`."""
    msg, exact = decode_exact(data, msg_class)
    if not data.startswith(exact):
        raise CdrError(f"{len(data)} bytes are not the {len(exact)}-byte CDR of their "
                       f"{msg_class.__name__} plus at most {MAX_TRANSPORT_PADDING} zero bytes of "
                       "padding")  # fmt: skip
    return exact


__all__ = [
    "CDR_LE_HEADER", "MAX_TRANSPORT_PADDING", "CdrError", "Layout", "Reader", "decode_exact",
    "exact_bytes", "flat_packer", "is_transport_padding", "padding", "serializer",
    "without_source_location", "write_string",
]  # fmt: skip
