"""Coverage of the fit's 95 % intervals: over seeded runs with a known truth, how often each
stage's interval holds it, and how the stated standard error compares with the estimates' own
scatter.

Cells: scene x record x stage.

* scenes (the ``rigid`` rung at 1 kHz, the truth the seed's parameters, ``m_wing`` = 2 kg):
  ``stroke`` (opened and closed by stroke commands), ``force`` (force commands 1500, 0, 2500,
  0 N: onto the stops and back), ``trajectory`` (a trajectory through mid-stroke points);
* records: ``node`` (what a node bag holds: stroke, its rate and the piston force; the
  acceleration differentiated; the stops declared held only under force commands),
  ``node+noise`` (the same with 10 um of seeded stroke-sensor noise), ``foreign`` (a
  JointState-only bag another tool wrote: the same signals, with 10 um of noise, nothing known
  of its commands, so a stop may have held the rod);
* stages: ``equation``, ``output`` (re-simulating the commands; not for ``foreign``, which holds
  none), ``both`` (the final estimate of a fit of both stages, and whether it was INCONSISTENT),
  and ``output-stroke`` (:data:`STROKE_ONLY`: the output error on the stroke alone, force
  commands only).

A noise-free cell is one deterministic run (its seeds are all the same run): it reports whether
its interval holds the truth and its width. A noisy cell runs ``--runs`` seeds and reports the
coverage, its binomial standard error, the mean stated standard error over the estimates'
empirical scatter (target 1/1.5 .. 1.5) and the runs that gave no value or an INCONSISTENT
verdict. The target: 90-98 % coverage.

Usage: ``python benchmarks/interval_coverage.py [--runs 100] [--output-runs 30]
[--cells stroke:node+noise:equation,...] [--json benchmarks/results/interval_coverage.json]``

``--hydraulic RUNS`` adds the hydraulic rung's cells (2 kHz, ``leak_to_outside``,
``coulomb_friction`` and ``breakaway_friction`` fitted together from HydraulicParams' defaults,
the truth a leak to the outside of 2e-13 m^3/(s Pa), Coulomb 70 N, breakaway 90 N), by scene
(:data:`HYDRAULIC_SCENES`: the flap opened and closed; the same with a supply step; a healthy
actuator given the leak and a jam as fault parameters, whose supply is lost and back) and
record (``foreign``: JointState and FluidPressure only: the stroke with 10 um of noise, its
rate, the chamber pressures; no spool, force or supply): the equation stage with RUNS seeds
per noisy cell, and with ``--hydraulic-output RUNS`` the output error and both stages (the
output error re-running the scene as ``drs-bag fit`` does: the faults it estimates left out,
the supply's loss replayed). ``--hydraulic-scenes`` picks scenes.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from identify_support import (  # noqa: E402
    force_run,
    hydraulic_signals,
    noisy_record,
    run_rung,
)

from drs_model.fidelity import HydraulicParams  # noqa: E402
from drs_model.identify.driver import fit  # noqa: E402
from drs_model.identify.parameters import with_values  # noqa: E402
from drs_model.params import DRSParams  # noqa: E402
from drs_ros.bag.season.fit_rerun import FAULTS_LEFT_OUT  # noqa: E402

SCENES = ("stroke", "force", "trajectory")
RECORDS = ("node", "node+noise", "foreign")
STAGES = ("equation", "output", "both")
#: The output error fitted on the stroke alone (``signals=["stroke"]``): where the force is
#: recorded exactly it holds the mass to rounding, and only this cell shows the output error's
#: intervals where the stroke's noise drives them. Under stroke commands or a trajectory the
#: stroke holds no mass (the flap follows the path), so it is run on force commands only.
STROKE_ONLY = "output-stroke"
EXTRA_CELLS = (("force", "node+noise", STROKE_ONLY),)
NAME = "m_wing"
NOISE = 1e-5


def scene_table(scene: str, p: DRSParams) -> np.ndarray:
    """The rung's run of ``scene`` with the parameters ``p`` (rows of identify_support's
    COLUMNS)."""
    if scene == "stroke":
        return run_rung("rigid", p, moves=((0, True), (60, False)), steps=120)
    if scene == "force":
        return force_run(p)
    times = np.array([0.02, 0.04, 0.07, 0.1])
    strokes = np.array([0.03, 0.012, 0.04, 0.02])
    return run_rung("rigid", p, steps=120, trajectory=(times, strokes, None))


def record_of(table, scene: str, record: str, seed: int):
    noise = 0.0 if record == "node" else NOISE
    held = scene == "force" or record == "foreign"
    return noisy_record(table, noise, seed, stops_hold=held, stroke_acceleration=True)


def simulator(scene: str, p: DRSParams):
    def simulate(values):
        q, _ = with_values(values, p, HydraulicParams())
        table = scene_table(scene, q)
        return {"stroke": table[:, 1], "piston_force": table[:, 4]}

    return simulate


def one_run(table, scene, record, stage, seed, p):
    """``(value, lower, upper, std, inconsistent)`` of one seeded run (NaN: no value)."""
    rec = record_of(table, scene, record, seed)
    simulate = None if stage == "equation" else simulator(scene, p)
    signals = ["stroke"] if stage == STROKE_ONLY else None
    stage = "output" if stage == STROKE_ONLY else stage
    try:
        result = fit(rec, [NAME], "rigid", p, simulate=simulate, stage=stage, signals=signals)
    except Exception as exc:  # noqa: BLE001 - a refusal is a run with no value, counted
        return math.nan, math.nan, math.nan, math.nan, False, f"{type(exc).__name__}: {exc}"
    e = result.estimate(NAME)
    return e.value, e.lower, e.upper, e.std, bool(result.inconsistent), ""


def cell(scene, record, stage, runs, p) -> dict:
    table = scene_table(scene, p)
    truth = float(getattr(p, NAME))
    n = 1 if record == "node" else runs
    started = time.perf_counter()
    rows = [one_run(table, scene, record, stage, seed, p) for seed in range(n)]
    return _summary(scene, record, stage, rows, truth, started)


def _summary(scene, record, stage, rows, truth, started) -> dict:
    """A cell's figures from its runs' ``(value, lower, upper, std, inconsistent, error)``."""
    values = np.array([r[:4] for r in rows], dtype=float)
    ok = np.isfinite(values[:, 0])
    hit = ok & (values[:, 1] <= truth) & (truth <= values[:, 2])
    out = {
        "scene": scene,
        "record": record,
        "stage": stage,
        "runs": len(rows),
        "valued": int(ok.sum()),
        "covered": int(hit.sum()),
        "inconsistent": int(sum(r[4] for r in rows)),
        "min_width": float(np.min(values[ok, 2] - values[ok, 1])) if ok.any() else math.nan,
        "seconds": time.perf_counter() - started,
        "errors": sorted({r[5] for r in rows if r[5]})[:3],
    }
    if ok.sum() >= 2:
        out["coverage"] = float(hit.sum() / ok.sum())
        out["coverage_se"] = math.sqrt(out["coverage"] * (1 - out["coverage"]) / ok.sum())
        scatter = float(np.std(values[ok, 0], ddof=1))
        out["std_over_scatter"] = float(np.mean(values[ok, 3]) / scatter) if scatter else math.inf
        bias = float(np.mean(values[ok, 0]) - truth)
        out["bias"] = bias
        out["scatter"] = scatter
        out["mean_std"] = float(np.mean(values[ok, 3]))
    return out


HYDRAULIC_TRUTH = {"leak_to_outside": 2e-13, "coulomb_friction": 70.0, "breakaway_friction": 90.0}
FOREIGN_DROPPED = {"piston_force": True, "spool": True, "supply_pressure": True}


#: The hydraulic scenes (2 kHz physics, 240 steps), each with its table's options of
#: ``run_rung`` on top of the flap opened and closed: ``open-close`` with the truth as the
#: actuator's parameters; ``supply-step`` the same with the supply stepped from 21 to 12 MPa
#: over 2.5 ms 20 ms into the hold and back 25 ms later; ``faults`` a healthy actuator given a
#: leak and a jam as the node's ``fault.*`` parameters at the start (the same run to the bit),
#: whose supply is lost 20 ms into the hold (the servo commanded closed, the air load closes
#: the flap) and back 30 ms later, the flap opened again and closed.
HYDRAULIC_SCENES = {
    "open-close": {"moves": ((0, True), (120, False)), "truth_as": "params"},
    "supply-step": {
        "moves": ((0, True), (120, False)),
        "supply": ((40, 12e6, 0.0025), (90, 21e6, 0.0025)),
        "truth_as": "params",
    },
    "faults": {
        "moves": ((0, True), (150, True), (200, False)),
        "faults": (
            (40, "supply_loss_ramp_s", 0.0025),
            (40, "supply_loss", True),
            (100, "supply_loss", False),
        ),
        "truth_as": "faults",
    },
}
#: The faults that give the truth on a healthy actuator (``truth_as: faults``), at the start.
TRUTH_FAULTS = (
    (0, "leak_m3_per_s_per_pa", HYDRAULIC_TRUTH["leak_to_outside"]),
    (0, "jam_friction_n", HYDRAULIC_TRUTH["coulomb_friction"] - HydraulicParams().coulomb_friction),
)


def hydraulic_table(scene: str, p: DRSParams, values: dict | None = None) -> np.ndarray:
    """The run of hydraulic ``scene``: the truth (``values`` None), or a fit's re-run with the
    trial ``values`` on HydraulicParams' defaults (the faults it estimates left out)."""
    s = HYDRAULIC_SCENES[scene]
    faults = tuple(s.get("faults", ()))
    if values is None and s["truth_as"] == "faults":
        q, hp, faults = p, HydraulicParams(), TRUTH_FAULTS + faults
    elif values is None:
        q, hp = p, HydraulicParams(**HYDRAULIC_TRUTH)
    else:
        q, hp = with_values(values, p, HydraulicParams())
        faults = tuple(f for f in faults if f[1] not in FAULTS_LEFT_OUT)
    return run_rung(
        "hydraulic",
        q,
        moves=s["moves"],
        steps=240,
        dt=5e-4,
        hydraulic=hp,
        supply=s.get("supply", ()),
        faults=faults,
    )


def hydraulic_simulator(scene: str, p: DRSParams):
    def simulate(values):
        return hydraulic_signals(hydraulic_table(scene, p, values))

    return simulate


def hydraulic_cells(
    runs: int, p: DRSParams, output_runs: int = 0, scenes=("open-close",)
) -> list[dict]:
    """The hydraulic rung's cells, one per scene, record, stage and parameter: the equation
    stage with ``runs`` seeds per noisy cell, the output error and both with ``output_runs``
    (none: 0)."""
    cells = []
    for scene in scenes:
        table = hydraulic_table(scene, p)
        for record in RECORDS:
            stages = ("equation",) if record == "foreign" or not output_runs else STAGES
            for stage in stages:
                n = 1 if record == "node" else (runs if stage == "equation" else output_runs)
                cells += _hydraulic_cell(table, scene, record, stage, n, p)
    return cells


def _hydraulic_cell(table, scene, record, stage, n, p) -> list[dict]:
    drop = FOREIGN_DROPPED if record == "foreign" else {}
    simulate = None if stage == "equation" else hydraulic_simulator(scene, p)
    rows = {name: [] for name in HYDRAULIC_TRUTH}
    started = time.perf_counter()
    for seed in range(n):
        noise = 0.0 if record == "node" else NOISE
        held = record == "foreign"
        rec = noisy_record(table, noise, seed, stops_hold=held, stroke_acceleration=True, **drop)
        for name, row in _hydraulic_run(rec, p, stage, simulate).items():
            rows[name].append(row)
    return [
        _summary(f"{scene}:{name}", record, stage, runs_of, HYDRAULIC_TRUTH[name], started)
        for name, runs_of in rows.items()
    ]


def _hydraulic_run(rec, p, stage="equation", simulate=None) -> dict:
    """Each parameter's run: all three fitted together; where the record cannot give the leak
    (the continuity equations need the spool), the friction pair alone, the leak's refusal
    counted as its run with no value (the continuity equations also need the supply)."""
    names, refused = list(HYDRAULIC_TRUTH), {}
    hp = HydraulicParams()
    try:
        result = fit(rec, names, "hydraulic", p, hp, simulate=simulate, stage=stage)
    except Exception as exc:  # noqa: BLE001 - a refusal is a run with no value, counted
        refused["leak_to_outside"] = (math.nan,) * 4 + (False, f"{type(exc).__name__}: {exc}")
        names.remove("leak_to_outside")
        result = fit(rec, names, "hydraulic", p, hp, simulate=simulate, stage=stage)
    bad = bool(result.inconsistent)
    rows = {
        n: (
            result.estimate(n).value,
            result.estimate(n).lower,
            result.estimate(n).upper,
            result.estimate(n).std,
            bad,
            "",
        )
        for n in names
    }
    return rows | refused


def table_md(cells) -> str:
    lines = [
        "| scene | record | stage | runs | valued | coverage | stated std / scatter | "
        "scatter | INCONSISTENT | min width |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cells:
        if "coverage" in c:
            cov = f"{100 * c['coverage']:.1f} % +- {100 * c['coverage_se']:.1f}"
            ratio = f"{c['std_over_scatter']:.2f}"
            scatter = f"{c['scatter']:.3g}"
        else:
            cov = "holds" if c["covered"] else ("no value" if not c["valued"] else "misses")
            ratio = scatter = "-"
        lines.append(
            f"| {c['scene']} | {c['record']} | {c['stage']} | {c['runs']} | "
            f"{c['valued']} | {cov} | {ratio} | {scatter} | {c['inconsistent']} | "
            f"{c['min_width']:.3g} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100, help="seeds per noisy equation cell")
    ap.add_argument(
        "--output-runs",
        type=int,
        default=100,
        help="seeds per noisy cell with an output-error stage",
    )
    ap.add_argument("--cells", default="", help="scene:record:stage,... (default: all)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument(
        "--hydraulic",
        type=int,
        default=0,
        metavar="RUNS",
        help="add the hydraulic rung's cells with RUNS seeds per noisy equation cell",
    )
    ap.add_argument(
        "--hydraulic-output",
        type=int,
        default=0,
        metavar="RUNS",
        help="and its output-error and both-stage cells with RUNS seeds per noisy cell",
    )
    ap.add_argument(
        "--hydraulic-scenes",
        default=",".join(HYDRAULIC_SCENES),
        help=f"the hydraulic scenes, of {','.join(HYDRAULIC_SCENES)}",
    )
    args = ap.parse_args(argv)
    wanted = [tuple(c.split(":")) for c in args.cells.split(",") if c]
    if not wanted:
        wanted = [
            (s, r, g)
            for s in SCENES
            for r in RECORDS
            for g in STAGES
            if not (r == "foreign" and g != "equation")
        ] + list(EXTRA_CELLS)
    p = DRSParams()
    load = os.getloadavg()[0]
    cells = []
    for scene, record, stage in wanted:
        runs = args.runs if stage == "equation" else args.output_runs
        cells.append(cell(scene, record, stage, runs, p))
        print(table_md(cells[-1:]).splitlines()[-1], flush=True)
    if args.hydraulic:
        scenes = [x for x in args.hydraulic_scenes.split(",") if x]
        unknown = sorted(set(scenes) - set(HYDRAULIC_SCENES))
        if unknown:
            ap.error(f"unknown hydraulic scenes {unknown}: the scenes are {list(HYDRAULIC_SCENES)}")
        hydraulic = hydraulic_cells(args.hydraulic, p, args.hydraulic_output, scenes)
        print(table_md(hydraulic), flush=True)
        cells += hydraulic
    print(table_md(cells))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        doc = {
            "parameter": NAME,
            "truth": float(getattr(p, NAME)),
            "noise_m": NOISE,
            "hydraulic_truth": HYDRAULIC_TRUTH if args.hydraulic else None,
            "load_before": load,
            "load_after": os.getloadavg()[0],
            "cells": cells,
        }
        args.json.write_text(json.dumps(doc, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
