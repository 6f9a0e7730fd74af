"""``drs-node``'s console script: SIGINT and SIGTERM taken first thing, then the node's modules
imported (rclpy, numba, scipy, the model: a second or more), then :func:`.runner.run`. A signal
during the imports ends the process at once with status 0, without a traceback, having created
nothing; from :func:`.runner.main`'s start on, a signal is the node's stop."""

from __future__ import annotations

import importlib

from drs_model.cli.start_signals import exit_at_once_on_signal

#: The modules the node imports while it is made (its rung's forward dynamics with scipy's
#: integrators, numba's builds, the bag writer): imported here, where a signal still ends the
#: process at once, they are half a second less of start-up during which a stop must wait for
#: the node to be made (0.56 s of 0.87 s on an idle machine).
MADE_WITH = ("drs_model.forward", "drs_model.compiled.ufuncs", "drs_ros.recording.mcap_recorder")


def run() -> None:
    """``drs-node``: :func:`.runner.run` behind a stop taken before the imports."""
    exit_at_once_on_signal("drs-node")
    from .runner import run as run_node  # the imports a signal may interrupt; main takes over

    for name in MADE_WITH:
        try:
            importlib.import_module(name)
        except ImportError:  # numba is an optional extra: the node says so when it is made
            pass
    run_node()


__all__ = ["MADE_WITH", "run"]
