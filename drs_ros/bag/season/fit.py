"""``drs-bag fit BAG --params NAME,...``: the actuator's parameters from a recorded run, with
their intervals (docs/identify.md).

The run fitted is the one of the drs node the bag names (:mod:`drs_ros.bag.read.nodes`: ``--node``
picks one of several), read on its topics as it recorded them, whatever its name and remapping;
its signals are read by role (:mod:`drs_ros.bag.season.measured`; ``--topic-map`` for a bag another
tool wrote). Then :func:`drs_model.identify.fit` runs on the rung named (``--fidelity``;
default: the one the node recorded): equation error, then, where the bag holds its commands (a
drs bag's effect record), output error by re-simulating them
(:mod:`drs_ros.bag.season.fit_rerun`). It prints each estimate with its interval, what it could not
determine and why, the identifiability and the residuals; ``-o FILE.json`` writes the report,
``--plot FILE.png`` the measured against the fitted signals.

Many bags (a directory, globs, ``--jobs``, ``--scheduler``, or ``-o season.parquet``) are a
season: one Dask task per bag (:mod:`drs_ros.bag.season.fleet`), one table row per drs node of each
bag (its ``node`` column) with each parameter's value, interval, standard error and whether it
was determined, for ``drs-bag trend``.

Every option is checked when parsed, before any bag is read: a parameter that cannot be fitted,
a ``--set`` or ``--noise`` of no parameter or signal, a malformed ``--topic-map``, a
``--level`` out of range is argparse's usage error naming the option.

Exit status (docs/cli.md): 0 every parameter determined; 1 one or more not determined (each
with its reason); 2 a bad option (``--node`` naming no drs node of the bag, or none of its
several, is one), the bag cannot be read or holds no measurement, or the model refuses the fit
(a parameter its rung does not hold, a ``--set`` value); 4 an internal error (no verdict); 6
the equation and the output error disagree on a parameter by more than their intervals allow
(verdict INCONSISTENT, the parameters named).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, field

from drs_model.cli._common import (
    fit_names_argument,
    output_path,
    parameter_names_argument,
    png_output_path,
)
from drs_model.cli.exit_status import (
    EXIT_FAILED,
    EXIT_INCONSISTENT,
    EXIT_OK,
    EXIT_REFUSED,
    EXIT_UNREADABLE,
    EXIT_USAGE,
)
from drs_model.errors import DRSError, ParameterError
from drs_model.fidelity import RUNGS
from drs_model.identify import driver as identify
from drs_model.identify.parameters import (
    RIGID_PARAMETERS,
    hydraulic_field_names,
    with_values,
)
from drs_model.overrides import assignment_overrides, split_overrides
from drs_model.params import NUMERIC_FIELDS
from drs_ros.bag.read.effects import hydraulic_params_from
from drs_ros.bag.read.nodes import BagNode, NodeSelectionError, add_node_arguments
from drs_ros.bag.season import fleet
from drs_ros.bag.season.fit_report import document, dumps, format_text, plot, row_columns
from drs_ros.bag.season.fit_rerun import SIMULATED_SIGNALS
from drs_ros.bag.season.measured import MeasurementError, parse_topic_map, read_measured
from drs_ros.bag.verb import INTERNAL, Failure, Verb, bag_node, caught, failure_of
from drs_ros.errors import DRSRosError, UsageError

#: The verdict of each exit status of ``drs-bag fit``.
FIT_VERDICTS = {
    **fleet.verdicts(passed="FITTED", failed="NOT DETERMINED"),
    EXIT_INCONSISTENT: "INCONSISTENT",
}
#: The verdict of a fit the model refuses (exit status 2, as an unreadable bag).
REFUSED = "REFUSED"
#: How fitting a bag fails, in this order.
FAILURES = (
    INTERNAL,
    Failure((NodeSelectionError, UsageError), EXIT_USAGE),
    Failure(DRSRosError, EXIT_UNREADABLE),  # the bag: unreadable, or without what a fit needs
    # the model refuses: a parameter its rung lacks, a --set value
    Failure(DRSError, EXIT_REFUSED, "error: the model refuses the fit: ", verdict=REFUSED),
)


# ---- options, checked when parsed (argparse ``type=``) ---------------------------------------
def _assignment(item: str, known, what: str) -> tuple[str, float]:
    try:
        ((name, value),) = assignment_overrides([item]).items()
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    if name not in known:
        raise argparse.ArgumentTypeError(f"{name!r} is no {what}; valid: {', '.join(known)}")
    return name, value


def set_argument(item: str) -> str:
    """``--set NAME=VALUE``: a number for a model or hydraulic parameter, bare or as the node
    names it (``model.m_wing``, ``hydraulic.leak_to_outside``), or ``flow_law=WORD`` (the
    values are the model's to accept, with the others)."""
    try:
        model, hydraulic = split_overrides(assignment_overrides([item]))
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    known = {"model": NUMERIC_FIELDS, "hydraulic": (*hydraulic_field_names(), "flow_law")}
    for what, names in (("model", model), ("hydraulic", hydraulic)):
        for name in names:
            if name not in known[what]:
                given = item.partition("=")[0].strip()
                if given.startswith(("model.", "hydraulic.")):  # the prefix given says which
                    kind = given.partition(".")[0]
                    valid = known[kind]
                else:  # a bare name of neither
                    kind, valid = "model or hydraulic", (*known["model"], *known["hydraulic"])
                raise argparse.ArgumentTypeError(
                    f"{name!r} is no {kind} parameter; valid: {', '.join(valid)}"
                )
    return item


def noise_argument(item: str) -> str:
    """``--noise SIGNAL=STD``: a finite noise > 0 of a signal the re-simulation gives."""
    name, value = _assignment(item, SIMULATED_SIGNALS, "signal a re-simulation gives")
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(
            f"the noise of {name} must be a finite number > 0, got {value!r}"
        )
    return item


def signals_argument(text: str) -> list[str]:
    """``--signals NAME,...``: signals a re-simulation gives."""
    names = parameter_names_argument(text)
    unknown = [n for n in names if n not in SIMULATED_SIGNALS]
    if unknown:
        raise argparse.ArgumentTypeError(
            f"{unknown}: not signals a re-simulation gives; valid: {', '.join(SIMULATED_SIGNALS)}"
        )
    return names


def topic_map_argument(text: str) -> dict[str, str]:
    """``--topic-map ROLE=TOPIC,...``: known roles, each with a topic."""
    try:
        return parse_topic_map([text])
    except MeasurementError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def level_argument(text: str) -> float:
    """``--level``: of the intervals, in [0.5, 1)."""
    try:
        level = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.5 <= level < 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0.5, 1), got {level!r}")
    return level


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The options of ``drs-bag fit``."""
    ap.add_argument(
        "bag",
        nargs="+",
        help="bag directory, .mcap or .db3 file; several, "
        "directories searched for bags, or globs fit a season (one row per drs node "
        "of each bag)",
    )
    ap.add_argument(
        "--params",
        dest="fit_params",
        required=True,
        type=fit_names_argument,
        metavar="NAME,...",
        help="the parameters to fit: DRSParams' masses, "
        "inertias and air loads, any HydraulicParams field (docs/identify.md)",
    )
    ap.add_argument(
        "--fidelity",
        choices=[r for r in RUNGS if r != "kinematic"],
        help="the rung whose model is fitted (default: the one the bag recorded)",
    )
    ap.add_argument(
        "--stage",
        choices=identify.STAGES,
        default="both",
        help="equation error, output error, or both (default)",
    )
    ap.add_argument(
        "--topic-map",
        action="append",
        default=[],
        metavar="ROLE=TOPIC,...",
        type=topic_map_argument,
        help="topics by role, for a bag another tool wrote "
        "(or to override the node's): joint_states, stroke_acceleration, "
        "pressure_a, pressure_b, supply_pressure, spool",
    )
    ap.add_argument(
        "--joint",
        help="the piston joint's name in the joint states (default: "
        "the node's first joint, or the message's first)",
    )
    _add_estimation_arguments(ap)
    ap.add_argument(
        "-o",
        "--output",
        type=output_path,
        help="one bag: write the report (FILE.json); many bags: the season's table (FILE.parquet)",
    )
    ap.add_argument(
        "--plot", metavar="FILE.png", type=png_output_path, help="one bag: measured against fitted"
    )
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    add_node_arguments(ap)
    fleet.add_fleet_arguments(ap)


def _add_estimation_arguments(ap: argparse.ArgumentParser) -> None:
    """The options of the estimation: the start, the intervals' level, the output error's noise
    and signals."""
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        type=set_argument,
        help="a model or hydraulic parameter's value (the start, or the value held "
        "for one not fitted), e.g. --set bulk_modulus=1.2e9 (repeatable)",
    )
    ap.add_argument(
        "--level", type=level_argument, default=0.95, help="of the intervals, in [0.5, 1) (0.95)"
    )
    ap.add_argument(
        "--noise",
        action="append",
        default=[],
        metavar="SIGNAL=STD",
        type=noise_argument,
        help="a signal's noise for the output error, e.g. "
        "stroke=1e-5 (default: estimated from the residuals)",
    )
    ap.add_argument(
        "--signals",
        type=signals_argument,
        metavar="NAME,...",
        help="the signals the output error compares (default: the rung's)",
    )


@dataclass
class FitOutcome:
    """One bag's fit: exit status, result, measurement, error line ('' when none), and the
    verdict of a season's row."""

    status: int
    result: object = None
    measured: object = None
    error: str = ""
    notes: list = field(default_factory=list)
    verdict: str = ""

    def __post_init__(self) -> None:
        self.verdict = self.verdict or FIT_VERDICTS[self.status]


def _models(measured, sets):
    """The starting DRSParams and HydraulicParams: as recorded (the defaults where the bag
    recorded none), then ``--set`` (a geometry value through :meth:`DRSParams.replace`, which
    keeps the parameters consistent)."""
    model, hydraulic = split_overrides(assignment_overrides(sets))
    geometry = {k: v for k, v in model.items() if k in NUMERIC_FIELDS and k not in RIGID_PARAMETERS}
    p = measured.params.replace(**geometry) if geometry else measured.params
    hp = hydraulic_params_from(measured.node_parameters)
    if "flow_law" in hydraulic:  # a word, not a number: with_values sets numbers
        hp = hp.replace(flow_law=hydraulic.pop("flow_law"))
    rest = {k: v for k, v in model.items() if k not in geometry} | hydraulic
    return with_values(rest, p, hp)


def _simulation(measured, rung, p, hp):
    """The re-simulation of the node's commands, or None (with the reason in the measurement's
    notes) where the bag cannot be re-run."""
    from drs_ros.bag.read.recorded_run import ResimulationError, read_run
    from drs_ros.bag.season.fit_rerun import RunResimulation

    if measured.node_parameters is None or measured.record.step is None:
        return None
    try:
        recorded = read_run(measured.bag, measured.node)
    except ResimulationError as exc:
        measured.notes.append(f"no output error: {exc}")
        return None
    return RunResimulation(recorded, p, hp, rung, measured.record.step)


def fit_one(bag, args: argparse.Namespace, node: BagNode | None = None) -> FitOutcome:
    """Fit the run of ``node`` (default: the one ``--node`` picks) in one bag with the options
    of ``drs-bag fit``; never raises for the bag's faults."""
    measured = None
    try:
        node = bag_node(bag, args, node)
        topic_map = {k: v for item in args.topic_map for k, v in item.items()}
        measured = read_measured(bag, node, topic_map, args.joint)
        rung = args.fidelity or measured.rung
        if rung is None:
            raise UsageError("--fidelity: the bag does not say which rung it ran on: name it")
        p, hp = _models(measured, args.set)
        identify.check_names(args.fit_params, rung, p, hp)
        simulate = _simulation(measured, rung, p, hp) if args.stage != "equation" else None
        result = identify.fit(
            measured.record,
            args.fit_params,
            rung,
            p,
            hp,
            simulate=simulate,
            stage=args.stage,
            level=args.level,
            noise=assignment_overrides(args.noise) or None,
            signals=args.signals,
        )
    except caught(FAILURES) as exc:
        failure = failure_of(exc, FAILURES)
        return FitOutcome(
            failure.status, error=failure.line(exc), measured=measured, verdict=failure.verdict
        )
    status = EXIT_OK if all(e.determined for e in result.estimates) else EXIT_FAILED
    if result.inconsistent:  # a value neither stage's interval can be bet on, first
        status = EXIT_INCONSISTENT
    return FitOutcome(status, result, measured)


def fleet_row(bag: str, args: argparse.Namespace) -> list[dict]:
    """One bag of a season (a Dask task): its rows (see :mod:`drs_ros.bag.season.fleet`), one per
    drs
    node it holds (the one ``--node`` names, if given): verdict, exit status, error, counts, the
    rung, and per parameter its value, interval, standard error, whether determined and by
    which stage; per signal the residual RMS."""
    return VERB.rows(bag, args)


def _row(bag: str, args: argparse.Namespace, outcome: FitOutcome, node) -> dict:
    row = fleet.base_row(bag, outcome.status, outcome.verdict, outcome.error, node)
    m = outcome.measured
    if m is not None and m.counts:
        row.update(fleet.count_columns(m.counts, m.start_ns, m.end_ns, False))
    for name in args.fit_params:  # the same columns on every row, a fit or not
        for suffix, empty in (
            ("", math.nan),
            ("_lower", math.nan),
            ("_upper", math.nan),
            ("_std", math.nan),
            ("_determined", False),
            ("_stage", ""),
        ):
            row[f"{name}{suffix}"] = empty
    if outcome.result is not None:
        row.update(row_columns(outcome.result))
    row.update(fleet.param_columns(None if m is None else m.params))
    if m is not None:
        row.update(fleet.hydraulic_columns(m.node_parameters, _start_hydraulic(m, args.set)))
    return row


def _start_hydraulic(measured, sets):
    """The HydraulicParams the fit started from (recorded, then ``--set``), or None where the
    model refused them (the row's error says why)."""
    try:
        return _models(measured, sets)[1]
    except DRSError:
        return None


def _report(outcome: FitOutcome, args: argparse.Namespace, prog: str) -> int:
    """One bag's report (text or JSON), written to ``-o FILE.json`` and plotted to ``--plot``
    if asked."""
    bag = args.bag[0]
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
        return EXIT_USAGE
    return outcome.status


#: ``drs-bag fit`` on the skeleton of the verbs that judge a run.
VERB = Verb(
    one=fit_one,
    row=_row,
    report=_report,
    done="fitted",
    summary=lambda args: ("messages", *args.fit_params[:3]),
)


def run(args: argparse.Namespace, prog: str = "drs-bag fit") -> int:
    """Run ``drs-bag fit``; returns the exit status (see the module docstring)."""
    if not fleet.is_fleet(args) and args.output and not str(args.output).endswith(".json"):
        print(
            f"{prog}: error: -o {args.output!r}: with one bag, -o names the report "
            "(FILE.json); FILE.parquet makes a season's table",
            file=sys.stderr,
        )
        return EXIT_USAGE
    return VERB.run(args, prog, fleet_row)


__all__ = [
    "FIT_VERDICTS",
    "REFUSED",
    "FitOutcome",
    "add_arguments",
    "fit_names_argument",
    "fit_one",
    "fleet_row",
    "level_argument",
    "noise_argument",
    "parameter_names_argument",
    "run",
    "set_argument",
    "signals_argument",
    "topic_map_argument",
]
