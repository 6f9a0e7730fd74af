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
from drs_ros.bag.read.decoded import stamp_s
from drs_ros.errors import UsageError
from drs_ros.names import DEFAULT_JOINT_NAMES, DEFAULT_TOPICS
from drs_ros.timestamps import ns_from_seconds

#: The name of the piston-force check from finite differences of the logged velocities.
FORCE_CHECK = "piston force vs model"


class ForceModelError(UsageError):
    """The piston-force hook (``--force-model``) cannot be loaded."""


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


def joint_row(log_ns: int, msg, joint_names: Sequence[str]) -> tuple | None:
    """One JointState as numbers: ``(t [s], log [ns], q, qd, effort of the piston [N])``, the
    values ordered by ``joint_names`` when the message carries names (NaN where absent); None
    for a message without those joints or with fewer than 3 positions (skipped)."""
    names = list(msg.name)
    if names:
        try:
            order = [names.index(n) for n in joint_names]
        except ValueError:
            return None
    else:
        order = [0, 1, 2]

    def pick(values):
        values = list(values)
        return [values[i] if i < len(values) else math.nan for i in order]

    if len(msg.position) < 3:
        return None
    eff = list(msg.effort)
    return (
        stamp_s(log_ns, msg),
        log_ns,
        pick(msg.position),
        pick(msg.velocity),
        eff[order[0]] if len(eff) > order[0] else math.nan,
    )


def _worst(err: np.ndarray, t: np.ndarray) -> tuple[float, float, int]:
    ok = np.isfinite(err)
    if not np.any(ok):
        return math.nan, math.nan, 0
    i = int(np.argmax(np.where(ok, err, -np.inf)))
    return float(err[i]), float(t[i]), int(ok.sum())


def _skipped(name, topic, unit, tol, why) -> CheckResult:
    """A check with nothing to check, and why."""
    return CheckResult(name, topic, unit, 0, math.nan, math.nan, tol, "skipped", why)


def _refused(name, topic, samples, tol, exc) -> CheckResult:
    """A force check failed because the force model refuses the logged motion."""
    return CheckResult(
        name,
        topic,
        "N",
        samples,
        math.inf,
        math.nan,
        tol,
        "FAIL",
        f"the force model refuses the logged motion: {exc}",
    )


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


#: Joint states per block of the streaming checks: the checks hold three blocks at a time (a
#: block and its neighbours, for the nearest-in-time pairing and the finite differences), so the
#: memory of a check does not grow with the bag.
BLOCK_STATES = 16384


@dataclass
class _Block:
    """The numbers of one block of joint states, and the scalar samples logged while it filled."""

    t: np.ndarray
    log: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    effort: np.ndarray
    scalars: dict[str, tuple[np.ndarray, np.ndarray]]  # key -> (log [ns], value)


class _Worst:
    """The largest finite error seen so far, the time of its first occurrence, and the number of
    finite samples, accumulated block after block."""

    def __init__(self):
        self.value, self.at, self.samples = math.nan, math.nan, 0

    def add(self, err, t) -> None:
        worst, at, n = _worst(np.asarray(err, dtype=float), np.asarray(t, dtype=float))
        self.samples += n
        if n and (math.isnan(self.value) or worst > self.value):  # the first of equals stays
            self.value, self.at = worst, at

    def result(self, name, topic, unit, tol, note="") -> CheckResult:
        if self.samples == 0:
            return _skipped(name, topic, unit, tol, note or "no samples")
        status = "ok" if self.value <= tol else "FAIL"
        return CheckResult(name, topic, unit, self.samples, self.value, self.at, tol, status, note)


class ModelChecker:
    """The checks of ``drs-bag check``, fed one decoded message at a time (:meth:`add`) and
    finished with :meth:`results`: memory holds three blocks of :data:`BLOCK_STATES` joint
    states (as numbers, not messages), whatever the length of the bag.

    A block is checked once the next block is full (or at the end): a scalar sample logged
    while a block filled is paired with the nearest joint state of that block or of its
    neighbours, and the finite differences of a block's velocities see its neighbours' samples.
    For a bag whose messages are in time order to within a block (every recorder's), this is
    exactly what the checks over the whole bag at once give; a bag of one block is read whole.
    Parameters
    ----------
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
    block_states : int, optional
        Joint states per block; :data:`BLOCK_STATES` by default.
    """

    def __init__(
        self,
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
        block_states: int | None = None,
    ):
        self.p = params if params is not None else DRSParams()
        self.tol, self.force_tol, self.force_model_tol = tol, force_tol, force_model_tol
        self.tp = {**DEFAULT_TOPICS, **(topics or {})}
        self.joint_names = tuple(joint_names)
        self.force_model, self.force_note = force_model, force_note
        self.max_ns = ns_from_seconds(max_match_s)
        self.block_states = int(BLOCK_STATES if block_states is None else block_states)
        self.scalar_key = {self.tp["flap_gap"]: "gap", self.tp["piston_acceleration"]: "accel"}
        self._rows: list[tuple] = []
        self._scalars: dict[str, list] = {"gap": [], "accel": []}
        self._window: list[_Block] = []  # blocks not yet dropped: [previous,] current[, next]
        self._closed = self._checked = 0  # blocks closed, blocks checked
        self.skipped = 0
        self.states = 0
        self.accel_seen = False
        self.loop, self.velocity, self.gap = _Worst(), _Worst(), _Worst()
        self.n_bad, self.first_bad = 0, math.nan
        self.accel, self.accel_used, self.accel_on_stop = _Worst(), 0, 0
        self.accel_refusal: Exception | None = None
        self.fd, self.fd_good, self.fd_peak = _Worst(), 0, math.nan
        self.fd_refusal: Exception | None = None

    @property
    def topics(self) -> set[str]:
        """The topics the checks read."""
        return {self.tp["joint_states"], *self.scalar_key}

    def add(self, topic: str, log_ns: int, msg) -> None:
        """One decoded message, in the bag's order (other topics are ignored)."""
        if topic == self.tp["joint_states"]:
            self.add_row(joint_row(log_ns, msg, self.joint_names))
        elif topic in self.scalar_key:
            key = self.scalar_key[topic]
            self._scalars[key].append((log_ns, float(msg.data)))
            self.accel_seen |= key == "accel"

    def add_row(self, row: tuple | None) -> None:
        """One joint state as :func:`joint_row` gives it (None: a message without the joints,
        counted as skipped)."""
        if row is None:
            self.skipped += 1
            return
        self._rows.append(row)
        if len(self._rows) >= self.block_states:
            self._close_block()

    def _close_block(self) -> None:
        rows, self._rows = self._rows, []
        scalars = {}
        for key, samples in self._scalars.items():
            scalars[key] = (
                np.array([s[0] for s in samples], dtype=np.int64),
                np.array([s[1] for s in samples], dtype=float),
            )
            self._scalars[key] = []
        self._window.append(
            _Block(
                np.array([r[0] for r in rows], dtype=float),
                np.array([r[1] for r in rows], dtype=np.int64),
                np.array([r[2] for r in rows], dtype=float).reshape(-1, 3),
                np.array([r[3] for r in rows], dtype=float).reshape(-1, 3),
                np.array([r[4] for r in rows], dtype=float),
                scalars,
            )
        )
        self.states += len(rows)
        self._closed += 1
        # a block is checked when its successor is complete; the one before it is then dropped
        if len(self._window) == 3 or (self._checked == 0 and len(self._window) == 2):
            self._check_block(len(self._window) - 2)

    def _check_block(self, k: int) -> None:
        """Check block ``k`` of the window, with its neighbours as context; drop what is no
        longer needed."""
        window = self._window
        own = window[k]
        ctx = window[max(k - 1, 0) : k + 2]
        start = sum(len(b.t) for b in ctx[: k - max(k - 1, 0)])
        mine = slice(start, start + len(own.t))
        t, log = np.concatenate([b.t for b in ctx]), np.concatenate([b.log for b in ctx])
        q, qd = np.concatenate([b.q for b in ctx]), np.concatenate([b.qd for b in ctx])
        effort = np.concatenate([b.effort for b in ctx])
        p = self.p
        if len(own.t):
            self.loop.add(np.max(np.abs(constraint(own.q, p)), axis=-1), own.t)
            self.velocity.add(
                np.max(np.abs(constraint_velocity_term(own.q, own.qd, p)), axis=-1), own.t
            )
            finite = np.all(np.isfinite(own.q), axis=1) & np.all(np.isfinite(own.qd), axis=1)
            bad = int((~finite).sum())
            if bad and not self.n_bad:
                self.first_bad = float(own.t[~finite][0])
            self.n_bad += bad
        gap_log, gap_val = own.scalars["gap"]
        if len(log) and len(gap_val):
            idx, dt = _nearest(log, gap_log)
            ok = dt <= self.max_ns
            if ok.any():
                self.gap.add(np.where(ok, np.abs(gap_val - model_gap(q[idx], p)), np.nan), t[idx])
        if self.force_model is not None:
            acc_log = np.concatenate([b.scalars["accel"][0] for b in ctx])
            acc_val = np.concatenate([b.scalars["accel"][1] for b in ctx])
            self._accel_block(q[mine], qd[mine], effort[mine], t[mine], log[mine], acc_log, acc_val)
            if not self.accel_seen:
                self._fd_block(t, q, qd, effort, mine)
        self._checked += 1
        if k > 0:
            del window[0]

    def _accel_block(self, q, qd, effort, t, log, acc_log, acc_val) -> None:
        """The piston force of the logged motion with the logged piston acceleration: exact.

        Each joint state is paired with the acceleration logged nearest in time; ``qdd``
        follows from ``Phi_q qdd = gamma`` (:func:`drs_model.kinematics.solve_acceleration`).
        Samples resting on an end stop are left out (the stop carries the difference between
        the force and the static load), as are non-finite ones."""
        from drs_model.kinematics import solve_acceleration, stroke_limits

        if not len(q):
            return
        p = self.p
        s_min, s_max = stroke_limits(p)
        at_rest = np.all(qd == 0.0, axis=1)
        on_stop = at_rest & ((np.abs(q[:, 0] - s_min) < 1e-12) | (np.abs(q[:, 0] - s_max) < 1e-12))
        self.accel_on_stop += int(on_stop.sum())
        if not len(acc_log):
            return
        idx, dt = _nearest(acc_log, log)  # for each joint state, the nearest acceleration
        sdd = acc_val[idx]
        use = (dt <= self.max_ns) & ~on_stop & np.isfinite(sdd)
        use &= np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(qd), axis=1)
        self.accel_used += int(use.sum())
        if not use.any() or self.accel_refusal is not None:
            return
        try:
            qdd = solve_acceleration(q[use], qd[use], sdd[use], p, "s")
            model = np.asarray(self.force_model(q[use], qd[use], qdd, p), dtype=float)
        except DRSError as exc:
            self.accel_refusal = exc
            return
        self.accel.add(np.abs(effort[use] - model.reshape(-1)), t[use])

    def _fd_block(self, t, q, qd, effort, mine: slice) -> None:
        """The piston force with ``qdd`` from finite differences of the logged velocities, over
        the block and its neighbours in stamp order; the block's own samples are kept."""
        order = np.argsort(t, kind="stable")
        ts, qs, qds, fs = t[order], q[order], qd[order], effort[order]
        owned = (order >= mine.start) & (order < mine.stop)
        # only finite samples with strictly increasing stamps can be differentiated
        good = np.all(np.isfinite(qs), axis=1) & np.all(np.isfinite(qds), axis=1)
        good &= np.concatenate([[True], np.diff(ts) > 0])
        ts, qs, qds, fs, owned = ts[good], qs[good], qds[good], fs[good], owned[good]
        self.fd_good += int(owned.sum())
        if len(ts) < 2 or not owned.any() or self.fd_refusal is not None:
            return
        qdd = np.gradient(qds, ts, axis=0)
        try:
            model = np.asarray(
                self.force_model(qs[owned], qds[owned], qdd[owned], self.p), dtype=float
            ).reshape(-1)
        except DRSError as exc:
            self.fd_refusal = exc
            return
        if len(model):
            peak = float(np.nanmax(np.abs(model)))
            self.fd_peak = peak if math.isnan(self.fd_peak) else max(self.fd_peak, peak)
        self.fd.add(np.abs(fs[owned] - model), ts[owned])

    def results(self) -> list[CheckResult]:
        """Check what is left and report every check (the rows of ``drs-bag check``)."""
        if self._rows or self._scalars["gap"] or self._scalars["accel"] or not self._closed:
            self._close_block()
        if self._checked < self._closed:  # the last block, with the one before it
            self._check_block(len(self._window) - 1)
        js_topic, tol = self.tp["joint_states"], self.tol
        names = list(self.joint_names)
        note = f"{self.skipped} message(s) without the joints {names}" if self.skipped else ""
        out = [
            self.loop.result("loop constraint |Phi(q)|", js_topic, "m", tol, note),
            self.velocity.result("velocity constraint |Phi_q qd|", js_topic, "m/s", tol, note),
        ]
        if self.states:
            bad = self.n_bad
            out.append(
                CheckResult(
                    "finite joint states",
                    js_topic,
                    "count",
                    self.states,
                    float(bad),
                    self.first_bad if bad else math.nan,
                    0.0,
                    "FAIL" if bad else "ok",
                    f"{bad} joint states hold NaN/inf" if bad else "",
                )
            )
        out.append(self.gap.result("gap vs kinematics.gap(q)", self.tp["flap_gap"], "m", tol))
        if self.force_model is not None and self.accel_seen and self.states:
            out.append(self._accel_result())
        else:
            out.append(self._fd_result())
        return out

    def _accel_result(self) -> CheckResult:
        name, topic = "piston force vs model, logged accel.", self.tp["piston_acceleration"]
        if self.accel_used == 0:
            return _skipped(
                name,
                topic,
                "N",
                self.force_tol,
                "no joint state paired with an acceleration off the end stops",
            )
        if self.accel_refusal is not None:
            return _refused(name, topic, self.accel_used, self.force_tol, self.accel_refusal)
        note = f"{self.force_note}; {self.accel_on_stop} samples resting on an end stop left out"
        return self.accel.result(name, topic, "N", self.force_tol, note)

    def _fd_result(self) -> CheckResult:
        js_topic, force_tol = self.tp["joint_states"], self.force_tol
        if self.force_model is None:
            return _skipped(
                FORCE_CHECK, js_topic, "N", force_tol, self.force_note or "skipped: no force model"
            )
        if self.states < 3:
            return _skipped(FORCE_CHECK, js_topic, "N", force_tol, "fewer than 3 joint states")
        if self.fd_good < 3:
            return _skipped(
                FORCE_CHECK, js_topic, "N", force_tol, "fewer than 3 usable joint states"
            )
        if self.fd_refusal is not None:
            return _refused(FORCE_CHECK, js_topic, self.fd_good, force_tol, self.fd_refusal)
        note = (
            f"{self.force_note}; qdd by finite differences of the logged qd, peak |F| "
            f"{self.fd_peak:.4g} N"
        )
        if self.force_model_tol is None:
            res = self.fd.result(
                FORCE_CHECK,
                js_topic,
                "N",
                math.inf,
                note + "; informational, set a tolerance to enforce",
            )
            return CheckResult(
                **{**asdict(res), "tol": math.nan, "status": "info" if res.samples else res.status}
            )
        return self.fd.result(FORCE_CHECK, js_topic, "N", self.force_model_tol, note)


__all__ = [
    "BLOCK_STATES",
    "CheckResult",
    "ModelChecker",
    "ForceModelError",
    "joint_row",
    "load_force_model",
    "stamp_s",
]
