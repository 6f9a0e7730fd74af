"""The ``drs`` command line: one module per subcommand group, each with ``register(subparsers)``.

Every subcommand prints a readable table, or JSON with ``--json``. A bad option is argparse's
usage error (``--params`` and ``--set`` are read when parsed); an input the model refuses
(:class:`~drs_model.errors.DRSError`) prints one line on stderr. Both exit with status 2
(docs/cli.md, :mod:`drs_model.cli.exit_status`).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from ..errors import DRSError
from ._common import dumps
from .exit_status import EXIT_OK, EXIT_REFUSED

#: Subcommand modules of this package, in help order. Each defines ``register(subparsers)`` and
#: sets ``func`` (returning an ``Output``) on its parsers.
SUBCOMMAND_MODULES = ("geometry", "coriolis", "dynamics", "forward", "fidelity", "study", "excite")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="drs", description="DRS flap actuator model: kinematics, profile, dynamics."
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in SUBCOMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        out = args.func(args)
    except DRSError as exc:
        print(f"drs {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    try:
        print(dumps(out.data) if getattr(args, "json", False) else out.text, flush=True)
    except BrokenPipeError:  # the reader went away (drs kinematics ... | head -1): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
