r"""Excitation design (``drs excite``): a stroke trajectory, within the actuator's limits, that
makes the parameters asked for as well determined as a run of its length can.

The stroke is a windowed Fourier series about mid-stroke (Swevers et al. 1997):

.. math::

    s(t) = s_{min} + W(t) \left( s_c - s_{min} + \lambda \sum_{k=1}^K
           \frac{a_k \sin(2\pi k t / T) + b_k \cos(2\pi k t / T)}{k} \right)

with ``W`` a quintic smoothstep up over the first ``R`` and down over the last (the run starts
and ends at rest at the closed stop, as the node does), ``T`` the time between, ``lambda`` the
largest amplitude within the limits: the stroke range (a margin from each stop), the rate (the
rated flow over the piston area: the valve's flow limit), and the piston force (the force limit,
and the supply's over the piston area). The Fisher information is that of the equation-error
regressions the fit runs (the rigid regressor weighted for the stroke noise, :mod:`.regressor`;
the friction law's columns, :mod:`.friction`). The coefficients minimise, by default
(``criterion="worst-ratio"``), the largest ratio of a parameter's predicted standard error to
the one the seed's manoeuvre of the same length gives (each parameter on its own scale, plus a
tenth of their mean log ratio to break ties): ``log det`` (``criterion="D"``, the parameters
in their typical sizes) rewards a trade, one parameter far tighter for another looser than the
seed's manoeuvre leaves it. Nelder-Mead from several seeded starts.

The node follows a trajectory as quintic segments between points, each reached at rest in
acceleration (:func:`drs_model.profile.plan_trajectory`): the design is written as points every
``point_spacing``, and the optimiser scores the information of that path, the one the actuator
runs, sampled as the bag will be, at the largest amplitude at which it keeps the limits (the
path is linear in the amplitude). The series between the points accelerates otherwise: scored on
it, a design's information was orders of magnitude above what the followed path gave.

Parameters whose information the motion alone does not give (a leak, the bulk modulus: they
need the pressures the motion will produce) are refused, with the reason.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from ..errors import InputError, StrokeRangeError
from ..fidelity.hydraulic_params import HydraulicParams
from ..inverse import FusedInverseDynamics
from ..kinematics import stroke_limits
from ..params import FORCE_LIMIT_DEFAULT_N, DRSParams
from ..profile import QuinticPath, plan_trajectory
from ..timebase import ns_from_seconds, split_ns
from .friction import FRICTION_PARAMETERS
from .information import information, log_det, seed_manoeuvre_information, standard_errors
from .parameters import RIGID_PARAMETERS

#: Time [s] the trajectory takes to rise from the closed stop to where the design starts (its
#: margin above the stop), before the design's first point.
LEAD_IN = 0.015
#: The parameters an excitation can be designed for: their information follows from the motion.
DESIGNABLE = (*RIGID_PARAMETERS, *(n for n in FRICTION_PARAMETERS if n != "stribeck_velocity"))
#: What a design optimises (module docstring).
CRITERIA = ("worst-ratio", "D")
#: Weight of the mean log ratio beside the worst in the ``worst-ratio`` criterion.
TIE_BREAK = 0.1
#: ``k`` of the smooth worst ratio ``log sum exp(k r) / k`` the starts minimise.
SHARPNESS = 4.0


@dataclass(frozen=True)
class Limits:
    """The actuator's limits a design keeps within: ``margin`` [m] from each stop, ``rate``
    [m/s], ``force`` [N] (the piston's, either way)."""

    margin: float
    rate: float
    force: float


def default_limits(
    p: DRSParams, hp: HydraulicParams | None = None, force_limit: float = FORCE_LIMIT_DEFAULT_N
) -> Limits:
    """0.5 mm from each stop; 80 % of the valve's no-load speed (its rated flow over the piston
    area); 80 % of the smaller of the node's force limit and the supply's force (supply less
    return pressure, times the piston area)."""
    hp = HydraulicParams() if hp is None else hp
    supply_force = (hp.supply_pressure - hp.return_pressure) * hp.piston_area
    return Limits(5e-4, 0.8 * hp.no_load_speed, 0.8 * min(force_limit, supply_force))


@dataclass(frozen=True)
class Waveform:
    """One period ``duration`` [s] of the Fourier series (module docstring) from ``start`` [m]
    with ``harmonics`` harmonics; the first harmonic's coefficients are set by the others so
    that the series starts (and, periodic, ends) at rest in rate and acceleration."""

    duration: float
    start: float
    harmonics: int

    def _omegas(self) -> np.ndarray:
        return 2 * math.pi * np.arange(1, self.harmonics + 1) / self.duration

    def coefficients(self, free) -> tuple[np.ndarray, np.ndarray]:
        """``(a, b)`` from the free ones (``a_2..a_K, b_2..b_K`` and two more, ignored for the
        first harmonic): ``sum a_k = 0`` (no rate at the start), ``sum b_k w_k = 0`` (no
        acceleration)."""
        k, w = self.harmonics, self._omegas()
        a, b = np.array(free[:k], dtype=float), np.array(free[k:], dtype=float)
        a[0] = -a[1:].sum()
        b[0] = -(b[1:] * w[1:]).sum() / w[0]
        return a, b

    def series(self, t, free):
        """``(m - m(0), m', m'')`` of ``m = sum (a_k sin w_k t - b_k cos w_k t) / w_k``."""
        a, b = self.coefficients(free)
        w = self._omegas()[:, None]
        ph = w * np.asarray(t, dtype=float)[None, :]
        sin, cos = np.sin(ph), np.cos(ph)
        m = ((a[:, None] * sin - b[:, None] * cos) / w).sum(0) + (b / w[:, 0]).sum()
        dm = (a[:, None] * cos + b[:, None] * sin).sum(0)
        ddm = (w * (-a[:, None] * sin + b[:, None] * cos)).sum(0)
        return m, dm, ddm

    def evaluate(self, t, free, amplitude):
        """``(s, s', s'')`` at times ``t`` [s] for the amplitude ``lambda``."""
        m, dm, ddm = self.series(t, free)
        return self.start + amplitude * m, amplitude * dm, amplitude * ddm


def check_designable(names: Sequence[str], rung: str) -> None:
    """Refuse a parameter whose information the motion alone does not give."""
    if not names:
        raise InputError("name at least one parameter to design for")
    other = [n for n in names if n not in DESIGNABLE]
    if other:
        raise InputError(
            f"an excitation is designed for parameters whose information the motion itself "
            f"gives ({', '.join(DESIGNABLE)}); {', '.join(other)} depend on the pressures the "
            "motion will produce: fit them on a run that holds against a pressure and moves at "
            "full spool (docs/identify.md, Excitation)"
        )
    if rung != "hydraulic" and any(n in FRICTION_PARAMETERS for n in names):
        raise InputError(f"the {rung!r} rung has no friction: design for friction on 'hydraulic'")


@dataclass(frozen=True)
class Excitation:
    """A designed run: the trajectory's points (``times`` [s from the command], ``strokes``
    [m], ``rates`` [m/s]), the path the actuator follows sampled at ``t`` (``s``, ``sd``,
    ``sdd``, ``force`` [N]: its rigid piston force), its information and ``log det``, the
    standard errors it predicts for ``names`` [their units], and the limits kept."""

    names: tuple[str, ...]
    rung: str
    times: np.ndarray
    strokes: np.ndarray
    rates: np.ndarray
    t: np.ndarray
    s: np.ndarray
    sd: np.ndarray
    sdd: np.ndarray
    force: np.ndarray
    information: np.ndarray
    log_det: float
    std: np.ndarray
    limits: Limits

    def goal(self, joint: str = "drs_piston") -> dict:
        """The ``control_msgs/FollowJointTrajectory`` goal (``ros2 action send_goal``'s YAML
        as a mapping): the piston joint's points with positions and velocities."""
        points = []
        for t, s, v in zip(self.times, self.strokes, self.rates, strict=True):
            sec, nanosec = split_ns(ns_from_seconds(float(t)))
            points.append(
                {
                    "positions": [float(s)],
                    "velocities": [float(v)],
                    "time_from_start": {"sec": sec, "nanosec": nanosec},
                }
            )
        return {"trajectory": {"joint_names": [joint], "points": points}}


def path_samples(p: DRSParams, times, strokes, rates, t) -> tuple[np.ndarray, ...]:
    """``(s, s', s'')`` at ``t`` [s] of the path an actuator at rest at the closed stop follows
    for the trajectory ``(times, strokes, rates)`` commanded at ``t = 0``."""
    plan = plan_trajectory(p, times, strokes, rates)
    path = QuinticPath.of_plan(plan, 0.0, plan.head(stroke_limits(p)[0], 0.0, 0.0))
    out = np.array([path.at(float(x)) for x in t])
    return out[:, 0], out[:, 1], out[:, 2]


def largest_within_force(over, lam: float) -> float:
    """``lam`` if ``over(lam)`` (the force limit exceeded at that amplitude) is false, else the
    largest amplitude in ``[0, lam]`` within it, by 14 bisections (to ``lam / 16384``)."""
    if not over(lam):
        return lam
    lo, hi = 0.0, lam
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if over(mid) else (mid, hi)
    return lo


def _amplitude(wave: Waveform, coeffs, t, limits: Limits, force_of, s_range) -> float:
    """The largest amplitude within the stroke, rate and force limits (stroke and rate are
    linear in it; the force by bisection)."""
    m, dm, _ = wave.series(t, coeffs)
    bounds = [math.inf]
    if m.min() < 0:  # below the start: to half the margin above the closed stop (the
        # quintics between the points may undershoot a design that touches it)
        bounds.append((wave.start - s_range[0] - 0.5 * limits.margin) / -m.min())
    if m.max() > 0:
        bounds.append((s_range[1] - limits.margin - wave.start) / m.max())
    if np.abs(dm).max() > 0:
        bounds.append(limits.rate / np.abs(dm).max())
    lam = max(min(bounds), 0.0)

    def over(a):
        s, sd, sdd = wave.evaluate(t, coeffs, a)
        return float(np.max(np.abs(force_of(s, sd, sdd)))) > limits.force

    return largest_within_force(over, lam)


def design_excitation(
    names: Sequence[str],
    p: DRSParams,
    hp: HydraulicParams | None = None,
    *,
    rung: str = "rigid",
    duration: float = 0.3,
    harmonics: int = 10,
    sample_period: float = 1e-3,
    point_spacing: float = 2e-3,
    limits: Limits | None = None,
    stroke_noise: float = 1e-5,
    seed: int = 0,
    starts: int = 12,
    maxiter: int = 600,
    criterion: str = "worst-ratio",
) -> Excitation:
    """The excitation of ``names`` on ``rung`` optimal by ``criterion`` (module docstring)."""
    hp = HydraulicParams() if hp is None else hp
    names = tuple(names)
    check_designable(names, rung)
    if criterion not in CRITERIA:
        raise InputError(f"criterion must be one of {CRITERIA}, got {criterion!r}")
    if not (duration >= 0.02 and 0 < sample_period <= point_spacing < duration / 8):
        raise InputError(
            f"duration must be >= 0.02 s and 0 < sample_period <= point_spacing < "
            f"duration / 8, got {duration!r}, {sample_period!r}, "
            f"{point_spacing!r}"
        )
    limits = default_limits(p, hp) if limits is None else limits
    s_min, s_max = stroke_limits(p)
    # from and to rest a margin above the closed stop (a quintic to the stop itself could
    # undershoot it between the last points)
    wave = Waveform(duration, s_min + limits.margin, harmonics)
    t = np.arange(0.0, duration + 0.5 * sample_period, sample_period)
    fused = FusedInverseDynamics.from_params(p)

    smooth, exact = _criterion(
        criterion, names, p, hp, rung, LEAD_IN + duration, sample_period, stroke_noise
    )

    local = np.arange(0.0, duration + 0.5 * point_spacing, point_spacing)
    path_t = np.arange(0.0, LEAD_IN + duration + 0.5 * sample_period, sample_period)
    followed = _FollowedPath(p, wave, local, path_t, limits, fused.force_array)

    def amplitude(c):
        return _amplitude(wave, c, t, limits, fused.force_array, (s_min, s_max))

    def cost(c, score=smooth):
        # the information of the path the actuator follows through the points (at rest in
        # acceleration at each), at the largest amplitude that path keeps the limits at: the
        # series between the points has other accelerations, and information orders apart
        lam, path = followed.at_limits(c, amplitude(c))
        return (
            math.inf
            if path is None
            else score(information(names, *path, p, hp, rung, stroke_noise))
        )

    rng = np.random.default_rng(seed)
    options = {"maxiter": maxiter, "xatol": 1e-3, "fatol": 1e-4}
    ends = [
        minimize(cost, rng.normal(size=2 * harmonics), method="Nelder-Mead", options=options).x
        for _ in range(starts)
    ]
    best = min(ends, key=lambda c: cost(c, exact))
    # Nelder-Mead's simplex collapses in many dimensions: a fresh one about the best point, on
    # the exact criterion
    polished = minimize(cost, best, args=(exact,), method="Nelder-Mead", options=options).x
    best = polished if cost(polished, exact) < cost(best, exact) else best
    lam = followed.at_limits(best, amplitude(best))[0]
    return _realised(
        names, rung, wave, best, lam, t, point_spacing, p, hp, limits, stroke_noise, fused
    )


class _FollowedPath:
    """The path the actuator follows through a series' points: linear in the amplitude (the
    quintics are linear in their ends), ``base + lambda * unit``, from two plans."""

    def __init__(self, p, wave, local, t, limits, force_of):
        self.p, self.wave, self.local, self.t = p, wave, local, t
        self.limits, self.force_of = limits, force_of
        self.range = stroke_limits(p)
        self.base = self._samples(np.zeros(2 * wave.harmonics), 0.0)

    def _samples(self, c, lam):
        strokes, rates, _ = self.wave.evaluate(self.local, c, lam)
        rates[-1] = 0.0
        return np.array(path_samples(self.p, LEAD_IN + self.local, strokes, rates, self.t))

    def at_limits(self, c, guess):
        """``(lambda, (s, s', s''))``: the largest amplitude whose path keeps the stroke, rate
        and force limits, and the path; ``(0, None)`` where the plan refuses the points."""
        try:
            unit = (self._samples(c, guess) - self.base) / guess if guess > 0 else None
        except StrokeRangeError:
            unit = None
        if unit is None:
            return 0.0, None
        base, lim = self.base, self.limits
        low, high = self.range[0] + 0.5 * lim.margin, self.range[1] - lim.margin
        with np.errstate(divide="ignore", invalid="ignore"):
            bounds = [
                np.where(unit[0] > 0, (high - base[0]) / unit[0], np.inf),
                np.where(unit[0] < 0, (low - base[0]) / unit[0], np.inf),
                np.where(
                    unit[1] != 0, (lim.rate - np.sign(unit[1]) * base[1]) / np.abs(unit[1]), np.inf
                ),
            ]
        lam = max(0.0, 0.999 * min(float(np.min(b)) for b in bounds))

        def over(a):
            return float(np.max(np.abs(self.force_of(*(base + a * unit))))) > lim.force

        lam = largest_within_force(over, lam)
        return lam, tuple(base + lam * unit)


def _criterion(criterion, names, p, hp, rung, duration, sample_period, noise):
    """``(smooth, exact)`` costs of an information matrix: ``-log det`` for both, or for
    ``worst-ratio`` the log ratios ``r`` of the standard errors to the seed's manoeuvre's (run on
    the rung for ``duration``): ``log sum exp(k r) / k`` (k = :data:`SHARPNESS`, a worst ratio
    smooth enough for the simplex) and ``max r + TIE_BREAK mean r``."""
    if criterion == "D":
        return (lambda info: -log_det(info),) * 2
    seed_std = standard_errors(
        seed_manoeuvre_information(names, p, hp, rung, duration, sample_period, noise), names, p, hp
    )
    if not np.all(np.isfinite(seed_std) & (seed_std > 0.0)):  # nothing to weigh against: D
        return (lambda info: -log_det(info),) * 2

    def ratios(info):
        std = standard_errors(info, names, p, hp)
        if not np.all(np.isfinite(std) & (std > 0.0)):
            return None
        return np.log(std / seed_std)

    def smooth(info):
        r = ratios(info)
        return math.inf if r is None else float(np.log(np.sum(np.exp(SHARPNESS * r))) / SHARPNESS)

    def exact(info):
        r = ratios(info)
        return math.inf if r is None else float(r.max() + TIE_BREAK * r.mean())

    return smooth, exact


def _realised(names, rung, wave, coeffs, lam, t, spacing, p, hp, limits, noise, fused):
    """The design as trajectory points, shrunk until the path the actuator follows between
    them (accelerations zero at the points) keeps the limits too."""
    local = np.arange(0.0, wave.duration + 0.5 * spacing, spacing)
    times = LEAD_IN + local  # first the margin's rise from the closed stop, at rest
    t = np.arange(0.0, LEAD_IN + wave.duration + 0.5 * (t[1] - t[0]), t[1] - t[0])
    for _ in range(30):
        strokes, rates, _ = wave.evaluate(local, coeffs, lam)
        rates[-1] = 0.0
        try:
            s, sd, sdd = path_samples(p, times, strokes, rates, t)
        except StrokeRangeError:
            lam *= 0.95
            continue
        force = fused.force_array(s, sd, sdd)
        if np.max(np.abs(sd)) <= limits.rate and np.max(np.abs(force)) <= limits.force:
            break
        lam *= 0.95
    else:
        raise InputError("no amplitude keeps the followed path within the limits")
    info = information(names, s, sd, sdd, p, hp, rung, noise)
    return Excitation(
        names,
        rung,
        times,
        strokes,
        rates,
        t,
        s,
        sd,
        sdd,
        force,
        info,
        log_det(info),
        standard_errors(info, names, p, hp),
        limits,
    )


def reference_motion(p: DRSParams, duration: float = 0.2, seed: int = 1):
    """A rich motion (a multisine over the whole stroke, random coefficients, within the
    limits): what a run could show at best, for telling a parameter no motion determines from
    one this run does not."""
    hp = HydraulicParams()
    s_min, s_max = stroke_limits(p)
    wave = Waveform(duration, s_min + 5e-4, 6)
    t = np.arange(0.0, duration, 5e-4)
    coeffs = np.random.default_rng(seed).normal(size=12)
    fused = FusedInverseDynamics.from_params(p)
    lam = _amplitude(wave, coeffs, t, default_limits(p, hp), fused.force_array, (s_min, s_max))
    return wave.evaluate(t, coeffs, lam)


__all__ = [
    "CRITERIA",
    "DESIGNABLE",
    "Excitation",
    "Limits",
    "Waveform",
    "check_designable",
    "default_limits",
    "design_excitation",
    "path_samples",
    "reference_motion",
]
