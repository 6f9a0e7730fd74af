"""The ``drs`` ROS 2 node (``drs-node``, ``python -m drs_ros``): a thin adapter around
:class:`drs_model.actuator.ActuatorSim`.

Modules: ``adapter`` (:class:`DRSNode`: its topics, its life stages, the clock and the tick;
the topics are listed there); the node's parts ``intake`` (the commands), ``publishers``,
``effect_record`` (the effect record and the diagnostics), ``rung_choice``, ``fault_parameters``
and ``recordings`` (the bag and the rerun recording); ``parameters`` (the parameter table and its
declaration), ``trajectory_cdr`` (a trajectory command read in place from its bytes),
``managed`` (:class:`ManagedDRSNode`, the lifecycle node) and ``runner`` (``main``, the stop a
signal asks for and the deadline loop). This module re-exports their public names.
"""

import importlib

from .entry import run

#: name -> the module that defines it, imported when the name is first asked for: ``drs-node``
#: (``run``) starts by taking SIGINT and SIGTERM, before rclpy, numba and the model are imported.
_LAZY = {
    "COMMANDS": ".adapter",
    "DRSNode": ".adapter",
    "ManagedDRSNode": ".managed",
    "NODE_PARAMETERS": ".parameters",
    "StartupError": ".parameters",
    "StopRequest": ".runner",
    "main": ".runner",
    "run_deadline_loop": ".runner",
    "spin_until_stopped": ".runner",
}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "COMMANDS",
    "NODE_PARAMETERS",
    "DRSNode",
    "ManagedDRSNode",
    "StartupError",
    "StopRequest",
    "main",
    "run",
    "run_deadline_loop",
    "spin_until_stopped",
]
