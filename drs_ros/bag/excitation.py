"""An excitation (``drs excite``) as the node takes it: a ``trajectory_msgs/JointTrajectory`` of
the piston joint, written as a bag that ``drs-bag play`` publishes on the node's
``~/trajectory_cmd`` (the node follows it as its trajectory command). (The FollowJointTrajectory
goal file is plain data: :meth:`drs_model.identify.excitation.Excitation.goal`.)
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..names import DEFAULT_JOINT_NAMES, DEFAULT_TOPICS
from .synthetic import T0_NS


def trajectory_message(times: Sequence[float], strokes: Sequence[float],
                       rates: Sequence[float] | None = None, *,
                       joint: str = DEFAULT_JOINT_NAMES[0]):  # fmt: skip
    """A JointTrajectory of ``joint`` alone: point ``k`` reaches ``strokes[k]`` [m] at
    ``times[k]`` [s from the start] with ``rates[k]`` [m/s] (none given: the node's default
    rates)."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    points = []
    for k, (t, s) in enumerate(zip(times, strokes, strict=True)):
        sec, nanosec = divmod(int(round(float(t) * 1e9)), 1_000_000_000)
        pt = JointTrajectoryPoint(positions=[float(s)],
                                  time_from_start=Duration(sec=sec, nanosec=nanosec))  # fmt: skip
        if rates is not None:
            pt.velocities = [float(rates[k])]
        points.append(pt)
    return JointTrajectory(joint_names=[joint], points=points)


def write_trajectory_bag(bag_dir: str | Path, times, strokes, rates=None, *,
                         joint: str = DEFAULT_JOINT_NAMES[0], t0_ns: int = T0_NS) -> Path:
    """A bag holding the trajectory once on ``/drs/trajectory_cmd`` (``drs-bag play`` sends
    it to a running node)."""
    from trajectory_msgs.msg import JointTrajectory

    from ..recording.mcap_recorder import McapRecorder

    topic = DEFAULT_TOPICS["trajectory_cmd"]
    with McapRecorder(bag_dir, flush_thread=False) as rec:
        rec.register_topic(topic, JointTrajectory, 10)
        rec.write(topic, trajectory_message(times, strokes, rates, joint=joint), t0_ns)
    return Path(bag_dir)


__all__ = ["trajectory_message", "write_trajectory_bag"]
