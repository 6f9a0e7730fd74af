"""``drs-bag resimulate BAG``: the model against a recorded run.

Re-runs a recorded run in a fresh :class:`drs_model.actuator.ActuatorSim` (no DDS), on the rung
of :mod:`drs_model.fidelity` the node recorded (``--fidelity`` picks another): with the
parameters the node recorded at start (``/parameter_events``; ``--set`` / ``--params`` change
them), it feeds the recorded commands in at the simulated instants the effect record
(``~/command_events``) says they took effect: the stroke, force and trajectory commands (their
recorded bytes, by sequence number), the service calls, and the node's own physics resets (a
``reset`` record: the flap held at its recorded stroke at its recorded time, as the node did when
its model refused a step; a step the re-run's model refuses is held the same way, with a note if
the run did not).
Superseded and refused commands are left out, as they were in the run. It then compares the
recorded ``/joint_states``, piston force and gap with the re-simulated ones, sample by sample
(each recorded stamp is ``t0 + simulated time``; the clock records give ``t0``), and reports the
largest deviation per signal with its time.

The bag is read twice, a chunk at a time: first (verifying every byte) the parameters, the effect
record and the commands; then the signals, while the re-run advances as they ask and keeps only
the last :data:`.rerun.STATE_WINDOW` steps. Many bags run on Dask, one row per bag
(:func:`fleet_row`, :mod:`drs_ros.bag.season.fleet`).

The run is the one of the drs node the bag names (:mod:`drs_ros.bag.read.nodes`: ``--node`` picks
one
of several), with its topics as it recorded them, whatever its name and remapping.

Exit status (docs/cli.md): 0 every deviation within its tolerance; 1 past a tolerance; 2 a bad
option (or ``--node`` naming no drs node of the bag, or none of its several), the bag cannot be
read (or its ``metadata.yaml`` is malformed), holds commands but no effect record (it was
recorded before drs recorded when commands took effect) or no parameters of its node, or the
model refuses the parameters of the re-run (the recorded ones with ``--params`` / ``--set``); 4
decoding a message that passed every check of the file failed (a type that is not installed):
one line ``internal error``, no verdict on the bag; 5 nothing to re-run: the bag names no drs
node (another tool's bag), or its node took no command and never stepped (a bag that ``-o``
wrote, say).
"""

from __future__ import annotations

import argparse
import json
import math
from contextlib import ExitStack
from dataclasses import dataclass, field

from drs_model.cli._common import output_path
from drs_model.cli.exit_status import (
    EXIT_FAILED,
    EXIT_NOTHING_TO_RERUN,
    EXIT_OK,
    EXIT_UNREADABLE,
)
from drs_model.errors import DRSError
from drs_model.fidelity import RUNGS
from drs_model.overrides import (
    assignment_argument,
    parameter_file_argument,
)
from drs_model.params import DRSParams
from drs_ros.bag.read.effects import MissingRecordError
from drs_ros.bag.read.files import BagReadError
from drs_ros.bag.read.nodes import BagNode, NodeSelectionError, add_node_arguments
from drs_ros.bag.read.recorded_run import (
    RUN_ROLES,
    NothingToRerunError,
    RecordedRun,
    ResimulationError,
    read_run,
    run_models,
)
from drs_ros.bag.replay.deviations import SIGNALS, compare
from drs_ros.bag.replay.rerun import resimulate
from drs_ros.bag.replay.rerun_bag import bag_writer
from drs_ros.bag.season import fleet
from drs_ros.bag.verb import (
    INTERNAL,
    NO_NODE,
    Failure,
    Verb,
    bag_node,
    caught,
    failure_of,
    node_topics,
)
from drs_ros.recording.errors import RecordingError

#: The roles with a ``--<role>-topic`` option.
TOPIC_OPTIONS = ("command_events", "joint_states", "piston_force", "flap_gap")
#: How re-running a bag fails, in this order (nothing to re-run is a kind of ResimulationError).
FAILURES = (
    INTERNAL,  # our own failure on an intact message
    Failure(NothingToRerunError, EXIT_NOTHING_TO_RERUN, ""),
    Failure((BagReadError, MissingRecordError, ResimulationError), EXIT_UNREADABLE),  # the bag's
    Failure(RecordingError, EXIT_UNREADABLE, "error: -o: "),  # -o OUT exists or cannot be written
    # the model refuses the re-run's parameters (or the recorded rung's)
    Failure(
        DRSError,
        EXIT_UNREADABLE,
        "error: the model refuses the re-run (the recorded parameters with --params/--set): ",
    ),
)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument(
        "bag",
        nargs="+",
        help="bag directory, .mcap or .db3 file recorded by drs-node; several, directories "
        "searched for bags, or globs re-run a fleet (one row per bag)",
    )
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        type=assignment_argument,
        help="change a model or hydraulic parameter for the re-run (repeatable), e.g. "
        "m_wing=0.5 or leak_to_outside=1e-12",
    )
    ap.add_argument(
        "--params",
        type=parameter_file_argument,
        help="a .toml/.yaml file of model (and hydraulic) parameters for the re-run",
    )
    ap.add_argument(
        "--fidelity",
        choices=list(RUNGS),
        help="re-run on this rung of the fidelity ladder (default: the one recorded)",
    )
    ap.add_argument(
        "-o",
        "--output",
        type=output_path,
        help="write the re-simulated run as a new bag directory; "
        "with many bags, FILE.parquet: the table, one row per bag",
    )
    ap.add_argument(
        "--tol",
        type=float,
        default=1e-9,
        help="tolerance of the joint states and the gap [m, rad, /s] (default 1e-9)",
    )
    ap.add_argument(
        "--force-tol",
        type=float,
        default=1e-6,
        help="tolerance of the piston force [N] (default 1e-6)",
    )
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    add_node_arguments(ap, TOPIC_OPTIONS)
    fleet.add_fleet_arguments(ap)


@dataclass
class ResimulationOutcome:
    """What re-running one bag gave: exit status (see the module docstring), the rows of
    :func:`.deviations.compare`, the notes, the error line ('' when none), the recorded run and
    the model."""

    status: int
    rows: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    error: str = ""
    run: RecordedRun | None = None
    model: DRSParams | None = None
    hydraulic: object = None  # the HydraulicParams of the re-run


def resimulate_one(
    bag, args: argparse.Namespace, output: str | None = None, node: BagNode | None = None
) -> ResimulationOutcome:
    """Re-run one bag with the options of ``drs-bag resimulate`` (``args``), the run of
    ``node`` (default: the one ``--node`` picks), writing the re-simulated bag to ``output`` if
    given; never raises for the bag's faults."""
    tolerances = {
        name: (args.force_tol if unit == "N" else args.tol) for name, (unit, _) in SIGNALS.items()
    }
    recorded = model = None
    try:
        node = bag_node(bag, args, node)
    except NodeSelectionError as exc:
        return ResimulationOutcome(NO_NODE.status, error=NO_NODE.line(exc))
    named = node_topics(bag, node, RUN_ROLES, args, TOPIC_OPTIONS)
    try:
        recorded = read_run(bag, node, named.topics)
        model, hydraulic = run_models(recorded.node_parameters, args.set, args.params)
        rung = getattr(args, "fidelity", None) or recorded.rung()
        result = resimulate(
            recorded,
            model,
            rung,
            rung_options={"hydraulic": hydraulic} if rung == "hydraulic" else None,
        )
        with ExitStack() as stack:
            on_state = None
            if output:
                on_state = stack.enter_context(
                    bag_writer(output, recorded, (model, hydraulic), result["sim"].name)
                )
            rows = compare(recorded, result, tolerances, on_state)
    except caught(FAILURES) as exc:
        failure = failure_of(exc, FAILURES)
        if failure.status == EXIT_NOTHING_TO_RERUN:  # what there is to say is in the notes
            return ResimulationOutcome(failure.status, notes=named.notes, error=failure.line(exc))
        return ResimulationOutcome(
            failure.status, error=failure.line(exc), run=recorded, model=model
        )
    ok = all(r["ok"] for r in rows)
    if output:
        result["notes"].append(f"wrote the re-simulated run to {output}")
    notes = named.notes + result["notes"]
    return ResimulationOutcome(
        EXIT_OK if ok else EXIT_FAILED, rows, notes, "", recorded, model, hydraulic
    )


#: The verdict of each exit status of ``drs-bag resimulate``.
RERUN_VERDICTS = fleet.verdicts(passed="PASS", failed="DEVIATES")


def fleet_row(bag: str, args: argparse.Namespace) -> list[dict]:
    """Re-run one bag of a fleet (a Dask task): its rows of the table (see
    :mod:`drs_ros.bag.season.fleet`), one per drs node it holds (the one ``--node`` names, if
    given):
    verdict, exit status, error, each signal's largest deviation, counts, the notes and the
    model parameters of the re-run."""
    return VERB.rows(bag, args)


def _row(
    bag: str, args: argparse.Namespace, outcome: ResimulationOutcome, node: BagNode | None
) -> dict:
    row = fleet.base_row(bag, outcome.status, RERUN_VERDICTS[outcome.status], outcome.error, node)
    for name, (unit, _) in SIGNALS.items():
        row[f"{name}_deviation_{unit.replace('/', '_')}"] = math.nan
    for r in outcome.rows:
        unit = r["unit"].replace("/", "_")
        row[f"{r['signal']}_deviation_{unit}"] = float(r["max_deviation"])
    recorded = outcome.run
    if recorded is not None:
        row.update(fleet.count_columns(recorded.counts, recorded.start_ns, recorded.end_ns, False))
    row["notes"] = list(outcome.notes)
    # the rung of the re-run: asked for, or the one the bag recorded
    rung = None if recorded is None else recorded.rung()
    row["fidelity"] = getattr(args, "fidelity", None) or rung
    row.update(fleet.param_columns(outcome.model))
    row.update(
        fleet.hydraulic_columns(
            None if recorded is None else recorded.node_parameters, outcome.hydraulic
        )
    )
    return row


def _report(outcome: ResimulationOutcome, args: argparse.Namespace, prog: str) -> int:
    """One bag's report: each signal's largest deviation, as a table or JSON."""
    rows, notes, ok = outcome.rows, outcome.notes, outcome.status == 0
    if args.json:
        print(
            json.dumps(
                {
                    "bag": str(args.bag[0]),
                    "node": outcome.run.node,
                    "ok": ok,
                    "signals": rows,
                    "notes": notes,
                    "changed": args.set,
                    "fidelity": args.fidelity,
                },
                indent=2,
                default=lambda x: None,
            )
        )
    else:
        print(
            f"re-simulated {args.bag[0]}, the run of {outcome.run.node}"
            + (f" with {', '.join(args.set)}" if args.set else "")
            + (f" on the {args.fidelity} rung" if args.fidelity else "")
        )
        print(
            f"{'signal':<14} {'unit':<6} {'n':>6} {'max deviation':>14} {'at t [s]':>10} "
            f"{'tol':>8}  status"
        )
        for r in rows:
            at = "-" if r["at_time_s"] is None else f"{r['at_time_s']:.4f}"
            print(
                f"{r['signal']:<14} {r['unit']:<6} {r['samples']:>6} "
                f"{r['max_deviation']:>14.3e} {at:>10} {r['tol']:>8.1e}  "
                f"{'ok' if r['ok'] else 'DEVIATES'}"
            )
        for n in notes:
            print(f"note: {n}")
    return outcome.status


def _single(bag, args: argparse.Namespace) -> ResimulationOutcome:
    """The one bag of a command line, re-run (and written to ``-o``, if given)."""
    return resimulate_one(bag, args, args.output)


#: ``drs-bag resimulate`` on the skeleton of the verbs that judge a run.
VERB = Verb(
    one=resimulate_one,
    single=_single,
    row=_row,
    report=_report,
    done="re-simulated",
    summary=lambda args: ("messages", "stroke_deviation_m", "piston_force_deviation_N"),
)


def run(args: argparse.Namespace, prog: str = "drs-bag resimulate") -> int:
    """Run ``drs-bag resimulate``; returns the exit status (see the module docstring)."""
    return VERB.run(args, prog, fleet_row)


__all__ = [
    "RERUN_VERDICTS",
    "ResimulationOutcome",
    "add_arguments",
    "fleet_row",
    "resimulate_one",
    "run",
]
