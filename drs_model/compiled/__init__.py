"""The numba-compiled paths of drs_model (optional: ``pip install 'drs[fast]'``).

numba compiles the plain kernels of :mod:`drs_model.kernels` as they are, no copy of them:

* :mod:`.jit`: numba's options for every compiled function, and the kernels registered as
  callable from compiled code (importing it imports numba, or raises
  :class:`~drs_model.errors.NumbaUnavailableError`);
* :mod:`.scalar`: a kernel bound to its constants for one sample at a time (the real-time fixed
  step, the psi3 right-hand side, one inverse-dynamics force): compiled with
  ``numba.njit(cache=True)`` when numba is installed, the plain Python function otherwise;
* :mod:`.ufuncs`: the kernels with a branch or a ``math`` function as numpy gufuncs, the array
  path of :mod:`drs_model.elementwise` when numba is installed;
* :mod:`.rk`: the adaptive Runge-Kutta driver of formulation (a) (dopri5, dop853), plain Python
  in numba's subset, compiled whole; :mod:`.tableaux` reads its coefficients from scipy;
  :mod:`.simulate` validates, plans and runs it (``simulate(..., method="dop853-numba")``);
* :mod:`.warm`: compiles every one of them once (``python -m drs_model.compiled``).

Without numba, ``import drs_model`` and every model function work: the one-sample paths and the
arrays run the plain Python kernels (the same values, slower: docs/forward.md, "Without numba");
only the compiled RK methods (``dopri5-numba``, ``dop853-numba``) refuse, with
:class:`~drs_model.errors.NumbaUnavailableError`.

Start-up: numba compiles a function at its first call and keeps the machine code in its on-disk
cache (``__pycache__`` next to the source); later processes load it. ``make`` fills the cache once
after installing (``python -m drs_model.compiled``), and so does the test suite. Processes that
compile at once are safe: numba writes each cache file under a temporary name and renames it.

Two things to know when changing a kernel:

* numba checks only the source file of the function it compiled: after editing
  :mod:`drs_model.kernels` or :mod:`drs_model.explicit_steps`, the cached builds of the compiled
  functions in other files that call them (the RK driver, the fixed steps of formulation (a) and
  of the hydraulic rung, the gufuncs) are stale. ``make clean-cache``
  deletes every numba cache of the project (the tests compare the compiled paths with the plain
  kernels, so a stale cache fails them).
* ``NUMBA_DISABLE_JIT=1`` runs every compiled function as the Python it is written in, for a
  debugger.
"""
