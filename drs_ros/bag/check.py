"""``drs-bag check BAG`` (alias ``drs-check``): verify every byte of a bag, then recompute what
the model says from it and report the discrepancies.

First :func:`drs_ros.bag.reader.scan` reads the whole file and verifies it (CRCs, summary and
``metadata.yaml`` counts against what was read, exact CDR bytes of every message); any problem is
an error naming the offset and the topic. Then the model checks, each reported as the largest
discrepancy per topic:

* ``/joint_states`` positions ``q = [s, psi1, psi3]`` satisfy the loop constraint:
  ``max |Phi(q)|`` [m] (:func:`drs_model.constraints.constraint`);
* its velocities satisfy ``Phi_q qd = 0``: ``max |Phi_q qd|`` [m/s]; every state is finite;
* ``/drs/flap_gap`` equals :func:`drs_model.kinematics.gap` of the joint state nearest in time [m];
* the piston force of the logged motion from the inverse dynamics: with the logged
  ``~/piston_acceleration`` exactly, or (older bags) from finite differences of the logged
  velocities, reported only unless ``--force-model-tol`` is given.

Exit status: 0 verified and every check within tolerance; 1 a model check failed; 2 the bag is
missing, unreadable, corrupt or inconsistent, or its ``metadata.yaml`` is malformed (one line on
stderr); 3 ``--recover`` checked the readable part of a damaged bag (it stopped early: the report
says where and why); 4 the check itself failed on a message that passed every check of the file
(e.g. a checked topic of a type that is not installed): one line ``internal error``, no verdict
on the bag.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from drs_model.constraints import constraint, constraint_velocity_term
from drs_model.errors import DRSError
from drs_model.kinematics import gap as model_gap
from drs_model.params import DRSParams, from_file

from ..names import DEFAULT_JOINT_NAMES, DEFAULT_TOPICS
from .reader import BagReadError, MessageCallbackError, scan

#: The topics the model checks read (overridable with ``--<key>-topic``).
CHECK_TOPICS = ("joint_states", "piston_force", "flap_gap", "piston_acceleration")
#: Exit statuses.
EXIT_OK, EXIT_FAILED, EXIT_UNREADABLE, EXIT_RECOVERED, EXIT_INTERNAL = 0, 1, 2, 3, 4


class ForceModelError(DRSError):
    """The piston-force hook cannot be loaded or fails on the logged motion."""


# ---- reading ------------------------------------------------------------------------------------
@dataclass
class BagData:
    """Decoded messages of the topics of interest.

    Attributes
    ----------
    path : Path
        The ``.mcap`` file read.
    messages : dict
        topic -> list of ``(log_time_ns, decoded message)`` in file order.
    counts : dict
        topic -> number of messages (every topic of the file), as read.
    recovered : bool
        The bag is damaged and only its readable part was read (``--recover``).
    notes : list of str
        What the reader had to say (verification, truncation point...).
    """

    path: Path
    messages: dict[str, list] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    recovered: bool = False
    notes: list[str] = field(default_factory=list)


def read_bag(path: str | Path, topics: Sequence[str], recover: bool = False) -> BagData:
    """Verify a whole bag (:func:`drs_ros.bag.reader.scan`) and decode the messages of ``topics``.

    Raises
    ------
    BagReadError
        The bag is missing, unreadable, corrupt or inconsistent (with ``recover``: nothing of it
        is readable).
    MessageCallbackError
        Decoding a message that passed the file's checks failed (its type is not installed):
        not a fault of the bag.
    """
    from rclpy.serialization import deserialize_message

    from .. import msgdefs

    wanted = set(topics)
    messages: dict[str, list] = {t: [] for t in topics}
    classes: dict[str, type] = {}

    def keep(m) -> None:
        cls = classes.get(m.type_name) or classes.setdefault(
            m.type_name, msgdefs.message_class(m.type_name)
        )
        messages[m.topic].append((m.log_time, deserialize_message(m.data, cls)))

    result = scan(path, keep, recover=recover, topics=wanted)
    notes = list(result.notes)
    if result.complete:
        notes.insert(0, f"verified: {result.message_count} messages, every byte read "
                        "(CRCs, summary, metadata.yaml, exact CDR)")  # fmt: skip
    return BagData(result.path, messages, dict(result.counts), not result.complete, notes)


# ---- checks -------------------------------------------------------------------------------------
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


def _stamp_s(log_ns: int, msg) -> float:
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
        t.append(_stamp_s(log_ns, msg))
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
        return CheckResult(
            name, topic, unit, 0, math.nan, math.nan, tol, "skipped", note or "no samples"
        )
    return CheckResult(name, topic, unit, n, worst, at, tol, "ok" if worst <= tol else "FAIL", note)


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
        return CheckResult(
            name,
            accel_topic,
            "N",
            0,
            math.nan,
            math.nan,
            force_tol,
            "skipped",
            "no joint state paired with an acceleration off the end stops",
        )
    try:
        qdd = solve_acceleration(q[use], qd[use], sdd[use], p, "s")
        model = np.asarray(force_model(q[use], qd[use], qdd, p), dtype=float).reshape(-1)
    except DRSError as exc:
        return CheckResult(
            name,
            accel_topic,
            "N",
            int(use.sum()),
            math.inf,
            math.nan,
            force_tol,
            "FAIL",
            f"the force model refuses the logged motion: {exc}",
        )
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
        out.append(
            CheckResult(
                "piston force vs model",
                js_topic,
                "N",
                0,
                math.nan,
                math.nan,
                force_tol,
                "skipped",
                force_note or "skipped: no force model",
            )
        )
    elif len(q) < 3:
        out.append(
            CheckResult(
                "piston force vs model",
                js_topic,
                "N",
                0,
                math.nan,
                math.nan,
                force_tol,
                "skipped",
                "fewer than 3 joint states",
            )
        )
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
                out.append(
                    CheckResult(
                        "piston force vs model",
                        js_topic,
                        "N",
                        len(ts),
                        math.inf,
                        math.nan,
                        force_tol,
                        "FAIL",
                        f"the force model refuses the logged motion: {exc}",
                    )
                )
        elif force_model is not None:
            out.append(
                CheckResult(
                    "piston force vs model",
                    js_topic,
                    "N",
                    0,
                    math.nan,
                    math.nan,
                    force_tol,
                    "skipped",
                    "fewer than 3 usable joint states",
                )
            )
    if force_model is not None and model is not None:
        note = (
            f"{force_note}; qdd by finite differences of the logged qd, peak |F| "
            f"{np.nanmax(np.abs(model)):.4g} N"
        )
        if force_model_tol is None:
            res = _result(
                "piston force vs model",
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
                    "piston force vs model",
                    js_topic,
                    "N",
                    np.abs(fs - model),
                    ts,
                    force_model_tol,
                    note,
                )
            )
    return out


# ---- reporting ----------------------------------------------------------------------------------
def format_table(data: BagData, results: Sequence[CheckResult]) -> str:
    """A plain-text report: counts per topic, then one row per check."""
    lines = [f"bag: {data.path}" + ("  (recovered prefix)" if data.recovered else "")]
    lines += [f"note: {n}" for n in data.notes]
    for topic, n in sorted(data.counts.items()):
        lines.append(f"  {topic:<28} {n:>8} messages")
    # times are shown from the earliest header stamp (the checks report stamps, epoch seconds)
    stamps = [_stamp_s(ln, m) for msgs in data.messages.values() for ln, m in msgs[:1]]
    t0 = min(stamps) if stamps else 0.0
    head = (
        f"{'check':<38} {'topic':<20} {'n':>7} {'max error':>11} {'at t-t0 [s]':>12} "
        f"{'tol':>9}  status"
    )
    lines += ["", head, "-" * len(head)]
    for r in results:
        err = "-" if math.isnan(r.max_error) else f"{r.max_error:.3e}"
        at = "-" if math.isnan(r.at_time_s) else f"{r.at_time_s - t0:.6f}"
        row = (
            f"{r.name + ' [' + r.unit + ']':<38} {r.topic:<20} {r.samples:>7} {err:>11} "
            f"{at:>12} {r.tol:>9.2g}  {r.status}"
        )
        lines.append(row + (f"  ({r.note})" if r.note else ""))
    return "\n".join(lines)


def to_json(data: BagData, results: Sequence[CheckResult]) -> str:
    """The report as JSON (NaN written as null)."""

    def clean(value):
        return None if isinstance(value, float) and math.isnan(value) else value

    return json.dumps(
        {
            "bag": str(data.path),
            "recovered": data.recovered,
            "notes": data.notes,
            "messages": data.counts,
            "checks": [{k: clean(v) for k, v in asdict(r).items()} for r in results],
            "ok": not any(r.status == "FAIL" for r in results),
        },
        indent=2,
    )


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The options of ``drs-bag check``."""
    ap.add_argument("bag", help="bag directory or .mcap file")
    ap.add_argument(
        "--tol",
        type=float,
        default=1e-6,
        help="tolerance of the kinematic checks [m, m/s] (default 1e-6)",
    )
    ap.add_argument(
        "--force-tol", type=float, default=1.0, help="tolerance of the force checks [N] (default 1)"
    )
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    ap.add_argument(
        "--recover",
        action="store_true",
        help="check the readable part of a damaged bag (exit status 3 if damaged)",
    )
    ap.add_argument(
        "--params",
        help="parameter file (.toml/.yaml) of the recorded run (default: "
        "the model parameters the bag recorded, else the seed's)",
    )
    ap.add_argument(
        "--force-model",
        default=None,
        help="piston force hook module:function f(q, qd, qdd, params) [N] "
        "(default: drs_model.inverse)",
    )
    ap.add_argument(
        "--force-model-tol",
        type=float,
        default=None,
        help="tolerance [N] of the finite-difference force check (default: report)",
    )
    ap.add_argument(
        "--joint-names",
        default=",".join(DEFAULT_JOINT_NAMES),
        help="joint names of [s, psi1, psi3], comma-separated",
    )
    ap.add_argument(
        "--max-match",
        type=float,
        default=1e-3,
        help="largest time offset [s] pairing a scalar topic with a joint state",
    )
    for key in CHECK_TOPICS:
        default = DEFAULT_TOPICS[key]
        ap.add_argument(
            f"--{key.replace('_', '-')}-topic",
            dest=f"topic_{key}",
            default=default,
            help=f"(default {default})",
        )


def run(args: argparse.Namespace, prog: str = "drs-bag check") -> int:
    """Run ``drs-bag check``; returns the exit status (see the module docstring)."""
    from .effects import recorded_model_params

    topics = {key: getattr(args, f"topic_{key}") for key in CHECK_TOPICS}
    names = tuple(n.strip() for n in args.joint_names.split(",") if n.strip())
    try:
        if len(names) != 3:
            raise BagReadError(f"--joint-names needs 3 names (s, psi1, psi3), got {list(names)}")
        force_model, force_note = load_force_model(args.force_model)
        data = read_bag(
            args.bag,
            list(topics.values()) + [DEFAULT_TOPICS["parameter_events"]],
            recover=args.recover,
        )
        if args.params:
            params = from_file(args.params)
        else:
            params, origin = recorded_model_params(
                data.messages.get(DEFAULT_TOPICS["parameter_events"], [])
            )
            data.notes.append(f"model parameters: {origin}")
        results = check_bag(
            data,
            params,
            tol=args.tol,
            force_tol=args.force_tol,
            topics=topics,
            joint_names=names,
            force_model=force_model,
            force_note=force_note,
            max_match_s=args.max_match,
            force_model_tol=args.force_model_tol,
        )
    except MessageCallbackError as exc:  # the checker's own failure: no verdict on the bag
        print(f"{prog}: internal error (not a verdict on the bag): {exc}", file=sys.stderr)
        return EXIT_INTERNAL
    except DRSError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_UNREADABLE
    print(to_json(data, results) if args.json else format_table(data, results))
    if any(r.status == "FAIL" for r in results):
        return EXIT_FAILED
    return EXIT_RECOVERED if data.recovered else EXIT_OK


def main(argv: Sequence[str] | None = None, prog: str = "drs-bag check") -> int:
    """``drs-bag check`` / ``drs-check``; returns the exit status."""
    ap = argparse.ArgumentParser(
        prog=prog,
        description="Verify every byte of a recorded DRS bag and check it against "
        "the model. Exit status: 0 ok, 1 a check failed, 2 unreadable or corrupt, 3 damaged "
        "(--recover read its readable part), 4 internal error (no verdict on the bag).",
    )
    add_arguments(ap)
    return run(ap.parse_args(argv), prog)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
