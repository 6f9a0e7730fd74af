"""``drs-bag from-goal GOAL.yaml -o DIR``: a FollowJointTrajectory goal as a bag that
``drs-bag play`` sends to a running node.

The goal file is ``ros2 action send_goal``'s YAML (JSON is YAML too), as ``drs excite -o``
writes it: ``trajectory: {joint_names: [...], points: [{positions, velocities?,
accelerations?, time_from_start: {sec, nanosec}}, ...]}``. The bag (a rosbag2 directory, MCAP
and ``metadata.yaml``, written by :class:`~drs_ros.recording.mcap_recorder.McapRecorder`) holds
that trajectory once, as a ``trajectory_msgs/JointTrajectory`` on the node's trajectory command
``~/trajectory_cmd``, which the node follows as it follows its action's goal. ``--node NAME``
puts it under the node's fully qualified name (``/car7/drs_rear/trajectory_cmd``; default
``/drs``), ``--topic`` on any topic (``drs-bag play --remap`` moves it too).

The goal is checked as it is read: a file that does not parse, or a trajectory with no joint,
no point, a point whose values do not match the joints, a value that is no finite number, or
times that do not increase (the node would refuse it) is the file's error, naming the point.

Exit status (docs/cli.md): 0 the bag was written; 2 a bad option, a goal file that cannot be
read or is malformed, or ``-o DIR`` that exists or cannot be written (nothing left behind).
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
from collections.abc import Mapping
from pathlib import Path

from drs_model.cli._common import output_path
from drs_model.cli.exit_status import EXIT_OK, EXIT_UNREADABLE
from drs_model.overrides import parse_error_text
from drs_ros.errors import DRSRosError
from drs_ros.names import DEFAULT_NODE, NODE_TOPICS, expand_topic
from drs_ros.recording.errors import RecordingError
from drs_ros.timestamps import NS_PER_S, T0_NS, ns_from_parts, split_ns

#: The fields of a trajectory point that hold one value per joint (the node takes these).
POINT_VALUES = ("positions", "velocities", "accelerations")


class GoalFileError(DRSRosError, ValueError):
    """A goal file cannot be read, or holds no trajectory the node would take (the message
    names the file and the point)."""


def read_goal(path: str | Path) -> dict:
    """The goal's ``trajectory`` mapping from a YAML (or JSON) file, checked (module
    docstring).

    Raises
    ------
    GoalFileError
        The file cannot be read or parsed, or its trajectory is malformed.
    """
    import yaml

    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise GoalFileError(
            f"{str(path)!r}: cannot read the goal: {parse_error_text(exc)}"
        ) from None
    trajectory = data.get("trajectory") if isinstance(data, Mapping) else None
    if not isinstance(trajectory, Mapping):
        raise GoalFileError(
            f"{str(path)!r}: no 'trajectory' mapping (a FollowJointTrajectory "
            "goal, as drs excite -o writes it)"
        )
    try:
        check_trajectory(trajectory)
    except GoalFileError as exc:
        raise GoalFileError(f"{str(path)!r}: {exc}") from None
    return dict(trajectory)


def _time_ns(point: Mapping, k: int) -> int:
    t = point.get("time_from_start", {})
    sec, nanosec = (t.get("sec", 0), t.get("nanosec", 0)) if isinstance(t, Mapping) else (t, 0)
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in (sec, nanosec)):
        raise GoalFileError(
            f"point {k}: time_from_start must be integer sec and nanosec, got {t!r}"
        )
    if not 0 <= nanosec < NS_PER_S or sec < 0:
        raise GoalFileError(
            f"point {k}: time_from_start must be >= 0 s with nanosec in [0, 1e9), got {t!r}"
        )
    return ns_from_parts(sec, nanosec)


def check_trajectory(trajectory: Mapping) -> None:
    """Refuse a trajectory the node would not take (:class:`GoalFileError`, naming the point)."""
    joints = trajectory.get("joint_names")
    if not (isinstance(joints, list) and joints and all(isinstance(j, str) for j in joints)):
        raise GoalFileError(f"joint_names must be a list of names, got {joints!r}")
    points = trajectory.get("points")
    if not (isinstance(points, list) and points):
        raise GoalFileError("the trajectory has no points")
    last = -1
    for k, point in enumerate(points):
        if not isinstance(point, Mapping):
            raise GoalFileError(f"point {k} is no mapping: {point!r}")
        for key in POINT_VALUES:
            values = point.get(key, [])
            if key == "positions" or values:
                if not (isinstance(values, list) and len(values) == len(joints)):
                    raise GoalFileError(
                        f"point {k}: {key} must hold {len(joints)} value(s), one "
                        f"per joint, got {values!r}"
                    )
                if not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                    for v in values
                ):
                    raise GoalFileError(f"point {k}: {key} must be finite numbers, got {values!r}")
        now = _time_ns(point, k)
        if now <= last:
            raise GoalFileError(
                f"point {k}: time_from_start must increase from point to point "
                f"(the node refuses a trajectory whose times do not)"
            )
        last = now


def trajectory_message(trajectory: Mapping):
    """The ``trajectory_msgs/JointTrajectory`` of a goal's (checked) ``trajectory`` mapping."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    points = []
    for point in trajectory["points"]:
        sec, nanosec = split_ns(_time_ns(point, len(points)))
        values = {key: [float(v) for v in point.get(key) or []] for key in POINT_VALUES}
        points.append(
            JointTrajectoryPoint(**values, time_from_start=Duration(sec=sec, nanosec=nanosec))
        )
    return JointTrajectory(joint_names=list(trajectory["joint_names"]), points=points)


def node_topic(node: str | None = None) -> str:
    """The trajectory command's topic of the node named ``node`` (default ``/drs``)."""
    name = node or DEFAULT_NODE
    return expand_topic(NODE_TOPICS["trajectory_cmd"], name if name.startswith("/") else "/" + name)


def write_goal_bag(
    out: str | Path, trajectory: Mapping, topic: str | None = None, t0_ns: int = T0_NS
) -> Path:
    """Write the new bag directory ``out`` holding ``trajectory`` once on ``topic`` (default:
    ``/drs/trajectory_cmd``), logged at ``t0_ns``.

    Raises
    ------
    RecordingError
        ``out`` exists, or cannot be written (nothing is left behind).
    """
    from trajectory_msgs.msg import JointTrajectory

    from drs_ros.recording.mcap_recorder import McapRecorder

    out = Path(out)
    if out.exists():
        raise RecordingError(f"{str(out)!r} exists: name a new bag directory")
    topic = topic or node_topic()
    try:
        with McapRecorder(out, flush_thread=False) as rec:
            rec.register_topic(topic, JointTrajectory, 10)
            rec.write(topic, trajectory_message(trajectory), t0_ns)
    except (OSError, RecordingError) as exc:
        shutil.rmtree(out, ignore_errors=True)
        raise RecordingError(f"cannot write {str(out)!r}: {exc}") from None
    return out


def _topic_argument(text: str) -> str:
    """argparse ``type=`` of ``--topic``: an absolute topic name."""
    if not text.startswith("/") or text.endswith("/") or "//" in text:
        raise argparse.ArgumentTypeError(f"needs an absolute topic name (/car7/traj), got {text!r}")
    return text


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument(
        "goal",
        help="the FollowJointTrajectory goal (YAML or JSON), e.g. the one drs excite -o writes",
    )
    ap.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="DIR",
        type=output_path,
        help="the bag directory to write (must not exist)",
    )
    where = ap.add_mutually_exclusive_group()
    where.add_argument(
        "--node",
        metavar="NAME",
        help="the node that will follow it, by its "
        "fully qualified name: the bag's topic is NAME/trajectory_cmd (default "
        f"{DEFAULT_NODE})",
    )
    where.add_argument("--topic", type=_topic_argument, help="the topic to write it on instead")


def run(args: argparse.Namespace, prog: str = "drs-bag from-goal") -> int:
    try:
        trajectory = read_goal(args.goal)
        topic = args.topic or node_topic(args.node)
        write_goal_bag(args.output, trajectory, topic)
    except (GoalFileError, RecordingError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_UNREADABLE
    points = len(trajectory["points"])
    print(
        f"wrote {args.output}: {points} points of {', '.join(trajectory['joint_names'])} on "
        f"{topic} (drs-bag play {args.output} sends them to the node)"
    )
    return EXIT_OK


__all__ = [
    "GoalFileError",
    "add_arguments",
    "check_trajectory",
    "node_topic",
    "read_goal",
    "run",
    "trajectory_message",
    "write_goal_bag",
]
