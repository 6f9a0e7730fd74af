"""Fit time per bag: ``drs-bag fit`` against one ``drs-bag resimulate`` of the same bag, and
against the anchor method, a plain ``scipy.optimize.least_squares`` on the full output error.

The bag: a hydraulic run recorded as the node records it (``tests/run_support.py``, the tests'
fixture):
opened and closed through the service, 130 physics steps at 1 kHz, with a leak to the outside of
2e-13 m^3/(s Pa) and a jam of 30 N (truth: ``leak_to_outside`` 2e-13, ``coulomb_friction`` 70 N,
``breakaway_friction`` 90 N) and 10 um of stroke noise. In one run, each ``--repeats`` times
(medians reported):

* ``resimulate``: :func:`drs_ros.bag.replay.resimulate.resimulate_one` (read, re-run, compare);
* ``fit``: :func:`drs_ros.bag.season.fit.fit_one` of the three parameters (equation error, then
  output
  error from its estimates, identifiability, intervals);
* ``anchor``: ``least_squares`` with its defaults (trust-region reflective, 2-point Jacobian)
  and the parameters' bounds, from the values the bag records (no leak, 40 N, 60 N), on the
  residuals of the same signals (stroke, force, chamber pressures) over the sensors'
  resolutions, each evaluation a re-simulation
  (:class:`drs_ros.bag.season.fit_rerun.RunResimulation`):
  the bag read once before the clock starts.

Each reports its wall time, re-simulations and its estimates' relative errors. The machine is
shared: the load average before and after is recorded with the figures.

Usage: ``python benchmarks/fit_speed.py [--repeats 3] [--json benchmarks/results/fit_speed.json]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# the run recorder is the tests' fixture (tests/run_support.py), not a part of the product
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

TRUTH = {"leak_to_outside": 2e-13, "coulomb_friction": 70.0, "breakaway_friction": 90.0}


def _bag(work: Path) -> Path:
    from run_support import Command, record_run

    faults = {
        "leak_m3_per_s_per_pa": 2e-13,
        "jam_friction_n": 30.0,
        "sensor.noise_std_m": 1e-5,
        "sensor.noise_seed": 3,
    }
    return record_run(
        work / "bag",
        130,
        [Command(1, "drs", True), Command(70, "drs", False)],
        fidelity="hydraulic",
        faults=faults,
    )


def _args(verb: str, argv: list[str]) -> argparse.Namespace:
    import importlib

    from drs_ros.bag.cli import VERBS

    ap = argparse.ArgumentParser()
    importlib.import_module(VERBS[verb][0]).add_arguments(ap)
    return ap.parse_args(argv)


def _anchor(bag: Path):
    """``least_squares`` as it comes, on the full output error; returns (estimates, nfev)."""
    from scipy.optimize import least_squares

    from drs_model.fidelity.hydraulic_params import HydraulicParams
    from drs_model.identify.output_error import RESOLUTION
    from drs_ros.bag.read.nodes import find_node
    from drs_ros.bag.read.recorded_run import read_run
    from drs_ros.bag.season.fit_rerun import RunResimulation
    from drs_ros.bag.season.measured import read_measured

    node = find_node(bag, None)
    m = read_measured(bag, node)
    simulate = RunResimulation(
        read_run(bag, node), m.params, HydraulicParams(), "hydraulic", m.record.step
    )
    signals = ("stroke", "piston_force", "pressure_a", "pressure_b")
    measured = {k: getattr(m.record, k) for k in signals}
    names = list(TRUTH)
    count = [0]

    def residuals(x):
        count[0] += 1
        try:
            sim = simulate(dict(zip(names, x, strict=True)))
        except Exception:  # noqa: BLE001 - a trial the model refuses (breakaway < Coulomb)
            return np.full(sum(v.size for v in measured.values()), 1e6)
        return np.concatenate([(sim[k] - measured[k]) / RESOLUTION[k] for k in signals])

    hp = HydraulicParams()
    x0 = [getattr(hp, n) for n in names]
    res = least_squares(residuals, x0, bounds=([0.0] * 3, [np.inf] * 3))
    return dict(zip(names, res.x, strict=True)), count[0], res.message


def _errors(estimates: dict) -> dict:
    return {n: abs(estimates.get(n, float("nan")) / TRUTH[n] - 1.0) for n in TRUTH}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    from drs_ros.bag.replay.resimulate import resimulate_one
    from drs_ros.bag.season.fit import fit_one

    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="drs-fit-speed-") as tmp:
        bag = _bag(Path(tmp))
        fit_args = _args("fit", [str(bag), "--params", ",".join(TRUTH)])
        resim_args = _args("resimulate", [str(bag)])
        resimulate_one(bag, resim_args)  # warm: numba's cache, imports
        times: dict[str, list[float]] = {"resimulate": [], "fit": [], "anchor": []}
        out: dict = {}
        for _ in range(args.repeats):
            start = time.perf_counter()
            resimulate_one(bag, resim_args)
            times["resimulate"].append(time.perf_counter() - start)
            start = time.perf_counter()
            outcome = fit_one(bag, fit_args)
            times["fit"].append(time.perf_counter() - start)
            start = time.perf_counter()
            anchor, nfev, message = _anchor(bag)
            times["anchor"].append(time.perf_counter() - start)
        estimates = {e.name: e.value for e in outcome.result.estimates}
        inside = {e.name: e.contains(TRUTH[e.name]) for e in outcome.result.estimates}
        resims = sum(
            int(s.notes[0].split()[0]) for s in outcome.result.stages if s.stage == "output"
        )
        med = {k: statistics.median(v) for k, v in times.items()}
        out = {
            "median_s": med,
            "fit_over_resimulate": med["fit"] / med["resimulate"],
            "anchor_over_resimulate": med["anchor"] / med["resimulate"],
            "fit_over_anchor": med["fit"] / med["anchor"],
            "fit": {
                "estimates": estimates,
                "relative_errors": _errors(estimates),
                "truth_within_interval": inside,
                "re_simulations": resims,
            },
            "anchor": {
                "estimates": anchor,
                "relative_errors": _errors(anchor),
                "re_simulations": nfev,
                "message": message,
            },
            "repeats": args.repeats,
            "load_average_before": load_before,
            "load_average_after": os.getloadavg(),
            "machine": f"{os.cpu_count()} cores, shared with other work (see the load)",
        }
    print(json.dumps(out, indent=2, default=str))
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
