"""A trajectory_msgs/JointTrajectory read in place from its CDR bytes, for the real-time node.

Why: rclpy's ``deserialize_message`` builds one Python object per point and per field, holding the
GIL throughout: a 10,000-point trajectory took 80-250 ms, a stall of the node's real-time tick.
This reader walks the bytes once and hands :func:`drs_ros.conversions.trajectory_points` views
with the attributes it reads (``joint_names``, ``points[k].positions``, ``.velocities``,
``.accelerations``, ``.effort``, ``.time_from_start.sec/.nanosec``), so the trajectory is
validated by the same code whichever way it was decoded.

It accepts exactly what :func:`drs_ros.cdr.exact_bytes` accepts: the exact CDR (little-endian
plain CDR, zero padding, valid UTF-8 strings ending in NUL) followed by at most 3 zero bytes of
transport padding; anything else raises :class:`drs_ros.cdr.CdrError`. So what the node records
on a typed topic is what every reader decodes.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import NamedTuple

from .cdr import CDR_LE_HEADER, MAX_TRANSPORT_PADDING, CdrError

_U32 = struct.Struct("<I")
_TIME = struct.Struct("<iI")
_F64 = struct.Struct("<d")


class Doubles(Sequence):
    """A CDR sequence of float64 seen in place: ``len`` and indexing, values read on access."""

    __slots__ = ("_buf", "_offset", "_count")

    def __init__(self, buf: memoryview, offset: int, count: int) -> None:
        self._buf, self._offset, self._count = buf, offset, count

    def __len__(self) -> int:
        return self._count

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(self._count))]
        if i < 0:
            i += self._count
        if not 0 <= i < self._count:
            raise IndexError(f"index {i} out of a sequence of {self._count}")
        return _F64.unpack_from(self._buf, self._offset + 8 * i)[0]


class Duration(NamedTuple):
    sec: int
    nanosec: int


class Point(NamedTuple):
    positions: Doubles
    velocities: Doubles
    accelerations: Doubles
    effort: Doubles
    time_from_start: Duration


class JointTrajectoryView(NamedTuple):
    """What :func:`read_joint_trajectory` found: the header's stamp and frame, the joint names
    and the points (views on the bytes)."""

    stamp: Duration
    frame_id: str
    joint_names: list[str]
    points: list[Point]


class _Reader:
    """A cursor over the CDR body (offsets count from the end of the 4-byte header)."""

    def __init__(self, body: memoryview) -> None:
        self.body, self.pos = body, 0

    def align(self, n: int) -> None:
        pad = -self.pos % n
        if any(self.body[self.pos : self.pos + pad]):
            raise CdrError(f"non-zero alignment padding at byte {self.pos + 4}")
        self.pos += pad

    def need(self, n: int, what: str) -> None:
        if n < 0 or self.pos + n > len(self.body):
            raise CdrError(
                f"{what} at byte {self.pos + 4} needs {n} bytes; the message ends at "
                f"{len(self.body) + 4}"
            )

    def u32(self, what: str) -> int:
        self.align(4)
        self.need(4, what)
        (value,) = _U32.unpack_from(self.body, self.pos)
        self.pos += 4
        return value

    def time(self, what: str) -> Duration:
        self.align(4)
        self.need(8, what)
        value = Duration(*_TIME.unpack_from(self.body, self.pos))
        self.pos += 8
        return value

    def string(self, what: str) -> str:
        size = self.u32(what)
        self.need(size, what)
        if size == 0 or self.body[self.pos + size - 1] != 0:
            raise CdrError(f"{what} at byte {self.pos + 4} is not a NUL-terminated string")
        try:
            text = str(self.body[self.pos : self.pos + size - 1], "utf-8")
        except UnicodeDecodeError as exc:
            raise CdrError(f"{what} at byte {self.pos + 4} is not UTF-8: {exc}") from None
        if "\0" in text:
            raise CdrError(f"{what} at byte {self.pos + 4} holds a NUL before its end")
        self.pos += size
        return text

    def doubles(self, what: str) -> Doubles:
        count = self.u32(what)
        if count:
            self.align(8)
            self.need(8 * count, what)
        view = Doubles(self.body, self.pos, count)
        self.pos += 8 * count
        return view


def read_joint_trajectory(data: bytes) -> JointTrajectoryView:
    """The JointTrajectory whose exact CDR is ``data`` (plus at most 3 zero bytes of transport
    padding), read in place; :class:`~drs_ros.cdr.CdrError` for anything else."""
    buf = memoryview(bytes(data))
    if len(buf) < 4 or buf[:4] != CDR_LE_HEADER:
        raise CdrError(
            f"{len(buf)} bytes do not start with the little-endian CDR header {CDR_LE_HEADER.hex()}"
        )
    r = _Reader(buf[4:])
    stamp = r.time("header.stamp")
    frame_id = r.string("header.frame_id")
    names = [r.string(f"joint_names[{k}]") for k in range(r.u32("joint_names"))]
    count = r.u32("points")
    # each point needs at least 24 bytes: refuse a count the bytes cannot hold before looping
    r.need(24 * count, f"{count} points")
    points = []
    for k in range(count):
        points.append(Point(r.doubles(f"points[{k}].positions"),
                            r.doubles(f"points[{k}].velocities"),
                            r.doubles(f"points[{k}].accelerations"),
                            r.doubles(f"points[{k}].effort"),
                            r.time(f"points[{k}].time_from_start")))  # fmt: skip
    tail = r.body[r.pos :]
    if len(tail) > MAX_TRANSPORT_PADDING or any(tail):
        raise CdrError(
            f"{len(tail)} bytes follow the JointTrajectory's CDR ({r.pos + 4} bytes): at most "
            f"{MAX_TRANSPORT_PADDING} zero bytes of transport padding may"
        )
    return JointTrajectoryView(stamp, frame_id, names, points)


__all__ = ["Doubles", "Duration", "JointTrajectoryView", "Point", "read_joint_trajectory"]
