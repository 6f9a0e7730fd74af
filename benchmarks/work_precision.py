"""Work-precision benchmark of the forward dynamics on the seed manoeuvre.

Problem: the open-hold-close manoeuvre (0-50 ms) driven by its own inverse-dynamics piston force
(:class:`drs_model.forward.ManoeuvreForce`, exact to rounding). The exact solution of the forward
problem is then the profile itself, so the reference is the profile ``s(t)`` (and ``psi3(s(t))``
in closed form), not a tight numerical run: it carries no integration error of its own. A DOP853
run at rtol 1e-13 on formulation (a) is recorded against it as a check (its deviation bounds what
the rounding of the force, amplified by the open-loop instability, leaves).

For every formulation x adaptive method x rtol (and every fixed-step method x dt) it records the
errors ``max |s - s_ref|``, ``max |psi3 - psi3_ref|`` over a 0.1 ms grid, the constraint residual
(full coordinates), the CPU time (``time.process_time``, median of repeats), the function
evaluations, or the failure (type and message). The baseline a user would otherwise take - the
sympy.physics.mechanics index-1 right-hand side of ``benchmarks/sympy_baseline.py`` with
solve_ivp (RK45, DOP853, Radau, LSODA; same segments and force) - runs in the same process.

The compiled methods of :mod:`drs_model.compiled.simulate` (``dopri5-numba``, ``dop853-numba``
on formulation (a), numba) run as further rows when numba is installed: warmed first (compiled, or
loaded from numba's cache), each timed over a batch of calls; the one-off start-up cost of every
numba function of drs_model (:func:`drs_model.compiled.warm.warm_up`) is measured apart, in fresh
interpreters, without and with numba's on-disk cache (``compiled`` in the JSON).

Outputs ``benchmarks/results/work_precision.json`` and ``docs/img/work_precision.png`` (left: the
baseline and our best few; right: every row); prints the target ratios. ``--quick`` runs a subset
in ~30 s. Importable: :func:`run` returns the figures.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # pragma: no cover - running as a script
    sys.path.insert(0, str(ROOT))

from drs_model import forward as fw  # noqa: E402
from drs_model.errors import DRSError  # noqa: E402
from drs_model.forward import FixedStepIntegrator, FullCoordinates, simulate  # noqa: E402
from drs_model.kinematics import (  # noqa: E402
    dead_centre,
    solve_position,
    stroke_limits,
)
from drs_model.params import DRSParams  # noqa: E402

FORMULATIONS = ("psi3", "s", "index1", "baumgarte", "projection")
METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
RTOLS = (1e-4, 1e-6, 1e-8, 1e-10, 1e-12)
FIXED = ("rk4", "rk2", "semi-implicit-euler")
DTS = (1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5)
BASELINE_METHODS = ("RK45", "DOP853", "Radau", "LSODA")
COMPILED = ("dopri5-numba", "dop853-numba")  # formulation (a) only
COMPILED_RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
COMPILED_INNER = 20  # calls per timing sample (one call takes ~0.1-0.5 ms)
TARGETS = (1e-6, 1e-9)  # max |s err| [m]

QUICK = {
    "formulations": ("psi3", "s", "index1", "projection"),
    "methods": ("RK45", "DOP853", "LSODA"),
    "rtols": (1e-6, 1e-9, 1e-11),
    "fixed": ("rk4",),
    "dts": (1e-3, 1e-4, 1e-5),
    "baseline_methods": ("DOP853", "LSODA"),
    "compiled_rtols": (1e-6, 1e-9, 1e-11),
}


def _cpu(fn, repeats: int, inner: int = 1):
    """(median CPU seconds per call, last result) of ``repeats`` samples of ``inner`` calls."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.process_time()
        for _ in range(inner):
            out = fn()
        times.append((time.process_time() - t0) / inner)
    return statistics.median(times), out


class Problem:
    """The manoeuvre, its force, the grid and the exact reference."""

    def __init__(self, p: DRSParams, n_grid: int = 501) -> None:
        self.p = p
        self.force = fw.ManoeuvreForce(p)
        self.t_end = p.T_total
        self.grid = np.linspace(0.0, self.t_end, n_grid)
        s, _, _ = self.force.profile(self.grid)
        self.s_ref = s
        self.psi3_ref = solve_position(s, p)[:, 2]

    def errors(self, t, s, psi3) -> tuple[float, float]:
        s_ref, _, _ = self.force.profile(t)
        psi_ref = solve_position(s_ref, self.p)[:, 2]
        return float(np.max(np.abs(s - s_ref))), float(np.max(np.abs(psi3 - psi_ref)))


def adaptive_case(
    prob: Problem, form: str, method: str, rtol: float, repeats: int, inner: int = 1
) -> dict:
    options = {"drift_bound": 1e-3} if form in ("index1", "baumgarte", "projection") else {}
    kind = "compiled" if method in COMPILED else "adaptive"
    rec = {"kind": kind, "formulation": form, "method": method, "rtol": rtol}

    def go():
        return simulate(
            form,
            prob.force,
            (0.0, prob.t_end),
            params=prob.p,
            method=method,
            rtol=rtol,
            t_eval=prob.grid,
            **options,
        )

    try:
        cpu, sol = _cpu(go, repeats, inner)
    except DRSError as exc:
        rec.update(ok=False, error=type(exc).__name__, message=str(exc)[:300])
        return rec
    es, ep = prob.errors(sol.t, sol.s, sol.psi3)
    rec.update(
        ok=True,
        cpu=cpu,
        nfev=sol.nfev,
        njev=sol.njev,
        nlu=sol.nlu,
        nsteps=sol.nsteps,
        nrejected=sol.nrejected,
        err_s=es,
        err_psi3=ep,
        residual=float(np.max(sol.residual)),
        velocity_residual=float(np.max(sol.velocity_residual)),
    )
    return rec


def fixed_case(prob: Problem, method: str, dt: float, repeats: int) -> dict:
    n = int(round(prob.t_end / dt))
    rec = {"kind": "fixed", "formulation": "psi3", "method": method, "dt": dt, "steps": n}
    integ = FixedStepIntegrator(prob.p, dt, method=method, stroke_margin=1e-3)
    force = prob.force

    def go():
        integ.reset()
        out = np.empty((n, 3))
        step = integ.step
        for i in range(n):
            st = step(force)
            out[i] = st.t, st.s, st.psi3
        return out

    try:
        cpu, out = _cpu(go, repeats)
    except DRSError as exc:
        rec.update(ok=False, error=type(exc).__name__, message=str(exc)[:300])
        return rec
    es, ep = prob.errors(out[:, 0], out[:, 1], out[:, 2])
    evals = {"rk4": 4, "rk2": 2}.get(method, 1)
    rec.update(
        ok=True,
        cpu=cpu,
        nfev=evals * n,
        err_s=es,
        err_psi3=ep,
        residual=0.0,
        us_per_step=cpu / n * 1e6,
    )
    return rec


def realtime_step_cost(p: DRSParams, dt: float, n: int = 20000, repeats: int = 5) -> dict:
    """CPU per ``step(F)`` with a float force held over the step (the node's use), us."""
    force = fw.ManoeuvreForce(p)
    integ = FixedStepIntegrator(p, dt, method="rk4", stroke_margin=1e-3)
    n_man = int(round(p.T_total / dt))
    forces = [force(k * dt) for k in range(n_man)]
    costs = []
    for _ in range(repeats):
        done = 0
        t0 = time.process_time()
        while done < n:
            integ.reset()
            step = integ.step
            for f in forces:
                try:
                    step(f)
                except DRSError:
                    break  # ZOH of a 10 ms move at 1 kHz may overrun the stroke: restart
                done += 1
        costs.append((time.process_time() - t0) / done * 1e6)
    return {
        "dt": dt,
        "method": "rk4",
        "formulation": "psi3",
        "us_per_step": min(costs),
        "us_per_step_median": statistics.median(costs),
        "steps": n,
    }


def baseline_case(prob: Problem, bl, method: str, rtol: float, repeats: int) -> dict:
    rec = {"kind": "baseline", "formulation": "sympy-index1", "method": method, "rtol": rtol}
    bps = [0.0, *prob.force.breakpoints[1:-1], prob.t_end]
    q0 = solve_position(stroke_limits(prob.p)[0], prob.p)
    y0 = np.concatenate([q0, np.zeros(3)])
    atol = rtol * np.array(FullCoordinates.scales)

    def go():
        y, ts, ss, ps, nfev = y0, [], [], [], 0
        for k, (a, b) in enumerate(zip(bps[:-1], bps[1:], strict=True)):
            piece = prob.force.segment(a, b)
            mask = (prob.grid >= a if k == 0 else prob.grid > a) & (prob.grid <= b)
            sol = solve_ivp(
                lambda t, yy, f=piece: bl.rhs(t, yy, f),
                (a, b),
                y,
                method=method,
                t_eval=prob.grid[mask],
                rtol=rtol,
                atol=atol,
            )
            if sol.status != 0:
                raise RuntimeError(sol.message)
            nfev += sol.nfev
            ts.append(sol.t)
            ss.append(sol.y[0])
            ps.append(sol.y[2])
            y = sol.y[:, -1]
        return np.concatenate(ts), np.concatenate(ss), np.concatenate(ps), nfev

    try:
        cpu, (t, s, psi3, nfev) = _cpu(go, repeats)
    except (RuntimeError, ArithmeticError, ValueError) as exc:
        rec.update(ok=False, error=type(exc).__name__, message=str(exc)[:300])
        return rec
    es, ep = prob.errors(t, s, psi3)
    rec.update(ok=True, cpu=cpu, nfev=nfev, err_s=es, err_psi3=ep)
    return rec


# ---- stability study ----------------------------------------------------------------------------
def _outcome(fn) -> dict:
    try:
        out = fn()
    except DRSError as exc:
        return {"ok": False, "error": type(exc).__name__, "message": str(exc)[:300]}
    return {"ok": True, **out}


def stability_study(p: DRSParams, quick: bool) -> list[dict]:
    rows = []
    force = fw.ManoeuvreForce(p)
    s_min, s_max = stroke_limits(p)
    s_dead = dead_centre(p)
    hold_closed = force(0.0)
    # 1. near the dead centre: 20 % less than the closed holding force lets the flap close further
    low = 0.8 * hold_closed
    for form in ("s", "psi3"):

        def go(form=form):
            sol = simulate(form, low, (0.0, 0.03), params=p, method="DOP853", rtol=1e-9)
            i = int(np.argmin(sol.s))
            return {
                "min_s": float(sol.s[i]),
                "t_min_s": float(sol.t[i]),
                "psi3_at_min_s": float(sol.psi3[i]),
            }

        rows.append(
            {
                "study": "dead centre",
                "case": f"{form}, F = 0.8 F_hold(closed)",
                "s_dead": s_dead,
                **_outcome(go),
            }
        )

    def go_fixed_dead():
        integ = FixedStepIntegrator(p, 1e-4)
        for _ in range(500):
            integ.step(low)
        return {"t": integ.t}

    rows.append(
        {
            "study": "dead centre",
            "case": "fixed rk4 dt=0.1 ms, F = 0.8 F_hold(closed)",
            **_outcome(go_fixed_dead),
        }
    )
    # 2. fixed step too large on the manoeuvre
    for dt in (2e-3, 5e-3) if quick else (1e-3, 2e-3, 5e-3, 1e-2):
        for method in ("rk4",) if quick else ("rk4", "rk2", "semi-implicit-euler"):

            def go(dt=dt, method=method):
                integ = FixedStepIntegrator(p, dt, method=method, stroke_margin=1e-3)
                n = int(round(p.T_total / dt))
                errs = []
                for _ in range(n):
                    st = integ.step(force)
                    errs.append(abs(st.s - float(force.profile(st.t)[0])))
                return {"err_s": max(errs)}

            rows.append(
                {"study": "fixed step", "case": f"{method} dt={dt * 1e3:g} ms", **_outcome(go)}
            )
    # 3. Baumgarte gains (RK45 and Radau at rtol 1e-6)
    gains = (0.0, 50.0, 1e3, 1e5) if quick else (0.0, 10.0, 50.0, 200.0, 1e3, 1e4, 1e5)
    for method in ("RK45",) if quick else ("RK45", "Radau"):
        for k in gains:

            def go(k=k, method=method):
                t0 = time.process_time()
                sol = simulate(
                    "index1" if k == 0 else "baumgarte",
                    force,
                    (0.0, p.T_total),
                    params=p,
                    method=method,
                    rtol=1e-6,
                    drift_bound=1e-3,
                    **({} if k == 0 else {"alpha": k, "beta": k}),
                )
                cpu = time.process_time() - t0
                s_ref = force.profile(sol.t)[0]
                return {
                    "nfev": sol.nfev,
                    "cpu": cpu,
                    "err_s": float(np.max(np.abs(sol.s - s_ref))),
                    "residual": float(np.max(sol.residual)),
                }

            rows.append(
                {
                    "study": "Baumgarte gains",
                    "case": f"{method} alpha=beta={k:g} 1/s",
                    **_outcome(go),
                }
            )
    # 4. drift over a long run: five manoeuvres back to back (0.25 s), RK45 at rtol 1e-8
    periodic = Periodic(force, 5)
    for form in ("index1", "baumgarte", "projection", "psi3"):

        def go(form=form):
            t_end = 5 * p.T_total
            grid = np.linspace(0.0, t_end, 6)
            sol = simulate(
                form,
                periodic,
                (0.0, t_end),
                params=p,
                method="RK45",
                rtol=1e-8,
                t_eval=grid,
                **({} if form == "psi3" else {"drift_bound": 1.0}),
            )
            s_ref = force.profile(np.mod(grid, p.T_total))[0]
            return {
                "residual_after_1": float(sol.residual[1]),
                "residual_after_5": float(sol.residual[-1]),
                "err_s_after_5": float(abs(sol.s[-1] - s_ref[-1])),
                "nfev": sol.nfev,
            }

        rows.append(
            {
                "study": "drift, 5 manoeuvres (0.25 s)",
                "case": f"{form} RK45 rtol 1e-8",
                **_outcome(go),
            }
        )

    # 5. index-1 with a tight drift bound at loose tolerance: the drift error is raised
    def go_drift():
        sol = simulate(
            "index1", force, (0.0, p.T_total), params=p, method="RK45", rtol=1e-3, drift_bound=1e-7
        )
        return {"residual": float(np.max(sol.residual))}

    rows.append(
        {
            "study": "drift bound",
            "case": "index1 RK45 rtol 1e-3, drift_bound 1e-7 m",
            **_outcome(go_drift),
        }
    )
    return rows


class Periodic:
    """The manoeuvre force repeated ``n`` times (the force protocol of drs_model.forward)."""

    def __init__(self, force: fw.ManoeuvreForce, n: int) -> None:
        self.force, self.period = force, force.p.T_total
        self.breakpoints = tuple(k * self.period + b for k in range(n) for b in force.breakpoints)

    def __call__(self, t: float) -> float:
        return self.force(t % self.period)

    def segment(self, a: float, b: float):
        k = math.floor(0.5 * (a + b) / self.period)
        shift = k * self.period
        piece = self.force.segment(a - shift, b - shift)
        return lambda t: piece(t - shift)


def growth_rates(p: DRSParams) -> dict:
    """Open-loop growth rate sqrt(d psi3''/d psi3) [1/s] at rest at both ends (hold force)."""
    force = fw.ManoeuvreForce(p)
    f = fw.Psi3Minimal(p)
    out = {}
    for name, s, F in (
        ("closed", stroke_limits(p)[0], force(0.0)),
        ("open", stroke_limits(p)[1], force(0.025)),
    ):
        b = float(solve_position(s, p)[2])
        h = 1e-7
        k = (f.accel(b + h, 0.0, F) - f.accel(b - h, 0.0, F)) / (2 * h)
        out[name] = math.sqrt(k) if k > 0 else -math.sqrt(-k)
    return out


# ---- summary, chart -----------------------------------------------------------------------------
def _best(records, target):
    ok = [r for r in records if r.get("ok") and r["err_s"] <= target]
    return min(ok, key=lambda r: r["cpu"]) if ok else None


def summarise(results: dict) -> dict:
    """Per target: the fastest of ours (every row, compiled included), the fastest pure-Python
    row, the fastest baseline row, and the ratios."""
    python = [r for r in results["adaptive"] + results["fixed"] if r.get("ok")]
    ours = python + [r for r in results.get("compiled_rows", []) if r.get("ok")]
    base = [r for r in results["baseline"] if r.get("ok")]
    out = {}
    for target in TARGETS:
        b_ours, b_py, b_base = _best(ours, target), _best(python, target), _best(base, target)
        entry = {"target_err_s": target, "ours": b_ours, "ours_python": b_py, "baseline": b_base}
        if b_ours and b_base:
            entry["cpu_ratio"] = b_base["cpu"] / b_ours["cpu"]
            entry["meets_20x"] = entry["cpu_ratio"] >= 20.0
        if b_py and b_base:
            entry["cpu_ratio_python"] = b_base["cpu"] / b_py["cpu"]
        out[f"{target:g}"] = entry
    return out


def _label(r: dict) -> str:
    setting = f"rtol {r['rtol']:g}" if "rtol" in r else f"dt {r['dt']:g}"
    return f"{r['formulation']}/{r['method']} {setting}"


# ---- start-up cost of the compiled path ---------------------------------------------------------
_STARTUP = r"""
import json, time
t0 = time.perf_counter()
import numba
t_numba = time.perf_counter() - t0
from drs_model.compiled.warm import warm_up
t1 = time.perf_counter()
warm_up()
t_warm = time.perf_counter() - t1
print(json.dumps({"import_numba_s": t_numba, "compile_or_load_s": t_warm,
                  "numba": numba.__version__}))
"""


def compiled_startup() -> dict:
    """One-off cost of the compiled path in a fresh interpreter [s, wall]: import numba, then
    compile every kernel and run both methods (``warm_up``), first with an empty numba cache
    (cold: compile and write the cache), then again with that cache (what every later start
    pays, e.g. the second CI test run or node start on the same checkout)."""
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        for key in ("cold", "cached"):
            proc = subprocess.run(
                [sys.executable, "-c", _STARTUP],
                env=env,
                capture_output=True,
                text=True,
                timeout=600,
                check=True,
            )
            out[key] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


FLOOR_RTOLS = (1e-6, 1e-9)
FLOOR_TARGET = 1.5  # a compiled run within 1.5x of nfev x (RHS + force)


def compiled_floor(prob: Problem, repeats: int = 15, inner: int = 20, n: int = 2000) -> list[dict]:
    """The compiled methods against their floor, ``nfev x (RHS + force)``: per repeat, back to back,
    the CPU time of one ``simulate`` call and of ``n`` compiled evaluations of the psi3 right-hand
    side (at the states of the run) and of the manoeuvre force (at its times); the ratio's median
    over the repeats (and the ratio of the fastest samples) is printed."""
    from drs_model import elementwise
    from drs_model.compiled import simulate as compiled

    p = prob.p
    form = compiled.psi3_formulation(p)
    kc = compiled.psi3_constants(form)
    mc, mp = compiled.manoeuvre_constants(prob.force)
    t = np.linspace(0.0, prob.t_end, n)
    out = []
    for method in COMPILED:
        for rtol in FLOOR_RTOLS:

            def go(method=method, rtol=rtol):
                return simulate(
                    "psi3", prob.force, (0.0, prob.t_end), params=p, method=method, rtol=rtol
                )

            sol = go()
            b = np.interp(t, sol.t, sol.y[0])
            bd = np.interp(t, sol.t, sol.y[1])
            f = elementwise.fused_manoeuvre_force(t, mc, mp)

            def rhs_block(b=b, bd=bd, f=f):
                return elementwise.psi3_acceleration(b, bd, f, kc)

            def force_block():
                return elementwise.fused_manoeuvre_force(t, mc, mp)

            calls, rhs, force = [], [], []
            _cpu(go, 1, inner)  # warm the caches of this method and tolerance
            for _ in range(repeats):
                calls.append(_cpu(go, 1, inner)[0])
                rhs.append(_cpu(rhs_block, 1, inner)[0] / n)
                force.append(_cpu(force_block, 1, inner)[0] / n)
            ratios = [c / (sol.nfev * (r + g)) for c, r, g in zip(calls, rhs, force, strict=True)]
            out.append(
                {
                    "method": method,
                    "rtol": rtol,
                    "nfev": sol.nfev,
                    "call_us": statistics.median(calls) * 1e6,
                    "rhs_ns": statistics.median(rhs) * 1e9,
                    "force_ns": statistics.median(force) * 1e9,
                    "ratio": statistics.median(ratios),
                    "ratio_fastest": min(calls) / (sol.nfev * (min(rhs) + min(force))),
                }
            )
    return out


def floor_report(rows: list[dict]) -> str:
    return "\n".join(
        f"{r['method']} rtol {r['rtol']:g}: {r['call_us']:.1f} us per run, nfev {r['nfev']} x "
        f"(RHS {r['rhs_ns']:.0f} ns + force {r['force_ns']:.0f} ns) = "
        f"{r['nfev'] * (r['rhs_ns'] + r['force_ns']) * 1e-3:.1f} us: ratio {r['ratio']:.2f} "
        f"(fastest samples {r['ratio_fastest']:.2f}; target <= {FLOOR_TARGET:g}: "
        f"{'met' if r['ratio'] <= FLOOR_TARGET else 'missed'})"
        for r in rows
    )


def _groups(records) -> dict[str, list]:
    groups: dict[str, list] = {}
    for r in records:
        if r.get("ok"):
            groups.setdefault(f"{r['formulation']} {r['method']}", []).append(r)
    return {k: sorted(v, key=lambda r: r["cpu"]) for k, v in sorted(groups.items())}


def _highlights(results: dict) -> set[str]:
    """The baseline's best method and our fastest few groups at the targets."""
    keys = set()
    for e in results["summary"].values():
        for who in ("ours", "ours_python", "baseline"):
            if e.get(who):
                keys.add(f"{e[who]['formulation']} {e[who]['method']}")
    keys |= {f"psi3 {m}" for m in COMPILED} | {"psi3 DOP853", "psi3 LSODA"}
    return keys


def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    records = (
        results["adaptive"]
        + results.get("compiled_rows", [])
        + results["fixed"]
        + results["baseline"]
    )
    groups = _groups(records)
    keep = _highlights(results)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(15, 6.5), sharey=True)
    cmap = plt.get_cmap("tab20")

    def draw(ax, items, lw_scale):
        for i, (key, recs) in enumerate(items):
            base = key.startswith("sympy")
            comp = recs[0]["kind"] == "compiled"
            style = "--" if base else (":" if recs[0]["kind"] == "fixed" else "-")
            color = (
                "k"
                if base
                else (
                    "tab:red" if "dop853-numba" in key else "tab:orange" if comp else cmap(i % 20)
                )
            )
            ax.loglog(
                [r["cpu"] for r in recs],
                [max(r["err_s"], 1e-16) for r in recs],
                style,
                marker="s" if comp else "o",
                ms=3.5,
                color=color,
                label=key,
                lw=(2.5 if base or comp else 1.2) * lw_scale,
            )
        for target in TARGETS:
            ax.axhline(target, color="grey", lw=0.6)
        ax.set_xlabel("CPU time per simulation [s] (median of repeats)")
        ax.grid(True, which="both", lw=0.3)

    draw(ax1, [(k, v) for k, v in groups.items() if k in keep], 1.0)
    for e in results["summary"].values():
        if e.get("ours") and e.get("baseline"):
            o, b = e["ours"], e["baseline"]
            ax1.annotate(
                f"{e['cpu_ratio']:.0f}x",
                xy=(o["cpu"], e["target_err_s"]),
                xytext=(b["cpu"], e["target_err_s"]),
                fontsize=8,
                va="bottom",
                arrowprops={"arrowstyle": "->", "lw": 0.8},
            )
    ax1.set_ylabel("max |s - s_ref| [m] over the 0.1 ms grid")
    ax1.set_title("Baseline (sympy index-1) and our best (compiled psi3 in red/orange)")
    ax1.legend(fontsize=7.5, loc="upper right")
    draw(ax2, list(groups.items()), 0.8)
    ax2.set_title("Every formulation x method")
    ax2.legend(fontsize=5.5, ncol=2, loc="upper right")
    fig.suptitle("Forward dynamics on the seed manoeuvre: work-precision")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(
    quick: bool = False,
    json_path: Path | str | None = ROOT / "benchmarks" / "results" / "work_precision.json",
    png_path: Path | str | None = ROOT / "docs" / "img" / "work_precision.png",
    repeats: int | None = None,
    log=print,
) -> dict:
    """Run the benchmark, write the JSON and the chart (unless a path is None), return the
    figures."""
    t_start = time.perf_counter()
    p = DRSParams()
    prob = Problem(p)
    cfg = (
        QUICK
        if quick
        else {
            "formulations": FORMULATIONS,
            "methods": METHODS,
            "rtols": RTOLS,
            "fixed": FIXED,
            "dts": DTS,
            "baseline_methods": BASELINE_METHODS,
        }
    )
    repeats = (1 if quick else 3) if repeats is None else repeats
    results: dict = {"quick": quick, "repeats": repeats, "reference": "exact profile s(t)"}

    # the reference and the force, checked
    sol = simulate(
        "psi3", prob.force, (0, prob.t_end), params=p, method="DOP853", rtol=1e-13, t_eval=prob.grid
    )
    es, ep = prob.errors(sol.t, sol.s, sol.psi3)
    results["reference_check"] = {
        "dop853_rtol1e-13_vs_profile_err_s": es,
        "dop853_rtol1e-13_vs_profile_err_psi3": ep,
    }
    f_ours = np.array([prob.force(t) for t in prob.grid])
    try:
        from drs_model.inverse import manoeuvre_force

        results["force_check_vs_dynamics"] = float(
            np.max(np.abs(manoeuvre_force(prob.grid, p) - f_ours))
        )
    except ImportError:  # pragma: no cover
        results["force_check_vs_dynamics"] = None
    results["growth_rate_per_s"] = growth_rates(p)
    t0 = time.perf_counter()
    results["force_us_per_call"] = (
        _cpu(lambda: [prob.force(t) for t in prob.grid], 3)[0] / prob.grid.size * 1e6
    )
    log(
        f"reference check: DOP853 rtol 1e-13 vs profile: max|ds| = {es:.2e} m; "
        f"growth rates {results['growth_rate_per_s']}"
    )

    results["adaptive"] = []
    for form in cfg["formulations"]:
        for method in cfg["methods"]:
            for rtol in cfg["rtols"]:
                if method in ("Radau", "BDF") and rtol < 1e-11:
                    continue  # minutes of CPU, nothing to learn
                rec = adaptive_case(prob, form, method, rtol, repeats)
                results["adaptive"].append(rec)
    log(f"adaptive: {len(results['adaptive'])} runs in {time.perf_counter() - t0:.1f} s")

    t0 = time.perf_counter()
    results["compiled_rows"] = []
    try:
        from drs_model.compiled.warm import warm_up

        t_w = time.perf_counter()
        warm_up(p)  # compile or load from cache before any timing
        results["compiled"] = {"in_process_warm_up_s": time.perf_counter() - t_w}
    except ImportError as exc:  # numba missing: the pure-Python rows only
        results["compiled"] = {"unavailable": str(exc)}
        log(f"compiled methods skipped: {exc}")
    else:
        rtols = cfg.get("compiled_rtols", COMPILED_RTOLS)
        for method in COMPILED:
            for rtol in rtols:
                results["compiled_rows"].append(
                    adaptive_case(prob, "psi3", method, rtol, repeats, inner=COMPILED_INNER)
                )
        results["compiled_floor"] = compiled_floor(prob, repeats=5 if quick else 15)
        results["compiled"].update(compiled_startup())
        log(
            f"compiled: {len(results['compiled_rows'])} runs + start-up in "
            f"{time.perf_counter() - t0:.1f} s"
        )
    t0 = time.perf_counter()
    results["fixed"] = [fixed_case(prob, m, dt, repeats) for m in cfg["fixed"] for dt in cfg["dts"]]
    results["realtime"] = [
        realtime_step_cost(p, dt, n=5000 if quick else 20000) for dt in (1e-3, 1e-4)
    ]
    log(f"fixed step: {time.perf_counter() - t0:.1f} s")

    t0 = time.perf_counter()
    results["baseline"] = []
    try:
        from benchmarks.sympy_baseline import build_baseline
    except ImportError:  # pragma: no cover - run from benchmarks/
        from sympy_baseline import build_baseline  # type: ignore[no-redef]
    bl = build_baseline(p)
    results["baseline_build_time"] = bl.build_time
    q = solve_position(prob.s_ref[::50], p)
    results["force_check_vs_baseline"] = float(
        np.max(np.abs(bl.inverse_force(*_kin(prob, q)) - f_ours[::50]))
    )
    for method in cfg["baseline_methods"]:
        for rtol in cfg["rtols"]:
            if method == "Radau" and rtol < 1e-9:
                continue
            results["baseline"].append(baseline_case(prob, bl, method, rtol, repeats))
    log(f"baseline: {time.perf_counter() - t0:.1f} s (derivation {bl.build_time:.2f} s)")

    t0 = time.perf_counter()
    results["stability"] = stability_study(p, quick)
    log(f"stability study: {time.perf_counter() - t0:.1f} s")
    results["summary"] = summarise(results)
    results["wall_time"] = time.perf_counter() - t_start
    if json_path is not None:
        json_path = Path(json_path)
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps(_clean(results), indent=1))
    if png_path is not None:
        plot(results, Path(png_path))
    return results


def _kin(prob: Problem, q):
    """(q, qd, qdd) of the profile at the grid points used for the force check."""
    from drs_model.kinematics import kinematic_state

    s, sd, sdd = prob.force.profile(prob.grid[::50])
    st = kinematic_state(s, sd, sdd, prob.p)
    return st.q, st.qd, st.qdd


def _clean(obj):
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def report(results: dict) -> str:
    """The human summary: target ratios, fixed-step cost, stability study."""
    lines = []
    for key, e in results["summary"].items():
        o, py, b = e["ours"], e.get("ours_python"), e["baseline"]
        if o is None or b is None:
            lines.append(f"target {key}: ours {o and o['cpu']}, baseline {b and b['cpu']}")
            continue
        lines.append(
            f"target {key}: ours {o['cpu'] * 1e3:.3f} ms ({_label(o)}), baseline "
            f"{b['cpu'] * 1e3:.2f} ms ({_label(b)}), ratio {e['cpu_ratio']:.1f} (target >= 20: "
            f"{'met' if e['meets_20x'] else 'missed'})"
        )
        if py is not None:
            lines.append(
                f"    best pure Python: {py['cpu'] * 1e3:.2f} ms ({_label(py)}), ratio "
                f"{e['cpu_ratio_python']:.1f}"
            )
    comp = results.get("compiled", {})
    if "cold" in comp:
        cold, cached = comp["cold"], comp["cached"]
        lines.append(
            f"compiled start-up (numba {cold['numba']}, fresh interpreter, wall): import numba "
            f"{cold['import_numba_s']:.2f} s; compile {cold['compile_or_load_s']:.2f} s without "
            f"numba's cache, {cached['compile_or_load_s']:.2f} s from the cache"
        )
    elif comp:
        lines.append(f"compiled methods: {comp}")
    if results.get("compiled_floor"):
        lines.append("compiled run against nfev x (RHS + force):")
        lines.append(floor_report(results["compiled_floor"]))
    for r in results["realtime"]:
        lines.append(
            f"fixed step rk4/psi3 dt = {r['dt'] * 1e3:g} ms: {r['us_per_step']:.2f} us per step "
            f"(median {r['us_per_step_median']:.2f}; target <= 20 us)"
        )
    lines.append(f"force evaluation: {results['force_us_per_call']:.2f} us per call")
    lines.append("stability study:")
    for r in results["stability"]:
        what = r.get("error", "ok")
        detail = (
            r.get("message", "")
            if not r["ok"]
            else ", ".join(
                f"{k}={v:.3g}" for k, v in r.items() if isinstance(v, float) and k != "s_dead"
            )
        )
        lines.append(f"  [{r['study']}] {r['case']}: {what} {detail[:160]}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a ~30 s subset")
    ap.add_argument("--repeats", type=int, default=None)
    ap.add_argument(
        "--floor", action="store_true", help="only the compiled runs against their floor (~10 s)"
    )
    args = ap.parse_args(argv)
    if args.floor:
        from drs_model.compiled.warm import warm_up

        prob = Problem(DRSParams())
        warm_up(prob.p)
        print(floor_report(compiled_floor(prob, repeats=args.repeats or 15)))
        return 0
    results = run(quick=args.quick, repeats=args.repeats)
    print(report(results))
    print(f"wall time {results['wall_time']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
