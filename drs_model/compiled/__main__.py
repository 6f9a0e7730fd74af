"""``python -m drs_model.compiled``: compile every numba function of drs_model into numba's
cache."""

from __future__ import annotations

import sys

from ..errors import NumbaUnavailableError


def main() -> int:
    try:
        from .warm import warm_up
    except NumbaUnavailableError as exc:
        print(f"nothing to compile: {exc}")
        return 0
    print(f"drs_model: numba functions compiled or loaded from the cache in {warm_up():.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
