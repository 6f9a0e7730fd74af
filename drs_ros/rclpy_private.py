"""The few private parts of rclpy (7.1, Jazzy) the node needs, where rclpy has no public API.

Every use of a private rclpy name is here, so that an rclpy upgrade that changes one breaks one
module, and ``tests/test_rclpy_private.py`` says which:

* :func:`parameter_overrides`: the values given to a node (``-p``, ``--params-file``,
  ``parameter_overrides=``) before they are declared. rclpy reads them only in
  ``declare_parameter``; the node needs them earlier, to refuse a misspelt name (never
  declared, otherwise silently ignored) and to take an integer given for a float parameter as
  that float (``-p rate:=500``), as the parameter's type requires.
* :func:`mark_executing`: a goal of an action server enters EXECUTING without its execute
  callback being scheduled. rclpy's public ``ServerGoalHandle.execute()`` does both at once;
  the action server schedules the callback only once the goal's outcome is known, so that no
  task waits in the executor (a Jazzy executor resumes every pending task at every spin).
* :func:`schedule_result`: schedule the execute callback of a goal already EXECUTING (it sets
  the terminal state and returns the result), what ``execute()`` does after the transition.
* :func:`log_for_callers`: a module that calls rclpy's logger on behalf of its callers
  (:mod:`drs_ros.log_throttle`) is skipped when rclpy identifies a line's caller. rclpy keys
  each logger's state on the calling location and refuses one location logging at two
  severities (``ValueError``); every line would otherwise come from the same place.
"""

from __future__ import annotations

import os
from collections.abc import Callable

from rclpy.impl import rcutils_logger as _rcutils_logger
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy


def parameter_overrides(node) -> dict:
    """The node's parameter overrides, name -> :class:`rclpy.parameter.Parameter`: rclpy's own
    dictionary (a change is what ``declare_parameter`` then takes)."""
    return node._parameter_overrides


def mark_executing(handle) -> None:
    """Move an accepted goal (``ServerGoalHandle``) to EXECUTING, scheduling nothing."""
    handle._update_state(_rclpy.GoalEvent.EXECUTE)


def schedule_result(server, handle, callback: Callable) -> None:
    """Run ``callback(handle)`` in a task of the node's executor, as the ``ActionServer`` runs
    an execute callback: its return value is the goal's result."""
    server.notify_execute(handle, callback)


def log_for_callers(path: str) -> None:
    """Skip the module at ``path`` when rclpy's logger identifies the caller of a line: the
    caller is the frame that called into it, as for rclpy's own logging modules (rclpy keeps
    their names in ``_internal_callers``, a list it says third parties may extend)."""
    real = os.path.realpath(path)
    if real not in _rcutils_logger._internal_callers:
        _rcutils_logger._internal_callers.append(real)


__all__ = ["log_for_callers", "mark_executing", "parameter_overrides", "schedule_result"]
