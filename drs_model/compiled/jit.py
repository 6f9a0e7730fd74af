"""numba for drs_model: the options of every compiled function, and the kernels of
:mod:`drs_model.kernels` and the steps of :mod:`drs_model.explicit_steps` made callable from
compiled code.

Importing this module imports numba; without numba it raises
:class:`~drs_model.errors.NumbaUnavailableError` (an ``ImportError``) saying how to install it.

Every kernel and every step is registered with :func:`numba.extending.register_jitable`: the
function itself is unchanged (Python calls it as before), and a compiled function that calls it
compiles it in. :func:`compiled` gives the compiled build of a plain function for Python to call,
one per function and process; :func:`gufunc` builds a numpy gufunc.
"""

from __future__ import annotations

from functools import cache
from types import FunctionType

from ..errors import NumbaUnavailableError

try:
    import numba
    from numba.extending import register_jitable
except ImportError as exc:
    raise NumbaUnavailableError(
        "the compiled paths (the methods 'dopri5-numba', 'dop853-numba') need numba, which is "
        "not installed: pip install 'drs[fast]' (or pip install 'numba>=0.60'); the scipy methods "
        "('RK45', 'DOP853', 'LSODA', ...) and every model function work without it"
    ) from exc

from .. import explicit_steps, kernels

#: numba's options for every compiled function: numpy's error model, so that a division by zero
#: gives inf or NaN (which the callers treat as a failed stage or sample) instead of a
#: ZeroDivisionError check on every division.
OPTIONS = {"error_model": "numpy"}

#: ``numba.njit`` with :data:`OPTIONS` and numba's on-disk cache.
jit = numba.njit(cache=True, **OPTIONS)


def jitable(fn, inline: str = "never"):
    """Register the plain function ``fn`` as callable from compiled code and return it unchanged.
    ``inline="always"`` inlines it in numba's IR (where a caller keeps some of its results)."""
    return register_jitable(inline=inline, **OPTIONS)(fn)


def jitable_inlined(fn):
    """Register the helper ``fn`` inlined into its caller in numba's IR. The helpers of an RK
    step (its stages, error norm, checks and output) are: called, each passed its arrays as
    structures with their references counted, they cost ~0.2-0.3 us a step, a sixth of a run
    at rtol 1e-6 (``benchmarks/work_precision.py --floor``: 53.5 -> 44.8 us a run); the
    warm-up (``python -m drs_model.compiled``) compiles ~25 s longer."""
    return jitable(fn, "always")


#: Inlined into their callers: the two halves of psi3_acceleration, which the RK driver calls
#: separately to keep the position of a step's last stage (split, they cost as much as whole).
_INLINED = (kernels.psi3_position, kernels.psi3_acceleration_at)

for _kernel in kernels.KERNELS:
    jitable(_kernel, "always" if _kernel in _INLINED else "never")

# the fixed steps, each compiled once per right-hand side, which is inlined into it (registered by
# the caller: drs_model.compiled.scalar.compiled_or_plain's ``inlined``): no call and no reference
# counting per stage (an RK4 step of formulation (a) ~10 % faster); inlining the steps too into
# their callers took numba several times longer to compile and was no faster
for _step in explicit_steps.STEPS.values():
    jitable(_step)


def _inlined_kernels() -> dict:
    """Every kernel again, each inlined into its callers in numba's IR: the same code objects
    (one formula, not a copy), run with a namespace where each kernel's name is its inlined
    build. Only an entry point that asks for them (:func:`inlined`) compiles them: inlined
    everywhere, the warm-up's compile takes many times longer."""
    namespace = dict(vars(kernels))
    for fn in kernels.KERNELS:
        clone = FunctionType(fn.__code__, namespace, fn.__name__, fn.__defaults__, fn.__closure__)
        namespace[fn.__name__] = numba.njit(inline="always", **OPTIONS)(clone)
    return namespace


@cache
def inlined(fn):
    """The build of kernel ``fn`` whose callees are all inlined into it (numba calls between
    kernels cost a third of a fused sample)."""
    return _inlined_namespace()[fn.__name__]


@cache
def _inlined_namespace() -> dict:
    return _inlined_kernels()


def gufunc(signature: str, layout: str):
    """``numba.guvectorize`` of one signature and layout, with numba's on-disk cache (the kernel a
    gufunc calls compiles with :data:`OPTIONS`, as registered above)."""
    return numba.guvectorize([signature], layout, cache=True)


@cache
def compiled(fn):
    """``fn`` compiled by :data:`jit`, one dispatcher per function and process (it compiles at its
    first call, or loads from numba's cache)."""
    return jit(fn)
