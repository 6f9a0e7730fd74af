"""Exact CDR of a diagnostic_msgs/DiagnosticArray of string key/values, packed directly.

The node's effect record (``~/command_events``) and diagnostics (``/diagnostics``) are
DiagnosticArrays of text: building them as rclpy message objects and walking those with
:func:`drs_ros.recording.cdr.serializer` cost ~60-120 us a record, on the real-time tick for the
effect record. :func:`diagnostic_array_cdr` writes the same bytes (the tests compare them with
the serialiser's and with rclpy's decoder) straight from Python strings, by the rules of
:mod:`~drs_ros.recording.cdr` (:func:`~drs_ros.recording.cdr.padding`,
:func:`~drs_ros.recording.cdr.write_string`):

* ``header``: ``stamp.sec`` (int32), ``stamp.nanosec`` (uint32), ``frame_id`` (string);
* ``status``: a uint32 count, then each status: ``level`` (one byte), ``name``, ``message``,
  ``hardware_id`` (strings), ``values``: a uint32 count, then each KeyValue's ``key`` and
  ``value`` (strings).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import NamedTuple

from ..timestamps import split_ns
from .cdr import CDR_LE_HEADER, CdrError, padding, write_string

_STAMP = struct.Struct("<iI")
_U32 = struct.Struct("<I")
_LEVEL = struct.Struct("<B")


class Status(NamedTuple):
    """The fields of one diagnostic_msgs/DiagnosticStatus: ``level`` (``DiagnosticStatus.OK``
    etc., a byte), ``name``, ``message``, ``hardware_id`` and ``values``, the ``(key, value)``
    pairs of its KeyValues (strings)."""

    level: bytes
    name: str
    message: str
    hardware_id: str
    values: Sequence[tuple[str, str]]


def _write_count(buf: bytearray, n: int) -> None:
    """A sequence's uint32 element count, aligned to 4."""
    buf += bytes(padding(len(buf), 4))
    buf += _U32.pack(n)


def _level_byte(level) -> int:
    """A status level as rclpy holds it (``bytes`` of length 1) or as an int 0..255."""
    if isinstance(level, (bytes, bytearray)):
        if len(level) != 1:
            raise CdrError(f"a DiagnosticStatus level is one byte, got {level!r}")
        return level[0]
    return level


def diagnostic_array_cdr(stamp_ns: int, statuses: Sequence[Status], frame_id: str = "") -> bytes:
    """The exact CDR (encapsulation header included) of a DiagnosticArray stamped ``stamp_ns``
    [ns since the epoch] in frame ``frame_id``, holding ``statuses`` (:class:`Status`): the bytes
    ``cdr.serializer(DiagnosticArray)`` gives for the equivalent message.

    Raises
    ------
    CdrError
        A stamp outside builtin_interfaces/Time's range, a level outside 0..255, a text that is
        not encodable as UTF-8 (a lone surrogate).
    """
    buf = bytearray(CDR_LE_HEADER)
    try:
        buf += _STAMP.pack(*split_ns(stamp_ns))
        write_string(buf, frame_id)
        _write_count(buf, len(statuses))
        for level, name, message, hardware_id, values in statuses:
            buf += _LEVEL.pack(_level_byte(level))  # an octet: no alignment
            write_string(buf, name)
            write_string(buf, message)
            write_string(buf, hardware_id)
            _write_count(buf, len(values))
            for key, value in values:
                write_string(buf, key)
                write_string(buf, value)
    except (struct.error, TypeError, AttributeError, UnicodeError) as exc:
        raise CdrError(f"cannot serialise a DiagnosticArray: {exc}") from exc
    return bytes(buf)


__all__ = ["Status", "diagnostic_array_cdr"]
