"""``drs-bag``: the bag tools, with the verbs and options of ``ros2 bag``.

* ``drs-bag info BAG``: topics, types, counts, duration (:mod:`drs_ros.bag.info`);
* ``drs-bag check BAG``: verify every byte, then check the run against the model
  (:mod:`drs_ros.bag.check`; ``drs-check`` is its alias);
* ``drs-bag recover BAG -o OUT``: a killed or truncated recording made whole
  (:mod:`drs_ros.bag.recover`);
* ``drs-bag merge A B -o OUT``: several bags in one, byte for byte (:mod:`drs_ros.bag.merge`);
* ``drs-bag resimulate BAG``: re-run the recorded commands in the model and compare
  (:mod:`drs_ros.bag.resimulate`);
* ``drs-bag play BAG``: publish the recorded messages onto ROS 2 topics (:mod:`drs_ros.bag.play`);
* ``drs-bag index DIR -o catalogue.parquet``: a table of many bags from their summaries alone
  (:mod:`drs_ros.bag.catalogue`);
* ``drs-bag fit BAG --params NAME,...``: the actuator's parameters from a run, with intervals
  (:mod:`drs_ros.bag.fit`); ``drs-bag trend season.parquet``: their drift over a season
  (:mod:`drs_ros.bag.trend`);
* ``drs-bag from-goal GOAL.yaml -o DIR``: a FollowJointTrajectory goal (``drs excite -o``'s) as
  a bag for ``play`` (:mod:`drs_ros.bag.from_goal`).

``check``, ``resimulate`` and ``fit`` take many bags too (a fleet, on Dask:
:mod:`drs_ros.bag.fleet`).

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

#: verb -> (module, one-line help)
VERBS = {
    "info": ("drs_ros.bag.info", "print what a bag holds (as ros2 bag info)"),
    "check": ("drs_ros.bag.check", "verify every byte of a bag and check it against the model"),
    "recover": ("drs_ros.bag.recover", "make a killed or truncated recording a complete bag"),
    "merge": ("drs_ros.bag.merge", "merge several bags into one rosbag2 bag, byte for byte"),
    "resimulate": ("drs_ros.bag.resimulate", "re-run a recorded run in the model and compare"),
    "play": ("drs_ros.bag.play", "publish a bag onto ROS 2 topics (as ros2 bag play)"),
    "index": ("drs_ros.bag.catalogue", "catalogue many bags from their summaries (Parquet)"),
    "fit": ("drs_ros.bag.fit", "identify the actuator's parameters from a bag, with intervals"),
    "trend": ("drs_ros.bag.trend", "fitted parameters over a season: drift, threshold crossing"),
    "from-goal": ("drs_ros.bag.from_goal", "write a FollowJointTrajectory goal (drs excite's) as "
                  "a bag that play sends to the node"),
}


#: The verbs that take SIGINT and SIGTERM as a stop of their own (a flag read between two
#: messages); the others end on a :class:`KeyboardInterrupt`, which :func:`main` turns into one
#: line and status 0.
STOPPABLE_VERBS = ("play",)


def build_parser(verb: str | None = None) -> argparse.ArgumentParser:
    """The parser of every verb's name and help; only ``verb``'s options (its module imported):
    a verb imports what it needs, not every other verb's libraries (scipy's, dask's)."""
    ap = argparse.ArgumentParser(prog="drs-bag", description=__doc__.splitlines()[0])
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
    thread's), it is a :class:`KeyboardInterrupt` (whatever error a library made of it, and
    whatever status the verb made of that error): one line and status 0."""
    verb = next((a for a in argv if not a.startswith("-")), None)  # argparse judges it
    interruptible = False
    try:
        args = build_parser(verb).parse_args(argv)
        module = importlib.import_module(VERBS[args.verb][0])
        if signals and args.verb not in STOPPABLE_VERBS:  # a signal interrupts, as it did
            interrupt_on_signal()
            interruptible = True
        status = module.run(args, prog=f"drs-bag {args.verb}")
    except BrokenPipeError:  # the reader of our output went away (drs-bag info | head)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        status = EXIT_OK
    except KeyboardInterrupt:
        if not signal_received():
            print(f"drs-bag {verb}: stopped by a signal", file=sys.stderr)
        status = EXIT_OK
    except Exception:
        if not (interruptible and signal_received()):
            raise
    if interruptible and signal_received():
        print(f"drs-bag {verb}: stopped by {signal_received()}", file=sys.stderr)
        return EXIT_OK
    return status


def check_alias(argv: Sequence[str] | None = None) -> int:
    """``drs-check``: the old name of ``drs-bag check``."""
    from .check import main as check_main

    return check_main(argv, prog="drs-check")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
