"""``python -m drs_model.compiled [--part I/N]``: compile every numba function of drs_model into
numba's cache, or only the share I (1-based) of N, so that N processes fill it together."""

from __future__ import annotations

import sys

from ..cli.strict_parser import StrictParser
from ..errors import NumbaUnavailableError


def main(argv: list[str] | None = None) -> int:
    ap = StrictParser(prog="python -m drs_model.compiled", description=__doc__)
    ap.add_argument("--part", default="1/1", help="the share I of N to compile (default 1/1)")
    args = ap.parse_args(argv)
    try:
        part, parts = (int(x) for x in args.part.split("/"))
    except ValueError:
        ap.error(f"--part {args.part!r} is not I/N (two whole numbers)")
    if not 1 <= part <= parts:
        ap.error(f"--part {args.part!r}: I is not in 1..N")
    try:
        from .warm import warm_up
    except NumbaUnavailableError as exc:
        print(f"nothing to compile: {exc}")
        return 0
    seconds = warm_up(part=part - 1, parts=parts)
    print(
        f"drs_model: numba functions (share {part}/{parts}) compiled or loaded from the cache "
        f"in {seconds:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
