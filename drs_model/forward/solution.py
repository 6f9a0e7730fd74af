"""The result of a forward simulation (as scipy's ``OdeResult``): one type for every method."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constraints import PSI3, S


@dataclass
class Solution:
    """Result of :func:`simulate`.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Output times [s].
    y : ndarray, shape (n_state, n)
        The formulation's states.
    q, qd : ndarray, shape (n, 3)
        Configurations [m, rad, rad] and velocities [m/s, rad/s] (mapped back).
    residual, velocity_residual : ndarray, shape (n,)
        ``max |Phi|`` [m] and ``max |Phi_q qd|`` [m/s] (zero for minimal coordinates).
    nfev, njev, nlu, nsteps : int
        Right-hand-side and Jacobian evaluations, LU decompositions, accepted steps.
    segments : list of (float, float)
        The integration segments [s] (restarts at the force's breakpoints).
    nrejected : int
        Rejected steps (counted by the compiled methods only; 0 for the scipy methods).
    """

    formulation: str
    method: str
    t: np.ndarray
    y: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    residual: np.ndarray
    velocity_residual: np.ndarray
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    nsteps: int = 0
    segments: list[tuple[float, float]] = field(default_factory=list)
    nrejected: int = 0

    @property
    def s(self) -> np.ndarray:
        """Stroke [m], shape (n,)."""
        return self.q[:, S]

    @property
    def psi3(self) -> np.ndarray:
        """Flap angle [rad], shape (n,)."""
        return self.q[:, PSI3]
