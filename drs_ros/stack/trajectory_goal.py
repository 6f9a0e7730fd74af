"""A FollowJointTrajectory goal read as ros2_control's joint_trajectory_controller (Jazzy) reads
it: its tolerances over the controller's defaults (JTC's ``get_segment_tolerances``), its
validation into the piston's move (JTC's ``validate_trajectory_msg``, with the action's error
codes), and the first tolerance an error exceeds.

:mod:`.follow_trajectory` serves the action with these; its docstring says what JTC does and
where drs differs.
"""

from __future__ import annotations

from dataclasses import dataclass

from control_msgs.action import FollowJointTrajectory

from drs_model.errors import InputError

from ..commands import PointNow, TrajectoryMove, trajectory_move
from ..conversions import PastTrajectoryError, started_points
from ..errors import DRSRosError
from ..timestamps import ns_of, seconds_from_ns

Result = FollowJointTrajectory.Result
#: JTC's "-1 erases a tolerance" (compared within float epsilon, as JTC does).
ERASE = -1.0
FLOAT_EPS = 1.1920928955078125e-07


@dataclass(frozen=True)
class Tolerances:
    """One joint's tolerances (0: not enforced), as JTC's ``SegmentTolerances``."""

    path_position: float = 0.0
    path_velocity: float = 0.0
    path_acceleration: float = 0.0
    goal_position: float = 0.0
    goal_velocity: float = 0.0
    goal_acceleration: float = 0.0
    goal_time: float = 0.0


class GoalError(DRSRosError):
    """A goal refused with an error code of FollowJointTrajectory.Result."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


def _resolve(default: float, given: float) -> float:
    """JTC's ``resolve_tolerance_source``."""
    if given > 0.0:
        return given
    if abs(given - ERASE) < FLOAT_EPS:
        return 0.0
    if given < 0.0:
        raise ValueError(f"illegal tolerance value {given!r}")
    return default


def goal_tolerances(goal, defaults: Tolerances, joint: str) -> tuple[Tolerances, str]:
    """The goal's tolerances over the defaults (JTC's ``get_segment_tolerances``); returns them
    and a note when the goal's were unusable and the defaults apply (as JTC logs)."""
    given_time = seconds_from_ns(ns_of(goal.goal_time_tolerance))
    try:
        values = dict(vars(defaults))
        values["goal_time"] = _resolve(defaults.goal_time, given_time)
        for kind, entries in (("path", goal.path_tolerance), ("goal", goal.goal_tolerance)):
            for tol in entries:
                if tol.name != joint:
                    raise ValueError(
                        f"joint {tol.name!r} of goal.{kind}_tolerance is not "
                        f"the controller's ({joint!r})"
                    )
                for q in ("position", "velocity", "acceleration"):
                    key = f"{kind}_{q}"
                    values[key] = _resolve(getattr(defaults, key), getattr(tol, q))
    except ValueError as exc:
        return defaults, f"{exc}: the default tolerances apply"
    return Tolerances(**values), ""


def plan_goal(goal, joint: str, now_ns: int) -> TrajectoryMove | PointNow:
    """The piston's move of a FollowJointTrajectory goal, times from now [s] (a single point
    at 0 s: :class:`~drs_ros.commands.PointNow`, timed when it starts); raises
    :class:`GoalError` with JTC's check and the code of the action's result."""
    traj = goal.trajectory
    names = list(traj.joint_names)
    if list(goal.multi_dof_trajectory.joint_names):
        raise GoalError(
            Result.INVALID_JOINTS,
            "multi-DOF joints "
            f"{list(goal.multi_dof_trajectory.joint_names)} are not joints of this "
            f"controller; its only joint is {joint!r}",
        )
    if names != [joint]:
        others = [n for n in names if n != joint] or names
        raise GoalError(
            Result.INVALID_JOINTS,
            f"joints {names} don't match the controller's joints [{joint!r}]"
            + (
                f": {others} are not controlled (the link and the flap are passive joints of the "
                "closed loop, moved through the piston)"
                if others
                else ""
            ),
        )
    if not traj.points:
        raise GoalError(Result.INVALID_GOAL, "empty trajectory received")
    last = traj.points[-1]
    if any(abs(v) > FLOAT_EPS for v in last.velocities):
        raise GoalError(
            Result.INVALID_GOAL,
            f"velocity of the last trajectory point of {joint} "
            f"is not zero: {list(last.velocities)[0]!r}",
        )
    if any(len(pt.effort) for pt in traj.points):
        raise GoalError(
            Result.INVALID_GOAL,
            "trajectories with effort fields are only supported "
            "for controllers using the 'effort' command interface",
        )
    try:
        times, strokes, rates = started_points(traj, joint, now_ns)
    except PastTrajectoryError as exc:
        raise GoalError(Result.OLD_HEADER_TIMESTAMP, str(exc)) from exc
    except InputError as exc:
        raise GoalError(Result.INVALID_GOAL, str(exc)) from exc
    return trajectory_move(times, strokes, rates)


def violation(kind: str, joint: str, err: tuple[float, float, float], tol) -> str:
    """The first tolerance ``err`` (position, velocity, acceleration) exceeds, or ''."""
    for name, e, t, unit in zip(
        ("position", "velocity", "acceleration"), err, tol, ("m", "m/s", "m/s^2"), strict=True
    ):
        if t > 0.0 and abs(e) > t:
            return f"{joint} {name} error {e:.6g} {unit} exceeds the {kind} tolerance {t:g} {unit}"
    return ""


__all__ = [
    "ERASE",
    "FLOAT_EPS",
    "GoalError",
    "Result",
    "Tolerances",
    "goal_tolerances",
    "plan_goal",
    "violation",
]
