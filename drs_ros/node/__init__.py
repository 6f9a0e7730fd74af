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

from .adapter import COMMANDS, DRSNode
from .managed import ManagedDRSNode
from .parameters import NODE_PARAMETERS, StartupError
from .runner import StopRequest, main, run, run_deadline_loop, spin_until_stopped

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
