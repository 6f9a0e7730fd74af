"""What the model says about a recorded run: the checks of ``drs-bag check``, each reported as
the largest discrepancy per topic:

* ``/joint_states`` positions ``q = [s, psi1, psi3]`` satisfy the loop constraint:
  ``max |Phi(q)|`` [m] (:func:`drs_model.constraints.constraint`);
* its velocities satisfy ``Phi_q qd = 0``: ``max |Phi_q qd|`` [m/s]; every state is finite;
* ``/drs/flap_gap`` equals :func:`drs_model.kinematics.gap` of the joint state nearest in time [m];
* the piston force of the logged motion from the inverse dynamics: with the logged
  ``~/piston_acceleration`` exactly, or (older bags) from finite differences of the logged
  velocities, reported only unless ``--force-model-tol`` is given.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from drs_model.constraints import constraint, constraint_velocity_term
from drs_model.errors import DRSError
from drs_model.kinematics import gap as model_gap
from drs_model.params import DRSParams

from ..names import DEFAULT_JOINT_NAMES, DEFAULT_TOPICS
from .decoded import BagData

#: The name of the piston-force check from finite differences of the logged velocities.
FORCE_CHECK = "piston force vs model"


class ForceModelError(DRSError):
    """The piston-force hook cannot be loaded or fails on the logged motion."""


@dataclass(frozen=True)
class CheckResult:
    """Largest discrepancy of one check on one topic (``status``: ok, FAIL, skipped or info)."""

    name: str
    topic: str
    unit: str
    samples: int
    max_error: float
    at_time_s: float
    tol: float
    status: str
    note: str = ""


def stamp_s(log_ns: int, msg) -> float:
    header = getattr(msg, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is not None and (stamp.sec or stamp.nanosec):
        return stamp.sec + stamp.nanosec * 1e-9
    return log_ns * 1e-9


def joint_arrays(
    messages: list, joint_names: Sequence[str]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Stack JointState messages: times [s], log times [ns], q, qd, effort[0], messages skipped.

    Values are ordered by ``joint_names`` when a message carries names; NaN where absent.
    """
    t, log, q, qd, f = [], [], [], [], []
    skipped = 0
    for log_ns, msg in messages:
        names = list(msg.name)
        if names:
            try:
                order = [names.index(n) for n in joint_names]
            except ValueError:
                skipped += 1
                continue
        else:
            order = [0, 1, 2]

        def pick(values, order=order):
            values = list(values)
            return [values[i] if i < len(values) else math.nan for i in order]

        pos = pick(msg.position)
        if len(msg.position) < 3:
            skipped += 1
            continue
        t.append(stamp_s(log_ns, msg))
        log.append(log_ns)
        q.append(pos)
        qd.append(pick(msg.velocity))
        eff = list(msg.effort)
        f.append(eff[order[0]] if len(eff) > order[0] else math.nan)
    return (
        np.array(t, dtype=float),
        np.array(log, dtype=np.int64),
        np.array(q, dtype=float).reshape(-1, 3),
        np.array(qd, dtype=float).reshape(-1, 3),
        np.array(f, dtype=float),
        skipped,
    )


def _worst(err: np.ndarray, t: np.ndarray) -> tuple[float, float, int]:
    ok = np.isfinite(err)
    if not np.any(ok):
        return math.nan, math.nan, 0
    i = int(np.argmax(np.where(ok, err, -np.inf)))
    return float(err[i]), float(t[i]), int(ok.sum())


def _result(name, topic, unit, err, t, tol, note="") -> CheckResult:
    worst, at, n = _worst(np.asarray(err, dtype=float), t)
    if n == 0:
        return _skipped(name, topic, unit, tol, note or "no samples")
    return CheckResult(name, topic, unit, n, worst, at, tol, "ok" if worst <= tol else "FAIL", note)


def _skipped(name, topic, unit, tol, why) -> CheckResult:
    """A check with nothing to check, and why."""
    return CheckResult(name, topic, unit, 0, math.nan, math.nan, tol, "skipped", why)


def _refused(name, topic, samples, tol, exc) -> CheckResult:
    """A force check failed because the force model refuses the logged motion."""
    return CheckResult(name, topic, "N", samples, math.inf, math.nan, tol, "FAIL",
                       f"the force model refuses the logged motion: {exc}")  # fmt: skip


def _nearest(log_ref: np.ndarray, log_query: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index into sorted-by-time ``log_ref`` of the sample nearest each query, and |dt| [ns]."""
    order = np.argsort(log_ref, kind="stable")
    ref = log_ref[order]
    j = np.clip(np.searchsorted(ref, log_query), 1, max(len(ref) - 1, 1))
    left = ref[j - 1]
    right = ref[np.minimum(j, len(ref) - 1)]
    pick = np.where(np.abs(log_query - left) <= np.abs(right - log_query), j - 1, j)
    pick = np.minimum(pick, len(ref) - 1)
    return order[pick], np.abs(ref[pick] - log_query)


def load_force_model(spec: str | None = None) -> tuple[Callable, str]:
    """The piston-force hook ``f(q, qd, qdd, params) -> (n,) [N]`` and a note.

    ``spec`` is ``"module:function"``; by default (None) the inverse dynamics of
    :func:`drs_model.inverse.inverse_dynamics`. A ``spec`` that cannot be loaded raises
    :class:`ForceModelError`.
    """
    if spec is None:
        from drs_model.inverse import inverse_dynamics

        def piston_force(q, qd, qdd, p):
            return inverse_dynamics((q, qd, qdd), p).piston_force

        return piston_force, "model drs_model.inverse.inverse_dynamics"
    module_name, _, func_name = spec.partition(":")
    try:
        func = getattr(importlib.import_module(module_name), func_name)
    except (ImportError, AttributeError, ValueError) as exc:
        raise ForceModelError(f"cannot load force model {spec!r}: {exc}") from exc
    if not callable(func):
        raise ForceModelError(f"force model {spec!r} is not callable")
    return func, f"model {spec}"


def _logged_acceleration_force(
    q,
    qd,
    effort,
    t,
    log,
    accel_msgs,
    p,
    force_model,
    force_tol,
    max_match_s,
    accel_topic,
    force_note,
) -> CheckResult:
    """The piston force of the logged motion with the logged piston acceleration: exact.

    Each joint state is paired with the acceleration logged nearest in time; ``qdd`` follows from
    ``Phi_q qdd = gamma`` (:func:`drs_model.kinematics.solve_acceleration`). Samples resting on an
    end stop are left out (the stop carries the difference between the force and the static
    load), as are non-finite ones.
    """
    from drs_model.kinematics import solve_acceleration, stroke_limits

    vals = np.array([m.data for _, m in accel_msgs], dtype=float)
    logs = np.array([ln for ln, _ in accel_msgs], dtype=np.int64)
    idx, dt = _nearest(logs, log)  # for each joint state, the nearest acceleration
    sdd = vals[idx]
    s_min, s_max = stroke_limits(p)
    at_rest = np.all(qd == 0.0, axis=1)
    on_stop = at_rest & ((np.abs(q[:, 0] - s_min) < 1e-12) | (np.abs(q[:, 0] - s_max) < 1e-12))
    use = (dt <= max_match_s * 1e9) & ~on_stop & np.isfinite(sdd)
    use &= np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(qd), axis=1)
    name = "piston force vs model, logged accel."
    if not use.any():
        return _skipped(name, accel_topic, "N", force_tol,
                        "no joint state paired with an acceleration off the end stops")  # fmt: skip
    try:
        qdd = solve_acceleration(q[use], qd[use], sdd[use], p, "s")
        model = np.asarray(force_model(q[use], qd[use], qdd, p), dtype=float).reshape(-1)
    except DRSError as exc:
        return _refused(name, accel_topic, int(use.sum()), force_tol, exc)
    note = f"{force_note}; {int(on_stop.sum())} samples resting on an end stop left out"
    return _result(name, accel_topic, "N", np.abs(effort[use] - model), t[use], force_tol, note)


def check_bag(
    data: BagData,
    params: DRSParams | None = None,
    *,
    tol: float = 1e-6,
    force_tol: float = 1.0,
    topics: dict[str, str] | None = None,
    joint_names: Sequence[str] = DEFAULT_JOINT_NAMES,
    force_model: Callable | None = None,
    force_note: str = "",
    max_match_s: float = 1e-3,
    force_model_tol: float | None = None,
) -> list[CheckResult]:
    """Run every check on decoded bag data.

    Parameters
    ----------
    data : BagData
        From :func:`read_bag`.
    params : DRSParams, optional
        Model parameters (the seed by default).
    tol : float
        Tolerance of the kinematic checks [m, m/s].
    force_tol : float
        Tolerance of the force checks [N].
    topics : dict, optional
        Overrides of :data:`DEFAULT_TOPICS`.
    joint_names : sequence of str
        Joint names of ``[s, psi1, psi3]``.
    force_model : callable, optional
        ``f(q, qd, qdd, params) -> (n,)`` [N]; None skips the model force check (with
        ``force_note`` as the reason).
    max_match_s : float
        Largest time offset [s] at which a Float64 sample is paired with a joint state.
    force_model_tol : float, optional
        Tolerance [N] of the model force check. None (default) reports it as ``info`` without
        failing: ``qdd`` comes from finite differences of the logged ``qd``, which near the
        manoeuvre's jerk discontinuities is off by several % of the peak force even at 1 kHz.
    """
    p = params if params is not None else DRSParams()
    tp = {**DEFAULT_TOPICS, **(topics or {})}
    js_topic = tp["joint_states"]
    t, log, q, qd, effort, skipped = joint_arrays(data.messages.get(js_topic, []), joint_names)
    note = f"{skipped} message(s) without the joints {list(joint_names)}" if skipped else ""
    out = [
        _result(
            "loop constraint |Phi(q)|",
            js_topic,
            "m",
            np.max(np.abs(constraint(q, p)), axis=-1) if len(q) else [],
            t,
            tol,
            note,
        ),
        _result(
            "velocity constraint |Phi_q qd|",
            js_topic,
            "m/s",
            np.max(np.abs(constraint_velocity_term(q, qd, p)), axis=-1) if len(q) else [],
            t,
            tol,
            note,
        ),
    ]
    if len(q):
        finite = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(qd), axis=1)
        n_bad = int((~finite).sum())
        out.append(
            CheckResult(
                "finite joint states",
                js_topic,
                "count",
                len(q),
                float(n_bad),
                float(t[~finite][0]) if n_bad else math.nan,
                0.0,
                "FAIL" if n_bad else "ok",
                f"{n_bad} joint states hold NaN/inf" if n_bad else "",
            )
        )
    max_ns = max_match_s * 1e9

    def scalar_topic(key: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        msgs = data.messages.get(tp[key], [])
        vals = np.array([m.data for _, m in msgs], dtype=float)
        logs = np.array([ln for ln, _ in msgs], dtype=np.int64)
        if not len(q) or not len(vals):
            return vals, np.zeros(0, dtype=int), np.zeros(len(vals), dtype=bool)
        idx, dt = _nearest(log, logs)
        return vals, idx, dt <= max_ns

    vals, idx, ok = scalar_topic("flap_gap")
    err = np.where(ok, np.abs(vals - model_gap(q[idx], p)), np.nan) if ok.any() else []
    out.append(
        _result(
            "gap vs kinematics.gap(q)", tp["flap_gap"], "m", err, t[idx] if len(idx) else [], tol
        )
    )
    model = None
    accel_msgs = data.messages.get(tp["piston_acceleration"], [])
    if force_model is not None and accel_msgs and len(q):
        out.append(
            _logged_acceleration_force(
                q,
                qd,
                effort,
                t,
                log,
                accel_msgs,
                p,
                force_model,
                force_tol,
                max_match_s,
                tp["piston_acceleration"],
                force_note,
            )
        )
        return out
    if force_model is None:
        out.append(_skipped(FORCE_CHECK, js_topic, "N", force_tol,
                            force_note or "skipped: no force model"))  # fmt: skip
    elif len(q) < 3:
        out.append(_skipped(FORCE_CHECK, js_topic, "N", force_tol, "fewer than 3 joint states"))
    else:
        order = np.argsort(t, kind="stable")
        ts, qs, qds, fs = t[order], q[order], qd[order], effort[order]
        # only finite samples with strictly increasing stamps can be differentiated
        good = np.all(np.isfinite(qs), axis=1) & np.all(np.isfinite(qds), axis=1)
        good &= np.concatenate([[True], np.diff(ts) > 0])
        ts, qs, qds, fs = ts[good], qs[good], qds[good], fs[good]
        if len(ts) >= 3:
            qdd = np.gradient(qds, ts, axis=0)
            try:
                model = np.asarray(force_model(qs, qds, qdd, p), dtype=float).reshape(-1)
            except DRSError as exc:
                out.append(_refused(FORCE_CHECK, js_topic, len(ts), force_tol, exc))
        else:
            out.append(_skipped(FORCE_CHECK, js_topic, "N", force_tol,
                                "fewer than 3 usable joint states"))  # fmt: skip
    if force_model is not None and model is not None:
        note = (
            f"{force_note}; qdd by finite differences of the logged qd, peak |F| "
            f"{np.nanmax(np.abs(model)):.4g} N"
        )
        if force_model_tol is None:
            res = _result(
                FORCE_CHECK,
                js_topic,
                "N",
                np.abs(fs - model),
                ts,
                math.inf,
                note + "; informational, set a tolerance to enforce",
            )
            out.append(
                CheckResult(
                    **{
                        **asdict(res),
                        "tol": math.nan,
                        "status": "info" if res.samples else res.status,
                    }
                )
            )
        else:
            out.append(
                _result(
                    FORCE_CHECK,
                    js_topic,
                    "N",
                    np.abs(fs - model),
                    ts,
                    force_model_tol,
                    note,
                )
            )
    return out


__all__ = [
    "CheckResult",
    "ForceModelError",
    "check_bag",
    "joint_arrays",
    "load_force_model",
    "stamp_s",
]
