"""The compiled RK driver (:func:`.rk.integrate`) built once per method, its tableau bound in.

numba freezes the arrays and numbers of a closure into the build: the number of stages, the
coefficients and the method's branches are constants to the compiler (its loops unrolled, DOP853's
branches gone from dopri5), and a call passes 17 arguments instead of 26 (numba's dispatch types
each one, ~130 ns an array). A dopri5 run at rtol 1e-6 costs ~2.5 us (~7 %) less than with the
tableau passed at each call (``benchmarks/work_precision.py --floor``, docs/forward.md); the
warm-up compiles the driver once per method.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from .. import kernels
from . import jit as jit_options
from . import rk, rk_step
from .jit import jit, jitable
from .rk import integrate as integrate_tableau
from .tableaux import METHODS, tableau


def source_digest(*modules) -> str:
    """SHA-256 of the source files of ``modules``."""
    digest = hashlib.sha256()
    for module in modules:
        digest.update(Path(module.__file__).read_bytes())
    return digest.hexdigest()


#: The code a build inlines (the driver and its step, the kernels, their inlined builds), bound
#: into each build as well: numba's on-disk cache checks the stamp of this file alone, and the
#: closure's values are part of its key, so an edit there compiles anew instead of loading a
#: stale build.
INLINED_SOURCE = source_digest(rk, rk_step, kernels, jit_options)


def _driver(method: str):
    """:func:`.rk.integrate` compiled for ``method`` with its tableau
    (:func:`~.tableaux.tableau`) bound in."""
    a, c, e, e3, dense, ns, n_ext, err_order, is853 = tableau(method)
    inlined_source = INLINED_SOURCE

    def integrate(
        y_start0,
        y_start1,
        t_eval,
        has_eval,
        edges,
        kinds,
        values,
        mc,
        mp,
        kc,
        rtol,
        atol,
        first_step,
        max_step,
        min_step,
        checks,
        max_steps,
    ):
        inlined_source  # noqa: B018 - a value of the closure: part of numba's cache key
        return integrate_tableau(
            y_start0,
            y_start1,
            t_eval,
            has_eval,
            (edges, kinds, values, mc, mp, kc),
            (a, c, e, e3, dense, ns, n_ext, err_order, is853),
            (rtol, atol, first_step, max_step, min_step, checks, max_steps),
        )

    integrate.__qualname__ = integrate.__name__ = f"integrate_{method}"
    integrate.__doc__ = f""":func:`.rk.integrate` of {method!r}: its arguments without the
    tableau, the same returns."""
    return jit(integrate)


#: The driver of each method (``DRIVERS[method](y_start0, y_start1, t_eval, has_eval, edges,
#: kinds, values, mc, mp, kc, rtol, atol, first_step, max_step, min_step, checks, max_steps)``).
DRIVERS = {method: _driver(method) for method in METHODS}
integrate_dopri5 = DRIVERS["dopri5"]
integrate_dop853 = DRIVERS["dop853"]


@jitable
def integrate_method(is853, *arguments):
    """The driver of DOP853 (``is853``) or dopri5 on ``arguments`` (those of :data:`DRIVERS`'s),
    for compiled callers that choose the method at run time (:mod:`drs_model.study.crossing`)."""
    if is853:
        return integrate_dop853(*arguments)
    return integrate_dopri5(*arguments)


__all__ = [
    "DRIVERS",
    "INLINED_SOURCE",
    "integrate_dop853",
    "integrate_dopri5",
    "integrate_method",
    "source_digest",
]
