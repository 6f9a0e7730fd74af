"""Whether a quintic path stays within the stroke range: its sampled extremes, the Bernstein hull
that spares sampling a path well inside, and the check that refuses one that leaves.

A segment is a quintic ``s(tau) = sum c_k tau^k`` in local time on ``[0, T]`` (coefficients of
:func:`drs_model.profile.quintic_coefficients_array`); the range is ``[s_min, s_max]`` [m]. A
trajectory (:func:`drs_model.profile.plan_trajectory`) and a stroke command check their segments
here.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .errors import StrokeRangeError

#: Samples per segment (both ends included) at which a trajectory's path is checked against
#: ``[s_min, s_max]``.
PATH_SAMPLES = 65
#: Tolerance [m] of that check (and of the strokes' range check).
PATH_TOL = 1e-12
#: Those instants as fractions of a segment's duration (made once: a stroke command checks its
#: one segment on the real-time tick).
_PATH_FRACTIONS = np.linspace(0.0, 1.0, PATH_SAMPLES)
_PATH_FRACTIONS.flags.writeable = False


def path_extremes(coeffs: np.ndarray, durations: np.ndarray, chunk: int = 2048):
    """Smallest and largest stroke [m] of each quintic ``coeffs[k]`` (local time) over
    ``PATH_SAMPLES`` equally spaced instants of ``[0, durations[k]]``, all segments at once (in
    chunks of ``chunk`` segments, so memory stays bounded). Returns two arrays of shape
    ``(n,)``."""
    coeffs = np.asarray(coeffs, dtype=float).reshape(-1, 6)
    durations = np.asarray(durations, dtype=float).ravel()
    u = _PATH_FRACTIONS
    lo, hi = np.empty(len(durations)), np.empty(len(durations))
    for a in range(0, len(durations), chunk):
        c = coeffs[a : a + chunk]
        tau = durations[a : a + chunk, None] * u
        s = c[:, 5:6] * tau
        for j in (4, 3, 2, 1):
            s += c[:, j : j + 1]
            s *= tau
        s += c[:, 0:1]
        lo[a : a + chunk], hi[a : a + chunk] = s.min(axis=1), s.max(axis=1)
    return lo, hi


#: Power basis (in u = tau / T) -> Bernstein basis of degree 5: ``b_j = sum_k C(j,k)/C(5,k) d_k``.
_TO_BERNSTEIN = np.array(
    [[math.comb(j, k) / math.comb(5, k) if k <= j else 0.0 for k in range(6)] for j in range(6)]
)
_TO_BERNSTEIN.flags.writeable = False


def bernstein_hull(c, d, to_bernstein, lo: float, hi: float, out) -> int:
    """``out[k]``: whether a Bernstein control point of the quintic ``c[k]`` (local-time
    coefficients, shape ``(n, 6)``) on ``[0, d[k]]`` [s] lies outside ``[lo, hi]`` [m]; returns
    how many do. The control points are ``b_j = sum_k to_bernstein[j, k] c_k d^k``, the power
    coefficients in ``u = tau / d`` taken to the Bernstein basis (:data:`_TO_BERNSTEIN`); the
    path lies within their hull. One plain loop, compiled by numba where it is installed
    (:func:`hull_leaves`): a stroke command checks its one segment inside the node's tick, where
    the same sum on numpy arrays cost ~8 us, almost all numpy's cost per call."""
    leaving = 0
    for k in range(d.shape[0]):
        b_min, b_max = math.inf, -math.inf
        for j in range(6):
            b, power = 0.0, 1.0
            for i in range(j + 1):
                b += (c[k, i] * power) * to_bernstein[j, i]
                power *= d[k]
            b_min, b_max = min(b_min, b), max(b_max, b)
        out[k] = b_min < lo or b_max > hi
        leaving += out[k]
    return leaving


@functools.cache
def _hull():
    """:func:`bernstein_hull` compiled (or plain, without numba), built at its first use."""
    from .compiled.scalar import compiled_or_plain

    return compiled_or_plain(bernstein_hull)


def _segments(coeffs, durations) -> tuple[np.ndarray, np.ndarray]:
    return (
        np.ascontiguousarray(coeffs, dtype=float).reshape(-1, 6),
        np.ascontiguousarray(durations, dtype=float).ravel(),
    )


def _hull_check(coeffs: np.ndarray, durations: np.ndarray, limits) -> tuple[np.ndarray, int]:
    """:func:`bernstein_hull` of segments as :func:`_segments` gives them: ``(leaves, count)``."""
    out = np.empty(durations.size, dtype=np.bool_)
    count = _hull()(coeffs, durations, _TO_BERNSTEIN, float(limits[0]), float(limits[1]), out)
    return out, count


def hull_leaves(coeffs, durations, limits: tuple[float, float]) -> np.ndarray:
    """Whether the Bernstein control points of each quintic ``coeffs[k]`` (local time, on ``[0,
    durations[k]]``) leave ``limits`` [m], shape ``(n,)``; if not, the path lies inside them
    (:func:`bernstein_hull`)."""
    return _hull_check(*_segments(coeffs, durations), limits)[0]


def load_compiled() -> None:
    """Load the compiled hull check now (from numba's cache, a few ms the first time in a
    process), so that a real-time caller's first command does not pay it."""
    hull_leaves(np.zeros((1, 6)), np.ones(1), (0.0, 1.0))


def leaving_paths(coeffs, durations, limits: tuple[float, float]):
    """``(k, lo, hi)``: the quintics ``coeffs[k]`` (local time) whose path leaves ``limits`` [m]
    by more than :data:`PATH_TOL` at one of :data:`PATH_SAMPLES` instants, and their lowest and
    highest samples [m]; sampled only where the control points leave ``limits`` by more than
    half :data:`PATH_TOL` (:func:`hull_leaves`)."""
    coeffs, durations = _segments(coeffs, durations)
    # the hull against the limits widened by half the samples' tolerance: a move that ends on a
    # stop has its last control point there, a rounding error (~1e-17 m) beyond it, and a path
    # inside the widened limits cannot leave by more than PATH_TOL, the control points' and the
    # samples' rounding (a few ulps) included (nothing to sample: ~20 us a command)
    margin = PATH_TOL / 2
    leaves, count = _hull_check(coeffs, durations, (limits[0] - margin, limits[1] + margin))
    if not count:
        return np.empty(0, dtype=np.intp), np.empty(0), np.empty(0)
    k = np.flatnonzero(leaves)
    lo, hi = path_extremes(coeffs[k], durations[k])
    bad = (lo < limits[0] - PATH_TOL) | (hi > limits[1] + PATH_TOL)
    return k[bad], lo[bad], hi[bad]


def check_paths(coeffs, durations, limits: tuple[float, float], first: int = 0, n=None) -> None:
    """Raise :class:`StrokeRangeError` if the path of a quintic ``coeffs[i]`` leaves ``limits``
    (:func:`leaving_paths`), naming the first such segment (segment ``first + i`` leads to point
    ``first + i`` of ``0..n-1``)."""
    leaving, lo, hi = leaving_paths(coeffs, durations, limits)
    if leaving.size:
        n = np.size(durations) + first if n is None else n
        raise StrokeRangeError(
            f"the trajectory leaves [s_min, s_max] = [{limits[0]:.9g}, {limits[1]:.9g}] m on "
            f"its way to point {first + int(leaving[0])} (of 0..{n - 1}), reaching "
            f"{lo[0]:.6g}..{hi[0]:.6g} m"
        )
