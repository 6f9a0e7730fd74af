"""The arguments both forward drivers check alike, the scipy one
(:func:`drs_model.forward.simulate`) and the compiled one (:mod:`drs_model.compiled.simulate`):
the time span, the relative tolerance and the output times. Each raises
:class:`~drs_model.errors.InputError` naming the bad value."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError


def time_span(t_span) -> tuple[float, float]:
    """``(t_start, t_end)`` [s] as floats: finite, ``t_end > t_start``."""
    t0, t1 = (float(v) for v in t_span)
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"t_span must be finite with t_end > t_start, got {tuple(t_span)!r}")
    return t0, t1


def relative_tolerance(rtol) -> float:
    """``rtol`` [-] as a float: finite and > 0."""
    if not (rtol > 0.0 and math.isfinite(rtol)):
        raise InputError(f"rtol must be a finite number > 0, got {rtol!r}")
    return float(rtol)


def output_times(t_eval, t_span: tuple[float, float]) -> np.ndarray:
    """``t_eval`` [s] as a contiguous float64 array: 1-D, within ``t_span``, sorted."""
    t0, t1 = t_span
    te = np.ascontiguousarray(t_eval, dtype=np.float64)
    if te.ndim != 1 or np.any(te < t0) or np.any(te > t1):
        raise InputError(f"t_eval must be 1-D within t_span {(t0, t1)!r}")
    if np.any(np.diff(te) < 0.0):
        raise InputError("t_eval must be sorted in increasing order")
    return te
