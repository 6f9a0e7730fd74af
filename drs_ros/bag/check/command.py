"""``drs-bag check BAG`` (alias ``drs-check``): verify every byte of a bag, then recompute what
the model says from it and report the discrepancies.

First :func:`drs_ros.bag.read.reader.scan` reads the whole file and verifies it (CRCs, summary and
``metadata.yaml`` counts against what was read, exact CDR bytes of every message); any problem is
an error naming the offset and the topic. Then the model checks
(:mod:`drs_ros.bag.check.model_checks`), each reported as the largest discrepancy per topic: the
loop
and velocity constraints of the joint states, the gap, the piston force from the inverse
dynamics.

The bag is read a chunk at a time and the model checks run block by block
(:class:`drs_ros.bag.check.model_checks.ModelChecker`): memory does not grow with the bag. MCAP and
sqlite3 (``.db3``) bags are read. Many bags (several paths, a directory of bags, a glob, ``-o
FILE.parquet``, ``--jobs``, ``--scheduler``) are checked on Dask, one row per bag
(:func:`fleet_row`, :mod:`drs_ros.bag.season.fleet`).

The run checked is the one of the drs node the bag names (:mod:`drs_ros.bag.read.nodes`), on its
topics and with the parameters it recorded, whatever its name and remapping; the report says
which node and where the parameters came from.

Exit status (docs/cli.md): 0 verified and every check within tolerance; 1 a model check failed;
2 a bad option (argparse's line, naming it; or ``--node`` naming no drs node of the bag, or none
of its several), or the bag is missing, unreadable, corrupt or inconsistent, or its
``metadata.yaml`` is malformed, or the model refuses the parameters it is checked with (one line
on stderr); 3 ``--recover`` checked the readable part of a damaged bag
(it stopped early: the report says where and why); 4 the check itself failed on a message that
passed every check of the file (e.g. a checked topic of a type that is not installed): one line
``internal error``, no verdict on the bag.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field

from drs_model.cli.exit_status import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_RECOVERED,
    EXIT_UNREADABLE,
    EXIT_USAGE,
)
from drs_model.cli.strict_parser import StrictParser
from drs_model.errors import DRSError
from drs_model.overrides import file_overrides, parameter_file_argument, split_overrides
from drs_model.params import DRSParams, from_dict
from drs_ros.bag.check.model_checks import (
    CheckResult,
    ForceModelError,
    ModelChecker,
    load_force_model,
)
from drs_ros.bag.check.report import format_table, to_json
from drs_ros.bag.check.run_checks import TICK_TOPICS, RunChecker, fault_report
from drs_ros.bag.check.run_stats import STATS_ROLES, RunStats
from drs_ros.bag.read.decoded import BagData, stream_bag
from drs_ros.bag.read.effects import model_params_from
from drs_ros.bag.read.nodes import BagNode, NodeSelectionError, add_node_arguments, node_note
from drs_ros.bag.season import fleet
from drs_ros.bag.verb import (
    INTERNAL,
    NO_NODE,
    UNREADABLE,
    Failure,
    Verb,
    bag_node,
    caught,
    failure_of,
    node_topics,
)
from drs_ros.names import DEFAULT_JOINT_NAMES, DEFAULT_NODE

#: The topics the model checks read (overridable with ``--<key>-topic``).
CHECK_TOPICS = ("joint_states", "piston_force", "flap_gap", "piston_acceleration")
#: The further roles the run's checks read: its parameters, its effect record, the hydraulic
#: rung's pressures and spool (drs_ros.bag.check.run_checks).
RUN_ROLES = (
    "parameter_events",
    "command_events",
    *(r for r in TICK_TOPICS if r not in CHECK_TOPICS),
)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The options of ``drs-bag check``."""
    ap.add_argument(
        "bag",
        nargs="+",
        help="bag directory, .mcap or .db3 file; several, directories searched for bags, or globs "
        "check a fleet (one row per bag)",
    )
    ap.add_argument(
        "--tol",
        type=float,
        default=1e-6,
        help="tolerance of the kinematic checks [m, m/s] (default 1e-6)",
    )
    ap.add_argument(
        "--force-tol", type=float, default=1.0, help="tolerance of the force checks [N] (default 1)"
    )
    ap.add_argument(
        "--pressure-tol",
        type=float,
        default=1.0,
        help="tolerance of the hydraulic rung's pressure checks [Pa] (default 1)",
    )
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    ap.add_argument(
        "--recover",
        action="store_true",
        help="check the readable part of a damaged bag (exit status 3 if damaged)",
    )
    ap.add_argument(
        "--params",
        type=parameter_file_argument,
        help="parameter file (.toml/.yaml) of the recorded run (default: "
        "the model parameters the bag recorded, else the seed's)",
    )
    ap.add_argument(
        "--force-model",
        default=None,
        type=_force_model_argument,
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
        default=None,
        type=_joint_names_argument,
        help="joint names of [s, psi1, psi3], comma-separated (default: the node's joint_names "
        f"parameter as recorded, else {','.join(DEFAULT_JOINT_NAMES)})",
    )
    ap.add_argument(
        "--max-match",
        type=float,
        default=1e-3,
        help="largest time offset [s] pairing a scalar topic with a joint state",
    )
    add_node_arguments(ap, CHECK_TOPICS)
    fleet.add_fleet_arguments(ap, "-o", "--output")


def _joint_names(text: str) -> tuple[str, ...]:
    return tuple(n.strip() for n in text.split(",") if n.strip())


def _joint_names_argument(text: str) -> str:
    """argparse ``type=`` of ``--joint-names``: three comma-separated names."""
    if len(_joint_names(text)) != 3:
        raise argparse.ArgumentTypeError(
            f"needs 3 names (s, psi1, psi3), got {list(_joint_names(text))}"
        )
    return text


def _force_model_argument(spec: str) -> str:
    """argparse ``type=`` of ``--force-model``: a ``module:function`` that loads."""
    try:
        load_force_model(spec)
    except ForceModelError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return spec


def recorded_params(node: BagNode | None) -> tuple[DRSParams, str]:
    """The model parameters ``node`` recorded at its start (its first parameter event), and
    where they came from; else the seed's, and why."""
    if node is None:
        return DRSParams(), "the seed's (the bag names no drs node)"
    if node.parameters is None:
        return DRSParams(), f"the seed's (the bag recorded none for {node.name})"
    if not any(name.startswith("model.") for name in node.parameters):
        return DRSParams(), (
            f"the seed's (the parameters {node.name} recorded on "
            "/parameter_events hold no model.* value)"
        )
    return model_params_from(node.parameters), f"recorded by {node.name} on /parameter_events"


def joint_names(args: argparse.Namespace, node: BagNode | None) -> tuple[str, ...]:
    """``--joint-names``, else the node's recorded ``joint_names``, else the defaults."""
    if args.joint_names is not None:
        return _joint_names(args.joint_names)  # checked by argparse (_joint_names_argument)
    recorded = (node.parameters or {}).get("joint_names") if node is not None else None
    return tuple(recorded) if recorded else DEFAULT_JOINT_NAMES


@dataclass
class CheckOutcome:
    """What checking one bag gave: the exit status (see the module docstring), the bag's data
    and the checks' results (None and empty when it could not be read), the error line (''
    when there is none), the model parameters used, the run's figures (``stats=True``), and
    the drs node checked (None: the bag names none)."""

    status: int
    data: BagData | None = None
    results: list[CheckResult] = field(default_factory=list)
    error: str = ""
    params: DRSParams | None = None
    stats: RunStats | None = None
    faults: list[dict] = field(default_factory=list)
    rung: str | None = None
    node: BagNode | None = None


def check_one(
    bag, args: argparse.Namespace, stats: bool = False, node: BagNode | None = None
) -> CheckOutcome:
    """Check one bag with the options of ``drs-bag check`` (``args``), as the run of ``node``
    (default: the node ``--node`` picks, :func:`drs_ros.bag.read.nodes.select_node`); never raises
    for the bag's faults (they are the outcome's status and error)."""
    try:
        node = bag_node(bag, args, node)
    except NodeSelectionError as exc:
        return CheckOutcome(NO_NODE.status, error=NO_NODE.line(exc))
    named = node_topics(bag, node, [*CHECK_TOPICS, *STATS_ROLES, *RUN_ROLES], args, CHECK_TOPICS)
    # every role the checks read, as this node named it (the given --*-topic options win)
    topics = {key: named.topics[key] for key in (*CHECK_TOPICS, *RUN_ROLES)}
    names = joint_names(args, node)
    force_model, force_note = load_force_model(args.force_model)  # and _force_model_argument
    figures = None
    if stats:
        figures = RunStats(
            topics={r: named.topics[r] for r in STATS_ROLES},
            diagnostics_name=None if node is None else node.diagnostics_name,
            joint_names=names,
        )
    params, hydraulic = None, {}
    failures = _failures(args)
    try:
        if args.params:
            params, hydraulic = _file_params(args.params)
            origin = f"from {args.params} (--params)"
        else:
            params, origin = recorded_params(node)
        model = ModelChecker(
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
        checker = RunChecker(
            model,
            pressure_tol=getattr(args, "pressure_tol", 1.0),
            node=DEFAULT_NODE if node is None else node.name,
            hydraulic_overrides=hydraulic,
        )
        wanted = checker.topics

        def take(topic: str, log_ns: int, msg) -> None:
            if topic in wanted:
                checker.add(topic, log_ns, msg)
            if figures is not None:
                figures.add(topic, log_ns, msg)

        read = list(wanted) + ([t for t in figures.read if t not in wanted] if figures else [])
        data = stream_bag(bag, read, take, recover=args.recover)
        data.first_stamp_s = {t: v for t, v in data.first_stamp_s.items() if t in wanted}
        data.notes += [node_note(node), *named.notes]
        data.notes.append(f"model parameters: {origin}")
        results = checker.results()
        data.notes += run_notes(checker)
    except caught(failures) as exc:
        failure = failure_of(exc, failures)
        return CheckOutcome(failure.status, error=failure.line(exc), params=params)
    if hydraulic and checker.rung != "hydraulic":
        return CheckOutcome(
            EXIT_USAGE,
            error=f"error: --params {args.params!r}: "
            f"{', '.join(hydraulic)} are hydraulic parameters, and the run is "
            f"judged on the {checker.rung} rung, which has no hydraulic model: "
            "leave them out",
            params=params,
        )
    if any(r.status == "FAIL" for r in results):
        status = EXIT_FAILED
    else:
        status = EXIT_RECOVERED if data.recovered else EXIT_OK
    faults = fault_report(checker.run)
    return CheckOutcome(status, data, results, "", params, figures, faults, checker.rung, node)


def _failures(args: argparse.Namespace) -> list[Failure]:
    """How checking a bag fails: the checker's own failure (no verdict), the bag unreadable, the
    model refusing the parameters (--params's, or the bag's own)."""
    whose = f"--params {args.params!r}" if args.params else "the bag's recorded parameters"
    refused = Failure(DRSError, EXIT_UNREADABLE, f"error: the model refuses {whose}: ")
    return [INTERNAL, UNREADABLE, refused]


def _file_params(path) -> tuple[DRSParams, dict]:
    """The model parameters of a ``--params`` file and its hydraulic values (checked against
    HydraulicParams' defaults here; set over the recorded ones on the hydraulic rung)."""
    from drs_model.fidelity.hydraulic_params import hydraulic_from_dict

    model, hydraulic = split_overrides(file_overrides(path))
    hydraulic_from_dict(hydraulic)
    return from_dict(model), hydraulic


def run_notes(checker: RunChecker) -> list[str]:
    """What the report says of the run's rung and of its faults refused."""
    record = checker.run
    if checker.rung is None:
        rung = f"the rung of the run is unknown: {checker.rung_error}"
    elif record.fidelity == "auto":
        rung = f"judged on the {checker.rung} rung (fidelity auto's choice, in the effect record)"
    elif record.fidelity_recorded:
        rung = f"judged on the {checker.rung} rung (the recorded fidelity parameter)"
    else:  # say what the bag lacks: the rung is the node's default, not a recorded value
        why = (
            "the bag records no parameters of the node"
            if record.node_parameters is None
            else f"the parameters {record.node} recorded hold none"
        )
        rung = (
            f"judged on the {checker.rung} rung: no fidelity was recorded ({why}); the "
            f"node's default, {record.fidelity}, was assumed"
        )
    return [rung, *record.fault_notes]


#: Table columns of each check's result: check name -> column prefix.
CHECK_COLUMNS = {
    "loop constraint |Phi(q)|": "loop_constraint_m",
    "velocity constraint |Phi_q qd|": "velocity_constraint_m_s",
    "finite joint states": "nonfinite_joint_states",
    "gap vs kinematics.gap(q)": "gap_vs_model_m",
    "piston force vs model, logged accel.": "piston_force_vs_model_n",
    "piston force vs model": "piston_force_vs_model_n",
    "piston force vs statics": "piston_force_vs_model_n",
    "piston force vs chamber pressures": "piston_force_vs_pressures_n",
    "supply pressure vs faults": "supply_pressure_vs_faults_pa",
    "stroke vs faulty sensor model": "stroke_vs_sensor_model_m",
}
#: Columns of the printed summary of a fleet.
SUMMARY_COLUMNS = (
    "messages",
    "duration_s",
    "peak_force_n",
    "largest_gap_m",
    "refused_commands",
    "missed_deadlines",
)
#: The verdict of each exit status of ``drs-bag check``.
CHECK_VERDICTS = fleet.verdicts(passed="PASS", failed="FAIL")


def fleet_row(bag: str, args: argparse.Namespace) -> list[dict]:
    """Check one bag of a fleet (a Dask task): its rows of the table (see
    :mod:`drs_ros.bag.season.fleet`), one per drs node it holds (the one ``--node`` names, if
    given): verdict, exit status, error, each check's worst error and status, counts, the run's
    figures (:class:`RunStats`) and the model parameters used."""
    return VERB.rows(bag, args)


def _fleet_one(bag, args: argparse.Namespace, node: BagNode | None = None) -> CheckOutcome:
    """One run of a fleet's bag: checked, with its figures."""
    return check_one(bag, args, stats=True, node=node)


def _row(bag: str, args: argparse.Namespace, outcome: CheckOutcome, node: BagNode | None) -> dict:
    row = fleet.base_row(bag, outcome.status, CHECK_VERDICTS[outcome.status], outcome.error, node)
    for column in dict.fromkeys(CHECK_COLUMNS.values()):
        row[column] = math.nan
        row[f"{column}_status"] = None
    for r in outcome.results:
        column = CHECK_COLUMNS.get(r.name)
        if column is not None:
            row[column], row[f"{column}_status"] = r.max_error, r.status
    data = outcome.data
    if data is not None:
        row.update(fleet.count_columns(data.counts, data.start_ns, data.end_ns, data.recovered))
        row["notes"] = data.notes
    figures = (outcome.stats or RunStats()).row()
    row.update(figures if data is not None else dict.fromkeys(figures))  # unread: nulls
    row["fidelity"] = outcome.rung
    row["faults"] = [f"{f['fault']}={f['value']!r}" for f in outcome.faults]
    row.update(fleet.param_columns(outcome.params))
    return row


def _report(outcome: CheckOutcome, args: argparse.Namespace, prog: str) -> int:
    """One bag's report, as a table or JSON."""
    data, results, faults = outcome.data, outcome.results, outcome.faults
    if args.json:
        print(to_json(data, results, faults, outcome.node))
    else:
        print(format_table(data, results, faults))
    return outcome.status


#: ``drs-bag check`` on the skeleton of the verbs that judge a run.
VERB = Verb(
    one=_fleet_one,
    single=check_one,
    row=_row,
    report=_report,
    done="checked",
    summary=lambda args: SUMMARY_COLUMNS,
)


def run(args: argparse.Namespace, prog: str = "drs-bag check") -> int:
    """Run ``drs-bag check``; returns the exit status (see the module docstring). Many bags
    (or a table, or a cluster) go to :func:`drs_ros.bag.season.fleet.run_fleet`."""
    return VERB.run(args, prog, fleet_row)


def main(argv: Sequence[str] | None = None, prog: str = "drs-bag check") -> int:
    """``drs-bag check`` / ``drs-check``; returns the exit status."""
    ap = StrictParser(
        prog=prog,
        description="Verify every byte of a recorded DRS bag and check it against "
        "the model. Exit status (docs/cli.md): 0 ok, 1 a check failed, 2 a bad option (or "
        "--node naming no node of the bag, or none of its several) or an unreadable bag, "
        "3 damaged (--recover read its readable part), 4 internal error (no verdict on the "
        "bag).",
    )
    add_arguments(ap)
    return run(ap.parse_args(argv), prog)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
