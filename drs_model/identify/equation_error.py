"""Stage 1, equation error: each equation the rung's model satisfies at every sample, written as
a linear regression on the measured signals, solved by weighted least squares.

* ``rigid``, ``quasi-static`` and ``hydraulic``: the piston force is the rigid inverse dynamics
  of the measured motion (:mod:`.regressor`; at rest on ``quasi-static``, which has no inertia;
  off the end stops on ``hydraulic``). The stroke sensor's noise enters through the stroke the
  regressor is evaluated at, so each sample is weighted by ``1 / (dF/ds)^2`` (with a floor), the
  variance that noise gives it;
* ``hydraulic``: the chambers' continuity (:mod:`.continuity`) and the rod's force balance
  (:mod:`.friction`).

Each regression first asks what it can determine (:func:`.identifiability.assess`), holds the
rest at their starting values, and fits the rest. A parameter whose interval is wider than its
size is reported as not determined.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence

import numpy as np

from .. import elementwise
from ..bodies import model_constants
from ..errors import ConvergenceError, InputError
from ..fidelity.hydraulic import hydraulic_constants
from ..fidelity.hydraulic_params import HydraulicParams
from ..kinematics import stroke_limits
from ..params import DRSParams
from . import continuity, friction
from .identifiability import Identifiability, assess, too_wide, wide_reason
from .intervals import bounded_interval, profile_interval, quantile, wald_interval
from .least_squares import checked_covariance, errors_in_variables, weighted_least_squares
from .parameters import RIGID_PARAMETERS, current_value, fit_parameter
from .record import STOP_BAND, Record
from .regressor import rigid_regressor, rigid_values, rigid_weights
from .results import Estimate, FittedSignal, StageFit


def _estimates(
    names, values, cov, dof, level, p, hp, ident: Identifiability, stage: str, kinds=None
) -> list[Estimate]:
    """One :class:`Estimate` per name; NaN value (with the reason) where undetermined or the
    interval is wider than the value's size."""
    q = quantile(level, dof)
    if len(values):
        checked_covariance(np.asarray(cov), f"{stage}-error")
    out = []
    for name in names:
        fp = fit_parameter(name, p, hp)
        start = current_value(name, p, hp)
        if name in ident.undetermined:
            reason = ident.undetermined[name]
            if STRUCTURAL not in reason:
                reason += f"; to determine it: {fp.motion}"
            out.append(Estimate.withheld(name, fp.unit, start, stage, reason))
            continue
        i = list(values).index(name)
        value, std = float(values[name]), math.sqrt(cov[i, i])
        (lo, hi), kind = bounded_interval(value, std, q, fp.lower)
        if kinds and name in kinds:
            (lo, hi), kind = kinds[name]
        if too_wide(value, 0.5 * (hi - lo), fp.scale) or not math.isfinite(hi - lo):
            reason = wide_reason(name, (lo, hi), fp.unit, level, ident, fp.motion)
            out.append(Estimate.withheld(name, fp.unit, start, stage, reason, std, value))
            continue
        out.append(Estimate(name, fp.unit, value, lo, hi, std, start, stage, kind, "", value))
    return out


def _solve(X, y, w, names, scales, starts, covariance):
    """Identifiability, then the fit of what is determined (the rest held at ``starts``):
    ``(ident, values by name, covariance, fit)``."""
    ident = assess(X * np.sqrt(w)[:, None], names, scales)
    keep = [i for i, n in enumerate(names) if n in ident.determined]
    held = [i for i in range(len(names)) if i not in keep]
    y_kept = y - X[:, held] @ np.asarray(starts)[held] if held else y
    fit = weighted_least_squares(X[:, keep], y_kept, w, covariance)
    values = {names[i]: float(v) for i, v in zip(keep, fit.estimate, strict=True)}
    return ident, values, fit, X[:, keep] @ fit.estimate + (y - y_kept)


def rigid_stage(
    record: Record, names: Sequence[str], rung: str, p: DRSParams, level: float
) -> StageFit:
    """The rigid force regression of the parameters ``names`` (of :data:`RIGID_PARAMETERS`)."""
    started = time.perf_counter()
    if record.piston_force is None:
        raise InputError(
            "the rigid parameters are fitted on the piston force, which the run did not record"
        )
    s = record.stroke
    # derived rates by the quintic: the cubic's truncation biased the wing's mass under force
    # commands by 1.4 of its scatter over seeded noise; the quintic's error is a seventieth of
    # the cubic's there (the weights still pay for the cubic's, the covariance for its own)
    sd, sdd = record.rates(5)
    if rung == "quasi-static":  # the statics alone: no inertia in what was recorded
        sd, sdd = np.zeros_like(sd), np.zeros_like(sdd)
    ok, left_out = described_samples(record, sd, sdd, p, rung)
    held = [n for n in RIGID_PARAMETERS if n not in names]
    Y = rigid_regressor(s[ok], sd[ok], sdd[ok], p)
    theta = rigid_values(p)
    cols = [RIGID_PARAMETERS.index(n) for n in names]
    held_cols = [RIGID_PARAMETERS.index(n) for n in held]
    y = record.piston_force[ok] - Y[:, held_cols] @ theta[held_cols]
    w, derivative_force = _derivative_weights(record, ok, s, sd, sdd, p)
    scales = [fit_parameter(n, p).scale for n in names]
    ident, values, fit, fitted = _solve(
        Y[:, cols], y, w, list(names), scales, theta[cols], "classic"
    )
    kept = [n for n in names if n in values]
    try:
        fit, fitted, X = _noise_corrected(
            record.piston_force[ok], s[ok], sd[ok], sdd[ok], p, kept, fit.sigma2, w
        )
    except ConvergenceError as exc:  # the residual is no stroke noise: nothing to bet on
        ident = dataclasses.replace(
            ident, determined=(), undetermined={n: f"{MISFIT} ({exc})" for n in names}
        )
        kept, values = [], {}
    else:
        fit = _with_derivative_error(fit, X, derivative_force, w)
        values = dict(zip(kept, map(float, fit.estimate), strict=True))
    ident = _structure(ident, names, p, scales, rung)
    est = _estimates(
        names, values, fit.covariance, fit.dof, level, p, HydraulicParams(), ident, "equation"
    )
    force = FittedSignal("piston_force", "N", record.t[ok], record.piston_force[ok], fitted)
    return StageFit(
        "equation",
        "rigid force",
        tuple(est),
        ident,
        (force,),
        fit.sigma2,
        fit.dof,
        time.perf_counter() - started,
        (_left_out_note(left_out, len(record)), *derivation_notes(record)),
    )


def _derivative_weights(record: Record, ok, s, sd, sdd, p: DRSParams) -> np.ndarray:
    """The rigid weights (:func:`~.regressor.rigid_weights`: relative to the stroke noise's
    variance) with a derived acceleration's error in them: at each sample the variance
    ``(dF/ds)^2 sigma_s^2 + (dF/ds'' e)^2`` (``e`` :meth:`Record.derivative_error`,
    ``sigma_s`` :meth:`Record.stroke_noise`), over ``sigma_s^2``; and the force error of the
    quintic's acceleration, ``dF/ds'' e5`` (``e5`` :meth:`Record.acceleration_error`).

    The weights keep the cubic's larger error: they only rank the samples, and where the
    quintic is unsure its correction of the cubic is large."""
    w = rigid_weights(s[ok], sd[ok], sdd[ok], p)
    if record.stroke_acceleration is not None:
        return w, np.zeros_like(w)
    consts = tuple(model_constants(p))
    ones = np.ones(int(ok.sum()))
    gain = np.asarray(elementwise.fused_force(s[ok], sd[ok], ones, consts)) - np.asarray(
        elementwise.fused_force(s[ok], sd[ok], 0.0 * ones, consts)
    )
    sigma_s = record.stroke_noise()
    force = gain * record.derivative_error()[ok]
    return 1.0 / (1.0 / w + (force / sigma_s) ** 2), gain * record.acceleration_error()[ok]


def _with_derivative_error(fit, X, derivative_force, w):
    """``fit`` with a derived acceleration's error counted as what it is, one error through
    the whole run (a smooth truncation error, not independent scatter): its effect on the
    estimates, ``b = (X^T W X)^{-1} X^T W dF``, taken as a standard error along ``b``
    (``cov + b b^T``), ``X`` the regressor's fitted columns, ``W`` the weights. ``dF`` is the
    quintic's own error as :meth:`Record.acceleration_error` estimates it. Its correction of
    the cubic, counted here before, made the stated error under force commands 1.69x the
    estimates' scatter over seeded noise (1.15x with the septic's estimate)."""
    if not np.any(derivative_force):
        return fit
    XtW = X.T * w
    b = np.linalg.lstsq(XtW @ X, XtW @ derivative_force, rcond=None)[0]
    return dataclasses.replace(fit, covariance=fit.covariance + np.outer(b, b))


def described_samples(record: Record, sd, sdd, p: DRSParams, rung: str):
    """Which samples the rigid regressor describes, and how many of the others were left out
    for which reason: ``(mask, {reason: count})``.

    * a lost sample (NaN in a signal the regression reads);
    * contact with an end stop (within :data:`STOP_BAND`): the stop's force is in no recorded
      signal, so a force command that pushes the rod onto a stop holds any force there. Left
      out on the ``hydraulic`` rung (compliant stops), and on the others where the record says
      a stop may have held the rod (:attr:`Record.stops_hold`: force commands, or commands
      unknown);
    * where the rates were differentiated from the stroke (:meth:`Record.rates`): the samples
      whose derivative window reaches past the record's ends, a lost sample or a stop contact
      (the impact's kink is no cubic)."""
    s, force = record.stroke, record.piston_force
    finite = np.isfinite(s) & np.isfinite(sd) & np.isfinite(sdd) & np.isfinite(force)
    counts = {"lost": int(np.sum(~finite))}
    ok = finite.copy()
    if rung == "hydraulic" or record.stops_hold:
        lo, hi = stroke_limits(p)
        contact = finite & ((s <= lo + STOP_BAND) | (s >= hi - STOP_BAND))
        counts["end-stop contact"] = int(np.sum(contact))
        ok &= ~contact
    if rung != "quasi-static":
        window, kink = record.derivative_exclusions(ok)
        if record.derivative_reach():
            counts["derivative window"] = int(np.sum(window))
        counts["acceleration kink"] = int(np.sum(kink))
        ok &= ~(window | kink)
    if ok.sum() <= 1:
        raise InputError(
            f"no sample of the run is one the rigid force regression describes "
            f"({_left_out_note(counts, len(record))})"
        )
    return ok, counts


def _left_out_note(counts: dict, total: int) -> str:
    parts = [f"{n} {why}" for why, n in counts.items() if n]
    return (
        f"samples left out of the regression: {', '.join(parts)} (of {total})"
        if parts
        else f"every one of the {total} samples regressed"
    )


def derivation_notes(record: Record) -> tuple[str, ...]:
    """What the regression read that the run did not record (:meth:`Record.derived`)."""
    return tuple(f"{name} not recorded: {how}" for name, how in record.derived(5).items())


#: Step [m] of the regressor's stroke derivative in the noise correction.
_DERIVATIVE_STEP = 1e-8
#: Why the rigid regression gives no value where its residual is more than the stroke noise
#: the record shows can explain (the errors-in-variables correction exceeds the information).
MISFIT = (
    "the rigid force regression's residual is more than the stroke's noise explains: some "
    "samples are ones its model does not describe (a stop holding the rod, a saturation) "
    "and the record does not say which"
)
#: How a reason says that no motion determines a parameter.
STRUCTURAL = "no motion of the mechanism separates it"


def _noise_corrected(force, s, sd, sdd, p, kept, sigma2, w):
    """The rigid fit of ``kept`` again, corrected for the stroke noise the regressor is
    evaluated at (:func:`~.least_squares.errors_in_variables`; ``sigma2`` the first fit's: its
    weights make the whitened residual the stroke error itself), the other rigid parameters at
    their values in ``p``. Returns ``(fit, fitted force)``."""
    h = _DERIVATIVE_STEP
    Y = rigid_regressor(s, sd, sdd, p)
    dY = (rigid_regressor(s + h, sd, sdd, p) - rigid_regressor(s - h, sd, sdd, p)) / (2 * h)
    theta = rigid_values(p)
    k = [RIGID_PARAMETERS.index(n) for n in kept]
    j = [i for i in range(len(RIGID_PARAMETERS)) if i not in k]
    rest = Y[:, j] @ theta[j]
    fit = errors_in_variables(
        Y[:, k],
        force - rest,
        w,
        dY[:, k],
        -dY[:, j] @ theta[j],
        sigma2,
        np.abs(force) + np.abs(Y[:, j]) @ np.abs(theta[j]),
    )
    return fit, Y[:, k] @ fit.estimate + rest, Y[:, k]


def _structure(ident: Identifiability, names, p: DRSParams, scales, rung: str):
    """Tell what no motion separates from what this run does not: the same regression on a
    rich motion (:func:`~.excitation.reference_motion`)."""
    from .excitation import reference_motion

    lacking = [n for n, why in ident.undetermined.items() if "cannot separate" in why]
    if not lacking:
        return ident
    s, sd, sdd = reference_motion(p)
    if rung == "quasi-static":
        sd, sdd = np.zeros_like(sd), np.zeros_like(sdd)
    Y = rigid_regressor(s, sd, sdd, p, names) * np.sqrt(rigid_weights(s, sd, sdd, p))[:, None]
    structural = {m for group in assess(Y, names, scales).groups for m in group}
    why = dict(ident.undetermined)
    for n in lacking:
        if n in structural:
            partners = sorted({m for g in ident.groups if n in g for m in g} - {n})
            why[n] = (
                f"{STRUCTURAL} from {', '.join(partners)} (its effect is a combination "
                "of theirs): hold one of them at a value from another source, a weighing "
                "or a CAD inertia"
            )
        else:
            why[n] += f" (a richer motion does: drs excite --params {','.join(names)})"
    return dataclasses.replace(ident, undetermined=why)


def continuity_stage(
    record: Record, names: Sequence[str], p: DRSParams, hp: HydraulicParams, level: float
) -> StageFit:
    """The chambers' continuity regression of ``names`` (of
    :data:`~.continuity.CONTINUITY_PARAMETERS`)."""
    started = time.perf_counter()
    needed = ("stroke", "pressure_a", "pressure_b", "supply_pressure", "spool")
    ok = np.all([np.isfinite(getattr(record, n)) for n in needed if record.has(n)], axis=0)
    # an interval is usable when both its samples are
    rows = ok[1:] & ok[:-1]
    X, y = continuity.continuity_regression(record, list(names), p, hp)
    X, y = X[np.concatenate([rows, rows])], y[np.concatenate([rows, rows])]
    starts = {n: current_value(n, p, hp) for n in names}
    phi0 = continuity.from_fields({**starts, "bulk_modulus": hp.bulk_modulus}, list(names))
    scales = {n: fit_parameter(n, p, hp).scale for n in names}
    phi_scales = np.abs(
        continuity.from_fields({**scales, "bulk_modulus": hp.bulk_modulus}, list(names))
    )
    w = np.ones_like(y)
    ident, values, fit, fitted = _solve(X, y, w, list(names), phi_scales, phi0, "hac")
    kept = [n for n in names if n in values]
    phi = np.array([values[n] for n in kept])
    field_values, cov = continuity.to_fields(phi, fit.covariance, kept, hp)
    kinds = {}
    if "bulk_modulus" in kept:  # 1/phi is monotone: its interval's ends are phi's, inverted
        i = kept.index("bulk_modulus")
        lo, hi = wald_interval(phi[i], fit.std[i], quantile(level, fit.dof))
        if lo > 0.0:
            kinds["bulk_modulus"] = ((1.0 / hi, 1.0 / lo), "profile")
    est = _estimates(
        names,
        dict(zip(kept, field_values, strict=True)),
        cov,
        fit.dof,
        level,
        p,
        hp,
        ident,
        "equation",
        kinds,
    )
    t_mid = 0.5 * (record.t[1:] + record.t[:-1])[rows]
    n = t_mid.size
    signals = tuple(
        FittedSignal(
            f"continuity_{side}", "m^3", t_mid, y[k * n : (k + 1) * n], fitted[k * n : (k + 1) * n]
        )
        for k, side in enumerate("ab")
    )
    return StageFit(
        "equation",
        "chamber continuity",
        tuple(est),
        ident,
        signals,
        fit.sigma2,
        fit.dof,
        time.perf_counter() - started,
    )


def friction_stage(
    record: Record, names: Sequence[str], p: DRSParams, hp: HydraulicParams, level: float
) -> StageFit:
    """The rod balance's friction regression of ``names`` (of
    :data:`~.friction.FRICTION_PARAMETERS`)."""
    started = time.perf_counter()
    h = hydraulic_constants(hp, p)
    mask, sd, fr = friction.rod_balance(record, p, hp)
    linear = [n for n in names if n != "stribeck_velocity"]
    vs = hp.stribeck_velocity
    if "stribeck_velocity" in names:
        vs = friction.best_stribeck_velocity(sd, fr, linear, hp, h)
    X, y = friction.friction_regression(sd, fr, linear, hp, h, vs)
    starts = [current_value(n, p, hp) for n in names]
    if "stribeck_velocity" in names:
        values = {n: current_value(n, p, hp) for n in friction.FRICTION_PARAMETERS}
        if linear:  # the linear coefficients at the best vs: the Jacobian's column follows them
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            values.update(zip(linear, coef, strict=True))
        values["stribeck_velocity"] = vs
        X = np.column_stack([X, friction.stribeck_column(sd, names, values, h)])
        order = [*linear, "stribeck_velocity"]
        X = X[:, [order.index(n) for n in names]]
        y = y + X[:, list(names).index("stribeck_velocity")] * vs  # linearised about vs
    scales = [fit_parameter(n, p, hp).scale for n in names]
    ident, values, fit, fitted = _solve(
        X, y, np.ones_like(y), list(names), scales, starts, "classic"
    )
    kinds = {}
    if "stribeck_velocity" in values:
        kinds["stribeck_velocity"] = _stribeck_profile(sd, fr, linear, hp, h, values, fit, level)
    est = _estimates(names, values, fit.covariance, fit.dof, level, p, hp, ident, "equation", kinds)
    signal = FittedSignal("friction", "N", record.t[mask], fr, fitted + (fr - y))
    return StageFit(
        "equation",
        "rod friction",
        tuple(est),
        ident,
        (signal,),
        fit.sigma2,
        fit.dof,
        time.perf_counter() - started,
    )


def _stribeck_profile(sd, fr, linear, hp, h, values, fit, level):
    """The Stribeck velocity's profile interval (its model is nonlinear in it): the residual
    with the linear coefficients re-solved at each trial value."""
    names = list(values)
    i = names.index("stribeck_velocity")
    q = quantile(level, fit.dof)

    def rss(v: float) -> float:
        X, y = friction.friction_regression(sd, fr, linear, hp, h, v)
        if X.shape[1]:
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            y = y - X @ coef
        return float(y @ y) / fit.sigma2

    vs = values["stribeck_velocity"]
    interval = profile_interval(rss, vs, q * fit.std[i], q * q, friction.STRIBECK_RANGE, rss(vs))
    return interval, "profile"


def equation_error(
    record: Record,
    names: Sequence[str],
    rung: str,
    p: DRSParams,
    hp: HydraulicParams,
    level: float = 0.95,
) -> list[StageFit]:
    """Every regression of ``rung`` that covers some of ``names``; the names no regression
    covers are left to the output error."""
    out = []
    rigid = [n for n in names if n in RIGID_PARAMETERS]
    if rigid:
        out.append(rigid_stage(record, rigid, rung, p, level))
    if rung == "hydraulic":
        chambers = [n for n in names if n in continuity.CONTINUITY_PARAMETERS]
        if chambers:
            out.append(continuity_stage(record, chambers, p, hp, level))
        rod = [n for n in names if n in friction.FRICTION_PARAMETERS]
        if rod:
            out.append(friction_stage(record, rod, p, hp, level))
    return out


#: The parameters some regression of the hydraulic rung covers.
EQUATION_PARAMETERS = (
    *RIGID_PARAMETERS,
    *continuity.CONTINUITY_PARAMETERS,
    *friction.FRICTION_PARAMETERS,
)

__all__ = [
    "EQUATION_PARAMETERS",
    "continuity_stage",
    "equation_error",
    "friction_stage",
    "rigid_stage",
]
