r"""Forward dynamics: formulations of the equations of motion under a given piston force.

The constrained equations of motion (see :mod:`drs_model.bodies`) in ``q = [s, psi1, psi3]`` are

.. math::

    M(q) \ddot q + h(q, \dot q) + \Phi_q^T \lambda = Q(q, F), \qquad \Phi(q) = 0 ,

``M`` is block diagonal (``[[m_p + m_l, -m_l L_2/2 \sin\psi_1], [., m_l L_2^2/4 + I_l]]`` for
``(s, psi1)``; ``I_3 = m_w |r_{G3}|^2 + I_w`` for psi3),
``h = [-m_l (L_2/2) \cos\psi_1 \dot\psi_1^2, 0, 0]``; ``lambda`` has the sign of
:mod:`drs_model.inverse` (and of sympy's ``LagrangesMethod``): with ``Phi = r_C3 - r_C`` it is the
pin-C reaction on the link. Each formulation below turns these into an ODE ``y' = f(t, y)`` and maps
``y`` back to ``(q, qd)``; :func:`drs_model.forward.simulate` integrates any of them.

(a) Minimal coordinates, psi3 independent (``"psi3"``, state ``y = [psi3, psi3']``)
    Position from the closed form (``sin psi1 = (x_A - x_D + L_3 cos psi3)/L_2``, branch
    ``cos psi1 > 0``). With ``u = dq/dpsi3`` (``Phi_q u = 0``) and ``w = du/dpsi3`` (``Phi_q w =
    gamma(q, u)``) one has ``qd = u psi3'`` and ``qdd = u psi3'' + w psi3'^2``. Projecting the
    equations on ``u`` removes ``lambda`` (``u^T Phi_q^T = 0``, virtual work) and, ``h`` being
    quadratic in ``qd``:

    .. math::

        \ddot\psi_3 = \frac{u^T Q - \dot\psi_3^2\,(u^T M w + u^T h(q, u))}{u^T M u}.

    The dependent block's determinant is ``L2 cos psi1`` (~L2 over the stroke): regular
    everywhere, including through the dead centre, where ``s(psi3)`` merely has a minimum.

(b) Minimal coordinates, s independent (``"s"``, state ``y = [s, s']``)
    The same projection with ``u = dq/ds``, ``w = du/ds``. ``u`` holds ``dpsi3/ds =
    L2 cos(psi1)/(-L2 L3 cos(psi1 - psi3))`` which is infinite at the dead centre (B, C, D
    aligned, ``s_dead ~ -1.55 mm``, 1.75 mm below the closed stroke); below it the loop cannot close
    for any psi3. The formulation raises :class:`~drs_model.errors.SingularConfigurationError`
    when a step ends within ``dead_centre_margin`` of the dead centre, and whenever a stage asks for
    a stroke past it.

(c) Full coordinates at acceleration level (``"index1"``, ``"baumgarte"``; ``y = [q, qd]``)

    .. math::

        \begin{bmatrix} M & \Phi_q^T \\ \Phi_q & 0 \end{bmatrix}
        \begin{bmatrix} \ddot q \\ \lambda \end{bmatrix} =
        \begin{bmatrix} Q - h \\ \gamma - 2\alpha\dot\Phi - \beta^2\Phi \end{bmatrix}

    solved by the Schur complement ``(Phi_q M^-1 Phi_q^T) lambda' = rhs``. With ``alpha = beta =
    0`` the position and velocity residuals drift (the constraint holds only at acceleration
    level: ``Phi`` grows like the integrated local error, roughly linearly or quadratically in t);
    Baumgarte's terms make ``Phi'' + 2 alpha Phi' + beta^2 Phi = 0`` a damped oscillator. A step
    that ends with ``max |Phi|`` above ``drift_bound`` raises
    :class:`~drs_model.errors.ConstraintDriftError`.

(d) Full coordinates with projection (``"projection"``)
    Formulation (c) without stabilisation, and after every accepted step the position is
    projected on ``Phi = 0`` (Newton in the metric of M: ``dq = -M^-1 Phi_q^T (Phi_q M^-1
    Phi_q^T)^-1 Phi``) and the velocity on ``Phi_q qd = 0`` (same projector), as in Eich (1993).

(e) Index-2 GGL form (``"ggl"``, ``y = [q, qd, mu]``) is not provided; see docs/forward.md.

All right-hand sides run the scalar ``math`` kernels of :mod:`drs_model.kernels` (numpy's per-call
overhead on 3-vectors is several microseconds); formulation (a)'s, the one the real-time loop and
the compiled driver use, is compiled by numba when it is installed; those of (c) and (d) are in
:mod:`~drs_model.forward.full_kernel`.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping
from functools import partial
from types import MappingProxyType

import numpy as np

from .. import kernels
from ..bodies import model_constants
from ..compiled.scalar import bind
from ..constraints import constraint, constraint_jacobian
from ..errors import (
    ConstraintDriftError,
    InputError,
    IntegrationError,
    SingularConfigurationError,
)
from ..kernels import (
    flap_position,
    loop_residual,
    projected_dynamics,
    stroke_position,
    stroke_rates,
)
from ..kinematics import (
    dead_centre,
    solve_position,
    solve_position_from_flap_angle,
    stroke_limits,
    velocity_ratio,
)
from ..params import DRSParams
from .full_kernel import make_full_kernel

__all__ = [
    "FORMULATIONS",
    "Formulation",
    "FullCoordinates",
    "Projected",
    "Psi3Minimal",
    "StrokeMinimal",
    "check_options",
    "get_formulation",
    "manoeuvre_initial_state",
]


# ---- formulations -------------------------------------------------------------------------------
class Formulation:
    """One way of writing the equations of motion as an ODE ``y' = f(t, y)``.

    Subclasses set ``name``, ``n_state``, ``coordinates`` and implement :meth:`fun`,
    :meth:`initial_state` and :meth:`to_q_qd`. ``project`` (``y -> y`` after each accepted step)
    is ``None`` unless the formulation projects; :meth:`check` raises a typed error for a state the
    formulation must refuse.
    """

    name: str = ""
    n_state: int = 0
    coordinates: tuple[str, ...] = ()
    #: Typical magnitude of each state component [SI]: the default ``atol`` is ``rtol`` times this.
    scales: tuple[float, ...] = ()
    full: bool = False  #: full coordinates (the constraint residual is meaningful)

    def __init__(self, p: DRSParams, flap_limits: tuple[float, float] | None = None) -> None:
        if not isinstance(p, DRSParams):
            raise InputError(f"p must be DRSParams, got {type(p).__name__}")
        self.p = p
        self.flap_limits = flap_limits
        self.consts = model_constants(p, flap_limits)

    project: Callable[[np.ndarray], np.ndarray] | None = None

    def fun(self, force: Callable[[float], float]) -> Callable[[float, np.ndarray], np.ndarray]:
        """The right-hand side ``f(t, y)`` (shape ``(n_state,)``) under the piston force
        ``force(t)`` [N]."""
        raise NotImplementedError

    def initial_state(self, q, qd) -> np.ndarray:
        """``y0`` from a consistent configuration ``q`` (3,) and velocity ``qd`` (3,)."""
        raise NotImplementedError

    def to_q_qd(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(q, qd)``, each ``(n, 3)``, from states ``y`` of shape ``(n_state, n)``."""
        raise NotImplementedError

    def check(self, t: float, y: np.ndarray) -> None:
        """Raise a typed error if the state ``y`` at ``t`` must be refused (after each step)."""
        if not np.all(np.isfinite(y)):
            raise IntegrationError(f"{self.name}: non-finite state at t = {t!r} s: {y.tolist()}")

    def residual(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(max |Phi| [m], max |Phi_q qd| [m/s])`` at each column of ``y`` (zeros for minimal
        coordinates, which satisfy the constraints by construction), shapes ``(n,)``."""
        q, qd = self.to_q_qd(y)
        phi = np.max(np.abs(constraint(q, self.p)), axis=-1)
        vel = np.einsum("nij,nj->ni", constraint_jacobian(q, self.p), qd)
        return phi, np.max(np.abs(vel), axis=-1)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


def _consistent(q, qd, p: DRSParams, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(q, dtype=float).reshape(3)
    qd = np.asarray(qd, dtype=float).reshape(3)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
        raise InputError(f"initial state must be finite, got q={q.tolist()}, qd={qd.tolist()}")
    res = float(np.max(np.abs(constraint(q, p))))
    vres = float(np.max(np.abs(constraint_jacobian(q, p) @ qd)))
    if res > tol or vres > tol:
        raise InputError(
            f"initial state violates the constraints: max|Phi| = {res:.3g} m, "
            f"max|Phi_q qd| = {vres:.3g} m/s (tolerance {tol:g})"
        )
    return q, qd


class _MinimalCoordinates(Formulation):
    """Two states ``[x, x']`` of one independent coordinate: the constraints hold by
    construction (the dependent coordinates come from the closed form)."""

    n_state = 2

    def residual(self, y):
        n = np.asarray(y).reshape(self.n_state, -1).shape[1]
        return np.zeros(n), np.zeros(n)


class Psi3Minimal(_MinimalCoordinates):
    """(a) Minimal coordinates ``y = [psi3, psi3']`` [rad, rad/s]; regular over the stroke.

    Parameters
    ----------
    min_cos_psi1 : float
        The psi3 parametrisation is singular where ``cos psi1 = 0`` (the link horizontal, far
        outside the stroke: ``cos psi1 > 0.79`` over it). A step ending with ``cos psi1 <
        min_cos_psi1`` raises :class:`SingularConfigurationError`.
    """

    name = "psi3"
    coordinates = ("psi3", "psi3_dot")
    scales = (1.0, 100.0)  # rad, rad/s

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        min_cos_psi1: float = 0.05,
    ) -> None:
        super().__init__(p, flap_limits)
        if not 0.0 <= min_cos_psi1 < 1.0:
            raise InputError(f"min_cos_psi1 must be in [0, 1), got {min_cos_psi1!r}")
        self.min_cos_psi1 = float(min_cos_psi1)
        #: ``accel(psi3, psi3', F)`` [rad/s^2] and ``config(psi3) -> (s, psi1, u_s, u_psi1)``:
        #: :func:`drs_model.kernels.psi3_acceleration` and :func:`~drs_model.kernels.
        #: psi3_configuration` with these constants (compiled by numba when it is installed)
        self.accel = bind(kernels.psi3_acceleration, self.consts)
        self.config = bind(kernels.psi3_configuration, self.consts)

    def check(self, t, y):
        super().check(t, y)
        b = float(y[0])
        cos1 = flap_position(math.sin(b), math.cos(b), self.consts, 1.0)[2]
        if not cos1 >= self.min_cos_psi1:
            raise SingularConfigurationError(
                f"psi3 formulation: at psi3 = {b:.9g} rad (t = {t:.9g} s) cos psi1 = {cos1:.3g} < "
                f"min_cos_psi1 = {self.min_cos_psi1:g}: the link is nearly horizontal and psi3 "
                f"cannot stay the independent coordinate"
            )

    def fun(self, force):
        accel = self.accel

        def rhs(t, y):
            bd = float(y[1])
            return np.array([bd, accel(float(y[0]), bd, force(t))])

        return rhs

    def initial_state(self, q, qd) -> np.ndarray:
        q, qd = _consistent(q, qd, self.p)
        return np.array([q[2], qd[2]])

    def to_q_qd(self, y):
        y = np.asarray(y, dtype=float).reshape(2, -1)
        q = solve_position_from_flap_angle(y[0], self.p)
        u = velocity_ratio(q, self.p, "psi3", check=False)
        return q, u * y[1][:, None]


class StrokeMinimal(_MinimalCoordinates):
    """(b) Minimal coordinates ``y = [s, s']`` [m, m/s]; singular at the dead centre.

    Parameters
    ----------
    dead_centre_margin : float
        A step ending with ``s < s_dead + dead_centre_margin`` [m] raises
        :class:`SingularConfigurationError` (default 0.25 mm; the closed stroke is 1.75 mm above
        the dead centre for the seed).
    """

    name = "s"
    coordinates = ("s", "s_dot")
    scales = (0.05, 10.0)  # m, m/s

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        dead_centre_margin: float = 2.5e-4,
    ) -> None:
        super().__init__(p, flap_limits)
        if not (math.isfinite(dead_centre_margin) and dead_centre_margin >= 0.0):
            raise InputError(f"dead_centre_margin must be >= 0 m, got {dead_centre_margin!r}")
        self.dead_centre_margin = float(dead_centre_margin)
        self.s_dead = dead_centre(p)

    def terms(self, s: float) -> tuple[float, float, float]:
        """``(u.M.u, u.M.w + u.h, u.Q0)`` at stroke ``s`` [m] with ``u = dq/ds``, ``w = du/ds``
        (:func:`drs_model.kernels.projected_dynamics`), so that ``s'' = (u.Q0 + F - (u.M.w + u.h)
        s'^2) / u.M.u``; NaN past the dead centre, where the loop cannot close."""
        c = self.consts
        s1, c1, s3, c3, h2 = stroke_position(s, c, 1.0)
        if h2 < -kernels.ASSEMBLY_TOL:
            return math.nan, math.nan, math.nan
        u1, u2, w1, w2 = stroke_rates(s1, c1, s3, c3, 1.0, 0.0, c)
        return projected_dynamics(s1, c1, s3, c3, math.atan2(s3, c3), 1.0, u1, u2, 0.0, w1, w2, c)

    def fun(self, force):
        terms = self.terms

        def rhs(t, y):
            s, sd = float(y[0]), float(y[1])
            umu, quad, uq0 = terms(s)  # NaN past the dead centre: the error control rejects it
            return np.array([sd, (uq0 + force(t) - quad * sd * sd) / umu])

        return rhs

    def initial_state(self, q, qd) -> np.ndarray:
        q, qd = _consistent(q, qd, self.p)
        self._check_stroke(0.0, q[0])
        return np.array([q[0], qd[0]])

    def _check_stroke(self, t: float, s: float) -> None:
        guard = self.s_dead + self.dead_centre_margin
        if not s >= guard:
            raise SingularConfigurationError(
                f"s formulation: stroke s = {s:.9g} m at t = {t:.9g} s is within "
                f"{self.dead_centre_margin:g} m of the dead centre s_dead = {self.s_dead:.9g} m "
                f"(dpsi3/ds is infinite there, and no s < s_dead assembles); use the 'psi3' "
                f"formulation"
            )

    def check(self, t, y):
        super().check(t, y)
        self._check_stroke(t, float(y[0]))

    def to_q_qd(self, y):
        y = np.asarray(y, dtype=float).reshape(2, -1)
        q = solve_position(y[0], self.p)
        u = velocity_ratio(q, self.p, "s")
        return q, u * y[1][:, None]


class FullCoordinates(Formulation):
    """(c) Full coordinates ``y = [q, qd]`` at acceleration level, optionally Baumgarte-stabilised.

    Parameters
    ----------
    alpha, beta : float
        Baumgarte gains [1/s]: the acceleration constraint becomes ``Phi'' + 2 alpha Phi' +
        beta^2 Phi = 0``. ``0, 0`` is the plain index-1 form.
    drift_bound : float
        A step ending with ``max |Phi| > drift_bound`` [m] raises :class:`ConstraintDriftError`.
    """

    n_state = 6
    coordinates = ("s", "psi1", "psi3", "s_dot", "psi1_dot", "psi3_dot")
    scales = (0.05, 1.0, 1.0, 10.0, 100.0, 100.0)  # m, rad, rad, m/s, rad/s, rad/s
    full = True

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        alpha: float = 0.0,
        beta: float = 0.0,
        drift_bound: float = 1e-5,
    ) -> None:
        super().__init__(p, flap_limits)
        for key, value in (("alpha", alpha), ("beta", beta)):
            if not (math.isfinite(value) and value >= 0.0):
                raise InputError(f"Baumgarte gain {key} must be finite and >= 0 1/s, got {value!r}")
        if not drift_bound > 0.0:
            raise InputError(f"drift_bound must be > 0 m, got {drift_bound!r}")
        self.alpha, self.beta, self.drift_bound = float(alpha), float(beta), float(drift_bound)
        self.name = "baumgarte" if (alpha or beta) else "index1"
        self.accel, self._project = make_full_kernel(self.consts)

    def fun(self, force):
        accel, alpha, beta = self.accel, self.alpha, self.beta

        def rhs(t, y):
            a = accel(y.tolist(), force(t), alpha, beta)
            return np.array([y[3], y[4], y[5], a[0], a[1], a[2]])

        return rhs

    def initial_state(self, q, qd) -> np.ndarray:
        q, qd = _consistent(q, qd, self.p)
        return np.concatenate([q, qd])

    def to_q_qd(self, y):
        y = np.asarray(y, dtype=float).reshape(6, -1)
        return y[:3].T.copy(), y[3:].T.copy()

    def position_residual(self, y) -> float:
        """``max |Phi(q)|`` [m] at one state ``y`` (6,)."""
        s, a, b = float(y[0]), float(y[1]), float(y[2])
        p1, p2 = loop_residual(s, math.sin(a), math.cos(a), math.sin(b), math.cos(b), self.consts)
        return max(abs(p1), abs(p2))

    def check(self, t, y):
        super().check(t, y)
        res = self.position_residual(y)
        if not res <= self.drift_bound:
            raise ConstraintDriftError(
                f"{self.name}: constraint residual max|Phi| = {res:.3g} m at t = {t:.9g} s "
                f"exceeds drift_bound = {self.drift_bound:g} m"
                + ("" if self.alpha or self.beta else "; use Baumgarte gains or projection")
            )


class Projected(FullCoordinates):
    """(d) Full coordinates, plain index-1 right-hand side, with the position projected on
    ``Phi = 0`` and the velocity on ``Phi_q qd = 0`` after each accepted step (in the M metric):
    :attr:`project`, which the drivers call. The outputs are those states as they are
    (:meth:`to_q_qd` maps, it does not project), so :meth:`residual` shows what the projection
    achieved; an output between steps (``t_eval``) is the solver's dense output between
    projected states.
    """

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        drift_bound: float = 1e-5,
        tol: float = 1e-15,
    ) -> None:
        super().__init__(p, flap_limits, 0.0, 0.0, drift_bound)
        self.name = "projection"
        self.tol = float(tol)
        kernel = self._project

        def project(y: np.ndarray) -> np.ndarray:
            return np.array(kernel(y.tolist(), self.tol))

        self.project = project


#: Registry of formulations: name -> constructor ``(p, **options)``.
FORMULATIONS: Mapping[str, Callable[..., Formulation]] = MappingProxyType(
    {
        "psi3": Psi3Minimal,
        "s": StrokeMinimal,
        "index1": FullCoordinates,
        "baumgarte": partial(FullCoordinates, alpha=50.0, beta=50.0),
        "projection": Projected,
    }
)


def get_formulation(formulation, p: DRSParams, **options) -> Formulation:
    """A :class:`Formulation` instance from a name in :data:`FORMULATIONS` or an instance."""
    if isinstance(formulation, Formulation):
        if options:
            raise InputError("options go with a formulation name, not an instance")
        return formulation
    try:
        ctor = FORMULATIONS[formulation]
    except (KeyError, TypeError):
        raise InputError(
            f"formulation must be one of {sorted(FORMULATIONS)}, got {formulation!r}"
        ) from None
    check_options(formulation, options)
    return ctor(p, **options)


def check_options(formulation: str, options: Mapping) -> None:
    """Raise :class:`InputError` naming any of ``options`` that the constructor of
    ``FORMULATIONS[formulation]`` does not take."""
    valid = [k for k in inspect.signature(FORMULATIONS[formulation]).parameters if k != "p"]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise InputError(
            f"unknown option(s) {unknown} for formulation {formulation!r}; valid: {valid}"
        )


def manoeuvre_initial_state(p: DRSParams, s_limits=None) -> tuple[np.ndarray, np.ndarray]:
    """``(q, qd)`` at rest at the manoeuvre's closed stroke."""
    s0 = stroke_limits(p)[0] if s_limits is None else float(s_limits[0])
    return solve_position(s0, p), np.zeros(3)
