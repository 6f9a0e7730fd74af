"""The hydraulic rung's stiffness: the largest stable sub-step of each fixed-step method over the
oil's bulk modulus and the chambers' dead volume, and a work-precision chart (error against a
tight reference vs cost per simulated second) at the defaults.

Stable: the open-hold-close scene with 100 ms moves (0.6 s) and a 1500 N force step (0.2 s)
run to the end with every state finite, the stroke within 1 mm of its range and the pressures
below 10x the supply. The largest stable sub-step is found by bisection (8 halvings between
1 us and 1 ms, RK4's guard off), next to the guard's predicted limit (``RK4_LIMIT /
stiffest_rate``, its smallest over the run). The implicit methods are stable at 1 ms (the
physics step: no sub-step) everywhere on the grid; their step is set by accuracy.

Usage: ``python benchmarks/hydraulic_stability.py [--quick] [--json]``; writes
``benchmarks/results/hydraulic_stability.json`` and ``docs/img/hydraulic_work_precision.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from drs_model import DRSParams
from drs_model.errors import DRSError
from drs_model.fidelity import HydraulicParams, make_rung
from drs_model.fidelity import hydraulic_kernels as hk
from drs_model.fidelity.hydraulic_steps import RK4_LIMIT, STEP_METHODS
from drs_model.fidelity.ladder import REFERENCE
from drs_model.fidelity.scenes import SCENES, run_scene

ROOT = Path(__file__).resolve().parents[1]
P = DRSParams()
SCENE_NAMES = ("open-hold-close-100ms", "force-step")


def stable(hp: HydraulicParams, method: str, substep: float) -> bool:
    """Whether both scenes run to the end at ``substep`` [s] (module docstring)."""
    for name in SCENE_NAMES:
        try:
            tr = run_scene(
                "hydraulic",
                SCENES[name],
                P,
                1e-3,
                hydraulic=hp,
                method=method,
                substep=substep,
                guard=False,
            )
        except (DRSError, FloatingPointError, ValueError):
            return False
        lo, hi = tr.stroke.min(), tr.stroke.max()
        if not (np.all(np.isfinite(tr.stroke)) and lo > -1.5e-3 and hi < 0.047):
            return False
    return True


def largest_stable(hp: HydraulicParams, method: str) -> float:
    """The largest stable sub-step [s] (bisection in log between 1 us and 1 ms)."""
    lo, hi = 1e-6, 1e-3
    if stable(hp, method, hi):
        return hi
    if not stable(hp, method, lo):
        return math.nan
    for _ in range(8):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if stable(hp, method, mid) else (lo, mid)
    return lo


def predicted_limit(hp: HydraulicParams) -> float:
    """The guard's limit [s]: ``RK4_LIMIT / stiffest_rate``, smallest over the guarded run."""
    rung = make_rung("hydraulic", P, 1e-3, hydraulic=hp)
    c, h = rung._consts
    worst = 0.0
    rung.command_stroke(rung.s_max, 0.1)
    for _ in range(400):
        y = rung.y
        ps = hp.supply_pressure
        rate = hk.stiffest_rate(y[0], y[1], y[2], y[3], y[4], ps, tuple(c), tuple(h))
        worst = max(worst, rate)
        rung.step()
    return RK4_LIMIT / worst


def oil_frequency(hp: HydraulicParams) -> float:
    """The oil column's natural frequency [rad/s] at mid-stroke, at rest (Merritt)."""
    rung = make_rung("hydraulic", P, 1e-3, hydraulic=hp)
    rung.reset(s=0.5 * (rung.s_min + rung.s_max))
    c, h = rung._consts
    y = rung.y
    hz = tuple(h[: hk.F_COULOMB]) + (0.0, 0.0) + tuple(h[hk.F_BREAKAWAY + 1 :])
    hz = list(hz)
    hz[hk.C_VISCOUS] = hz[hk.C_LEAK_AB] = hz[hk.TAU_SPOOL] = 0.0
    hz[hk.LINEAR_LAW] = 1.0
    return hk.stiffest_rate(y[0], y[1], y[2], y[3], y[4], hp.supply_pressure, tuple(c), tuple(hz))


def work_precision(quick: bool) -> list[dict]:
    """Error against the chart's reference (:data:`drs_model.fidelity.ladder.REFERENCE`: RK4,
    events located) and cost per simulated second, per method and sub-step, on the
    open-hold-close scene with 100 ms moves at the defaults."""
    scene = SCENES["open-hold-close-100ms"]
    ref = run_scene("hydraulic", scene, P, 1e-3, **REFERENCE[2])
    out = []
    steps = (1e-3, 2.5e-4, 1e-4, 2.5e-5) if quick else (1e-3, 5e-4, 2.5e-4, 1e-4, 5e-5, 2e-5, 1e-5)
    runs = [("rk4", None, f) for f in (1.0, 0.5, 0.25)]
    runs += [(m, h, 1.0) for m in STEP_METHODS if not STEP_METHODS[m][1] for h in steps]
    for method, substep, fraction in runs:
        costs, tr = [], None
        for _ in range(1 if quick else 3):
            tr = run_scene(
                "hydraulic",
                scene,
                P,
                1e-3,
                method=method,
                substep=substep,
                stability_fraction=fraction,
            )
            costs.append(tr.cost_per_second)
        out.append(
            {
                "method": method,
                "substep": substep,
                "stability_fraction": fraction,
                "stroke_error": float(np.max(np.abs(tr.stroke - ref.stroke))),
                "force_error": float(np.max(np.abs(tr.force - ref.force))),
                "cost_per_simulated_second": float(np.median(costs)),
            }
        )
    return out


def plot(rows: list[dict], path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 4.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    for method in dict.fromkeys(r["method"] for r in rows):
        pts = sorted(
            (r["cost_per_simulated_second"], r["stroke_error"])
            for r in rows
            if r["method"] == method
        )
        ax.loglog(*zip(*pts, strict=True), "o-", label=method)
    ax.set_xlabel("cost per simulated second [s/s] (1 = a whole core at real time)")
    ax.set_ylabel("max stroke error vs the chart's reference [m]")
    ax.set_title("hydraulic rung, open-hold-close with 100 ms moves", fontsize=9)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smaller grid, one repeat")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args()
    betas = (0.5e9, 1.4e9, 5e9) if args.quick else (0.3e9, 0.7e9, 1.4e9, 3e9, 1e10)
    volumes = (0.5e-6, 2e-6, 8e-6) if args.quick else (0.25e-6, 1e-6, 2e-6, 8e-6, 32e-6)
    grid = []
    t0 = time.perf_counter()
    for beta in betas:
        for vol in volumes:
            hp = HydraulicParams(
                bulk_modulus=beta, dead_volume_piston_side=vol, dead_volume_rod_side=vol
            )
            row = {
                "bulk_modulus": beta,
                "dead_volume": vol,
                "oil_frequency": oil_frequency(hp),
                "rk4_predicted": predicted_limit(hp),
                "rk4_measured": largest_stable(hp, "rk4"),
            }
            for method in ("ros2", "linearly-implicit-euler"):
                row[f"{method}_stable_at_1ms"] = stable(hp, method, 1e-3)
            grid.append(row)
            if not args.json:
                print(
                    f"beta {beta:8.2g} Pa  V0 {vol:8.2g} m^3  w_h {row['oil_frequency']:8.0f} "
                    f"rad/s  rk4 stable to {row['rk4_measured']:.3g} s (guard "
                    f"{row['rk4_predicted']:.3g} s)  ros2/LIE at 1 ms: "
                    f"{row['ros2_stable_at_1ms']}/{row['linearly-implicit-euler_stable_at_1ms']}",
                    flush=True,
                )
    wp = work_precision(args.quick)
    result = {"grid": grid, "work_precision": wp, "seconds": time.perf_counter() - t0}
    (ROOT / "benchmarks" / "results").mkdir(exist_ok=True)
    (ROOT / "benchmarks" / "results" / "hydraulic_stability.json").write_text(
        json.dumps(result, indent=1)
    )
    plot(wp, ROOT / "docs" / "img" / "hydraulic_work_precision.png")
    if args.json:
        print(json.dumps(result, indent=1))
        return
    for r in wp:
        step = r["substep"] if r["substep"] else f"{r['stability_fraction']:g}x stable"
        print(
            f"{r['method']:>24} {step!s:>12}  stroke err {r['stroke_error']:.2e} m  force err "
            f"{r['force_error']:8.1f} N  cost {r['cost_per_simulated_second']:.3f} s/s"
        )


if __name__ == "__main__":
    main()
