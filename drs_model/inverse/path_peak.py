"""The largest piston force along a commanded path of quintic segments (a stroke command's move,
a trajectory), which a move is checked and stretched against (``force_limit``).

Each segment is sampled at :data:`PATH_FORCE_SAMPLES` equally spaced instants, and the best
sample's neighbourhood again on a finer grid of :data:`REFINE_SAMPLES`: a sampled peak lies below
the true one by ~(spacing)^2, 0.7 % with 33 samples; the finer grid leaves ~1e-5. The force at
a sample is the fused closed form (:func:`drs_model.kernels.fused_force`) of the segment's
``(s, s', s'')`` (:func:`drs_model.kernels.quintic`).

The scan (:func:`scan_path`) is one plain loop over the samples, compiled by numba when it is
installed (:func:`drs_model.compiled.scalar.compiled_or_plain`). Why: a stroke command from a
moving flap needs two scans inside the node's real-time tick, and on numpy arrays (three
``polyval``, the finiteness checks, ``argmax``, twice) a one-segment scan cost ~80 us, almost
all of it numpy's cost per call on 33 samples. Without numba the same loop runs in Python (the
same values, many times slower).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from ..errors import InputError
from ..kernels import fused_force, quintic
from ..params import DRSParams
from .manoeuvre import _fused

#: Instants per segment (both ends included) at which :func:`path_peak_force` evaluates a path.
PATH_FORCE_SAMPLES = 33
#: Instants of the finer grid across the best sample's two neighbouring intervals.
REFINE_SAMPLES = 65


class PathPeak(NamedTuple):
    """Largest ``|F|`` along a commanded path: the signed force [N], the segment it lies in, the
    time [s] into that segment and the stroke [m] there."""

    force: float
    segment: int
    time: float
    stroke: float


def scan_path(c, d, u, w, consts):
    """The peak ``(force [N], segment, time [s], stroke [m], failed)`` of the quintics ``c``
    (shape ``(n, 6)``, local-time coefficients) on ``[0, d[k]]`` [s]: sampled at ``d[k] * u``
    (``u`` from 0 to 1), then across the best sample's neighbours at ``lo + (hi - lo) * w``
    (``w`` from 0 to 1). The first sample of the largest ``|F|`` wins; with none above 0 the
    peak is ``(0, 0, 0, nan)``. ``failed``: a sample's force was not finite (the loop cannot
    close there, a dead centre, or a path whose numbers overflow), and the peak is that
    sample."""
    best_f, best_k, best_t, best_s = 0.0, 0, 0.0, math.nan
    for k in range(d.shape[0]):
        for j in range(u.shape[0]):
            tau = d[k] * u[j]
            s, v, a = quintic(tau, c[k], 0)
            f = fused_force(s, v, a, consts)
            if not math.isfinite(f):
                return f, k, tau, s, True
            if abs(f) > abs(best_f):
                best_f, best_k, best_t, best_s = f, k, tau, s
    k, h = best_k, d[best_k] / (u.shape[0] - 1)
    lo, hi = max(best_t - h, 0.0), min(best_t + h, d[k])
    for j in range(w.shape[0]):
        tau = lo + (hi - lo) * w[j]
        s, v, a = quintic(tau, c[k], 0)
        f = fused_force(s, v, a, consts)
        if not math.isfinite(f):
            return f, k, tau, s, True
        if abs(f) > abs(best_f):
            best_f, best_t, best_s = f, tau, s
    return best_f, best_k, best_t, best_s, False


@functools.cache
def _scan():
    """:func:`scan_path` compiled (or plain, without numba), built at its first use."""
    from ..compiled.scalar import compiled_or_plain

    return compiled_or_plain(scan_path)


@functools.cache
def _unit_grid(samples: int) -> np.ndarray:
    return np.linspace(0.0, 1.0, samples)


def path_peak_force(p: DRSParams, coeffs, durations, samples: int = PATH_FORCE_SAMPLES) -> PathPeak:
    """The inverse-dynamics peak ``|F|`` along quintic segments (a commanded move or
    trajectory): ``coeffs[k]`` the local-time coefficients ``a_0..a_5`` of segment ``k`` on ``[0,
    durations[k]]`` [s], sampled at ``samples`` equally spaced instants each and refined around
    the best (:func:`scan_path`).

    Raises
    ------
    InputError
        No segment, fewer than 2 samples, a non-finite coefficient or duration, or a path
        whose stroke, rate or acceleration overflows.
    AssemblyError, SingularConfigurationError
        The path passes a stroke where the loop cannot close, or a dead centre.
    """
    c_all = np.ascontiguousarray(coeffs, dtype=float).reshape(-1, 6)
    d_all = np.ascontiguousarray(durations, dtype=float).ravel()
    if not c_all.shape[0] or c_all.shape[0] != d_all.size or int(samples) < 2:
        raise InputError(
            f"need one duration per segment and >= 2 samples, got {c_all.shape[0]} "
            f"segments, {d_all.size} durations, {samples!r} samples"
        )
    for name, x in (("coefficient", c_all), ("duration", d_all)):
        if not np.all(np.isfinite(x)):
            raise InputError(f"a {name} must be finite, got {float(x[~np.isfinite(x)][0])!r}")
    fused = _fused(p, None, None)  # built once per parameter set
    u, w = _unit_grid(int(samples)), _unit_grid(REFINE_SAMPLES)
    force, k, t, s, failed = _scan()(c_all, d_all, u, w, fused.consts)
    if failed:
        # the mechanism fails at that stroke (the typed error raised here), or the numbers overflow
        fused.force_array(np.array([s]), 0.0, 0.0)
        motion = quintic(float(t), [float(x) for x in c_all[k]], 0)
        raise InputError(
            f"the force along the path is not finite at {t!r} s into segment {k}, where "
            f"(s, s', s'') = {motion!r}: its coefficients and durations overflow"
        )
    return PathPeak(float(force), int(k), float(t), float(s))


__all__ = ["PATH_FORCE_SAMPLES", "REFINE_SAMPLES", "PathPeak", "path_peak_force", "scan_path"]
