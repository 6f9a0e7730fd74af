"""One sample at a time: a kernel bound to its constants, compiled by numba when it is installed.

:func:`bind` is how the real-time fixed step (:class:`~drs_model.forward.FixedStepIntegrator`),
the psi3 right-hand side (:class:`~drs_model.forward.Psi3Minimal`), the manoeuvre's force
(:class:`~drs_model.forward.ManoeuvreForce`) and one inverse-dynamics force
(:class:`~drs_model.inverse.FusedInverseDynamics`) call their kernel: the ``numba.njit`` build of
the plain function (:func:`drs_model.compiled.jit.compiled`), or, without numba, the plain
function itself. Same values; the compiled call costs ~0.5 us, the plain Python one several
microseconds per kernel it calls.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from ..errors import NumbaUnavailableError


@cache
def _register(callees: tuple, inline: str) -> None:
    from .jit import jitable

    for fn in callees:
        jitable(fn, inline)


def compiled_or_plain(fn, callees: tuple = (), inlined: tuple = ()):
    """``fn`` compiled by numba (one dispatcher per function and process), or ``fn`` itself when
    numba is not installed. ``callees``: the plain functions ``fn`` calls beyond the kernels of
    :mod:`drs_model.kernels` (the hydraulic rung's), registered with numba first (once);
    ``inlined``: plain functions registered to be inlined where they are called (the right-hand
    side ``fn`` gives a step of :mod:`drs_model.explicit_steps`, inlined into that step's
    build)."""
    try:
        from .jit import compiled
    except NumbaUnavailableError:
        return fn
    _register(tuple(callees), "never")
    _register(tuple(inlined), "always")
    return compiled(fn)


def bind(fn, *constants, inlined: tuple = ()):
    """``fn(*args, *constants)`` as a function of ``args`` alone (``inlined``: as for
    :func:`compiled_or_plain`).

    With numba, the compiled ``fn`` with each constant as a float64 array (numba types an array
    argument in ~0.1 us, a tuple of 21 floats in ~10 us); without, the plain ``fn`` with the
    constants as they are (indexing a tuple is the fastest in Python).
    """
    run = compiled_or_plain(fn, inlined=inlined)
    if run is fn:
        values = constants
    else:
        values = tuple(np.array(c, dtype=np.float64) for c in constants)

    def bound(*args):
        return run(*args, *values)

    bound.__name__ = bound.__qualname__ = fn.__name__
    bound.__doc__ = fn.__doc__
    return bound
