"""``drs-node``'s console script: SIGINT and SIGTERM taken first thing, then the node's modules
imported (rclpy, numba, the model: a second or more), then :func:`.runner.run`. A signal during
the imports ends the process at once with status 0, without a traceback, having created
nothing; from :func:`.runner.main`'s start on, a signal is the node's stop."""

from __future__ import annotations

from drs_model.cli.start_signals import exit_at_once_on_signal


def run() -> None:
    """``drs-node``: :func:`.runner.run` behind a stop taken before the imports."""
    exit_at_once_on_signal("drs-node")
    from .runner import run as run_node  # the imports a signal may interrupt; main takes over

    run_node()


__all__ = ["run"]
