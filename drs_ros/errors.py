"""The root of drs_ros's exception types, apart from the model's.

drs_ros adapts the model to ROS 2: its failures are about messages, files, bags, recordings,
options and the node's start, never about the physics. They subclass :class:`DRSRosError`, not
:class:`drs_model.errors.DRSError`, so that a tool can tell "the model refuses this value" from
"this bag cannot be read" or "this option is wrong" by the type it catches (``except DRSError``
in a bag tool catches the model's refusals only). Each tool's exit status for each kind is in
docs/cli.md, and its constants in :mod:`drs_model.cli.exit_status`.
"""

from __future__ import annotations


class DRSRosError(Exception):
    """Root of every error raised by drs_ros (the node, its recordings, the bag tools, the
    demo); never a :class:`~drs_model.errors.DRSError`."""


class UsageError(DRSRosError, ValueError):
    """A command-line option has a value the tool cannot use; the message starts with the
    option's name. Reported as argparse reports a bad option: exit status 2, one line."""


__all__ = ["DRSRosError", "UsageError"]
