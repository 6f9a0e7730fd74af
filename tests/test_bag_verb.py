"""drs_ros.bag.verb (the skeleton of check, resimulate and fit) and drs_ros.bag.new_bag.

The verbs' exit statuses and messages end to end are test_errors.py's and test_cli_outputs.py's;
here the pieces: which failure answers an exception (the order decides between a type and its
subclass), one fleet row per drs node, and a new bag left whole or not at all."""

import argparse

import pytest

from drs_model.cli.exit_status import (
    EXIT_INTERNAL,
    EXIT_NOTHING_TO_RERUN,
    EXIT_REFUSED,
    EXIT_UNREADABLE,
    EXIT_USAGE,
)
from drs_model.errors import DRSError
from drs_ros.bag import verb
from drs_ros.bag.new_bag import new_bag
from drs_ros.bag.read.files import BagReadError
from drs_ros.bag.read.nodes import NodeSelectionError
from drs_ros.bag.read.recorded import MessageCallbackError
from drs_ros.bag.read.recorded_run import NothingToRerunError, ResimulationError
from drs_ros.bag.replay import resimulate
from drs_ros.bag.season import fit
from drs_ros.bag.season.measured import MeasurementError
from drs_ros.recording.errors import RecordingError

INTERNAL_LINE = "internal error (not a verdict on the bag): "


@pytest.mark.parametrize(
    ("exc", "status", "line"),
    [
        (MessageCallbackError("boom", "b.mcap", "/t", 1, 0), EXIT_INTERNAL, INTERNAL_LINE + "boom"),
        (NothingToRerunError("no command"), EXIT_NOTHING_TO_RERUN, "no command"),
        (ResimulationError("no joint states"), EXIT_UNREADABLE, "error: no joint states"),
        (BagReadError("crc"), EXIT_UNREADABLE, "error: crc"),
        (RecordingError("exists"), EXIT_UNREADABLE, "error: -o: exists"),
        (
            DRSError("m_wing"),
            EXIT_UNREADABLE,
            "error: the model refuses the re-run (the "
            "recorded parameters with --params/--set): m_wing",
        ),
    ],
)
def test_resimulate_answers_each_failure_the_first_that_fits(exc, status, line):
    # NothingToRerunError is a ResimulationError: listed first, it is not called unreadable
    failure = verb.failure_of(exc, resimulate.FAILURES)
    assert (failure.status, failure.line(exc)) == (status, line)


@pytest.mark.parametrize(
    ("exc", "status", "verdict"),
    [
        (NodeSelectionError("no node /x"), EXIT_USAGE, ""),
        (MeasurementError("no joint states"), EXIT_UNREADABLE, ""),
        (DRSError("m_wing"), EXIT_REFUSED, fit.REFUSED),
    ],
)
def test_fit_names_a_refused_fit_apart_from_an_unreadable_bag(exc, status, verdict):
    failure = verb.failure_of(exc, fit.FAILURES)
    assert (failure.status, failure.verdict) == (status, verdict)
    outcome = fit.FitOutcome(failure.status, error=failure.line(exc), verdict=failure.verdict)
    assert outcome.verdict == (verdict or fit.FIT_VERDICTS[status])


def test_an_exception_no_failure_answers_is_refused_by_name():
    with pytest.raises(ValueError, match="KeyError is none of the failures"):
        verb.failure_of(KeyError("x"), resimulate.FAILURES)
    assert KeyError not in verb.caught(resimulate.FAILURES)


class _Node:
    def __init__(self, name):
        self.name = name


def test_a_fleet_bag_has_one_row_per_node_and_one_row_naming_a_missing_node(monkeypatch):
    from drs_ros.bag.season import fleet

    nodes = [_Node("/a/drs"), _Node("/b/drs")]

    def row_nodes(bag, name):
        if name is None:
            return nodes
        raise NodeSelectionError(f"no drs node {name!r} in {bag}")

    monkeypatch.setattr(fleet, "row_nodes", row_nodes)
    seen = []

    def one(bag, args, node=None):
        seen.append(node.name)
        return argparse.Namespace(status=0, error="")

    def row(bag, args, outcome, node):
        return {"bag": bag, "node": node.name, "status": outcome.status}

    v = verb.Verb(one=one, row=row, report=lambda o, a, p: 0, done="x", summary=lambda a: ())
    rows = v.rows("b.mcap", argparse.Namespace(node=None))
    assert [r["node"] for r in rows] == seen == ["/a/drs", "/b/drs"]
    (missing,) = v.rows("b.mcap", argparse.Namespace(node="/c/drs"))
    assert missing["exit_status"] == EXIT_USAGE and missing["verdict"] == "NO SUCH NODE"
    assert "/c/drs" in missing["error"]


@pytest.mark.parametrize("existed", [False, True])
def test_a_new_bag_whose_writing_fails_leaves_nothing(tmp_path, existed):
    out = tmp_path / "out"
    if existed:
        out.mkdir()
    with pytest.raises(RuntimeError, match="copy failed"), new_bag(out) as rec:
        assert rec.path.exists()
        raise RuntimeError("copy failed")
    # an empty directory that was there stays, empty; one the tool made is gone
    assert (sorted(out.iterdir()) == []) if existed else not out.exists()


def test_a_new_bag_written_whole_is_kept(tmp_path):
    with new_bag(tmp_path / "out") as rec:
        rec.finish()
    assert rec.path.exists() and rec.metadata_path.exists()
