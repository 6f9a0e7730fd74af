"""Parameters of the DRS mechanism: every datum of seed 003 as the documented default.

Frames and points (seed 003, "Reference frames and points"), all planar, SI units:

* ground: x to the rear (along the main wing chord), y up.
* RF0 = translate(x_A, y_A): piston base at A. The piston rod slides along +y of RF0 by the
  stroke s.
* RF1 = RF0 . translate(0, s + L1) . rotate(psi1): B = origin, the pin between piston and link.
* RF2 = RF1 . translate(0, L2): C = origin, the link's other end.
* RF3 = translate(x_D, y_D) . rotate(psi3): the flap pivots at D; C3 = RF3 (-L3, 0) is the
  flap's pin.
* RF_flap_wing = RF3 . translate(-L_wing + d_tip, 0): T = origin, the flap tip; the flap outline is
  given in this frame.
* RF_main_wing = translate(d_wing, 0) . rotate(gamma): the main-wing outline and R = (x_R, y_R).

Angles are absolute (measured from ground x, counter-clockwise positive), in radians.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any

import numpy as np

from . import kernels
from .errors import ParameterError

MAIN_WING_OUTLINE: tuple[tuple[float, float], ...] = (
    (0.29, 0.0228114),
    (0.2755, 0.0198824),
    (0.261, 0.016965),
    (0.232, 0.012093),
    (0.203, 0.0081548),
    (0.174, 0.0047473),
    (0.1595, 0.0032915),
    (0.145, 0.0020851),
    (0.1305, 0.0009947),
    (0.116, 0.0003886),
    (0.1015, 0.0001044),
    (0.087, 0.0),
    (0.0725, 0.0001131),
    (0.058, 0.0008381),
    (0.0435, 0.0023722),
    (0.029, 0.0049967),
    (0.02175, 0.0069571),
    (0.0145, 0.0095352),
    (0.00725, 0.0130123),
    (0.00435, 0.0148335),
    (0.0029, 0.0160254),
    (0.0, 0.0198795),
    (0.0029, 0.0224054),
    (0.00435, 0.0227708),
    (0.00725, 0.023113),
    (0.0145, 0.0235567),
    (0.02175, 0.0235654),
    (0.029, 0.0234117),
    (0.0435, 0.0227128),
    (0.058, 0.0219095),
    (0.0725, 0.0212106),
    (0.087, 0.0205262),
    (0.1015, 0.0197664),
    (0.116, 0.0188761),
    (0.1305, 0.0182091),
    (0.145, 0.0177045),
    (0.1595, 0.017371),
    (0.174, 0.0173913),
    (0.203, 0.017951),
    (0.232, 0.0192386),
    (0.261, 0.021083),
    (0.2755, 0.0221995),
    (0.29, 0.0235654),
)

FLAP_WING_OUTLINE: tuple[tuple[float, float], ...] = (
    (0.1200126, 0.00018864),
    (0.11954484, 0.00030264),
    (0.1181484, 0.00063936),
    (0.11584368, 0.0011832),
    (0.11266452, 0.00190956),
    (0.10865784, 0.002787),
    (0.10388352, 0.0037794),
    (0.09841368, 0.00484752),
    (0.09233172, 0.0059514),
    (0.08573112, 0.00705012),
    (0.07871448, 0.00810336),
    (0.07139184, 0.00907056),
    (0.06387876, 0.00991224),
    (0.05629524, 0.01058988),
    (0.0487632, 0.01106808),
    (0.04133724, 0.0112908),
    (0.0341994, 0.01120224),
    (0.02748, 0.01079928),
    (0.0212946, 0.01009392),
    (0.01574868, 0.00911316),
    (0.01093464, 0.00789648),
    (0.0069306, 0.00649284),
    (0.00379812, 0.00495492),
    (0.00158256, 0.00333348),
    (0.00031224, 0.00167172),
    (0.0, 0.0),
    (0.00063396, -0.00157764),
    (0.00218748, -0.00296388),
    (0.00462864, -0.00414924),
    (0.00791256, -0.00512328),
    (0.01198332, -0.00587832),
    (0.01677516, -0.00641172),
    (0.02221452, -0.006729),
    (0.02822076, -0.00684516),
    (0.034707, -0.00678456),
    (0.04158072, -0.00657996),
    (0.04875108, -0.00626868),
    (0.05616996, -0.00585264),
    (0.06365604, -0.0053424),
    (0.07109388, -0.00477084),
    (0.07836756, -0.004167),
    (0.08536236, -0.00355548),
    (0.09196752, -0.0029562),
)

PYLON_OUTLINE: tuple[tuple[float, float], ...] = (
    (0.26, 0.0),
    (0.26, 0.05),
    (0.28, 0.05),
    (0.28, 0.0),
)


def real_number(name: str, value: Any) -> float:
    """``value`` as a finite float; :class:`ParameterError` naming ``name`` otherwise (a bool, a
    non-number, NaN or inf). Shared by every frozen parameter dataclass of drs_model."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
        raise ParameterError(f"{name} must be a real number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    return value


def check_signs(obj: Any, positive: tuple[str, ...], non_negative: tuple[str, ...]) -> None:
    """:class:`ParameterError` naming the first field of ``obj`` in ``positive`` that is not
    > 0 or in ``non_negative`` that is < 0. Shared by every frozen parameter dataclass."""
    for name in positive:
        if getattr(obj, name) <= 0.0:
            raise ParameterError(f"{name} must be > 0, got {getattr(obj, name)!r}")
    for name in non_negative:
        if getattr(obj, name) < 0.0:
            raise ParameterError(f"{name} must be >= 0, got {getattr(obj, name)!r}")


def _tuple_points(value: Any, name: str) -> tuple[tuple[float, float], ...]:
    """``value`` as a tuple of ``(x, y)`` floats [m], checked. A tuple is converted once per
    process (every :meth:`DRSParams.replace` passes the same outlines on: ~0.2 ms a copy)."""
    if isinstance(value, tuple):
        try:
            return _tuple_points_once(value, name)
        except TypeError:  # an unhashable element: convert it as any sequence
            pass
    return _points(value, name)


@lru_cache(maxsize=32)
def _tuple_points_once(value: tuple, name: str) -> tuple[tuple[float, float], ...]:
    return _points(value, name)


def _points(value: Any, name: str) -> tuple[tuple[float, float], ...]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a sequence of (x, y) points, got {value!r}") from exc
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 3:
        raise ParameterError(f"{name} must have shape (n >= 3, 2), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"{name} holds a non-finite coordinate")
    return tuple((float(x), float(y)) for x, y in arr)


@dataclass(frozen=True)
class DRSParams:
    """Geometry, masses, loads and manoeuvre of the DRS actuator (seed 003 values by default).

    Lengths in m, angles in rad, masses in kg, inertias in kg m^2 (about each body's centre of
    mass), forces in N, times in s.

    ``Iz_link`` defaults to ``m_link * L2**2 / 12`` (a slender rod about its centre) and
    ``Iz_wing`` to ``m_wing * L_wing**2 / 3``, the seed's choice: the inertia of a uniform plate
    about one end (its leading edge), used here about the flap's centre of mass, where a uniform
    plate has ``m_wing * L_wing**2 / 12`` (4x less; 14.8 kN of peak piston force instead of
    25.4 kN: README, "Dynamics"). The seed's line for ``Iz_wing`` is OCR-garbled; its plotted
    piston force (axis to 1.2e5 N) is what the dimensionally wrong ``m_wing * L_wing / 3 = 0.08``
    gives. Pass ``Iz_wing=SEED_LITERAL_IZ_WING`` to reproduce that.
    """

    # FIA regulation box and the gap rule
    box_height: float = 0.220
    box_width: float = 0.350
    gap_closed: float = 0.010  # seed: min_dist
    gap_open: float = 0.050  # seed: max_dist
    # fixed points
    x_A: float = 0.280
    y_A: float = 0.000
    x_D: float = 0.335
    y_D: float = 0.154
    x_R: float = 0.280  # in the main-wing frame
    y_R: float = 0.0223
    # fixed lengths
    L1: float = 0.016
    L2: float = 0.050
    L3: float = 0.100
    L_wing: float = 0.120
    d_wing: float = 0.0060  # main wing offset along x
    d_tip: float = 0.0100  # flap tip offset allowed by the FIA regulation
    gamma: float = 5.0 * math.pi / 180.0  # main wing inclination
    # manoeuvre times
    T_opening: float = 0.010
    T_still: float = 0.030
    T_closing: float = 0.010
    # masses
    m_pist: float = 0.0800
    m_link: float = 0.0375  # seed: 0.05 m of a 1 cm steel bar at 0.75 kg/m; not derived from L2
    m_wing: float = 2.0000
    g: float = 9.81
    # inertias about the centres of mass; None selects the documented default
    Iz_pist: float = 0.0
    Iz_link: float | None = None
    Iz_wing: float | None = None
    # air loads (seed: "values from paper"), interpolated linearly in psi3 between closed and open
    F_drag_closed: float = 145.51319
    F_drag_open: float = 51.32626
    F_down_closed: float = 819.11694
    F_down_open: float = 745.62411
    # outlines (flap in RF_flap_wing, main wing in RF_main_wing, pylon in ground)
    flap_outline: tuple[tuple[float, float], ...] = field(default=FLAP_WING_OUTLINE, repr=False)
    main_wing_outline: tuple[tuple[float, float], ...] = field(
        default=MAIN_WING_OUTLINE, repr=False
    )
    pylon_outline: tuple[tuple[float, float], ...] = field(default=PYLON_OUTLINE, repr=False)

    _LENGTHS = ("L1", "L2", "L3", "L_wing", "box_height", "box_width")
    _POSITIVE = ("T_opening", "T_closing", "m_pist", "m_link", "m_wing", "g")
    _NON_NEGATIVE = ("T_still", "Iz_pist", "Iz_link", "Iz_wing", "d_tip")

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name.endswith("_outline"):
                object.__setattr__(self, f.name, _tuple_points(value, f.name))
                continue
            if value is None:
                continue
            object.__setattr__(self, f.name, real_number(f.name, value))
        for name in DERIVED_INERTIAS:
            if getattr(self, name) is None:
                object.__setattr__(self, name, derived_inertia(self, name))
        for name in self._LENGTHS:
            if getattr(self, name) <= 0.0:
                raise ParameterError(f"{name} must be > 0 m, got {getattr(self, name)!r}")
        check_signs(self, self._POSITIVE, self._NON_NEGATIVE)
        if not 0.0 < self.gap_closed < self.gap_open:
            raise ParameterError(
                f"gaps must satisfy 0 < gap_closed < gap_open, got gap_closed={self.gap_closed!r}, "
                f"gap_open={self.gap_open!r}"
            )
        if self.d_tip >= self.L_wing:
            raise ParameterError(
                f"d_tip must be < L_wing = {self.L_wing!r} m, got d_tip={self.d_tip!r}"
            )
        check_geometry(self)  # the mechanism must assemble over the whole working stroke
        # hashed once: the compiled path looks its formulation up by the parameters on every call
        values = tuple(getattr(self, f.name) for f in dataclasses.fields(self))
        object.__setattr__(self, "_hash", hash(values))

    def __hash__(self) -> int:
        return self._hash

    # ---- derived quantities -------------------------------------------------------------------
    @property
    def T_total(self) -> float:
        """Duration of the open-hold-close manoeuvre [s]."""
        return self.T_opening + self.T_still + self.T_closing

    @property
    def tip_arm(self) -> float:
        """Distance D -> T along the flap frame's -x [m] (= L_wing - d_tip)."""
        return self.L_wing - self.d_tip

    @cached_property
    def flap_com_local(self) -> tuple[float, float]:
        """G3 in RF_flap_wing [m]: the mean of the flap outline points (the seed's ``getCoM``;
        computed once: every point table reads it)."""
        arr = np.asarray(self.flap_outline)
        return float(arr[:, 0].mean()), float(arr[:, 1].mean())

    @property
    def reference_point(self) -> tuple[float, float]:
        """R in ground [m]: (x_R, y_R) of the main-wing frame."""
        x, y = kernels.rotate(math.cos(self.gamma), math.sin(self.gamma), self.x_R, self.y_R)
        return self.d_wing + x, y

    @property
    def loop_constants(self) -> tuple[float, float, float, float, float, float]:
        """``(x_A, y_A + L1, x_D, y_D, L2, L3)`` [m]: the constants of the position kernels of
        :mod:`drs_model.kernels`."""
        return (self.x_A, self.y_A + self.L1, self.x_D, self.y_D, self.L2, self.L3)

    @cached_property
    def gap_constants(self) -> tuple[float, float]:
        """``(y_D - R_y, L_wing - d_tip)`` [m]: the constants of :func:`kernels.flap_gap` (computed
        once: the actuator's state reads them every step)."""
        return self.y_D - self.reference_point[1], self.tip_arm

    @property
    def singular_strokes(self) -> tuple[float, ...]:
        """Real strokes [m] where B, C, D align (the s-parametrisation is singular), sorted."""
        dx = self.x_D - self.x_A
        out = set()
        for length in (self.L2 + self.L3, abs(self.L3 - self.L2)):
            disc = length**2 - dx**2
            if disc >= 0.0:
                root = math.sqrt(disc)
                base = self.y_D - self.y_A - self.L1
                out.update((base - root, base + root))
        return tuple(sorted(out))

    # ---- construction -------------------------------------------------------------------------
    def replace(self, **overrides: Any) -> DRSParams:
        """A copy with ``overrides`` applied (validated like the constructor)."""
        return from_dict(overrides, base=self)

    def to_dict(self, outlines: bool = False) -> dict[str, Any]:
        """Plain dict of the parameters (outlines as lists when ``outlines``)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name.endswith("_outline"):
                if outlines:
                    out[f.name] = [list(p) for p in value]
                continue
            out[f.name] = value
        return out


def check_geometry(p: DRSParams) -> None:
    """Raise :class:`ParameterError` unless the mechanism assembles over the whole working stroke.

    Both gaps must be reachable by the flap tip, both must assemble on branch 1, the working stroke
    must hold no singular configuration, and the flap must open with increasing stroke.
    """
    c = p.loop_constants
    gap0, tip = p.gap_constants
    ends = []
    for name in ("gap_closed", "gap_open"):
        sin3 = kernels.flap_sine_for_gap(getattr(p, name), gap0, tip)
        if abs(sin3) > 1.0:
            raise ParameterError(
                f"unreachable geometry: gap {getattr(p, name)!r} m is unreachable: the flap tip "
                f"spans {gap0 - tip:.6g}..{gap0 + tip:.6g} m"
            )
        s, sin1, _, cos1_sq = kernels.flap_position(sin3, math.sqrt(1.0 - sin3 * sin3), c, 1.0)
        if cos1_sq < -kernels.ASSEMBLY_TOL:
            raise ParameterError(f"unreachable geometry: the loop cannot close at the {name}")
        ends.append((s, math.asin(min(1.0, max(-1.0, sin1))), math.asin(sin3)))
    lo, hi = ends[0][0], ends[1][0]
    if not lo < hi:
        raise ParameterError(
            f"unreachable geometry: the closed stroke {lo:.6g} m must lie below the open {hi:.6g} m"
        )
    inside = [x for x in p.singular_strokes if lo < x < hi]
    if inside:
        raise ParameterError(
            f"unreachable geometry: singular stroke {inside[0]:.6g} m lies inside "
            f"[{lo:.6g}, {hi:.6g}]"
        )
    for k in range(33):
        s = lo + (hi - lo) * k / 32.0
        if kernels.stroke_position(s, c, 1.0)[4] < -kernels.ASSEMBLY_TOL:
            raise ParameterError(f"unreachable geometry: the loop cannot close at stroke {s!r} m")
    # the closed-form psi3 branch must agree with the s-branch 1 solution at both ends
    for s, psi1, psi3 in ends:
        sin1, cos1, sin3, cos3, _ = kernels.stroke_position(s, c, 1.0)
        if max(abs(math.atan2(sin1, cos1) - psi1), abs(math.atan2(sin3, cos3) - psi3)) > 1e-8:
            raise ParameterError(
                "unreachable geometry: the gap rule's flap angles are not on assembly branch 1"
            )


#: The default ``force_limit`` [N]: the largest |piston force| the actuator accepts, as a force
#: command and (``limit_moves``) as a move's inverse-dynamics peak; the URDF's piston effort
#: limit. 30 kN: the seed's own opening (``T_opening``, 10 ms) peaks at 25.4 kN, which must fit
#: with a margin (18 %); a full stroke in 2 ms needs 0.61 MN, in 9 ms 31 kN.
FORCE_LIMIT_DEFAULT_N = 3.0e4

#: The inertias that follow their body's mass and length unless set: name -> (mass, length,
#: divisor), ``I = mass length^2 / divisor`` [kg m^2] (see :class:`DRSParams`).
DERIVED_INERTIAS = {"Iz_link": ("m_link", "L2", 12.0), "Iz_wing": ("m_wing", "L_wing", 3.0)}


def derived_inertia(p: DRSParams, name: str) -> float:
    """The default of the inertia ``name`` (a key of :data:`DERIVED_INERTIAS`) for the masses and
    lengths of ``p`` [kg m^2]."""
    mass, length, divisor = DERIVED_INERTIAS[name]
    return getattr(p, mass) * getattr(p, length) ** 2 / divisor


#: The seed's literal (dimensionally inconsistent) ``m_wing * L_wing / 3`` [kg m] for Iz_wing.
SEED_LITERAL_IZ_WING = 2.0 * 0.120 / 3.0

_FIELD_NAMES = frozenset(f.name for f in dataclasses.fields(DRSParams))
#: The numeric fields of DRSParams (all but the outlines), in declaration order.
NUMERIC_FIELDS = tuple(
    f.name for f in dataclasses.fields(DRSParams) if not f.name.endswith("_outline")
)


def from_dict(overrides: Mapping[str, Any], base: DRSParams | None = None) -> DRSParams:
    """Build validated parameters from ``base`` (default: the seed) with ``overrides`` applied.

    Raises :class:`ParameterError` for an unknown name or a bad value, and for a geometry that
    cannot assemble at the closed and open gaps.
    """
    if not isinstance(overrides, Mapping):
        raise ParameterError(
            f"parameter overrides must be a mapping, got {type(overrides).__name__}"
        )
    unknown = sorted(set(overrides) - _FIELD_NAMES)
    if unknown:
        raise ParameterError(f"unknown parameter(s) {unknown}; valid names: {sorted(_FIELD_NAMES)}")
    base = base if base is not None else DRSParams()
    overrides = dict(overrides)
    # a derived inertia follows its mass and length unless it was set explicitly
    for name in DERIVED_INERTIAS:
        if name not in overrides and getattr(base, name) == derived_inertia(base, name):
            overrides[name] = None
    try:
        return dataclasses.replace(base, **overrides)  # validated by __post_init__
    except TypeError as exc:  # pragma: no cover - dataclasses only raises for unknown names
        raise ParameterError(str(exc)) from exc
