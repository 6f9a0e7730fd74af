"""``drs-node``'s console script: SIGINT and SIGTERM taken first thing, then the node's modules
imported (rclpy, numba, the model: a second or more), then :func:`.runner.run`. A signal during
the imports is a stop: the process ends with status 0, without a traceback, having started
nothing."""

from __future__ import annotations

import sys

from ..stop_request import StopRequest


def run() -> None:
    """``drs-node``: :func:`.runner.run` behind a stop taken before the imports."""
    early = StopRequest.early()
    from .runner import run as run_node  # the imports a signal may interrupt

    if early.requested:
        print(f"drs-node: stopped by {early.signal_name} while starting, nothing created",
              file=sys.stderr)  # fmt: skip
        sys.exit(0)
    run_node()


__all__ = ["run"]
