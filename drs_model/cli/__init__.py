"""The ``drs`` command line: one module per subcommand group, each with ``register(subparsers)``.

Every subcommand prints a readable table, or JSON with ``--json``. Errors of the model
(:class:`~drs_model.errors.DRSError`) print one line on stderr and exit with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import DRSError
from ._common import dumps

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
        return 2
    print(dumps(out.data) if getattr(args, "json", False) else out.text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
