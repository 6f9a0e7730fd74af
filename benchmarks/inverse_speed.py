"""CPU per sample of the inverse dynamics: drs_model vs the lambdified sympy baseline.

Both paths go from time to piston force: profile -> kinematics -> force.

* ours, vectorised: :func:`drs_model.inverse.manoeuvre_force` (default ``"fused"``: the fused
  closed form) and, for reference, the Newton-Euler route through ``kinematic_state``;
* ours, one sample: :meth:`FusedInverseDynamics.force_at` (the compiled kernel, built once);
* baseline: the seed's profile (drs_model's, shared), the baseline's own Newton kinematics on its
  lambdified constraints, then its lambdified ``inverse_force``; one sample = the same call on an
  array of one.

A second table, one sample of Newton-Euler with every joint reaction, side by side: from a
state ``(q, qd, qdd)`` of shape ``(3,)`` through ``inverse_dynamics(state, p, "newton-euler")``
(what a caller with a state pays: validation, the compiled kernel, the result); from a time
through the scalar kinematics (:func:`~drs_model.kinematics.kinematic_state_scalar`) and the
same call; the manoeuvre route ``manoeuvre_force(t, p, "newton-euler")`` on an array of one; and
the baseline's lambdified ``inverse_force`` alone on the same state as arrays of one.

Medians of repeats of ``time.process_time`` (``time.perf_counter`` for the single-sample loops,
where process_time's resolution is too coarse).

Run: ``.venv/bin/python benchmarks/inverse_speed.py``.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from sympy_baseline import build_baseline  # noqa: E402

from drs_model.inverse import (  # noqa: E402
    FusedInverseDynamics,
    inverse_dynamics,
    manoeuvre_force,
    manoeuvre_state,
)
from drs_model.kinematics import kinematic_state_scalar  # noqa: E402
from drs_model.params import DRSParams  # noqa: E402
from drs_model.profile import drs_manoeuvre  # noqa: E402


def interleaved_medians(fns, repeats: int, clock=time.process_time) -> list[float]:
    """Median time [s] on ``clock`` of one call of each of ``fns``, the calls taken in turn at
    each repeat (the machine's slow and fast moments shared by all: a ratio of two medians taken
    apart moved by half between runs)."""
    out = [[] for _ in fns]
    for _ in range(repeats):
        for times, fn in zip(out, fns, strict=True):
            t0 = clock()
            fn()
            times.append(clock() - t0)
    return [statistics.median(times) for times in out]


def per_call(fn, calls: int, repeats: int = 5) -> float:
    """Median time [s] per call of ``fn`` in loops of ``calls`` calls."""

    def loop() -> None:
        for _ in range(calls):
            fn()

    return interleaved_medians((loop,), repeats, time.perf_counter)[0] / calls


def main() -> None:
    p = DRSParams()
    t_build = time.perf_counter()
    baseline = build_baseline(p)
    print(
        f"sympy baseline: derivation + lambdify {baseline.build_time:.3f} s "
        f"(build_baseline call {time.perf_counter() - t_build:.3f} s)"
    )
    man = drs_manoeuvre(p)
    fused = FusedInverseDynamics.from_params(p)

    def base_force(t: np.ndarray) -> np.ndarray:
        s, sd, sdd = man.evaluate(t)
        return baseline.inverse_force(*baseline.kinematics(s, sd, sdd))

    # same numbers first
    t = np.linspace(0.0, p.T_total, 1001)
    ref = manoeuvre_force(t, p)
    err = np.max(np.abs(base_force(t) - ref)) / np.max(np.abs(ref))
    print(f"max |F_baseline - F_ours| / max |F| over 1001 samples: {err:.2e}\n")

    header = (
        f"{'samples':>8}  {'ours [us/sample]':>17}  {'ours NE [us/sample]':>20}  "
        f"{'baseline [us/sample]':>21}  {'baseline/ours':>13}"
    )
    print(header)
    print("-" * len(header))
    cases = [
        (1, "1", np.array([0.0042])),
        (1000, "1000", np.linspace(0.0, p.T_total, 1000)),
        (100_000, "100000", np.linspace(0.0, p.T_total, 100_000)),
        # every sample inside the opening: no rest to compute once (the series path's saving)
        (100_000, "1e5 mv", np.linspace(0.0, p.T_opening, 100_002)[1:-1]),
    ]
    for n, label, t in cases:
        reps = 15 if n == 100_000 else 31
        if n == 1:
            ours = per_call(lambda: fused.force_at(0.0042), 20_000)
            ours_ne = per_call(lambda t=t: manoeuvre_force(t, p, "newton-euler"), 300)
            base = per_call(lambda t=t: base_force(t), 300)
        else:
            clock_reps = max(1, 100_000 // n // 10)

            def run_ours(t=t, k=clock_reps) -> None:
                for _ in range(k):
                    manoeuvre_force(t, p)

            def run_ne(t=t, k=clock_reps) -> None:
                for _ in range(k):
                    manoeuvre_force(t, p, "newton-euler")

            def run_base(t=t, k=clock_reps) -> None:
                for _ in range(k):
                    base_force(t)

            medians = interleaved_medians((run_ours, run_ne, run_base), reps)
            ours, ours_ne, base = (m / (n * clock_reps) for m in medians)
        print(
            f"{label:>8}  {ours * 1e6:>17.4g}  {ours_ne * 1e6:>20.4g}  {base * 1e6:>21.4g}  "
            f"{base / ours:>13.1f}"
        )
    print(
        "\nours at n = 1: FusedInverseDynamics.force_at (the compiled kernel, prebuilt); "
        "at n > 1: manoeuvre_force(t, p) (the fused kernel in one compiled pass over the "
        "times, the force once per stretch of rest).\n"
        "'mv': the times inside the opening only (every sample moving: nothing to reuse).\n"
        "ours NE: manoeuvre_force(t, p, 'newton-euler') (kinematic_state + closed-form NE)."
    )
    one_sample_newton_euler(p, baseline)


def one_sample_newton_euler(p: DRSParams, baseline) -> None:
    """Median time of one sample of Newton-Euler with every reaction, by route (module doc)."""
    t1 = 0.0042  # mid-opening: the rod accelerates, every term is non-zero
    _, st = manoeuvre_state(np.array([t1]), p)
    state = (st.q[0], st.qd[0], st.qdd[0])
    man = drs_manoeuvre(p)

    def from_time() -> None:
        s, sd, sdd = (float(x) for x in man.evaluate(t1))
        inverse_dynamics(kinematic_state_scalar(s, sd, sdd, p), p, "newton-euler")

    routes = {
        "inverse_dynamics(state of one, 'newton-euler')": (
            lambda: inverse_dynamics(state, p, "newton-euler"),
            20_000,
        ),
        "time -> kinematic_state_scalar -> the same": (from_time, 5_000),
        "manoeuvre_force([t], p, 'newton-euler')": (
            lambda: manoeuvre_force(np.array([t1]), p, "newton-euler"),
            300,
        ),
        "baseline inverse_force(state of one) alone": (
            lambda: baseline.inverse_force(st.q, st.qd, st.qdd),
            3_000,
        ),
    }
    res = inverse_dynamics(state, p, "newton-euler")
    print(
        f"\none sample of Newton-Euler, every reaction (F = {float(res.piston_force):.6g} N, "
        f"{len(res.reactions)} reactions); medians of 5 loops, time.perf_counter"
    )
    print(f"{'route':<50}  {'us per sample':>13}")
    for name, (fn, calls) in routes.items():
        print(f"{name:<50}  {per_call(fn, calls) * 1e6:>13.3g}")


if __name__ == "__main__":
    main()
