"""The fused closed form of the inverse dynamics, one sample at a time and on arrays:
:func:`drs_model.kernels.fused_force` with the constants of a parameter set and its manoeuvre."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import elementwise, kernels
from ..bodies import model_constants
from ..compiled.scalar import bind
from ..errors import AssemblyError, InputError, SingularConfigurationError
from ..kernels import SINGULAR_TOL
from ..params import DRSParams
from ..profile import Manoeuvre, drs_manoeuvre


@dataclass(frozen=True)
class FusedInverseDynamics:
    """Piston force from :func:`drs_model.kernels.fused_force`: closed-form kinematics fused with
    d'Alembert's principle along ``u = dq/ds`` (the seed's ``PVW_dynamic``).

    Build once with :meth:`from_params`. One sample (:meth:`force`, :meth:`force_at`) runs the
    kernel compiled by numba (~1 us; the plain Python kernel without numba); arrays
    (:meth:`force_array`, :meth:`force_at_times`) run it on every element
    (:mod:`drs_model.elementwise`). Same equations as :class:`VirtualWork` (tested against all
    formulations).

    Attributes
    ----------
    consts : tuple of float
        :func:`drs_model.bodies.model_constants` of the parameters and air law.
    manoeuvre : Manoeuvre
    profile : tuple of float
        :meth:`Manoeuvre.constants <drs_model.profile.Manoeuvre.constants>` of ``manoeuvre``.
    """

    consts: tuple[float, ...]
    manoeuvre: Manoeuvre
    profile: tuple[float, ...]

    @classmethod
    def from_params(
        cls,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        s_limits: tuple[float, float] | None = None,
    ) -> FusedInverseDynamics:
        """Precompute the constants of ``p`` (and the manoeuvre for :meth:`force_at`)."""
        man = drs_manoeuvre(p, *(s_limits if s_limits is not None else (None, None)))
        return cls(model_constants(p, flap_limits), man, man.constants())

    @cached_property
    def _force(self):
        return bind(kernels.fused_force, self.consts)

    @cached_property
    def _force_at(self):
        return bind(kernels.fused_manoeuvre_force, self.consts, self.profile)

    def force(self, s: float, sd: float, sdd: float) -> float:
        """Piston force [N] for stroke ``s`` [m], rate ``sd`` [m/s], acceleration ``sdd`` [m/s^2].

        Raises
        ------
        InputError
            A non-finite input.
        AssemblyError
            The loop cannot close at ``s``.
        SingularConfigurationError
            ``s`` at the dead centre.
        """
        if not (math.isfinite(s) and math.isfinite(sd) and math.isfinite(sdd)):
            raise InputError(f"s, sd, sdd must be finite, got {(s, sd, sdd)!r}")
        force = self._force(s, sd, sdd)
        if math.isnan(force):
            self.diagnose(np.array([s]))
        return force

    def force_at(self, t: float) -> float:
        """Piston force [N] at time ``t`` [s] of the open-hold-close manoeuvre."""
        if not math.isfinite(t):
            raise InputError(f"time must be finite, got {t!r}")
        return self._force_at(t)

    def force_array(self, s, sd, sdd) -> np.ndarray:
        """The same kernel on numpy arrays.

        ``s`` [m], ``sd`` [m/s], ``sdd`` [m/s^2] broadcast to a common shape; returns [N].
        """
        s, sd, sdd = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (s, sd, sdd)))
        for name, x in (("s", s), ("sd", sd), ("sdd", sdd)):
            if not np.all(np.isfinite(x)):
                bad = float(x[~np.isfinite(x)].ravel()[0])
                raise InputError(f"{name} must be finite, got {bad!r}")
        out = np.asarray(elementwise.fused_force(s, sd, sdd, self.consts), dtype=float)
        if np.any(np.isnan(out)):
            self.diagnose(s.ravel())
        return out

    def force_at_times(self, t) -> np.ndarray:
        """Piston force [N] along the manoeuvre at times ``t`` [s] (any shape)."""
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise InputError(f"time must be finite, got {float(t[~np.isfinite(t)].ravel()[0])!r}")
        return np.asarray(
            elementwise.fused_manoeuvre_force_series(t, self.consts, self.profile), dtype=float
        )

    def diagnose(self, s: np.ndarray) -> None:
        """Raise the typed error of the first stroke [m] of ``s`` where the kernel gave NaN."""
        *angles, h2 = elementwise.stroke_position(s, self.consts, 1.0)
        if np.any(h2 < -kernels.ASSEMBLY_TOL):
            raise AssemblyError(
                f"the loop cannot close at stroke {float(s[h2 < -kernels.ASSEMBLY_TOL][0])!r} m: "
                "it lies beyond a singular stroke (see `drs limits`)"
            )
        sin1, cos1, sin3, cos3 = angles
        dead = np.abs(cos1 * cos3 + sin1 * sin3) < SINGULAR_TOL
        raise SingularConfigurationError(
            f"stroke {float(s[dead][0]) if np.any(dead) else float(s[0])!r} m is a singular "
            "stroke (dead centre): no finite piston force moves the flap there"
        )
