"""The ``drs`` command line: one module per subcommand group, each with ``register(subparsers)``.

Every subcommand prints a readable table, or JSON with ``--json``. A bad option is argparse's
usage error (``--params`` and ``--set`` are read when parsed); an input the model refuses
(:class:`~drs_model.errors.DRSError`) prints one line on stderr. Both exit with status 2
(docs/cli.md, :mod:`drs_model.cli.exit_status`). A SIGINT or SIGTERM ends it with status 0 and
one line: at once while it starts (nothing imported but this package), then as a
:class:`KeyboardInterrupt` that unwinds the subcommand (:mod:`.start_signals`).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import threading

from ..errors import DRSError
from .exit_status import EXIT_OK, EXIT_REFUSED
from .start_signals import (
    end_signals,
    exit_at_once_on_signal,
    interrupt_on_signal,
    signal_received,
)
from .strict_parser import StrictParser

#: Subcommand modules of this package, in help order. Each defines ``register(subparsers)`` and
#: sets ``func`` (returning an ``Output``) on its parsers.
SUBCOMMAND_MODULES = ("geometry", "coriolis", "dynamics", "forward", "fidelity", "study", "excite")


def build_parser() -> argparse.ArgumentParser:
    parser = StrictParser(
        prog="drs", description="DRS flap actuator model: kinematics, profile, dynamics."
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in SUBCOMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    # signals are the main thread's only (a caller in another thread takes none)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = exit_at_once_on_signal("drs") if main_thread else {}
    try:
        return _run(argv, main_thread)
    finally:
        end_signals(previous, console_script=argv is None)


def _run(argv: list[str] | None, signals: bool) -> int:
    """Parse ``argv`` and run its subcommand. A signal while it runs is a
    :class:`KeyboardInterrupt` (whatever error a library made of it): one line, status 0."""
    from ._common import dumps  # numpy and the model: after the signals are taken

    args = build_parser().parse_args(argv)
    if signals:
        interrupt_on_signal()
    try:
        out = args.func(args)
        print(dumps(out.data) if getattr(args, "json", False) else out.text, flush=True)
    except BrokenPipeError:  # the reader went away (drs kinematics ... | head -1): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except KeyboardInterrupt:
        pass  # said below
    except Exception as exc:
        if signal_received() is None and isinstance(exc, DRSError):
            print(f"drs {args.command}: error: {exc}", file=sys.stderr)
            return EXIT_REFUSED
        if signal_received() is None:
            raise
    if signals and signal_received() is not None:
        print(f"drs {args.command}: stopped by {signal_received()}", file=sys.stderr)
    return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
