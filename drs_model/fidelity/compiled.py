"""The hydraulic rung's kernels and steps compiled by numba (as :mod:`drs_model.compiled` does for
the mechanism's kernels), or the plain functions without numba: the same values either way."""

from __future__ import annotations

from functools import cache

from ..errors import NumbaUnavailableError
from . import hydraulic_kernels, hydraulic_steps


@cache
def _registered() -> bool:
    """Register every hydraulic kernel and step as callable from compiled code (once); False
    without numba."""
    try:
        from ..compiled.jit import jitable
    except NumbaUnavailableError:
        return False
    for fn in hydraulic_kernels.KERNELS + hydraulic_steps.KERNELS:
        jitable(fn)
    return True


def compiled_kernel(fn):
    """``fn`` (a function of :mod:`~drs_model.fidelity.hydraulic_kernels` or
    :mod:`~drs_model.fidelity.hydraulic_steps`) compiled by numba, or itself without numba."""
    if not _registered():
        return fn
    from ..compiled.jit import compiled

    return compiled(fn)
