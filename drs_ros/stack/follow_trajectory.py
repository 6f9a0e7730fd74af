"""``~/follow_joint_trajectory``: control_msgs/action/FollowJointTrajectory, served as
ros2_control's joint_trajectory_controller (Jazzy) serves it.

The controller's joint is the piston (``joint_names[0]``); the link and the flap are passive
joints of the closed loop, driven through it. What follows is joint_trajectory_controller's
behaviour (``joint_trajectory_controller.cpp`` and ``tolerances.hpp``, branch jazzy), except
where a line says otherwise:

* **Validation** (JTC's ``validate_trajectory_msg``): the goal must name exactly the
  controller's joints (no partial goals, no unknown or passive joint, no multi-DOF joint), have
  points, ``time_from_start`` strictly increasing from the second point on (a first point at 0
  s, the state the sender saw as MoveIt sends it, is left out: the path starts from the
  actuator's own state and blends any difference over its first segment), positions (and
  velocities / accelerations, if any) one per joint, no efforts, and end at rest; a non-zero
  ``header.stamp`` starts the trajectory then, and a trajectory that ends before now is refused.
  Then the actuator must accept it (the stroke range, a path that stays in it). *Difference:*
  JTC rejects an invalid goal without a reason (a rejected ROS 2 goal carries no result); drs
  accepts it and aborts it at once with the error code the action defines (``INVALID_JOINTS``,
  ``INVALID_GOAL``, ``OLD_HEADER_TIMESTAMP``) and the reason in ``error_string``, so a client
  learns why. An invalid goal, like JTC's rejected one, leaves the active goal running.
* **Tolerances** (``get_segment_tolerances``): the node's defaults (``path_tolerance``,
  ``goal_tolerance`` [m], ``stopped_velocity_tolerance`` [m/s], ``goal_time_tolerance`` [s],
  JTC's ``constraints.*``), overridden per goal: a value > 0 replaces the default, 0 keeps it,
  -1 erases it; an unknown joint or another negative value makes the goal use the defaults.
  While the trajectory runs, the path tolerance applies (position, velocity, acceleration); from
  its last point on, the goal tolerance (position, and velocity by default
  ``stopped_velocity_tolerance``): within it, the goal SUCCEEDS; outside it for longer than
  ``goal_time_tolerance`` (when that is not 0), it aborts with ``GOAL_TOLERANCE_VIOLATED``; a
  path violation aborts with ``PATH_TOLERANCE_VIOLATED``. The error string says which joint,
  which quantity, by how much.
* **Feedback** at the publish rate: ``desired`` (the trajectory as the actuator plans it, from the
  goal's acceptance), ``actual`` (the actuator's state), ``error = desired - actual``.
* **Deactivation** (JTC's ``on_deactivate``): the goals are aborted with ``INVALID_GOAL``,
  "Current goal cancelled during deactivate transition.", and a piston still moving (or under
  a force) is held where it is, as after a cancel.
* **Preemption:** a new valid goal aborts the active one with ``INVALID_GOAL``, "Current goal
  preempted by new incoming action.", and takes over.
* **Cancel and abort:** a cancel is accepted; the goal ends CANCELED (or ABORTED) and the piston
  holds the position where it was (a quintic back to it, at rest, in ``T_opening``; if that path
  would leave the stroke range, a stop straight ahead instead), while the goal's own path is the
  one the actuator follows (the path object itself, not the rod's position: a hydraulic rod lags
  its reference).
* **Other commands** (the topics, the service, JointState commands) act on the actuator as they
  always do, latest wins; a goal whose trajectory they replaced is judged by its tolerances as
  JTC judges it. An abort or a cancel never undoes a newer command.
* The simulated piston follows its trajectory exactly, so ``error`` stays 0 unless another
  command takes the actuator (as with ros2_control's mock hardware).

Every move the server gives the actuator (a goal's trajectory, a hold) is an accepted record of
the effect log (source: the action's name, the move's exact values), every invalid goal a refused
one, and every goal's end a ``result`` record, so a bag re-runs the action's goals exactly.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from action_msgs.msg import GoalStatus
from control_msgs.action import FollowJointTrajectory
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from trajectory_msgs.msg import JointTrajectoryPoint

from drs_model.errors import DRSError

from ..commands import PointNow, StrokeMove, TrajectoryMove
from ..conversions import time_msg
from ..names import ACCEPTED, REFUSED
from ..rclpy_private import mark_executing, schedule_result
from ..timestamps import ns_from_seconds, set_ns
from .trajectory_goal import GoalError, Result, Tolerances, goal_tolerances, plan_goal, violation

#: Effect-record outcome of a goal's end.
RESULT = "result"


def _point(s: float, v: float, a: float, since_ns: int) -> JointTrajectoryPoint:
    """A feedback point ``since_ns`` [ns] after the goal started (integer nanoseconds: a
    float split of seconds is a whole second short just below one)."""
    pt = JointTrajectoryPoint(positions=[s], velocities=[v], accelerations=[a])
    set_ns(pt.time_from_start, since_ns)
    return pt


@dataclass
class ActiveGoal:
    """A goal whose trajectory the actuator took at simulated time ``t_start`` [s]."""

    handle: object
    move: TrajectoryMove
    path: object  # drs_model.profile.QuinticPath, as the actuator follows it
    t_start: float
    tolerances: Tolerances
    first_sample: bool = True

    @property
    def t_end(self) -> float:
        return self.path.t_end

    def desired(self, t: float) -> tuple[float, float, float]:
        """The planned ``(s, s', s'')`` [m, m/s, m/s^2] at simulated time ``t`` (at rest at the
        last point from its time on, as the actuator is)."""
        if t >= self.t_end:
            return self.move.strokes[-1], 0.0, 0.0
        s, v, a = self.path.at(t)
        return float(s), float(v), float(a)


class FollowJointTrajectoryServer:
    """The action server of one node: goals are taken by the executor, acted on at ticks.

    Parameters
    ----------
    node : rclpy.node.Node
    actuator : callable
        ``actuator()``: the node's actuator now (a rung of :mod:`drs_model.fidelity`; ``fidelity:
        auto`` may replace it before the first step), touched only from :meth:`update`, under
        the node's tick, and read (its parameters) by a goal's plan.
    joint : str
        The piston joint's name.
    defaults : Tolerances
    event : callable
        ``event(outcome, level, reason, values, now_ns)``: a record of the effect log.
    hold_duration : float
        Duration [s] of the move that holds the piston after a cancel.
    """

    def __init__(
        self,
        node,
        actuator: Callable[[], object],
        joint: str,
        defaults: Tolerances,
        event: Callable[..., None],
        hold_duration: float,
        now_ns: Callable[[], int],
    ) -> None:
        self.node, self._actuator, self.joint = node, actuator, joint
        self._now_ns = now_ns
        self.defaults = defaults
        self._event = event
        self.hold_duration = hold_duration
        self.active_flag = False
        self._lock = threading.Lock()
        self._incoming: list = []
        self._outcomes: dict[str, tuple] = {}
        self.goal: ActiveGoal | None = None
        self.results: dict[str, int] = {}
        self.server = ActionServer(
            node,
            FollowJointTrajectory,
            "~/follow_joint_trajectory",
            execute_callback=self._finished,
            goal_callback=self._on_goal,
            handle_accepted_callback=self._on_accepted,
            cancel_callback=lambda _handle: CancelResponse.ACCEPT,
        )
        self.name = node.resolve_topic_name("~/follow_joint_trajectory")

    @property
    def sim(self):
        """The node's actuator now."""
        return self._actuator()

    # ---- executor thread -----------------------------------------------------------------------
    def _on_goal(self, _goal) -> GoalResponse:
        # JTC: "Can't accept new action goals. Controller is not running."
        return GoalResponse.ACCEPT if self.active_flag else GoalResponse.REJECT

    def _on_accepted(self, handle) -> None:
        """Validated and planned here, outside the tick (the plan reads only the actuator's
        parameters; ~4 ms for 10,000 points); the next tick gives it to the actuator."""
        try:
            move = plan_goal(handle.request, self.joint, self._now_ns())
            entry = (handle, move, move.plan(self.sim))
        except GoalError as exc:
            entry = (handle, exc, None)
        except DRSError as exc:
            entry = (handle, GoalError(Result.INVALID_GOAL, str(exc)), None)
        with self._lock:
            self._incoming.append(entry)

    def _finished(self, handle):
        """Runs once a goal's outcome is known (scheduled by :meth:`_end`)."""
        with self._lock:
            status, result = self._outcomes.pop(_uuid(handle))
        if status == "succeeded":
            handle.succeed()
        elif status == "canceled":
            handle.canceled()
        else:
            handle.abort()
        return result

    # ---- ticks ---------------------------------------------------------------------------------
    def _end(self, handle, status: str, code: int, message: str, now_ns: int) -> None:
        """End a goal: the executor sets its terminal state and sends the result."""
        with self._lock:
            self._outcomes[_uuid(handle)] = (status, Result(error_code=code, error_string=message))
        # rclpy runs the execute callback in a task of the executor: the terminal state and the
        # result are set there (a callback that awaited the outcome instead would keep the
        # Jazzy executor busy, since it resumes every pending task at every spin)
        if handle.status == GoalStatus.STATUS_ACCEPTED:  # a goal ends from EXECUTING
            handle.execute(self._finished)
        else:
            schedule_result(self.server, handle, self._finished)
        self.results[status] = self.results.get(status, 0) + 1
        level = DiagnosticStatus.OK if status == "succeeded" else DiagnosticStatus.WARN
        self._event(
            RESULT,
            level,
            f"{status}: {message}" if message else status,
            {
                "goal_id": _uuid(handle),
                "status": status,
                "error_code": code,
                "error_string": message,
            },
            now_ns,
        )

    def _hold(self, now_ns: int) -> None:
        """Hold the piston where it is (JTC's ``set_hold_position``), as a smooth move."""
        st = self.sim.state
        s, v = float(st.q[0]), float(st.qd[0])
        stop = min(max(s + 0.5 * v * self.hold_duration, self.sim.s_min), self.sim.s_max)
        for move in (StrokeMove(s, self.hold_duration), StrokeMove(stop, self.hold_duration)):
            try:
                move.apply(self.sim)
            except DRSError:
                continue
            self._event(ACCEPTED, DiagnosticStatus.OK, "hold", move.record(), now_ns)
            return

    def _owns(self, goal: ActiveGoal) -> bool:
        """Whether the goal's trajectory is still the path the actuator follows (no newer command
        replaced it): decided by the path itself, never by where the rod is (a hydraulic rod
        lags its reference)."""
        motion = self.sim.motion
        return motion.mode == "stroke" and motion.path is goal.path

    def _stop(self, goal: ActiveGoal, status: str, code: int, message: str, now_ns: int) -> None:
        """End the active goal and, while its trajectory drives the piston, hold it where it is
        (JTC holds on cancel and on every abort)."""
        owned = self._owns(goal)
        self.goal = None
        self._end(goal.handle, status, code, message, now_ns)
        if owned:
            self._hold(now_ns)

    def _start(self, handle, move, plan, now_ns: int) -> None:
        goal_msg = handle.request
        try:
            if isinstance(move, GoalError):
                raise move
            if isinstance(move, PointNow):  # timed from the state it starts from, and recorded so
                move = move.now(self.sim)
            path = move.apply(self.sim, plan)  # the state-dependent first segments: checked now
        except GoalError as exc:
            code, why = exc.code, str(exc)
        except DRSError as exc:
            code, why = Result.INVALID_GOAL, str(exc)
        else:
            tolerances, note = goal_tolerances(goal_msg, self.defaults, self.joint)
            if note:
                self.node.get_logger().warning(f"goal {_uuid(handle)}: {note}")
            if self.goal is not None:  # JTC's preempt_active_goal
                self._end(
                    self.goal.handle,
                    "aborted",
                    Result.INVALID_GOAL,
                    "Current goal preempted by new incoming action.",
                    now_ns,
                )
            mark_executing(handle)
            self.goal = ActiveGoal(handle, move, path, self.sim.t, tolerances)
            values = {**move.record(), "goal_id": _uuid(handle)}
            self._event(ACCEPTED, DiagnosticStatus.OK, "", values, now_ns)
            return
        self._event(
            REFUSED,
            DiagnosticStatus.WARN,
            f"error_code {code}: {why}",
            {"goal_id": _uuid(handle), "error_code": code},
            now_ns,
        )
        self._end(handle, "aborted", code, why, now_ns)

    def update(self, stamp_ns: int, now_ns: int) -> None:
        """At a publish: take new goals, send feedback, judge tolerances, end goals."""
        with self._lock:
            incoming, self._incoming = self._incoming, []
        for handle, move, plan in incoming:
            if handle.is_cancel_requested:  # cancelled before it started: nothing to hold
                self._end(handle, "canceled", Result.SUCCESSFUL, "", now_ns)
            else:
                self._start(handle, move, plan, now_ns)
        goal = self.goal
        if goal is None:
            return
        if goal.handle.is_cancel_requested:  # JTC: setCanceled, then hold the position
            self._stop(goal, "canceled", Result.SUCCESSFUL, "", now_ns)
            return
        st = self.sim.state
        t = st.t
        want = goal.desired(t)
        have = (float(st.q[0]), float(st.qd[0]), float(st.qdd[0]))
        err = tuple(w - h for w, h in zip(want, have, strict=True))
        tol = goal.tolerances
        before_last = t < goal.t_end
        path = ""
        if before_last or goal.first_sample:
            path = violation(
                "path",
                self.joint,
                err,
                (tol.path_position, tol.path_velocity, tol.path_acceleration),
            )
        goal.first_sample = False
        outside = ""
        if not before_last:
            outside = violation(
                "goal",
                self.joint,
                err,
                (tol.goal_position, tol.goal_velocity, tol.goal_acceleration),
            )
        fb = FollowJointTrajectory.Feedback(joint_names=[self.joint])
        fb.header.stamp = time_msg(stamp_ns)
        # each instant to the nearest ns first: the difference is exact, whatever the floats' ulps
        since_ns = ns_from_seconds(t) - ns_from_seconds(goal.t_start)
        fb.desired, fb.actual, fb.error = (
            _point(*want, since_ns),
            _point(*have, since_ns),
            _point(*err, since_ns),
        )
        goal.handle.publish_feedback(fb)
        if path:
            self._stop(
                goal,
                "aborted",
                Result.PATH_TOLERANCE_VIOLATED,
                f"Aborted due to path tolerance violation: {path}",
                now_ns,
            )
        elif not before_last and not outside:
            self.goal = None
            self._end(
                goal.handle, "succeeded", Result.SUCCESSFUL, "Goal successfully reached!", now_ns
            )
        elif not before_last and tol.goal_time != 0.0 and t - goal.t_end > tol.goal_time:
            self._stop(
                goal,
                "aborted",
                Result.GOAL_TOLERANCE_VIOLATED,
                f"Aborted due to goal_time_tolerance exceeding by {t - goal.t_end:.6g} "
                f"seconds: {outside}",
                now_ns,
            )

    def deactivate(self, now_ns: int) -> None:
        """JTC's on_deactivate: the active goal (and any not yet started) is aborted and the
        piston held where it is (JTC writes the position command back, so the joint stays): a
        move still under way, whichever command made it, or a force, ends in the hold that
        ends a cancelled goal; it runs once the node is active again (no time passes while
        inactive)."""
        self.active_flag = False
        with self._lock:
            incoming, self._incoming = self._incoming, []
        ends = [entry[0] for entry in incoming]
        ends += [self.goal.handle] if self.goal is not None else []
        self.goal = None
        for handle in ends:
            self._end(
                handle,
                "aborted",
                Result.INVALID_GOAL,
                "Current goal cancelled during deactivate transition.",
                now_ns,
            )
        motion = self.sim.motion
        if motion.mode == "force" or (motion.mode == "stroke" and motion.t < motion.path.t_end):
            self._hold(now_ns)

    def destroy(self) -> None:
        self.server.destroy()


def _uuid(handle) -> str:
    return bytes(handle.goal_id.uuid).hex()


#: ``Tolerances`` with the server that takes them (:mod:`.trajectory_goal` defines it).
__all__ = ["ActiveGoal", "FollowJointTrajectoryServer", "Tolerances"]
