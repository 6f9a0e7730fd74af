"""The command line that starts ``drs-node`` in another process, with its parameters: what the
demo, the benchmarks and the tests start the node with (docs/cli.md: ``drs-node [--managed]
[--ros-args -p NAME:=VALUE ...]``)."""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence

#: ``python -m drs_ros`` with this interpreter: the same as the ``drs-node`` console script.
PYTHON_M_DRS_ROS = (sys.executable, "-m", "drs_ros")


def node_command(
    parameters: Mapping[str, object] | None = None,
    *,
    options: Sequence[str] = (),
    ros_args: Sequence[str] = (),
    program: Sequence[str] = PYTHON_M_DRS_ROS,
) -> list[str]:
    """The arguments of a process that starts the node: ``program`` (``python -m drs_ros`` by
    default, or the ``drs-node`` script), drs-node's own ``options`` (``--managed``), then
    ``--ros-args`` with ``ros_args`` (``-r``, ``--params-file``, ...) and one ``-p NAME:=VALUE``
    a parameter (``VALUE`` as ``str`` writes it: a path, ``500.0``, ``True``).

    >>> node_command({"bag_path": "/tmp/bag", "publish_rate_hz": 500.0})[1:]
    ['-m', 'drs_ros', '--ros-args', '-p', 'bag_path:=/tmp/bag', '-p', 'publish_rate_hz:=500.0']
    """
    pairs = [
        item for name, value in (parameters or {}).items() for item in ("-p", f"{name}:={value}")
    ]
    return [*program, *options, "--ros-args", *ros_args, *pairs]
