"""A trajectory_msgs/JointTrajectory read in place from its CDR bytes, for the real-time node.

Why: rclpy's ``deserialize_message`` builds one Python object per point and per field, holding the
GIL throughout: a 10,000-point trajectory took 80-250 ms, a stall of the node's real-time tick.
This reader walks the bytes once and hands :func:`drs_ros.conversions.trajectory_points` views
with the attributes it reads (``joint_names``, ``points[k].positions``, ``.velocities``,
``.accelerations``, ``.effort``, ``.time_from_start.sec/.nanosec``), so the trajectory is
validated by the same code whichever way it was decoded.

It accepts what :func:`drs_ros.recording.cdr_received.decode_exact` accepts: little-endian plain CDR
with valid UTF-8 strings ending in NUL, followed by at most 3 zero bytes of transport padding;
anything else raises :class:`drs_ros.recording.cdr.CdrError`. The bytes are walked by the CDR
engine's :class:`drs_ros.recording.cdr_received.Reader` (its alignment and padding rules); alignment
padding may hold any bytes (Fast DDS leaves it uninitialised in messages an rclpy publisher sends):
the view's ``exact`` is the message's exact CDR, the bytes with their padding zeroed, which the node
records.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import NamedTuple

from ..recording.cdr_received import Reader

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
    exact: bytes  # the exact CDR: the bytes read, alignment padding zeroed, no transport padding


def _doubles(r: Reader, what: str) -> Doubles:
    return Doubles(r.buf, *r.block(_F64.size, what))


def read_joint_trajectory(data: bytes) -> JointTrajectoryView:
    """The JointTrajectory whose exact CDR is ``data`` (plus at most 3 zero bytes of transport
    padding), read in place; :class:`~drs_ros.recording.cdr.CdrError` for anything else."""
    r = Reader(data)
    stamp = Duration(*r.read(_TIME, 4, "header.stamp"))
    frame_id = r.string("header.frame_id")
    names = [r.string(f"joint_names[{k}]") for k in range(r.count("joint_names"))]
    count = r.count("points")
    # each point needs at least 24 bytes: refuse a count the bytes cannot hold before looping
    r.need(24 * count, f"{count} points")
    points = []
    for k in range(count):
        where = f"points[{k}]"
        points.append(
            Point(
                _doubles(r, f"{where}.positions"),
                _doubles(r, f"{where}.velocities"),
                _doubles(r, f"{where}.accelerations"),
                _doubles(r, f"{where}.effort"),
                Duration(*r.read(_TIME, 4, f"{where}.time_from_start")),
            )
        )
    return JointTrajectoryView(stamp, frame_id, names, points, r.finish("JointTrajectory"))


__all__ = ["Doubles", "Duration", "JointTrajectoryView", "Point", "read_joint_trajectory"]
