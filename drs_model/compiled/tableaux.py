"""The Butcher tableaux of the compiled RK driver (:mod:`.rk`), read from scipy's public solver
classes (``RK45.A``, ``DOP853.E5`` ...): one source of truth for the coefficients."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.integrate import DOP853, RK45

from ..errors import InputError

#: The methods of the compiled driver.
METHODS = ("dopri5", "dop853")


@lru_cache(maxsize=2)
def tableau(method: str):
    """The method's arrays, read from scipy's public solver classes (one source of truth):
    ``A`` (n_ext, n_ext) with the weights B in row ``ns`` (FSAL: ``y_new`` is the stage at
    ``c = 1``) and DOP853's dense-output stages below it, ``C`` (n_ext,), the error weights ``E``
    (RK45) or ``E5`` and ``E3`` (DOP853), the dense-output matrix ``P`` (RK45, (7, 4)) or ``D``
    (DOP853, (4, 16)); then ``ns``, ``n_ext``, the error estimator's order, is-DOP853."""
    if method == "dopri5":
        ns, n_ext = RK45.n_stages, RK45.n_stages + 1
        a = np.zeros((n_ext, n_ext))
        a[:ns, : RK45.A.shape[1]] = RK45.A
        a[ns, :ns] = RK45.B
        c = np.zeros(n_ext)
        c[:ns], c[ns] = RK45.C, 1.0
        e, e3, dense = RK45.E, np.zeros(n_ext), RK45.P
        order = RK45.error_estimator_order
    elif method == "dop853":
        ns = DOP853.n_stages
        n_ext = ns + 1 + DOP853.A_EXTRA.shape[0]
        a = np.zeros((n_ext, n_ext))
        a[:ns, :ns] = DOP853.A
        a[ns, :ns] = DOP853.B
        a[ns + 1 :, : DOP853.A_EXTRA.shape[1]] = DOP853.A_EXTRA
        c = np.zeros(n_ext)
        c[:ns], c[ns], c[ns + 1 :] = DOP853.C, 1.0, DOP853.C_EXTRA
        e, e3, dense = DOP853.E5, DOP853.E3, DOP853.D
        order = DOP853.error_estimator_order
    else:
        raise InputError(f"method must be 'dopri5' or 'dop853', got {method!r}")
    arrays = tuple(np.ascontiguousarray(x, dtype=np.float64) for x in (a, c, e, e3, dense))
    return (*arrays, int(ns), int(n_ext), float(order), method == "dop853")
