"""The fit of a run: equation error, then output error, then the intervals (the driver behind
``drs-bag fit``).

1. The names are checked against the rung: a parameter the rung's equations do not hold (a
   leak on the ``rigid`` rung) is refused with the reason.
2. Equation error (:mod:`.equation_error`): the rung's regressions; a fast answer, and the start
   of the next stage.
3. Output error (:mod:`.output_error`), when a re-simulation of the run is given: the
   identifiability of every parameter from the sensitivities at the start (one re-simulation
   per parameter), the fit of those determined, each Jacobian interval checked along its
   linearised profile and replaced by the profile-likelihood interval where the two disagree.
4. Where both stages determined a parameter and their values lie farther apart than their
   intervals allow, the fit is inconsistent (:func:`disagreements`): it names them.

The result holds each parameter's final estimate (the output error's where it ran and
determined it, else the equation error's), every stage, and the signals as measured and as fitted.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from ..errors import InputError, ParameterError
from ..fidelity.hydraulic_params import HydraulicParams
from ..params import DRSParams
from . import intervals as iv
from .equation_error import EQUATION_PARAMETERS, equation_error
from .identifiability import assess, too_wide, wide_reason
from .output_error import (
    RESOLUTION,
    START_MARGIN,
    OutputErrorProblem,
    fit_output_error,
    profile_chi2,
)
from .parameters import RIGID_PARAMETERS, current_value, fit_parameter
from .record import SIGNALS, Record
from .results import Estimate, FitResult, FittedSignal, StageFit

#: The rungs a fit runs on (the kinematic rung models no force: nothing to identify).
FIT_RUNGS = ("quasi-static", "rigid", "hydraulic")
#: What the fit may do: both stages, or one.
STAGES = ("both", "equation", "output")
#: The signals an output-error fit compares, by rung (those the run recorded).
OUTPUT_SIGNALS = {
    "quasi-static": ("stroke", "piston_force"),
    "rigid": ("stroke", "piston_force"),
    "hydraulic": ("stroke", "piston_force", "pressure_a", "pressure_b"),
}


def check_names(names: Sequence[str], rung: str, p: DRSParams, hp: HydraulicParams) -> None:
    """Refuse an unknown rung, an empty or repeated list, an unknown name, and a parameter the
    rung's equations do not hold."""
    if rung not in FIT_RUNGS:
        why = " (it models no forces: nothing to identify)" if rung == "kinematic" else ""
        raise InputError(f"a fit runs on one of {FIT_RUNGS}, not {rung!r}{why}")
    if not names:
        raise InputError("name at least one parameter to fit")
    repeated = sorted({n for n in names if list(names).count(n) > 1})
    if repeated:
        raise InputError(f"parameters named twice: {repeated}")
    for name in names:
        fit_parameter(name, p, hp)  # ParameterError for an unknown name
    if rung != "hydraulic":
        foreign = [n for n in names if n not in RIGID_PARAMETERS]
        if foreign:
            raise ParameterError(
                f"the {rung!r} rung has no hydraulics: nothing it simulates depends on "
                f"{', '.join(foreign)}; fit them on the 'hydraulic' rung"
            )


def _withheld(name: str, p, hp, why: str) -> Estimate:
    fp = fit_parameter(name, p, hp)
    return Estimate.withheld(name, fp.unit, current_value(name, p, hp), "equation", why)


def _sensitivity(problem: OutputErrorProblem, noise: dict) -> np.ndarray:
    """Whitened residual sensitivities at the start (forward differences): the matrix the
    identifiability is judged on before the output error fits."""

    def whitened(theta):
        sim = problem.simulate(dict(zip(problem.names, map(float, theta), strict=True)))
        out = []
        for k, measured in problem.measured.items():
            m = np.isfinite(measured)
            out.append(np.asarray(sim[k])[m] / noise.get(k, 1.0))
        return np.concatenate(out)

    base = whitened(problem.start)
    J = np.empty((base.size, len(problem.names)))
    for j, h in enumerate(1e-3 * problem.scale):
        theta = problem.start.copy()
        theta[j] = theta[j] + h if theta[j] + h <= problem.upper[j] else theta[j] - h
        J[:, j] = (whitened(theta) - base) / (theta[j] - problem.start[j])
    return J


def _not_determined(name: str, p, hp, ident) -> Estimate:
    """The output stage's estimate of a parameter its identifiability left out, and why."""
    fp = fit_parameter(name, p, hp)
    reason = f"{ident.undetermined.get(name, 'not determined')}; to determine it: {fp.motion}"
    return Estimate.withheld(name, fp.unit, current_value(name, p, hp), "output", reason)


def _output_estimates(problem, fit, names, p, hp, level, ident) -> list[Estimate]:
    q = iv.quantile(level, fit.dof)
    out = []
    kept = list(problem.names)
    for name in names:
        fp = fit_parameter(name, p, hp)
        start = current_value(name, p, hp)
        if name not in kept:
            out.append(_not_determined(name, p, hp, ident))
            continue
        i = kept.index(name)
        value, std = float(fit.estimate[i]), math.sqrt(fit.covariance[i, i])
        (lo, hi), kind = iv.bounded_interval(value, std, q, fp.lower)
        ratios = iv.linearity_ratios(
            fit.chi2_of, fit.estimate, fit.covariance, i, q, fit.s2, fit.chi2
        )
        if not iv.agrees(ratios):
            profile = profile_chi2(problem, fit, i)
            lo, hi = iv.profile_interval(
                profile, value, q * std, q * q * fit.s2, (fp.lower, fp.upper), fit.chi2
            )
            kind = "profile"
            if fit.floor_std is not None:  # a profile steeper than the optimiser's own stop
                reach = q * float(fit.floor_std[i])
                lo, hi = min(lo, max(value - reach, fp.lower)), max(hi, value + reach)
        if not (math.isfinite(lo) and math.isfinite(hi)) or too_wide(
            value, 0.5 * (hi - lo), fp.scale
        ):
            reason = wide_reason(name, (lo, hi), fp.unit, level, ident, fp.motion)
            out.append(Estimate.withheld(name, fp.unit, start, "output", reason, std, value))
            continue
        out.append(Estimate(name, fp.unit, value, lo, hi, std, start, "output", kind, "", value))
    return out


def output_stage(
    record: Record,
    names: Sequence[str],
    rung: str,
    p: DRSParams,
    hp: HydraulicParams,
    simulate: Callable,
    starts: dict,
    level: float,
    noise: dict | None = None,
    signals: Sequence[str] | None = None,
    max_nfev: int | None = None,
) -> StageFit:
    """The output-error fit of ``names`` from ``starts`` (module docstring, step 3).
    ``simulate({name: value}) -> {signal: array}`` re-simulates the run at the record's
    samples."""
    started = time.perf_counter()
    wanted = signals or OUTPUT_SIGNALS[rung]
    measured = {k: getattr(record, k) for k in wanted if record.has(k)}
    if not measured:
        raise InputError(f"the run recorded none of the signals {list(wanted)}")
    fps = [fit_parameter(n, p, hp) for n in names]
    lower, upper = np.array([f.lower for f in fps]), np.array([f.upper for f in fps])
    scale = np.array([max(abs(starts[n]), f.scale) for n, f in zip(names, fps, strict=True)])
    # a start outside the bounds (an equation-error guess of a negative leak) comes inside them
    start = np.clip(
        [starts[n] for n in names], lower + START_MARGIN * scale, upper - START_MARGIN * scale
    )
    problem = OutputErrorProblem(
        tuple(names), start, lower, upper, scale, simulate, measured, noise
    )

    floor = {k: (noise or {}).get(k, RESOLUTION.get(k, 1.0)) for k in measured}
    ident = assess(_sensitivity(problem, floor), names, problem.scale)
    keep = [i for i, n in enumerate(names) if n in ident.determined]
    held = {n: starts[n] for n in names if n not in ident.determined}
    if not keep:  # nothing the recorded signals depend on: each withheld, saying why
        return _nothing_determined(names, p, hp, ident, measured, started)

    def simulate_kept(values: dict) -> dict:
        return simulate({**held, **values})

    sub = OutputErrorProblem(
        tuple(names[i] for i in keep),
        problem.start[keep],
        problem.lower[keep],
        problem.upper[keep],
        problem.scale[keep],
        simulate_kept,
        measured,
        noise,
    )
    fit = fit_output_error(sub, max_nfev)
    est = _output_estimates(sub, fit, names, p, hp, level, ident)
    fitted = tuple(
        FittedSignal(k, SIGNALS[k], record.t, measured[k], np.asarray(fit.simulated[k]))
        for k in measured
    )
    given = noise or {}
    used = ", ".join(
        f"{k} {v:.3g} {SIGNALS[k]} ({_noise_source(k, given, fit.exact)})"
        for k, v in fit.noise.items()
    )
    notes = (
        f"{fit.nfev} re-simulations; noise: {used} (from the record: the residual's "
        "scatter, or the recorded values' resolution where less; noise-free: the "
        f"re-simulation gives the record's own bits, so its resolution); {fit.message}",
    )
    return StageFit(
        "output",
        "output error",
        tuple(est),
        ident,
        fitted,
        fit.s2,
        fit.dof,
        time.perf_counter() - started,
        notes,
    )


def _noise_source(signal: str, given: dict, exact: tuple[str, ...]) -> str:
    if signal in given:
        return "given"
    return "noise-free" if signal in exact else "from the record"


def _nothing_determined(names, p, hp, ident, measured, started) -> StageFit:
    """The output stage of a run whose recorded signals depend on none of ``names`` (the
    rigid rung follows stroke commands exactly: its stroke holds no mass): no fit, each
    parameter withheld with the identifiability's reason."""
    est = [_not_determined(name, p, hp, ident) for name in names]
    note = f"no fit: the signals {sorted(measured)} depend on none of {list(names)}"
    return StageFit(
        "output",
        "output error",
        tuple(est),
        ident,
        (),
        math.nan,
        0,
        time.perf_counter() - started,
        (note,),
    )


def fit(
    record: Record,
    names: Sequence[str],
    rung: str,
    p: DRSParams,
    hp: HydraulicParams | None = None,
    *,
    simulate: Callable | None = None,
    stage: str = "both",
    level: float = 0.95,
    noise: dict | None = None,
    signals: Sequence[str] | None = None,
    max_nfev: int | None = None,
) -> FitResult:
    """Fit the parameters ``names`` of ``rung`` to ``record`` (module docstring).

    Parameters
    ----------
    record : Record
    names : sequence of str
        Parameters to fit (:func:`.parameters.fit_parameter`); the others keep their values in
        ``p`` and ``hp``, which are also the starts.
    rung : str
        One of :data:`FIT_RUNGS`.
    p, hp : DRSParams, HydraulicParams
        The run's parameters (``hp`` default: HydraulicParams' defaults).
    simulate : callable, optional
        ``simulate({name: value}) -> {signal: array}``: the run re-simulated at the record's
        samples; without it there is no output error.
    stage : str
        ``"both"``, ``"equation"`` or ``"output"``.
    level : float
        Of the intervals (0.95).
    noise : dict, optional
        ``signal -> sigma`` of the output error (default: estimated).
    signals : sequence of str, optional
        The signals the output error compares (default :data:`OUTPUT_SIGNALS` of the rung).
    """
    hp = HydraulicParams() if hp is None else hp
    names = list(names)
    _check_request(names, rung, p, hp, stage, level)
    stages: list[StageFit] = []
    final: dict[str, Estimate] = {}
    if stage in ("both", "equation"):
        stages = equation_error(
            record, [n for n in names if n in EQUATION_PARAMETERS], rung, p, hp, level
        )
        final = {e.name: e for s in stages for e in s.estimates}
    notes = []
    if stage in ("both", "output") and simulate is not None:
        starts = _output_starts(final, names, p, hp)
        out = output_stage(
            record, names, rung, p, hp, simulate, starts, level, noise, signals, max_nfev
        )
        stages.append(out)
        # the output error's where it determined them; an equation error's value stands
        # where the re-simulated signals do not depend on the parameter (its stage says why)
        final.update(
            {e.name: e for e in out.estimates if e.determined or not _determined(final, e.name)}
        )
    elif stage != "equation":  # asked for, and there is nothing to re-simulate the run with
        notes.append(NO_OUTPUT_ERROR)
    _withhold_the_rest(final, names, p, hp, stage)
    split = disagreements(stages)
    notes += [f"INCONSISTENT: {d}" for d in split.values()]
    return FitResult(
        rung, level, tuple(final[n] for n in names), tuple(stages), tuple(notes), tuple(split)
    )


def _determined(final: dict, name: str) -> bool:
    return name in final and final[name].determined


#: The note of a fit asked for its output error on a run that cannot be re-simulated.
NO_OUTPUT_ERROR = (
    "no output error: the run cannot be re-simulated (it holds no record of its commands)"
)


def _check_request(names, rung: str, p, hp, stage: str, level: float) -> None:
    """Refuse an unknown parameter or stage, or a level outside [0.5, 1)."""
    check_names(names, rung, p, hp)
    if stage not in STAGES:
        raise InputError(f"stage must be one of {STAGES}, got {stage!r}")
    if not 0.5 <= level < 1.0:
        raise InputError(f"level must be in [0.5, 1), got {level!r}")


def _output_starts(final: dict, names, p, hp) -> dict[str, float]:
    """The output error's starts: the equation error's numbers, withheld or not, where it
    gave a finite one (the best starts there are), else the parameters' current values."""
    return {
        n: (
            final[n].guess
            if n in final and math.isfinite(final[n].guess)
            else current_value(n, p, hp)
        )
        for n in names
    }


def _withhold_the_rest(final: dict, names, p, hp, stage: str) -> None:
    """Each parameter no stage determined, withheld in ``final`` with the reason."""
    why = "--stage equation" if stage == "equation" else "the run cannot be re-simulated"
    for n in names:
        if n not in final:
            final[n] = _withheld(
                n, p, hp, f"only the output error determines it, and it did not run ({why})"
            )


def disagreements(stages: Sequence[StageFit]) -> dict[str, str]:
    """``{name: why}`` for each parameter both the equation and the output error determined
    whose two values lie farther apart than the two intervals allow: the distance is more than
    ``sqrt(a^2 + b^2)``, ``a`` and ``b`` each interval's half on the side facing the other (at
    the fit's level: each value within the other's reach, errors independent)."""
    by_stage: dict[str, dict[str, Estimate]] = {"equation": {}, "output": {}}
    for s in stages:
        for e in s.estimates:
            if e.determined and s.stage in by_stage:
                by_stage[s.stage][e.name] = e
    out = {}
    for name, eq in by_stage["equation"].items():
        oe = by_stage["output"].get(name)
        if oe is None:
            continue
        up = oe.value > eq.value
        a = (eq.upper - eq.value) if up else (eq.value - eq.lower)
        b = (oe.value - oe.lower) if up else (oe.upper - oe.value)
        allowed = math.hypot(a, b)
        gap = abs(oe.value - eq.value)
        if gap > allowed:
            out[name] = (
                f"{name}: equation error {eq.value:.6g} [{eq.lower:.6g}, "
                f"{eq.upper:.6g}], output error {oe.value:.6g} [{oe.lower:.6g}, "
                f"{oe.upper:.6g}] {eq.unit}: {gap / allowed:.3g}x as far apart as "
                "their intervals allow; the model misses something in this run "
                "(a contact, a saturation, a signal's error): bet on neither"
            )
    return out


__all__ = [
    "FIT_RUNGS",
    "OUTPUT_SIGNALS",
    "STAGES",
    "check_names",
    "disagreements",
    "fit",
    "output_stage",
]
