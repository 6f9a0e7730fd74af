"""``drs-bag``: the bag tools, with the verbs and options of ``ros2 bag``.

* ``drs-bag info BAG``: topics, types, counts, duration (:mod:`drs_ros.bag.info`);
* ``drs-bag check BAG``: verify every byte, then check the run against the model
  (:mod:`drs_ros.bag.check.command`; ``drs-check`` is its alias);
* ``drs-bag recover BAG -o OUT``: a killed or truncated recording made whole
  (:mod:`drs_ros.bag.recover`);
* ``drs-bag merge A B -o OUT``: several bags in one, byte for byte (:mod:`drs_ros.bag.merge`);
* ``drs-bag resimulate BAG``: re-run the recorded commands in the model and compare
  (:mod:`drs_ros.bag.replay.resimulate`);
* ``drs-bag play BAG``: publish the recorded messages onto ROS 2 topics
  (:mod:`drs_ros.bag.replay.play`);
* ``drs-bag index DIR -o catalogue.parquet``: a table of many bags from their summaries alone
  (:mod:`drs_ros.bag.season.catalogue`);
* ``drs-bag fit BAG --params NAME,...``: the actuator's parameters from a run, with intervals
  (:mod:`drs_ros.bag.season.fit`); ``drs-bag trend season.parquet``: their drift over a season
  (:mod:`drs_ros.bag.season.trend`);
* ``drs-bag from-goal GOAL.yaml -o DIR``: a FollowJointTrajectory goal (``drs excite -o``'s) as
  a bag for ``play`` (:mod:`drs_ros.bag.from_goal`).

``check``, ``resimulate`` and ``fit`` take many bags too (a fleet, on Dask:
:mod:`drs_ros.bag.season.fleet`).

Each verb module has ``add_arguments(parser)`` and ``run(args) -> exit status`` (the statuses of
every verb: docs/cli.md, :mod:`drs_model.cli.exit_status`).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import threading
from collections.abc import Sequence

from drs_model.cli.exit_status import EXIT_OK
from drs_model.cli.start_signals import (
    end_signals,
    exit_at_once_on_signal,
    interrupt_on_signal,
    signal_received,
)
from drs_model.cli.strict_parser import StrictParser

#: verb -> (module, one-line help)
VERBS = {
    "info": ("drs_ros.bag.info", "print what a bag holds (as ros2 bag info)"),
    "check": (
        "drs_ros.bag.check.command",
        "verify every byte of a bag and check it against the model",
    ),
    "recover": ("drs_ros.bag.recover", "make a killed or truncated recording a complete bag"),
    "merge": ("drs_ros.bag.merge", "merge several bags into one rosbag2 bag, byte for byte"),
    "resimulate": (
        "drs_ros.bag.replay.resimulate",
        "re-run a recorded run in the model and compare",
    ),
    "play": ("drs_ros.bag.replay.play", "publish a bag onto ROS 2 topics (as ros2 bag play)"),
    "index": ("drs_ros.bag.season.catalogue", "catalogue many bags from their summaries (Parquet)"),
    "fit": (
        "drs_ros.bag.season.fit",
        "identify the actuator's parameters from a bag, with intervals",
    ),
    "trend": (
        "drs_ros.bag.season.trend",
        "fitted parameters over a season: drift, threshold crossing",
    ),
    "from-goal": (
        "drs_ros.bag.from_goal",
        "write a FollowJointTrajectory goal (drs excite's) as a bag that play sends to the node",
    ),
}


#: The verbs that take SIGINT and SIGTERM as a stop of their own (a flag read between two
#: messages); the others end on a :class:`KeyboardInterrupt`, which :func:`main` turns into one
#: line and status 0.
STOPPABLE_VERBS = ("play",)


def build_parser(verb: str | None = None) -> argparse.ArgumentParser:
    """The parser of every verb's name and help; only ``verb``'s options (its module imported):
    a verb imports what it needs, not every other verb's libraries (scipy's, dask's)."""
    ap = StrictParser(prog="drs-bag", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="verb", required=True, metavar="VERB")
    for name, (module, text) in VERBS.items():
        p = sub.add_parser(name, help=text, description=text)
        if name == verb:
            importlib.import_module(module).add_arguments(p)
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``drs-bag``; returns the verb's exit status. SIGINT and SIGTERM are taken
    first thing: one during the imports ends the process at once, status 0 and one line."""
    # signals are the main thread's only (a verb run from another thread takes none)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = exit_at_once_on_signal("drs-bag") if main_thread else {}
    try:
        return _run_verb(list(sys.argv[1:] if argv is None else argv), bool(previous))
    finally:
        end_signals(previous, console_script=argv is None)


def _run_verb(argv: list[str], signals: bool) -> int:
    """Parse ``argv``, import its verb and run it. A signal ends the process at once until the
    verb starts; then the verb takes it (``play``: a stop), or, with ``signals`` (the main
    thread's), it interrupts the verb (:func:`_interruptible`)."""
    verb = next((a for a in argv if not a.startswith("-")), None)  # argparse judges it
    try:
        args = build_parser(verb).parse_args(argv)
    except BrokenPipeError:  # --help into a closed pipe
        return _reader_gone()
    module = importlib.import_module(VERBS[args.verb][0])
    prog = f"drs-bag {args.verb}"
    interrupt = signals and args.verb not in STOPPABLE_VERBS
    return _interruptible(lambda: module.run(args, prog=prog), prog, interrupt)


def _interruptible(run, prog: str, signals: bool) -> int:
    """``run()``'s status. With ``signals``, SIGINT and SIGTERM interrupt it (whatever error a
    library made of the interrupt, and whatever status the verb made of that error): the line
    ``PROG: stopped by SIGNAL`` and status 0. A reader of the output that went away
    (``drs-bag info | head``) is status 0 too."""
    if signals:
        interrupt_on_signal()
    status = EXIT_OK
    try:
        status = run()
    except BrokenPipeError:
        status = _reader_gone()
    except KeyboardInterrupt:
        if not signal_received():
            print(f"{prog}: stopped by a signal", file=sys.stderr)
    except Exception:
        if not (signals and signal_received()):
            raise
    if signals and signal_received():
        print(f"{prog}: stopped by {signal_received()}", file=sys.stderr)
        return EXIT_OK
    return status


def _reader_gone() -> int:
    """Standard output's reader went away: further writes (and the flush at exit) go nowhere."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return EXIT_OK


def check_alias(argv: Sequence[str] | None = None) -> int:
    """``drs-check``: the old name of ``drs-bag check``, with the same signals."""
    main_thread = threading.current_thread() is threading.main_thread()
    previous = exit_at_once_on_signal("drs-check") if main_thread else {}
    try:
        from drs_ros.bag.check.command import main as check_main

        return _interruptible(
            lambda: check_main(argv, prog="drs-check"), "drs-check", bool(previous)
        )
    finally:
        end_signals(previous, console_script=argv is None)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
