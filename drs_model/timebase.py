"""Time: integer nanoseconds and their conversions, and a time on the physics step's grid. The
only place drs (the model and, through :mod:`drs_ros.timestamps`, the node and the bag tools)
turns nanoseconds into ``(sec, nanosec)`` or seconds and back, or a time into a number of steps.

Times are integer nanoseconds wherever they can be (stamps, log times, durations: ``_ns`` names,
as rosbag2 and MCAP keep them). A message's ``builtin_interfaces/Time`` or ``Duration`` holds
``sec`` and ``nanosec``; the model's simulated time and the tolerances are float seconds. This
module converts between the three, with no rclpy (plain integers and any object with ``.sec``
and ``.nanosec``), so that the node and the bag tools share it.

Rounding:

* :func:`split_ns` is floor division: ``nanosec`` in ``[0, 1e9)`` and ``sec`` negative for a
  negative time, as rclpy's ``Time.to_msg`` / ``Duration.to_msg`` and rcl do; exact.
* :func:`ns_from_parts` is exact.
* :func:`seconds_from_ns` is Python's true division of integers: the float nearest to the exact
  quotient (ties to even), also for epoch stamps beyond 2**53 ns.
* :func:`ns_from_seconds` rounds the float product ``seconds * 1e9`` to the nearest integer
  (ties to even): within half a nanosecond of the exact value plus the product's own rounding
  (2**-53 relative, under 0.07 ns for 1e6 s). For a float that came from :func:`seconds_from_ns`
  of at most 2**51 ns (26 days) it gives those nanoseconds back exactly. It is the one place a
  float becomes nanoseconds.

Steps (a time [s] on the grid of a physics step ``dt`` [s]), two questions, two functions:

* :func:`steps_within` is the whole steps that fit in a span (floor), counting a step whose end
  the span misses by rounding alone (within :data:`STEP_TOLERANCE` of a step: ``0.3 / 0.1`` is
  ``2.9999999999999996``): how far a simulation may step to reach a time.
* :func:`nearest_step` (:func:`nearest_steps` for an array) is the step nearest a time that lies
  on the grid up to rounding (a recorded stamp, a scene's duration), ties to even.

Why integers: a float split of seconds into whole seconds and a fraction is wrong at whole
seconds (``2.3 - 1.3`` is ``0.9999999999999998`` s, whose fraction rounds to ``1e9`` ns: a
split by ``t // 1`` and ``round`` gave 0 s 0 ns, a whole second short).
"""

from __future__ import annotations

import math

import numpy as np

#: Nanoseconds per second.
NS_PER_S = 1_000_000_000
#: The first stamp of a bag made without a node clock (a played goal, a test fixture) [ns]: a
#: fixed instant (2023-11-14), so that such bags are reproducible byte for byte.
T0_NS = 1_700_000_000_000_000_000


def split_ns(ns: int) -> tuple[int, int]:
    """``(sec, nanosec)`` of ``ns`` [ns]: the fields of builtin_interfaces/Time and Duration
    (floor division, ``0 <= nanosec < 1e9``)."""
    return divmod(int(ns), NS_PER_S)


def ns_from_parts(sec: int, nanosec: int) -> int:
    """Nanoseconds of ``sec`` [s] and ``nanosec`` [ns] (exact)."""
    return int(sec) * NS_PER_S + int(nanosec)


def ns_of(stamp) -> int:
    """Nanoseconds of a builtin_interfaces/Time or Duration (anything with ``.sec`` and
    ``.nanosec``)."""
    return ns_from_parts(stamp.sec, stamp.nanosec)


def set_ns(stamp, ns: int):
    """Set a builtin_interfaces/Time or Duration (``.sec``, ``.nanosec``) to ``ns`` [ns] in
    place; returns it."""
    stamp.sec, stamp.nanosec = split_ns(ns)
    return stamp


def seconds_from_ns(ns: int) -> float:
    """Seconds [s] of ``ns`` [ns]: the nearest float (where the model or a tolerance needs one)."""
    return ns / NS_PER_S


def ns_from_seconds(seconds: float) -> int:
    """Nanoseconds [ns] nearest to ``seconds`` [s] (ties to even; module docstring)."""
    return round(seconds * NS_PER_S)


#: A span short of a whole number of steps by less than this fraction of a step counts them all
#: (the rounding of ``span / dt``).
STEP_TOLERANCE = 1e-9


def steps_within(span_s: float, dt_s: float) -> int:
    """The whole steps of ``dt_s`` [s] that fit in ``span_s`` [s] (module docstring)."""
    return int(math.floor(span_s / dt_s + STEP_TOLERANCE))


def nearest_step(t_s: float, dt_s: float) -> int:
    """The index of the step of ``dt_s`` [s] nearest to ``t_s`` [s] (ties to even)."""
    return int(round(t_s / dt_s))


def nearest_steps(t_s: np.ndarray, dt_s: float) -> np.ndarray:
    """:func:`nearest_step` of each of the times ``t_s`` [s], as int64."""
    return np.rint(np.asarray(t_s) / dt_s).astype(np.int64)


__all__ = [
    "STEP_TOLERANCE",
    "nearest_step",
    "nearest_steps",
    "steps_within",
    "T0_NS",
    "NS_PER_S",
    "ns_from_parts",
    "ns_from_seconds",
    "ns_of",
    "seconds_from_ns",
    "set_ns",
    "split_ns",
]
