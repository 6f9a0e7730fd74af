"""The skeleton of the verbs that judge a bag's run: ``drs-bag check``, ``resimulate`` and
``fit``.

Each verb reads one run of a bag, the run of one drs node (:func:`bag_node`: the one ``--node``
picks), on that node's topics (:func:`node_topics`), and turns each failure into an exit
status and a one-line error (:class:`Failure`, :func:`failure_of`; the statuses of docs/cli.md).
A :class:`Verb` is what a verb brings of its own (its work on one run, its table row, its
report); :meth:`Verb.rows` makes one bag's rows of a fleet's table (one per drs node) and
:meth:`Verb.run` runs the verb on one bag or, on Dask, on many
(:func:`drs_ros.bag.season.fleet.run_fleet`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

from drs_model.cli.exit_status import EXIT_INTERNAL, EXIT_UNREADABLE, EXIT_USAGE
from drs_ros.bag.read import look_ahead
from drs_ros.bag.read.files import BagReadError
from drs_ros.bag.read.nodes import (
    BagNode,
    NodeSelectionError,
    NodeTopics,
    bag_nodes,
    given_topics,
    resolve_topics,
    select_node,
)
from drs_ros.bag.read.recorded import MessageCallbackError
from drs_ros.bag.season import fleet


@dataclass(frozen=True)
class Failure:
    """An exception a verb answers with an exit status and the error line ``prefix`` + the
    exception's message (:meth:`line`); ``verdict``: its row's verdict in a fleet's table, where
    not the status's own."""

    kinds: type[BaseException] | tuple[type[BaseException], ...]
    status: int
    prefix: str = "error: "
    verdict: str = ""

    def line(self, exc: BaseException) -> str:
        """The error line of ``exc``."""
        return f"{self.prefix}{exc}"


#: drs's own failure on a message that passed every check of the file: no verdict on the bag.
INTERNAL = Failure(
    MessageCallbackError, EXIT_INTERNAL, "internal error (not a verdict on the bag): "
)
#: ``--node`` names no drs node of the bag, or none of its several.
NO_NODE = Failure(NodeSelectionError, EXIT_USAGE)
#: The bag cannot be read, or fails its verification.
UNREADABLE = Failure(BagReadError, EXIT_UNREADABLE)


def caught(failures: Sequence[Failure]) -> tuple[type[BaseException], ...]:
    """The exception types ``failures`` answer (for an ``except`` clause)."""
    kinds: list[type[BaseException]] = []
    for f in failures:
        kinds += f.kinds if isinstance(f.kinds, tuple) else [f.kinds]
    return tuple(kinds)


def failure_of(exc: BaseException, failures: Sequence[Failure]) -> Failure:
    """The first of ``failures`` whose kinds ``exc`` is one of (the order decides between a type
    and its subclass)."""
    for f in failures:
        if isinstance(exc, f.kinds):
            return f
    raise ValueError(f"{type(exc).__name__} is none of the failures given") from exc


def bag_node(bag, args: argparse.Namespace, node: BagNode | None = None) -> BagNode | None:
    """``node``, else the drs node of ``bag`` that ``--node`` picks
    (:func:`drs_ros.bag.read.nodes.select_node`; None: the bag names none). Raises
    :class:`NodeSelectionError` (:data:`NO_NODE`)."""
    if node is not None:
        return node
    return select_node(bag_nodes(bag), args.node, bag)


def node_topics(
    bag,
    node: BagNode | None,
    roles: Sequence[str],
    args: argparse.Namespace,
    options: Sequence[str],
) -> NodeTopics:
    """The topic of each of ``roles`` as ``node`` recorded it, the ``--<role>-topic`` options
    of ``options`` that ``args`` gives winning (checked against the bag's channels)."""
    return resolve_topics(node, roles, given_topics(args, options), look_ahead.channels(bag))


class Outcome(Protocol):
    """What a verb's work on one run gave: its exit status and error line ('' when none)."""

    status: int
    error: str


@dataclass(frozen=True)
class Verb:
    """What a verb brings of its own to the skeleton.

    ``one(bag, args, node=None)``: its work on the run of ``node`` (default: the one ``--node``
    picks), an :class:`Outcome`, never raising for the bag's faults; ``single(bag, args)``: the
    same for the one bag of a command line (default ``one``); ``row(bag, args, outcome, node)``:
    the outcome's row of a fleet's table; ``report(outcome, args, prog)``: prints one bag's
    report, returns the exit status; ``done``: the summary's participle ("checked");
    ``summary(args)``: the columns of the printed summary of a fleet.
    """

    one: Callable[..., Outcome]
    row: Callable[[str, argparse.Namespace, Outcome, BagNode | None], dict]
    report: Callable[[Outcome, argparse.Namespace, str], int]
    done: str
    summary: Callable[[argparse.Namespace], Sequence[str]]
    single: Callable[[str, argparse.Namespace], Outcome] | None = None

    def rows(self, bag: str, args: argparse.Namespace) -> list[dict]:
        """One bag of a fleet: its rows, one per drs node it holds (the one ``--node`` names, if
        given; one row for a bag that names none, or none of that name)."""
        try:
            nodes = fleet.row_nodes(bag, args.node)
        except NodeSelectionError as exc:
            return [fleet.no_node_row(bag, exc)]
        return [self.row(bag, args, self.one(bag, args, node=node), node) for node in nodes]

    def run(self, args: argparse.Namespace, prog: str, task: Callable) -> int:
        """Run the verb; returns the exit status. Many bags (or a table, or a cluster) go to
        :func:`drs_ros.bag.season.fleet.run_fleet`, each bag's rows made by ``task`` (a
        module's function calling :meth:`rows`, which Dask sends to its workers)."""
        if fleet.is_fleet(args):
            return fleet.run_fleet(task, args, prog, self.done, self.summary(args))
        outcome = (self.single or self.one)(args.bag[0], args)
        if outcome.error:
            print(f"{prog}: {outcome.error}", file=sys.stderr)
            return outcome.status
        return self.report(outcome, args, prog)


__all__ = [
    "INTERNAL",
    "NO_NODE",
    "UNREADABLE",
    "Failure",
    "Outcome",
    "Verb",
    "bag_node",
    "caught",
    "failure_of",
    "node_topics",
]
