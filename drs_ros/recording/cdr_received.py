"""CDR as it arrives: the bytes a raw subscription received, checked against the exact CDR of
:mod:`.cdr` (:func:`decode_exact`, :func:`exact_bytes`), or read in place by the same rules where
rclpy's decoder would cost too much (:class:`Reader`, for a long trajectory). Fast DDS pads a
message that crosses processes to a multiple of 4 bytes and leaves alignment padding
uninitialised in what an rclpy publisher sends: both are taken, the exact bytes have them
removed and zeroed."""

from __future__ import annotations

import struct

from .cdr import CDR_LE_HEADER, CdrError, padding, serializer

_U32 = struct.Struct("<I")


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
            raise CdrError(
                f"{len(self.buf)} bytes do not start with the little-endian CDR "
                f"header {CDR_LE_HEADER.hex()}"
            )
        self.pos = len(CDR_LE_HEADER)
        self._dirty: list[int] = []  # where padding holds a non-zero byte

    def align(self, size: int) -> None:
        """Skip the padding before a primitive of ``size`` bytes."""
        end = min(self.pos + padding(self.pos, size), len(self.buf))
        self._dirty += [k for k in range(self.pos, end) if self.buf[k]]
        self.pos = end

    def need(self, n: int, what: str) -> None:
        if n < 0 or self.pos + n > len(self.buf):
            raise CdrError(
                f"{what} at byte {self.pos} needs {n} bytes; the message ends at {len(self.buf)}"
            )

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

    @property
    def padding_is_zero(self) -> bool:
        """Whether every alignment padding byte read so far is zero (the exact CDR's own)."""
        return not self._dirty

    def finish(self, what: str) -> bytes:
        """The exact CDR of what was read: the bytes up to here, padding zeroed; refused if more
        than the transport's padding follows."""
        tail = self.buf[self.pos :]
        if not is_transport_padding(tail):
            raise CdrError(
                f"{len(tail)} bytes follow the {what}'s CDR ({self.pos} bytes): at "
                f"most {MAX_TRANSPORT_PADDING} zero bytes of transport padding may"
            )
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
        raise CdrError(
            f"{len(data)} bytes are not the {len(exact)}-byte CDR of their "
            f"{msg_class.__name__} plus at most {MAX_TRANSPORT_PADDING} zero bytes of "
            "padding"
        )
    return exact


__all__ = [
    "MAX_TRANSPORT_PADDING",
    "Reader",
    "decode_exact",
    "exact_bytes",
    "is_transport_padding",
    "without_source_location",
]
