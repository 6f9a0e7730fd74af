"""The kernels of :mod:`drs_model.kernels` on numpy arrays, element by element.

The kernels that are arithmetic alone (:func:`~drs_model.kernels.rotate`,
:func:`~drs_model.kernels.quintic`, :func:`~drs_model.kernels.flap_gap`,
:func:`~drs_model.kernels.air_load`, :func:`~drs_model.kernels.loop_residual`,
:func:`~drs_model.kernels.loop_gamma` ...) take arrays as they are. The kernels with a branch or a
``math`` function are applied here to every element of their array arguments (broadcast as numpy
does; the constants ``c`` and ``k`` are sequences): by the numba gufuncs of
:mod:`drs_model.compiled.ufuncs` when numba is installed (each built at its first use), else by
:func:`numpy.vectorize` over the plain Python kernel (the same values, some 50x slower). Every
result is an array of the broadcast shape, or a tuple of them for a kernel with several results.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from . import kernels
from .errors import NumbaUnavailableError


@cache
def _gufuncs():
    """:mod:`drs_model.compiled.ufuncs`, or None when numba is not installed."""
    try:
        from .compiled import ufuncs
    except NumbaUnavailableError:
        return None
    return ufuncs


def _array(constants) -> np.ndarray:
    """The constants as the gufuncs take them: float64, C-contiguous (their signatures say so and
    numba reads them without strides)."""
    return np.ascontiguousarray(constants, dtype=np.float64)


def stroke_position(s, c, sign):
    """:func:`~drs_model.kernels.stroke_position` at each stroke of ``s`` [m]:
    ``(sin psi1, cos psi1, sin psi3, cos psi3, h2)``."""
    u = _gufuncs()
    if u is None:
        return np.vectorize(kernels.stroke_position, otypes=[float] * 5, excluded={1, 2})(
            s, c, sign
        )
    return u.gufunc(u.stroke_position)(s, _array(c), sign)


def flap_position(sin3, cos3, c, sign):
    """:func:`~drs_model.kernels.flap_position` at each flap angle of sine ``sin3`` and cosine
    ``cos3``: ``(s, sin psi1, cos psi1, cos^2 psi1)``."""
    u = _gufuncs()
    if u is None:
        return np.vectorize(kernels.flap_position, otypes=[float] * 4, excluded={2, 3})(
            sin3, cos3, c, sign
        )
    return u.gufunc(u.flap_position)(sin3, cos3, _array(c), sign)


def manoeuvre_profile(t, k):
    """:func:`~drs_model.kernels.manoeuvre_profile` at each time of ``t`` [s]:
    ``(s, s', s'')``."""
    u = _gufuncs()
    if u is None:
        return np.vectorize(kernels.manoeuvre_profile, otypes=[float] * 3, excluded={1})(t, k)
    return u.gufunc(u.manoeuvre_profile)(t, _array(k))


def fused_force(s, sd, sdd, c):
    """:func:`~drs_model.kernels.fused_force` [N] at each ``(s, s', s'')``."""
    u = _gufuncs()
    if u is None:
        return np.vectorize(kernels.fused_force, otypes=[float], excluded={3})(s, sd, sdd, c)
    return u.gufunc(u.fused_force)(s, sd, sdd, _array(c))


def fused_manoeuvre_force(t, c, k):
    """:func:`~drs_model.kernels.fused_manoeuvre_force` [N] at each time of ``t`` [s]."""
    u = _gufuncs()
    if u is None:
        return np.vectorize(kernels.fused_manoeuvre_force, otypes=[float], excluded={1, 2})(t, c, k)
    return u.gufunc(u.fused_manoeuvre_force)(t, _array(c), _array(k))


def fused_manoeuvre_force_series(t, c, k):
    """:func:`~drs_model.kernels.fused_manoeuvre_force` [N] at each time of ``t`` [s] (any
    shape) for one set of constants ``c`` and ``k``: the same values as
    :func:`fused_manoeuvre_force`, in one compiled pass over the times that computes the force
    once per stretch of rest (:func:`drs_model.compiled.ufuncs.fused_manoeuvre_force_series`)."""
    u = _gufuncs()
    if u is None:
        return fused_manoeuvre_force(t, c, k)
    t = np.asarray(t, dtype=np.float64)
    series = u.gufunc(u.fused_manoeuvre_force_series)
    return series(_array(t.reshape(-1)), _array(c), _array(k)).reshape(t.shape)


def psi3_acceleration(b, bd, force, c):
    """:func:`~drs_model.kernels.psi3_acceleration` [rad/s^2] at each ``(psi3, psi3', F)``."""
    u = _gufuncs()
    if u is None:
        return np.vectorize(kernels.psi3_acceleration, otypes=[float], excluded={3})(
            b, bd, force, c
        )
    return u.gufunc(u.psi3_acceleration)(b, bd, force, _array(c))
