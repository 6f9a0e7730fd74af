"""``drs-bag fit BAG --params NAME,...``: the actuator's parameters from a recorded run, with
their intervals (docs/identify.md).

The bag's signals are read by role (:mod:`drs_ros.bag.measured`; ``--topic-map`` for a bag
another tool wrote), then :func:`drs_model.identify.fit` runs on the rung named (``--fidelity``;
default: the one the bag recorded): equation error, then, where the bag holds its commands (a
drs bag's effect record), output error by re-simulating them
(:mod:`drs_ros.bag.fit_rerun`). It prints each estimate with its interval, what it could not
determine and why, the identifiability and the residuals; ``-o FILE.json`` writes the report,
``--plot FILE.png`` the measured against the fitted signals.

Many bags (a directory, globs, ``--jobs``, ``--scheduler``, or ``-o season.parquet``) are a
season: one Dask task per bag (:mod:`drs_ros.bag.fleet`), one table row per bag with each
parameter's value, interval, standard error and whether it was determined, for ``drs-bag
trend``.

Exit status: 0 every parameter determined; 1 one or more not determined (each with its
reason); 2 the bag cannot be read or an option is invalid; 4 an internal error (no verdict).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, field

from drs_model.errors import DRSError
from drs_model.fidelity import RUNGS
from drs_model.fidelity.hydraulic_params import HydraulicParams
from drs_model.identify import driver as identify
from drs_model.identify.parameters import with_values
from drs_model.overrides import assignment_overrides

from ..errors import DRSRosError, UsageError
from . import fleet
from .fit_report import document, dumps, format_text, plot, row_columns
from .measured import parse_topic_map, read_measured
from .reader import MessageCallbackError

VERDICTS = {0: "FITTED", 1: "NOT DETERMINED", 2: "UNREADABLE", 4: "INTERNAL ERROR"}


def _names(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("name at least one parameter")
    return names


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("bag", nargs="+", help="bag directory, .mcap or .db3 file; several, "
                    "directories searched for bags, or globs fit a season (one row per bag)")
    ap.add_argument("--params", dest="fit_params", required=True, type=_names,
                    metavar="NAME,...", help="the parameters to fit: DRSParams' masses, "
                    "inertias and air loads, any HydraulicParams field (docs/identify.md)")
    ap.add_argument("--fidelity", choices=[r for r in RUNGS if r != "kinematic"],
                    help="the rung whose model is fitted (default: the one the bag recorded)")
    ap.add_argument("--stage", choices=identify.STAGES, default="both",
                    help="equation error, output error, or both (default)")  # fmt: skip
    ap.add_argument("--topic-map", action="append", default=[], metavar="ROLE=TOPIC,...",
                    help="topics of a bag another tool wrote, by role: joint_states, "
                    "stroke_acceleration, pressure_a, pressure_b, supply_pressure, spool")
    ap.add_argument("--joint", help="the piston joint's name in the joint states (default: "
                    "the node's first joint, or the message's first)")  # fmt: skip
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="a model or hydraulic parameter's value (the start, or the value held "
                    "for one not fitted), e.g. --set bulk_modulus=1.2e9 (repeatable)")  # fmt: skip
    ap.add_argument("--level", type=float, default=0.95, help="of the intervals (0.95)")
    ap.add_argument("--noise", action="append", default=[], metavar="SIGNAL=STD",
                    help="a signal's noise for the output error, e.g. stroke=1e-5 (default: "
                    "estimated from the residuals)")  # fmt: skip
    ap.add_argument("--signals", type=_names, metavar="NAME,...",
                    help="the signals the output error compares (default: the rung's)")
    ap.add_argument("-o", "--output", help="one bag: write the report (FILE.json); many "
                    "bags: the season's table (FILE.parquet)")  # fmt: skip
    ap.add_argument("--plot", metavar="FILE.png", help="one bag: measured against fitted")
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    fleet.add_fleet_arguments(ap)


@dataclass
class FitOutcome:
    """One bag's fit: exit status, result, measurement, error line ('' when none)."""

    status: int
    result: object = None
    measured: object = None
    error: str = ""
    notes: list = field(default_factory=list)


def _models(measured, sets):
    """The starting DRSParams and HydraulicParams: as recorded, then ``--set``."""
    values = assignment_overrides(sets)
    return with_values(values, measured.params, HydraulicParams())


def _simulation(measured, rung, p, hp):
    """The re-simulation of the bag's commands, or None (with the reason in the measurement's
    notes) where the bag cannot be re-run."""
    from .fit_rerun import RunResimulation
    from .resimulate import ResimulationError, read_run

    if measured.node_parameters is None or measured.record.step is None:
        return None
    try:
        run = read_run(measured.bag)
    except ResimulationError as exc:
        measured.notes.append(f"no output error: {exc}")
        return None
    return RunResimulation(run, p, hp, rung, measured.record.step)


def fit_one(bag, args: argparse.Namespace) -> FitOutcome:
    """Fit one bag with the options of ``drs-bag fit``; never raises for the bag's faults."""
    measured = None
    try:
        topic_map = parse_topic_map(args.topic_map)
        noise = assignment_overrides(args.noise)
        measured = read_measured(bag, topic_map, args.joint)
        rung = args.fidelity or measured.rung
        if rung is None:
            raise UsageError("--fidelity: the bag does not say which rung it ran on: name it")
        p, hp = _models(measured, args.set)
        identify.check_names(args.fit_params, rung, p, hp)
        simulate = _simulation(measured, rung, p, hp) if args.stage != "equation" else None
        result = identify.fit(measured.record, args.fit_params, rung, p, hp, simulate=simulate,
                              stage=args.stage, level=args.level, noise=noise or None,
                              signals=args.signals)  # fmt: skip
    except MessageCallbackError as exc:
        return FitOutcome(4, error=f"internal error (not a verdict on the bag): {exc}",
                          measured=measured)  # fmt: skip
    except (DRSError, DRSRosError) as exc:  # the model refuses; a bag or an option
        return FitOutcome(2, error=f"error: {exc}", measured=measured)
    status = 0 if all(e.determined for e in result.estimates) else 1
    return FitOutcome(status, result, measured)


def fleet_row(bag: str, args: argparse.Namespace) -> dict:
    """One bag of a season (a Dask task): its row (see :mod:`drs_ros.bag.fleet`): verdict,
    exit status, error, counts, the rung, and per parameter its value, interval, standard error,
    whether determined and by which stage; per signal the residual RMS."""
    outcome = fit_one(bag, args)
    row = fleet.base_row(bag, outcome.status, VERDICTS[outcome.status], outcome.error)
    m = outcome.measured
    if m is not None and m.counts:
        row.update(fleet.count_columns(m.counts, m.start_ns, m.end_ns, False))
    for name in args.fit_params:  # the same columns on every row, a fit or not
        for suffix, empty in (("", math.nan), ("_lower", math.nan), ("_upper", math.nan),
                              ("_std", math.nan), ("_determined", False), ("_stage", "")):
            row[f"{name}{suffix}"] = empty
    if outcome.result is not None:
        row.update(row_columns(outcome.result))
    row.update(fleet.param_columns(None if m is None else m.params))
    return row


def run(args: argparse.Namespace, prog: str = "drs-bag fit") -> int:
    if fleet.is_fleet(args):
        return fleet.run_fleet(fleet_row, args, prog, "fitted", ("messages",
                               *args.fit_params[:3]))  # fmt: skip
    bag = args.bag[0]
    if args.output and not str(args.output).endswith(".json"):
        print(f"{prog}: error: -o {args.output!r}: with one bag, -o names the report "
              "(FILE.json); FILE.parquet makes a season's table", file=sys.stderr)  # fmt: skip
        return 2
    outcome = fit_one(bag, args)
    if outcome.error:
        print(f"{prog}: {outcome.error}", file=sys.stderr)
        return outcome.status
    doc = document(bag, outcome.result, outcome.measured)
    print(dumps(doc) if args.json else format_text(bag, outcome.result, outcome.measured))
    try:
        if args.output:
            with open(args.output, "w") as f:
                f.write(dumps(doc) + "\n")
        if args.plot:
            plot(outcome.result, args.plot, f"{bag}: measured against fitted")
    except OSError as exc:
        print(f"{prog}: error: cannot write: {exc}", file=sys.stderr)
        return 2
    return outcome.status


__all__ = ["VERDICTS", "FitOutcome", "add_arguments", "fit_one", "fleet_row", "run"]
