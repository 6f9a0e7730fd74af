r"""Stroke profiles: rest-to-rest quintics and the seed's open-hold-close manoeuvre.

A quintic segment ``s(t) = sum a_k (t - t0)^k`` on ``[t0, t0 + T]`` matches position, velocity and
acceleration at both ends (seed 003, "Opening profile"). For a rest-to-rest move of amplitude
``h`` with ``u = (t - t0)/T``: ``s = s0 + h (10 u^3 - 15 u^4 + 6 u^5)``.

The manoeuvre (seed): opening ``s_min -> s_max`` in ``T_opening``, hold ``T_still``, closing back in
``T_closing``. Jerk jumps at the segment joints (0, 10, 40, 50 ms): s, s', s'' are continuous,
s''' is not, which an integrator with error control sees as a kink.
"""

from __future__ import annotations

import math
from array import array
from bisect import bisect_left
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from . import elementwise, kernels
from .errors import InputError, StrokeRangeError
from .kinematics import stroke_limits
from .params import DRSParams
from .path_range import PATH_TOL, check_paths


def quintic_coefficients(
    duration: float, s0: float, s1: float, v0=0.0, v1=0.0, a0=0.0, a1=0.0
) -> np.ndarray:
    """Coefficients ``a_0..a_5`` in local time ``tau = t - t0`` [s] of the quintic through the
    boundary values (position [m], velocity [m/s], acceleration [m/s^2])."""
    T = float(duration)
    if not (math.isfinite(T) and T > 0.0):
        raise InputError(f"duration must be a finite number > 0 s, got {duration!r}")
    c3, c4, c5 = _end_terms(T, T**2, (2 * T**3, 2 * T**4, 2 * T**5), s1 - s0, v0, v1, a0, a1)
    return np.array([s0, v0, a0 / 2.0, c3, c4, c5])


def _end_terms(T, T2, denominators, h, v0, v1, a0, a1):
    """``a_3, a_4, a_5`` of the quintic: the closed-form solution of its three end conditions
    over the duration ``T`` [s] and the rise ``h`` [m] (scalars or arrays). ``T2`` is ``T^2``
    and ``denominators`` ``(2 T^3, 2 T^4, 2 T^5)`` as the caller computes them (``T**k`` for
    one segment, products for many: each path keeps its own rounding)."""
    d3, d4, d5 = denominators
    c3 = (20 * h - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T2) / d3
    c4 = (-30 * h + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T2) / d4
    c5 = (12 * h - 6 * (v1 + v0) * T + (a1 - a0) * T2) / d5
    return c3, c4, c5


def shift_polynomial(coeffs: np.ndarray, t0: float) -> np.ndarray:
    """Coefficients in absolute time t of ``sum c_k (t - t0)^k`` (how the seed prints them)."""
    poly = np.polynomial.Polynomial(coeffs)
    shifted = poly(np.polynomial.Polynomial([-t0, 1.0]))
    out = np.zeros(len(coeffs))
    out[: len(shifted.coef)] = shifted.coef
    return out


@dataclass(frozen=True)
class QuinticSegment:
    """A quintic move starting at ``t0`` [s] lasting ``duration`` [s]; holds its end values after
    its end and its start values before its start.

    ``coeffs`` are in local time; :meth:`absolute_coefficients` gives them in absolute time.
    """

    t0: float
    duration: float
    coeffs: tuple[float, ...]

    @classmethod
    def between(cls, t0, duration, s0, s1, v0=0.0, v1=0.0, a0=0.0, a1=0.0) -> QuinticSegment:
        c = quintic_coefficients(duration, s0, s1, v0, v1, a0, a1)
        return cls(float(t0), float(duration), tuple(float(x) for x in c))

    @property
    def t1(self) -> float:
        return self.t0 + self.duration

    @property
    def end_stroke(self) -> float:
        """The stroke [m] the move ends at (its quintic at local time ``duration``): what
        :meth:`evaluate` gives at and after ``t1``, from the scalar kernel (a ``~/drs`` call
        names it in its answer; the arrays' way costs ~30 us)."""
        return float(kernels.quintic(self.duration, self.coeffs, 0)[0])

    def absolute_coefficients(self) -> np.ndarray:
        return shift_polynomial(np.array(self.coeffs), self.t0)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s', s'')`` at time(s) t [s]; outside the segment the end state is held."""
        t = np.asarray(t, dtype=float)
        tau = np.clip(t - self.t0, 0.0, self.duration)
        c = self.coeffs
        s, v, a = kernels.quintic(tau, c, 0)
        outside = (t < self.t0) | (t > self.t1)
        if np.any(outside):
            # beyond the ends the move is at rest only if it ends at rest; hold position and
            # report the end rates (a rest-to-rest move gives zeros)
            v = np.where(outside, np.where(t < self.t0, c[1], v), v)
            a = np.where(outside, np.where(t < self.t0, 2 * c[2], a), a)
        return s, v, a


@dataclass(frozen=True)
class Manoeuvre:
    """The seed's open-hold-close manoeuvre: three segments on ``[0, T_total]``, at rest outside."""

    opening: QuinticSegment
    closing: QuinticSegment
    s_min: float
    s_max: float

    @property
    def t_end(self) -> float:
        return self.closing.t1

    @property
    def kinks(self) -> tuple[float, ...]:
        """Times [s] where the jerk jumps (the segment joints)."""
        return (self.opening.t0, self.opening.t1, self.closing.t0, self.closing.t1)

    def constants(self) -> tuple[float, ...]:
        """The 18 constants of :func:`drs_model.kernels.manoeuvre_profile`: ``(t0, T, 6
        coefficients)`` of the opening and of the closing, then ``s_min`` and ``s_max``."""
        o, c = self.opening, self.closing
        return (o.t0, o.duration, *o.coeffs, c.t0, c.duration, *c.coeffs, self.s_min, self.s_max)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s', s'')`` [m, m/s, m/s^2] at time(s) t [s] (any shape): the kernel
        :func:`drs_model.kernels.manoeuvre_profile` at each time."""
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise InputError("time must be finite")
        return elementwise.manoeuvre_profile(t, self.constants())


def drs_manoeuvre(
    p: DRSParams, s_min: float | None = None, s_max: float | None = None
) -> Manoeuvre:
    """The open-hold-close manoeuvre of ``p`` between ``s_min`` and ``s_max`` [m].

    The defaults are our exact gap-rule strokes; pass the seed's NLPSolve values to reproduce its
    printed coefficients. A non-finite stroke or ``s_min >= s_max`` raises :class:`InputError`.
    """
    lo, hi = stroke_limits(p)
    s_min = lo if s_min is None else float(s_min)
    s_max = hi if s_max is None else float(s_max)
    if not (math.isfinite(s_min) and math.isfinite(s_max) and s_min < s_max):
        raise InputError(
            f"the manoeuvre's strokes must be finite with s_min < s_max [m], got "
            f"s_min = {s_min!r}, s_max = {s_max!r} (the gap rule's: {lo:.9g}, "
            f"{hi:.9g})"
        )
    opening = QuinticSegment.between(0.0, p.T_opening, s_min, s_max)
    closing = QuinticSegment.between(p.T_opening + p.T_still, p.T_closing, s_max, s_min)
    return Manoeuvre(opening, closing, s_min, s_max)


def quintic_move(
    p: DRSParams,
    s_target: float,
    duration: float,
    s0: float,
    v0: float = 0.0,
    a0: float = 0.0,
    t0: float = 0.0,
    tol: float = 1e-12,
    limits: tuple[float, float] | None = None,
) -> QuinticSegment:
    """A quintic from the current state ``(s0, v0, a0)`` at ``t0`` to rest at ``s_target`` [m].

    ``limits`` is ``stroke_limits(p)`` when the caller holds it (solving for them costs more than
    the move: a stepping actuator passes its own).

    Raises :class:`StrokeRangeError` for a target outside ``[s_min, s_max]`` and
    :class:`InputError` for a non-finite input or a non-positive duration. The path may overshoot
    the target when the start velocity is large; callers that need a bounded path check it.
    """
    for name, value in (("s_target", s_target), ("s0", s0), ("v0", v0), ("a0", a0), ("t0", t0)):
        if not math.isfinite(float(value)):
            raise InputError(f"{name} must be finite, got {value!r}")
    if not (math.isfinite(float(duration)) and duration > 0.0):
        raise InputError(f"duration must be a finite number > 0 s, got {duration!r}")
    lo, hi = stroke_limits(p) if limits is None else limits
    if not lo - tol <= s_target <= hi + tol:
        raise StrokeRangeError(
            f"target stroke {s_target!r} m is outside [s_min, s_max] = [{lo:.9g}, {hi:.9g}] m"
        )
    return QuinticSegment.between(t0, duration, s0, s_target, v0, 0.0, a0, 0.0)


# ---- trajectories: many quintics end to end (ActuatorSim.command_trajectory) --------------------
#: The most points a trajectory may have.
MAX_TRAJECTORY_POINTS = 10_000
#: A time within this [s] after a segment's end still belongs to that segment.
_END_SLACK = 1e-12


def quintic_coefficients_array(duration, s0, s1, v0=0.0, v1=0.0, a0=0.0, a1=0.0) -> np.ndarray:
    """The quintic coefficients of many segments at once (:func:`quintic_coefficients` is one):
    the closed-form solution of the six end conditions, on arrays broadcast together
    (``duration`` [s] > 0, positions [m], velocities [m/s], accelerations [m/s^2], not checked
    here). Returns shape ``(..., 6)``, local-time coefficients ``a_0..a_5``."""
    T = np.asarray(duration, dtype=float)
    s0, s1, v0, v1, a0, a1 = np.broadcast_arrays(T, s0, s1, v0, v1, a0, a1)[1:]
    h = s1 - s0
    T2, T3 = T * T, T * T * T
    out = np.empty(T.shape + (6,))
    out[..., 0], out[..., 1], out[..., 2] = s0, v0, a0 / 2.0
    out[..., 3], out[..., 4], out[..., 5] = _end_terms(
        T, T2, (2 * T3, 2 * T3 * T, 2 * T3 * T2), h, v0, v1, a0, a1
    )
    return out


@dataclass(frozen=True, eq=False)
class TrajectoryPlan:
    """A validated trajectory, the part of ``ActuatorSim.command_trajectory`` that does not depend
    on the actuator's state (made by :func:`plan_trajectory`).

    Point ``k`` is reached at ``times[k]`` [s after the command] at stroke ``strokes[k]`` [m]
    with rate ``rates[k]`` [m/s], at rest in acceleration; segment ``k`` is the quintic from
    point ``k - 1`` (point ``-1`` being the actuator's state when commanded) to point ``k``.
    The first ``n_head`` segments depend on that state (the first always; with derived rates
    also the second, since the first point's rate is the slope from the start stroke to the
    second point: ``rates[0]`` is then NaN here): they are built and checked when commanded.
    The others are built here, as coefficients in local time, and their paths checked.

    Immutable and independent of any actuator: it can be made in another thread, before the
    tick that commands it, and commanded any number of times (to actuators of the same
    parameters: ``limits`` must match theirs).
    """

    times: np.ndarray
    strokes: np.ndarray
    rates: np.ndarray
    derived_rates: bool
    limits: tuple[float, float]  # (s_min, s_max) [m] the paths were checked against
    n_head: int
    # for the stepping loop, as array('d') (Python floats on access, bisect; no per-element
    # objects, so nothing for the garbage collector to walk): per segment the start and
    # duration [s], the end + 1e-12 [s] (relative to the command), the flat coefficients (6 per
    # segment; NaN for the head segments)
    starts: array = field(repr=False)
    durations: array = field(repr=False)
    ends: array = field(repr=False)
    coeffs: array = field(repr=False)

    def __len__(self) -> int:
        return len(self.durations)

    def head(self, s0: float, v0: float, a0: float) -> np.ndarray:
        """The first ``n_head`` segments' coefficients, shape ``(n_head, 6)``, from the state
        ``(s0, v0, a0)`` [m, m/s, m/s^2] the trajectory starts in. Raises
        :class:`StrokeRangeError` if one of their paths leaves ``[s_min, s_max]``."""
        t, s, v, m = self.times, self.strokes, self.rates, self.n_head
        v_first = float(v[0])
        if self.derived_rates and t.size > 1:  # the slope from the start stroke to point 1
            v_first = (float(s[1]) - s0) / (float(t[1]) - 0.0)
        dur = np.array(self.durations[:m])
        if m == 1:
            c = quintic_coefficients_array(dur, s0, s[0], v0, v_first, a0)
        else:
            c = quintic_coefficients_array(
                dur, [s0, s[0]], s[:2], [v0, v_first], [v_first, v[1]], [a0, 0.0]
            )
        check_paths(c, dur, self.limits, 0, t.size)
        return c


def _checked_points(times, strokes, limits: tuple[float, float]):
    """``(t, s)`` as flat float arrays, refused as :func:`plan_trajectory` says."""
    t = np.asarray(times, dtype=float).ravel()
    s = np.asarray(strokes, dtype=float).ravel()
    n = t.size
    if n == 0 or n > MAX_TRAJECTORY_POINTS or s.size != n:
        raise InputError(
            f"a trajectory needs 1..{MAX_TRAJECTORY_POINTS} points with one stroke per time, got "
            f"{n} times and {s.size} strokes"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(s))):
        raise InputError("trajectory times and strokes must be finite")
    if t[0] <= 0.0 or np.any(np.diff(t) <= 0.0):
        raise InputError(
            f"trajectory times must increase strictly from > 0 s, got {t.tolist()[:5]}..."
        )
    lo, hi = limits
    out = (s < lo - PATH_TOL) | (s > hi + PATH_TOL)
    if np.any(out):
        raise StrokeRangeError(
            f"stroke {float(s[out][0])!r} m is outside [s_min, s_max] = [{lo:.9g}, {hi:.9g}] m"
        )
    return t, s


def _point_rates(t: np.ndarray, s: np.ndarray, rates):
    """``(v, derived, n_head)``: the rates [m/s] at the points (given, or the slope across the
    neighbours with the first one's NaN until the start stroke is known), whether they were
    derived, and how many first segments depend on the actuator's state."""
    n = t.size
    if rates is None:
        v = np.zeros(n)
        if n > 1:  # interior points: the slope across the neighbours; the first one's needs
            v[0] = math.nan  # the start stroke (built when commanded)
            v[1:-1] = (s[2:] - s[:-2]) / (t[2:] - t[:-2])
        return v, True, min(n, 2)
    v = np.asarray(rates, dtype=float).ravel()
    if v.size != n or not np.all(np.isfinite(v)):
        raise InputError(f"trajectory rates must be {n} finite values, got {v.size}")
    if v[-1] != 0.0:
        raise InputError(
            f"a trajectory must end at rest: the last point's velocity is {v[-1]!r} m/s, "
            "give 0 (or no velocities)"
        )
    return v, False, 1


def plan_trajectory(p: DRSParams, times, strokes, rates=None) -> TrajectoryPlan:
    """Validate a trajectory and build what does not depend on the actuator's state.

    Parameters
    ----------
    p : DRSParams
        The actuator's parameters (its stroke range ``[s_min, s_max]``).
    times : array_like, shape (n,)
        Arrival times [s after the command], strictly increasing from > 0; ``1 <= n <= 10000``.
    strokes : array_like, shape (n,)
        Strokes [m] to pass at those times, each in ``[s_min, s_max]``.
    rates : array_like, shape (n,), optional
        Piston rates [m/s] at the points, the last 0 (a trajectory ends at rest). Default: the
        slope across the neighbouring points (a C1 path; the first point's uses the stroke the
        actuator is at when commanded) and rest at the last point.

    Returns
    -------
    TrajectoryPlan
        For ``ActuatorSim.command_trajectory(plan)``, which builds and checks only the
        state-dependent first segment(s).

    Raises
    ------
    InputError
        Wrong sizes, a non-finite value, times not strictly increasing from > 0, a last rate
        other than 0.
    StrokeRangeError
        A stroke outside ``[s_min, s_max]``, or a segment whose path leaves it (checked at
        :data:`~drs_model.path_range.PATH_SAMPLES` instants per segment, to 1e-12 m).

    Cost: a few ms for 10,000 points (numpy over all segments at once).
    """
    limits = stroke_limits(p)
    t, s = _checked_points(times, strokes, limits)
    n = t.size
    v, derived, n_head = _point_rates(t, s, rates)
    t_prev = np.concatenate([[0.0], t[:-1]])
    dur = t - t_prev
    coeffs = np.full((n, 6), math.nan)
    if n > n_head:
        k = slice(n_head, n)
        coeffs[k] = quintic_coefficients_array(
            dur[k], s[n_head - 1 : -1], s[k], v[n_head - 1 : -1], v[k]
        )
        check_paths(coeffs[k], dur[k], limits, n_head, n)
    for a in (t, s, v):
        a.flags.writeable = False
    return TrajectoryPlan(
        t,
        s,
        v,
        derived,
        limits,
        n_head,
        starts=_doubles(t_prev),
        durations=_doubles(dur),
        ends=_doubles(t + _END_SLACK),
        coeffs=_doubles(coeffs),
    )


def _doubles(values: np.ndarray) -> array:
    out = array("d")
    out.frombytes(np.ascontiguousarray(values, dtype=float).tobytes())
    return out


class QuinticPath(Sequence):
    """Quintic segments end to end from ``t_start`` [s] (absolute time), as
    ``ActuatorSim`` follows them: a sequence of :class:`QuinticSegment` (built on access), with
    the segment in force at a time found by bisection (:meth:`at`).

    Made by :meth:`of_segment` (one move) or :meth:`of_plan` (a trajectory: the plan's
    segments, the first ``n_head`` replaced by the ones built from the actuator's state; the
    plan's lists are shared, not copied).
    """

    __slots__ = ("t_start", "t_end", "_starts", "_durations", "_ends", "_head", "_tail", "_n_head")

    def __init__(self, t_start, t_end, starts, durations, ends, head, tail, n_head) -> None:
        self.t_start, self.t_end = float(t_start), float(t_end)
        self._starts, self._durations, self._ends = starts, durations, ends
        self._head, self._tail, self._n_head = head, tail, n_head

    @classmethod
    def of_segment(cls, seg: QuinticSegment) -> QuinticPath:
        """One segment (``t_end`` is the segment's ``t1``)."""
        return cls(
            seg.t0,
            seg.t1,
            [0.0],
            [seg.duration],
            [seg.duration + _END_SLACK],
            list(seg.coeffs),
            None,
            1,
        )

    @classmethod
    def of_plan(cls, plan: TrajectoryPlan, t_start: float, head: np.ndarray) -> QuinticPath:
        """The plan's segments from ``t_start`` [s], the first ``plan.n_head`` being ``head``
        (shape ``(n_head, 6)``)."""
        return cls(
            t_start,
            t_start + float(plan.times[-1]),
            plan.starts,
            plan.durations,
            plan.ends,
            np.asarray(head, dtype=float).ravel().tolist(),
            plan.coeffs,
            plan.n_head,
        )

    def __len__(self) -> int:
        return len(self._durations)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return tuple(self[i] for i in range(*k.indices(len(self))))
        n = len(self)
        if not -n <= k < n:
            raise IndexError(f"segment {k} of a path of {n}")
        k %= n
        c = self._head if k < self._n_head else self._tail
        return QuinticSegment(
            self.t_start + self._starts[k], self._durations[k], tuple(c[6 * k : 6 * k + 6])
        )

    def segment_index(self, t: float) -> int:
        """The segment in force at time ``t`` [s]: the first ending at or after ``t`` (within
        1e-12 s), the last after the end."""
        return min(bisect_left(self._ends, t - self.t_start), len(self._durations) - 1)

    def at(self, t: float) -> tuple[float, float, float]:
        """``(s, s', s'')`` [m, m/s, m/s^2] at time ``t`` [s] (scalar, the stepping loop's)."""
        tr = t - self.t_start
        k = bisect_left(self._ends, tr)
        if k >= len(self._durations):
            k = len(self._durations) - 1
        tau = min(max(tr - self._starts[k], 0.0), self._durations[k])
        return kernels.quintic(tau, self._head if k < self._n_head else self._tail, 6 * k)
