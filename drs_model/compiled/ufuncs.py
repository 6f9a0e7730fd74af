"""The kernels with a branch or a ``math`` function as numpy generalised ufuncs (numba
``guvectorize``): the array path of :mod:`drs_model.elementwise` when numba is installed.

Each function below writes its plain kernel of :mod:`drs_model.kernels` into its outputs;
:func:`gufunc` makes it a gufunc, which runs it on every element of its array arguments
(broadcast as numpy does), with the constants ``c`` (and ``k``) as one float64 array, and returns
one array per result. A gufunc is built at its first request (compiled, or loaded from numba's
cache), so a process builds only those it uses.
"""

from __future__ import annotations

import math
from functools import cache

from .. import kernels
from . import jit


def stroke_position(s, c, sign, sin1, cos1, sin3, cos3, h2):
    """:func:`drs_model.kernels.stroke_position`."""
    sin1[0], cos1[0], sin3[0], cos3[0], h2[0] = kernels.stroke_position(s, c, sign)


def flap_position(sin3, cos3, c, sign, s, sin1, cos1, cos1_sq):
    """:func:`drs_model.kernels.flap_position`."""
    s[0], sin1[0], cos1[0], cos1_sq[0] = kernels.flap_position(sin3, cos3, c, sign)


def manoeuvre_profile(t, k, s, sd, sdd):
    """:func:`drs_model.kernels.manoeuvre_profile`."""
    s[0], sd[0], sdd[0] = kernels.manoeuvre_profile(t, k)


def fused_force(s, sd, sdd, c, force):
    """:func:`drs_model.kernels.fused_force`."""
    force[0] = kernels.fused_force(s, sd, sdd, c)


def fused_manoeuvre_force(t, c, k, force):
    """:func:`drs_model.kernels.fused_manoeuvre_force`, its callees inlined (the batch path of
    the inverse dynamics along a manoeuvre)."""
    force[0] = _FUSED_MANOEUVRE_FORCE(t, c, k)


_FUSED_MANOEUVRE_FORCE = jit.inlined(kernels.fused_manoeuvre_force)
_MANOEUVRE_PROFILE = jit.inlined(kernels.manoeuvre_profile)
_FUSED_FORCE = jit.inlined(kernels.fused_force)


def fused_manoeuvre_force_series(t, c, k, force):
    """:func:`drs_model.kernels.fused_manoeuvre_force` along a series of times ``t``: its two
    halves, the profile and then the force, with the force of the time before taken again
    where the profile gives the same ``(s, s', s'')`` (the rod resting: before the opening, in
    the hold, after the closing). The force is a pure function of those three, so the value is
    the same to the bit; a series of times spends the kernel's trigonometry on the moves only."""
    s_before = sd_before = sdd_before = force_before = math.nan
    for i in range(t.shape[0]):
        s, sd, sdd = _MANOEUVRE_PROFILE(t[i], k)
        if s != s_before or sd != sd_before or sdd != sdd_before:
            force_before = _FUSED_FORCE(s, sd, sdd, c)
            s_before, sd_before, sdd_before = s, sd, sdd
        force[i] = force_before


def psi3_acceleration(b, bd, force, c, acc):
    """:func:`drs_model.kernels.psi3_acceleration`."""
    acc[0] = kernels.psi3_acceleration(b, bd, force, c)


#: numba's signature and numpy's layout of each gufunc (``()``: one value per element, ``(n)``,
#: ``(m)``: the constants). Every array is C-contiguous (``[::1]``; :mod:`drs_model.elementwise`
#: passes them so): indexing it needs no stride, which made the series path ~15 % faster than
#: with any layout (``[:]``).
SIGNATURES = {
    stroke_position: (
        "void(float64, float64[::1], float64, "
        "float64[::1], float64[::1], float64[::1], float64[::1], float64[::1])",
        "(),(n),()->(),(),(),(),()",
    ),
    flap_position: (
        "void(float64, float64, float64[::1], float64, "
        "float64[::1], float64[::1], float64[::1], float64[::1])",
        "(),(),(n),()->(),(),(),()",
    ),
    manoeuvre_profile: (
        "void(float64, float64[::1], float64[::1], float64[::1], float64[::1])",
        "(),(m)->(),(),()",
    ),
    fused_force: (
        "void(float64, float64, float64, float64[::1], float64[::1])",
        "(),(),(),(n)->()",
    ),
    fused_manoeuvre_force: (
        "void(float64, float64[::1], float64[::1], float64[::1])",
        "(),(n),(m)->()",
    ),
    fused_manoeuvre_force_series: (
        "void(float64[::1], float64[::1], float64[::1], float64[::1])",
        "(t),(n),(m)->(t)",
    ),
    psi3_acceleration: (
        "void(float64, float64, float64, float64[::1], float64[::1])",
        "(),(),(),(n)->()",
    ),
}


@cache
def gufunc(fn):
    """The gufunc of ``fn`` (a function of :data:`SIGNATURES`), built at its first request."""
    signature, layout = SIGNATURES[fn]
    return jit.gufunc(signature, layout)(fn)
